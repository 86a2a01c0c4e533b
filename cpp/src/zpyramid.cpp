// Z-pyramid construction, incremental maintenance and queries.
#include "zbuffer/zpyramid.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include "simd.h"

namespace zbuffer {

ZPyramid::ZPyramid(const float* depth, int width, int height, int first_level, bool cleared,
                   int pitch)
    : depth_(depth), pitch0_(size_t(pitch ? pitch : width)), first_(std::max(1, first_level)) {
  pyramid_level_sizes(width, height, widths_, heights_);
  // A pyramid shorter than first_level keeps at least its top level.
  first_ = std::min(first_, std::max(1, levels() - 1));
  offset_.assign(size_t(levels()), 0);
  size_t total = 0;
  for (int k = first_; k < levels(); ++k) {
    offset_[size_t(k)] = total;
    total += size_t(widths_[k]) * size_t(heights_[k]);
  }
  // (One cell more, never a level's: the small-triangle test reads cells
  // in pairs, and a pair at a level's last cell reaches one past it.)
  cells_.assign(total + 1, std::numeric_limits<float>::infinity());
  if (!cleared) rebuild();
}

inline bool ZPyramid::refresh(int k, int i, int j) {
  // The kept level below, and the block of its cells under (i, j).
  const int below = k == first_ ? 0 : k - 1;
  const int shift = k - below;
  const float* cells = level(below);
  const int bw = widths_[below], bh = heights_[below];
  const size_t stride = pitch(below);
  const int x0 = i << shift, y0 = j << shift;
  const int x1 = std::min(bw, x0 + (1 << shift)), y1 = std::min(bh, y0 + (1 << shift));
  float m = cells[size_t(y0) * stride + x0];
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  if (shift == 3 && x1 - x0 == 8) {  // a whole row of 8 pixels per instruction (AVX)
    __m256 v = _mm256_set1_ps(m);
    for (int y = y0; y < y1; ++y) v = _mm256_max_ps(v, _mm256_loadu_ps(cells + size_t(y) * stride + x0));
    __m128 h = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    h = _mm_max_ps(h, _mm_movehl_ps(h, h));
    h = _mm_max_ss(h, _mm_movehdup_ps(h));
    m = _mm_cvtss_f32(h);
  } else
#endif
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) m = std::max(m, cells[size_t(y) * stride + x]);
  float& cell = cells_[offset_[size_t(k)] + size_t(j) * widths_[k] + i];
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

int ZPyramid::refresh_block(int bx, int by, int top, bool& changed) {
  const int x0 = bx << kBlockShift, y0 = by << kBlockShift;
  const int side = 1 << kBlockShift;
  changed = false;
#ifdef ZBUFFER_AVX512
  if (top == 3 && x0 + side <= widths_[0] && y0 + side <= heights_[0]) {
    // The whole block in registers: sixteen rows of sixteen pixels, folded
    // into levels 1 (8 x 8 cells), 2 (4 x 4) and 3 (2 x 2); the kept ones
    // stored.
    const size_t pitch = pitch0_;
    const float* d = depth_ + size_t(y0) * pitch + size_t(x0);
    const __m512i evens = _mm512_set_epi32(30, 28, 26, 24, 22, 20, 18, 16, 14, 12, 10, 8, 6, 4, 2, 0);
    // Level 1: rows 2m and 2m + 1 in lanes 0-7 and 8-15 of l1[m].
    __m512 l1[4];
    for (int m = 0; m < 4; ++m) {
      __m512 rows[2];
      for (int r = 0; r < 2; ++r) {
        const int j = 2 * m + r;
        const __m512 v = _mm512_max_ps(_mm512_loadu_ps(d + size_t(2 * j) * pitch),
                                       _mm512_loadu_ps(d + size_t(2 * j + 1) * pitch));
        rows[r] = _mm512_max_ps(v, _mm512_permute_ps(v, 0xB1));  // pairs of lanes
      }
      l1[m] = _mm512_permutex2var_ps(rows[0], evens, rows[1]);
    }
    int count = 4;
    if (first_ <= 1) {
      float* c = cells_.data() + offset_[1] + size_t(y0 >> 1) * widths_[1] + size_t(x0 >> 1);
      const size_t w = size_t(widths_[1]);
      for (int m = 0; m < 4; ++m) {
        _mm256_storeu_ps(c + size_t(2 * m) * w, _mm512_castps512_ps256(l1[m]));
        _mm256_storeu_ps(c + size_t(2 * m + 1) * w, _mm512_extractf32x8_ps(l1[m], 1));
      }
      count += 64;
    }
    // Level 2: row m in lanes 4m .. 4m + 3 of l2.
    __m512 q[4];
    for (int m = 0; m < 4; ++m) {
      const __m512 t = _mm512_max_ps(l1[m], _mm512_shuffle_f32x4(l1[m], l1[m], 0x4E));
      q[m] = _mm512_max_ps(t, _mm512_permute_ps(t, 0xB1));  // row m in lanes 0, 2, 4, 6
    }
    const __m512i pick = _mm512_set_epi32(0, 0, 0, 0, 0, 0, 0, 0, 22, 20, 18, 16, 6, 4, 2, 0);
    const __m512 l2 = _mm512_shuffle_f32x4(_mm512_permutex2var_ps(q[0], pick, q[1]),
                                           _mm512_permutex2var_ps(q[2], pick, q[3]), 0x44);
    if (first_ <= 2) {
      float* c = cells_.data() + offset_[2] + size_t(y0 >> 2) * widths_[2] + size_t(x0 >> 2);
      const size_t w = size_t(widths_[2]);
      _mm_storeu_ps(c, _mm512_castps512_ps128(l2));
      _mm_storeu_ps(c + w, _mm512_extractf32x4_ps(l2, 1));
      _mm_storeu_ps(c + 2 * w, _mm512_extractf32x4_ps(l2, 2));
      _mm_storeu_ps(c + 3 * w, _mm512_extractf32x4_ps(l2, 3));
      count += 16;
    }
    // Level 3: cells (0, 0), (1, 0), (0, 1), (1, 1) in lanes 0, 2, 8, 10.
    const __m512 t = _mm512_max_ps(l2, _mm512_shuffle_f32x4(l2, l2, 0xB1));
    alignas(64) float l3[16];
    _mm512_store_ps(l3, _mm512_max_ps(t, _mm512_permute_ps(t, 0xB1)));
    float* c = cells_.data() + offset_[3] + size_t(y0 >> 3) * widths_[3] + size_t(x0 >> 3);
    const size_t w = size_t(widths_[3]);
    const float fresh[4] = {l3[0], l3[2], l3[8], l3[10]};
    float* cell[4] = {c, c + 1, c + w, c + w + 1};
    for (int k = 0; k < 4; ++k) {
      changed |= *cell[k] != fresh[k];
      *cell[k] = fresh[k];
    }
    return count;
  }
#elif defined(ZBUFFER_AVX2)
  if (top == 3 && x0 + side <= widths_[0] && y0 + side <= heights_[0]) {
    // As above, 8 lanes wide: level 1 row by row (l1[j]: 8 cells), level 2
    // in the low halves (l2[m]: 4 cells), level 3 in lanes 0 and 2.
    const size_t pitch = pitch0_;
    const float* d = depth_ + size_t(y0) * pitch + size_t(x0);
    __m256 l1[8];
    for (int j = 0; j < 8; ++j) {
      const float* r = d + size_t(2 * j) * pitch;
      __m256 lo = _mm256_max_ps(_mm256_loadu_ps(r), _mm256_loadu_ps(r + pitch));  // pixels 0-7
      __m256 hi = _mm256_max_ps(_mm256_loadu_ps(r + 8), _mm256_loadu_ps(r + pitch + 8));
      lo = _mm256_max_ps(lo, _mm256_permute_ps(lo, 0xB1));  // pairs: cells in lanes 0, 2, 4, 6
      hi = _mm256_max_ps(hi, _mm256_permute_ps(hi, 0xB1));
      // Cells 0 1 4 5 | 2 3 6 7, then the middle pairs swapped.
      const __m256 cells = _mm256_shuffle_ps(lo, hi, _MM_SHUFFLE(2, 0, 2, 0));
      l1[j] = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(cells), _MM_SHUFFLE(3, 1, 2, 0)));
    }
    int count = 4;
    if (first_ <= 1) {
      float* c = cells_.data() + offset_[1] + size_t(y0 >> 1) * widths_[1] + size_t(x0 >> 1);
      for (int j = 0; j < 8; ++j) _mm256_storeu_ps(c + size_t(j) * widths_[1], l1[j]);
      count += 64;
    }
    __m128 l2[4];
    for (int m = 0; m < 4; ++m) {
      __m256 t = _mm256_max_ps(l1[2 * m], l1[2 * m + 1]);
      t = _mm256_max_ps(t, _mm256_permute_ps(t, 0xB1));  // cells in lanes 0, 2, 4, 6
      const __m256 cells = _mm256_shuffle_ps(t, t, _MM_SHUFFLE(2, 0, 2, 0));
      l2[m] = _mm256_castps256_ps128(
          _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(cells), _MM_SHUFFLE(3, 1, 2, 0))));
    }
    if (first_ <= 2) {
      float* c = cells_.data() + offset_[2] + size_t(y0 >> 2) * widths_[2] + size_t(x0 >> 2);
      for (int m = 0; m < 4; ++m) _mm_storeu_ps(c + size_t(m) * widths_[2], l2[m]);
      count += 16;
    }
    float* c = cells_.data() + offset_[3] + size_t(y0 >> 3) * widths_[3] + size_t(x0 >> 3);
    const size_t w = size_t(widths_[3]);
    for (int r = 0; r < 2; ++r) {
      __m128 u = _mm_max_ps(l2[2 * r], l2[2 * r + 1]);
      u = _mm_max_ps(u, _mm_permute_ps(u, 0xB1));  // cells in lanes 0 and 2
      alignas(16) float l3[4];
      _mm_store_ps(l3, u);
      for (int k = 0; k < 2; ++k) {
        float& cell = c[size_t(r) * w + size_t(k)];
        changed |= cell != l3[2 * k];
        cell = l3[2 * k];
      }
    }
    return count;
  }
#endif
  // Level by level, the cells under the block that lie inside the image.
  int count = 0;
  for (int k = first_; k <= top; ++k) {
    const int i0 = x0 >> k, j0 = y0 >> k;
    const int i1 = std::min(widths_[k], (x0 + side) >> k), j1 = std::min(heights_[k], (y0 + side) >> k);
    for (int j = j0; j < j1; ++j)
      for (int i = i0; i < i1; ++i) {
        const bool c = refresh(k, i, j);
        if (k == top) changed |= c;
        ++count;
      }
  }
  return count;
}

int64_t ZPyramid::update_blocks(std::vector<int32_t>& blocks) {
  if (first_ > 3) throw std::logic_error("ZPyramid::update_blocks needs a kept level from 1 to 3");
  const int top = std::min(3, levels() - 1);  // the last level a block holds whole cells of
  if (top < first_) return 0;                 // a 1 x 1 image: no level above 0
  const int blocks_wide = (widths_[0] + (1 << kBlockShift) - 1) >> kBlockShift;
  int64_t count = 0;
  size_t changed_blocks = 0;
  for (const int32_t b : blocks) {
    bool changed;
    count += refresh_block(b % blocks_wide, b / blocks_wide, top, changed);
    if (changed) blocks[changed_blocks++] = b;  // its cell of level 4 comes next
  }
  blocks.resize(changed_blocks);
  if (top == 3 && levels() > 4) count += climb(kBlockShift, blocks);
  blocks.clear();
  return count;
}

int64_t ZPyramid::climb(int k, std::vector<int32_t>& cells) {
  int64_t count = 0;
  for (; k < levels() && !cells.empty(); ++k) {
    // Recompute this level's cells; the parents of those that changed,
    // each listed once, are the next level's work.
    const int w = widths_[k];
    const int parent_w = k + 1 < levels() ? widths_[k + 1] : 1;
    if (k + 1 < levels() && stamp_.size() < size_t(parent_w) * size_t(heights_[k + 1]))
      stamp_.resize(size_t(parent_w) * size_t(heights_[k + 1]), 0);
    ++round_;
    next_.clear();
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

float ZPyramid::max_over_cells(int k, int x0, int y0, int x1, int y1) const {
  const float* cells = level(k);
  const size_t w = pitch(k);
  const int i0 = x0 >> k, i1 = x1 >> k, j0 = y0 >> k, j1 = y1 >> k;
  float m = -std::numeric_limits<float>::infinity();
#ifdef ZBUFFER_AVX512
  // (The lanes past the rectangle masked off, -inf there: a load that
  // kept `v`'s lanes would wait on the maximum before it.)
  const __m512 none = _mm512_set1_ps(m);
  __m512 v = none;
  for (int j = j0; j <= j1; ++j) {
    const float* row = cells + size_t(j) * w;
    for (int i = i0; i <= i1; i += 16) {
      const int n = std::min(16, i1 - i + 1);
      v = _mm512_max_ps(v, _mm512_mask_loadu_ps(none, __mmask16((1u << n) - 1u), row + i));
    }
  }
  m = _mm512_reduce_max_ps(v);
#elif defined(ZBUFFER_AVX2)
  // (The cells past the last 8 of a row one by one.)
  __m256 v = _mm256_set1_ps(m);
  for (int j = j0; j <= j1; ++j) {
    const float* row = cells + size_t(j) * w;
    int i = i0;
    for (; i + 8 <= i1 + 1; i += 8) v = _mm256_max_ps(v, _mm256_loadu_ps(row + i));
    for (; i <= i1; ++i) m = std::max(m, row[i]);
  }
  alignas(32) float lanes[8];
  _mm256_store_ps(lanes, v);
  for (float x : lanes) m = std::max(m, x);
#else
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) m = std::max(m, cells[size_t(j) * w + size_t(i)]);
#endif
  return m;
}

float ZPyramid::max_over(int x0, int y0, int x1, int y1) const {
  const int k = query_level(x0, y0, x1, y1);
  const float* cells = level(k);
  const size_t w = pitch(k);
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
