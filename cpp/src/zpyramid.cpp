// Z-pyramid construction, incremental maintenance and queries.
#include "zbuffer/zpyramid.h"

#include <algorithm>

namespace zbuffer {

ZPyramid::ZPyramid(const float* depth, int width, int height) : depth_(depth) {
  int w = width, h = height;
  widths_.push_back(w);
  heights_.push_back(h);
  while (w > 1 || h > 1) {
    w = (w + 1) / 2;
    h = (h + 1) / 2;
    widths_.push_back(w);
    heights_.push_back(h);
    cells_.emplace_back(size_t(w) * size_t(h));
  }
  rebuild();
}

inline bool ZPyramid::refresh(int k, int i, int j) {
  const float* below = level(k - 1);
  const int bw = widths_[k - 1], bh = heights_[k - 1];
  const int x = 2 * i, y = 2 * j;
  float m = below[size_t(y) * bw + x];
  if (x + 1 < bw) m = std::max(m, below[size_t(y) * bw + x + 1]);
  if (y + 1 < bh) {
    m = std::max(m, below[size_t(y + 1) * bw + x]);
    if (x + 1 < bw) m = std::max(m, below[size_t(y + 1) * bw + x + 1]);
  }
  float& cell = cells_[k - 1][size_t(j) * widths_[k] + i];
  const bool changed = cell != m;
  cell = m;
  return changed;
}

void ZPyramid::rebuild() {
  for (int k = 1; k < levels(); ++k)
    for (int j = 0; j < heights_[k]; ++j)
      for (int i = 0; i < widths_[k]; ++i) refresh(k, i, j);
}

int64_t ZPyramid::update(int x0, int y0, int x1, int y1) {
  int64_t count = 0;
  for (int k = 1; k < levels(); ++k) {
    x0 >>= 1;
    y0 >>= 1;
    x1 >>= 1;
    y1 >>= 1;
    // Recompute the cells over the changed region; carry up only the
    // bounding rectangle of the cells that actually changed.
    int cx0 = x1 + 1, cy0 = y1 + 1, cx1 = x0 - 1, cy1 = y0 - 1;
    for (int j = y0; j <= y1; ++j)
      for (int i = x0; i <= x1; ++i)
        if (refresh(k, i, j)) {
          cx0 = std::min(cx0, i);
          cx1 = std::max(cx1, i);
          cy0 = std::min(cy0, j);
          cy1 = std::max(cy1, j);
        }
    count += int64_t(x1 - x0 + 1) * (y1 - y0 + 1);
    if (cx0 > cx1) break;  // nothing changed: nothing above changes either
    x0 = cx0;
    y0 = cy0;
    x1 = cx1;
    y1 = cy1;
  }
  return count;
}

float ZPyramid::max_over(int x0, int y0, int x1, int y1) const {
  int k = 0;
  while ((x1 >> k) - (x0 >> k) > 1 || (y1 >> k) - (y0 >> k) > 1) ++k;
  const float* cells = level(k);
  const int w = widths_[k];
  const int i0 = x0 >> k, i1 = x1 >> k, j0 = y0 >> k, j1 = y1 >> k;
  float m = cells[size_t(j0) * w + i0];
  if (i1 != i0) m = std::max(m, cells[size_t(j0) * w + i1]);
  if (j1 != j0) {
    m = std::max(m, cells[size_t(j1) * w + i0]);
    if (i1 != i0) m = std::max(m, cells[size_t(j1) * w + i1]);
  }
  return m;
}

}  // namespace zbuffer
