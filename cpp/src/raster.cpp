// The raster core's pixel loop.
#include "zbuffer/raster.h"

namespace zbuffer {

void rasterize_rect(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                    DepthTarget& target, RenderStats& stats) {
  const int64_t dx = x0 - s.x_min, dy = y0 - s.y_min;
  int64_t row[3];
  for (int k = 0; k < 3; ++k)
    row[k] = s.w_origin[k] + dx * s.step_x[k] + dy * s.step_y[k];

  int64_t covered = 0, written = 0;
  for (int y = y0; y <= y1; ++y) {
    int64_t w0 = row[0], w1 = row[1], w2 = row[2];
    const size_t base = size_t(y) * size_t(target.width);
    for (int x = x0; x <= x1; ++x) {
      if ((w0 | w1 | w2) >= 0) {  // all biased edge values >= 0: inside
        ++covered;
        const float z = depth_at(s, w1 + s.bias[1], w2 + s.bias[2]);
        written += depth_write(target.depth, target.triangle_id, base + x, z, s.id);
      }
      w0 += s.step_x[0];
      w1 += s.step_x[1];
      w2 += s.step_x[2];
    }
    row[0] += s.step_y[0];
    row[1] += s.step_y[1];
    row[2] += s.step_y[2];
  }
  stats.pixels_tested += int64_t(x1 - x0 + 1) * (y1 - y0 + 1);
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}

}  // namespace zbuffer
