// The plain Z-buffer: every triangle, every pixel of its box (wide boxes by
// exact spans, raster.h: rasterize_rect). It is the baseline
// every other algorithm is measured against, so it takes the fastest path the
// core has (triangle_batch.h).
#include "zbuffer/algorithms.h"
#include "zbuffer/triangle_batch.h"

namespace zbuffer {

void render_zbuffer(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  render_faces_batched(input, target, stats);
}

}  // namespace zbuffer
