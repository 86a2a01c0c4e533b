// The plain Z-buffer: every triangle in input order, its whole pixel box.
// It is the baseline every other algorithm is measured against.
#include <chrono>
#include <vector>

#include "zbuffer/algorithms.h"
#include "zbuffer/raster.h"
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
  std::vector<ScreenVertex> screen(size_t(input.mesh.n_vertices));
  transform_vertices(input.mesh, input.mvp, vp, screen.data());
  stats.vertex_ms += ms_since(t0);

  // Assembly and rasterization, one triangle at a time.
  t0 = std::chrono::steady_clock::now();
  for (int64_t f = 0; f < input.mesh.n_faces; ++f) {
    assemble_triangle(input.mesh, input.mvp, vp, screen.data(), f,
                      input.cull_backfaces, stats, [&](const ScreenTriangle& tri) {
                        ++stats.rasterized;
                        rasterize_triangle(tri, target, stats);
                      });
  }
  stats.raster_ms += ms_since(t0);
}

}  // namespace zbuffer
