// The plain Z-buffer: every triangle, its whole pixel box. It is the baseline
// every other algorithm is measured against, so it takes the fastest path the
// core has (triangle_batch.h).
#include <chrono>
#include <vector>

#include "zbuffer/algorithms.h"
#include "zbuffer/triangle_batch.h"
#include "zbuffer/vertex_stage.h"

namespace zbuffer {

namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
      .count();
}
}  // namespace

void render_zbuffer(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  const Viewport vp(target.width, target.height);

  // Vertex stage: each vertex once, however many faces share it.
  auto t0 = std::chrono::steady_clock::now();
  // Per-thread scratch: the buffers are reused from frame to frame instead
  // of being allocated, zeroed and faulted in anew (which cost more than the
  // transform itself).
  thread_local ScreenVertices screen;
  transform_vertices(input.mesh, input.mvp, vp, screen);
  stats.vertex_ms += ms_since(t0);

  // Assembly, setup and rasterization: every face, in batches.
  t0 = std::chrono::steady_clock::now();
  TriangleBatch batch(target, stats);
  batch.add_faces(input.mesh, input.mvp, vp, screen, 0, input.mesh.n_faces,
                  input.cull_backfaces);
  batch.flush();
  stats.raster_ms += ms_since(t0);
}

}  // namespace zbuffer
