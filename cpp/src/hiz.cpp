// The hierarchical Z-buffer (Greene, Kass and Miller 1993), image-space part:
// every triangle is tested against the Z-pyramid before it is drawn, and a
// large triangle that passes is drawn tile by tile, skipping tiles the
// pyramid shows to be nearer than the whole triangle (triangle_batch.h).
//
// Both tests are strict (the triangle's nearest possible depth, z_lo, must
// be greater than the region's farthest depth), so a culled triangle could
// not have won a single pixel, not even a tie: the output equals the plain
// Z-buffer's bit for bit.
#include <algorithm>
#include <chrono>

#include "zbuffer/algorithms.h"
#include "zbuffer/triangle_batch.h"
#include "zbuffer/vertex_stage.h"
#include "zbuffer/zpyramid.h"

namespace zbuffer {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
      .count();
}

// Triangles per batch: each batch is tested against the pyramid as it was
// after the previous one, so smaller batches cull sooner, but cost more
// upkeep: 128 instead of 512 made single unoccluded meshes ~10% slower.
constexpr int kBatch = TriangleBatch::kCapacity;

}  // namespace

void render_hiz(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  const Viewport vp(target.width, target.height);

  auto t0 = std::chrono::steady_clock::now();
  thread_local ScreenVertices screen;
  transform_vertices(input.mesh, input.mvp, vp, screen);
  stats.vertex_ms += ms_since(t0);

  // The batched path with a Z-pyramid over the depth buffer, kept from
  // 8x8-pixel cells (level 3) up: the batch tests triangles against it,
  // skips hidden tiles of large ones, and keeps it up to date.
  t0 = std::chrono::steady_clock::now();
  ZPyramid pyramid(target.depth, target.width, target.height, 3, /*cleared=*/true);
  TriangleBatch batch(target, stats, &pyramid, kBatch);
  batch.add_faces(input.mesh, input.mvp, vp, screen, 0, input.mesh.n_faces,
                  input.cull_backfaces);
  batch.flush();
  stats.raster_ms += ms_since(t0);
}

}  // namespace zbuffer
