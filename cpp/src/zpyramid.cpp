// Z-pyramid construction, incremental maintenance and queries.
#include "zbuffer/zpyramid.h"

#include <algorithm>
#include <limits>

#include "simd.h"

namespace zbuffer {

ZPyramid::ZPyramid(const float* depth, int width, int height, int first_level, bool cleared)
    : depth_(depth), first_(std::max(1, first_level)) {
  pyramid_level_sizes(width, height, widths_, heights_);
  // A pyramid shorter than first_level keeps at least its top level.
  first_ = std::min(first_, std::max(1, levels() - 1));
  cells_.resize(size_t(levels()));
  for (int k = first_; k < levels(); ++k)
    cells_[k].assign(size_t(widths_[k]) * size_t(heights_[k]),
                     std::numeric_limits<float>::infinity());
  if (!cleared) rebuild();
}

inline bool ZPyramid::refresh(int k, int i, int j) {
  // The kept level below, and the block of its cells under (i, j).
  const int below = k == first_ ? 0 : k - 1;
  const int shift = k - below;
  const float* cells = level(below);
  const int bw = widths_[below], bh = heights_[below];
  const int x0 = i << shift, y0 = j << shift;
  const int x1 = std::min(bw, x0 + (1 << shift)), y1 = std::min(bh, y0 + (1 << shift));
  float m = cells[size_t(y0) * bw + x0];
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  if (shift == 3 && x1 - x0 == 8) {  // a whole row of 8 pixels per instruction (AVX)
    __m256 v = _mm256_set1_ps(m);
    for (int y = y0; y < y1; ++y) v = _mm256_max_ps(v, _mm256_loadu_ps(cells + size_t(y) * bw + x0));
    __m128 h = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    h = _mm_max_ps(h, _mm_movehl_ps(h, h));
    h = _mm_max_ss(h, _mm_movehdup_ps(h));
    m = _mm_cvtss_f32(h);
  } else
#endif
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) m = std::max(m, cells[size_t(y) * bw + x]);
  float& cell = cells_[k][size_t(j) * widths_[k] + i];
  const bool changed = cell != m;
  cell = m;
  return changed;
}

void ZPyramid::rebuild() {
  if (levels() == 1) return;
  for (int k = first_; k < levels(); ++k)
    for (int j = 0; j < heights_[k]; ++j)
      for (int i = 0; i < widths_[k]; ++i) refresh(k, i, j);
}

int64_t ZPyramid::update(int x0, int y0, int x1, int y1) {
  int64_t count = 0;
  if (levels() == 1) return 0;
  int shift = first_;  // the first kept level is computed from the pixels
  for (int k = first_; k < levels(); ++k) {
    x0 >>= shift;
    y0 >>= shift;
    x1 >>= shift;
    y1 >>= shift;
    shift = 1;
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

int64_t ZPyramid::update_cells(std::vector<int32_t>& cells) {
  int64_t count = 0;
  if (levels() == 1) return 0;
  if (stamp_.size() < cells_[std::min(first_ + 1, levels() - 1)].size())
    stamp_.assign(cells_[std::min(first_ + 1, levels() - 1)].size(), 0);
  for (int k = first_; k < levels() && !cells.empty(); ++k) {
    // Recompute this level's cells; the parents of those that changed,
    // each listed once, are the next level's work.
    ++round_;
    next_.clear();
    const int w = widths_[k];
    const int parent_w = k + 1 < levels() ? widths_[k + 1] : 1;
    for (const int32_t c : cells) {
      const int i = c % w, j = c / w;
      ++count;
      if (!refresh(k, i, j) || k + 1 >= levels()) continue;
      const int32_t parent = (j >> 1) * parent_w + (i >> 1);
      if (stamp_[parent] != round_) {
        stamp_[parent] = round_;
        next_.push_back(parent);
      }
    }
    cells.swap(next_);
  }
  cells.clear();
  return count;
}

float ZPyramid::max_over(int x0, int y0, int x1, int y1) const {
  const int k = query_level(x0, y0, x1, y1);
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
