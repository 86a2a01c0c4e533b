// The hierarchical Z-buffer (Greene, Kass and Miller 1993), image-space part:
// every triangle is tested against the Z-pyramid before it is drawn, and a
// triangle that passes is drawn tile by tile, skipping tiles the pyramid
// shows to be nearer than the whole triangle.
//
// Both tests are strict (the triangle's nearest possible depth, z_lo, must
// be greater than the region's farthest depth), so a culled triangle could
// not have won a single pixel, not even a tie: the output equals the plain
// Z-buffer's bit for bit.
#include <algorithm>
#include <chrono>

#include "zbuffer/algorithms.h"
#include "zbuffer/raster.h"
#include "zbuffer/vertex_stage.h"
#include "zbuffer/zpyramid.h"

namespace zbuffer {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
      .count();
}

constexpr int kTileLevel = 3;  // tiles of 8 x 8 pixels: cells of pyramid level 3
constexpr int kUpdateEvery = 32;  // triangles drawn between pyramid updates
constexpr int kUpdateSpan = 32;   // ...unless their union spans more pixels than this

// The pixel rectangle drawn into since the pyramid was last updated.
// Design decision: the pyramid is brought up to date once per
// kUpdateEvery drawn triangles, over the union of their boxes, rather than
// after every triangle. A pyramid that lags behind the depth buffer only
// holds larger (farther) values, so it culls less, never wrongly; and
// neighbouring triangles (faces are visited in spatial order) share most of
// the cells an update recomputes.
struct DirtyRect {
  int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1, count = 0;
  // Would adding this box make the rectangle too large to be worth sharing?
  bool too_far(int ax0, int ay0, int ax1, int ay1) const {
    return count > 0 && (std::max(x1, ax1) - std::min(x0, ax0) > kUpdateSpan ||
                         std::max(y1, ay1) - std::min(y0, ay0) > kUpdateSpan);
  }
  void add(int ax0, int ay0, int ax1, int ay1) {
    x0 = std::min(x0, ax0);
    y0 = std::min(y0, ay0);
    x1 = std::max(x1, ax1);
    y1 = std::max(y1, ay1);
    ++count;
  }
  int64_t flush(ZPyramid& pyramid) {
    if (count == 0) return 0;
    const int64_t cells = pyramid.update(x0, y0, x1, y1);
    *this = DirtyRect();
    return cells;
  }
};

}  // namespace

void render_hiz(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  const Viewport vp(target.width, target.height);

  auto t0 = std::chrono::steady_clock::now();
  thread_local ScreenVertices screen;
  transform_vertices(input.mesh, input.mvp, vp, screen);
  stats.vertex_ms += ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  ZPyramid pyramid(target.depth, target.width, target.height);  // all +inf
  const bool tiles = pyramid.levels() > kTileLevel;
  const float* tile_max = tiles ? pyramid.level(kTileLevel) : nullptr;
  const int tiles_wide = tiles ? pyramid.width(kTileLevel) : 0;
  DirtyRect dirty;

  for (int64_t f = 0; f < input.mesh.n_faces; ++f) {
    assemble_triangle(
        input.mesh, input.mvp, vp, screen, f, input.cull_backfaces, stats,
        [&](const ScreenTriangle& tri) {
          const TriangleSetup s = setup_triangle(tri, target.width, target.height);
          if (s.x_min > s.x_max || s.y_min > s.y_max) {  // no pixel centre
            ++stats.rasterized;
            return;
          }
          // The triangle test: nearer than the farthest depth under its box?
          if (s.z_lo > pyramid.max_over(s.x_min, s.y_min, s.x_max, s.y_max)) {
            ++stats.culled_hidden;
            return;
          }
          ++stats.rasterized;
          const int tx0 = s.x_min >> kTileLevel, tx1 = s.x_max >> kTileLevel;
          const int ty0 = s.y_min >> kTileLevel, ty1 = s.y_max >> kTileLevel;
          if (!tiles || (tx0 == tx1 && ty0 == ty1)) {
            rasterize_rect(s, s.x_min, s.y_min, s.x_max, s.y_max, target, stats);
          } else {
            // Tile by tile, skipping the tiles already nearer than the
            // whole triangle.
            for (int ty = ty0; ty <= ty1; ++ty)
              for (int tx = tx0; tx <= tx1; ++tx) {
                if (s.z_lo > tile_max[size_t(ty) * tiles_wide + tx]) {
                  ++stats.tiles_skipped;
                  continue;
                }
                const int x0 = std::max(s.x_min, tx << kTileLevel);
                const int x1 = std::min(s.x_max, ((tx + 1) << kTileLevel) - 1);
                const int y0 = std::max(s.y_min, ty << kTileLevel);
                const int y1 = std::min(s.y_max, ((ty + 1) << kTileLevel) - 1);
                rasterize_rect(s, x0, y0, x1, y1, target, stats);
              }
          }
          if (dirty.too_far(s.x_min, s.y_min, s.x_max, s.y_max))
            stats.pyramid_cells_updated += dirty.flush(pyramid);
          dirty.add(s.x_min, s.y_min, s.x_max, s.y_max);
          if (dirty.count >= kUpdateEvery) stats.pyramid_cells_updated += dirty.flush(pyramid);
        });
  }
  stats.pyramid_cells_updated += dirty.flush(pyramid);
  stats.raster_ms += ms_since(t0);
}

}  // namespace zbuffer
