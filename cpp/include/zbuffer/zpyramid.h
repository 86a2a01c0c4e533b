// The Z-pyramid of Greene, Kass and Miller (SIGGRAPH 1993): a mip-map of the
// depth buffer in which every cell holds the farthest (largest) depth of the
// pixels under it, so that one lookup bounds the depth of a whole region.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace zbuffer {

class CullMap;

// The sizes of the levels of a pyramid over a width x height image: level 0
// the image, each next one ceil(w / 2) x ceil(h / 2), down to 1 x 1.
inline void pyramid_level_sizes(int width, int height, std::vector<int>& widths,
                                std::vector<int>& heights) {
  widths.assign(1, width);
  heights.assign(1, height);
  while (widths.back() > 1 || heights.back() > 1) {
    widths.push_back((widths.back() + 1) / 2);
    heights.push_back((heights.back() + 1) / 2);
  }
}

// Design decision: level 0 is the depth buffer itself (not copied); level k
// (k >= 1) is an owned float array of ceil(w / 2^k) x ceil(h / 2^k) cells
// (all of them in one allocation, so that one gather can read several),
// each the maximum of its two-by-two children that lie inside the image, i.e.
// of the pixels of its 2^k x 2^k block. Never-written pixels are +inf, so
// regions with holes never cull. Levels 1 .. first_level - 1 may be left
// out: the first kept level is then computed straight from the pixels (an
// algorithm that only asks about 8 x 8 tiles keeps levels 3 and up and does
// less upkeep). Batched upkeep works by 16 x 16 pixel blocks, whose levels
// 1 to 3 fit in registers. Good: a query costs at most four loads at the
// level where the rectangle spans two cells a side (max_over; the batches'
// queries read 3 x 3 cells of a fine level, max_over_at, and the trees' up
// to 16 x 16, max_over_cells), and updates climb only while values change.
// Bad: up to a third again of the depth buffer's memory, and bounds are
// conservative (a query reads whole cells, which may reach past the
// rectangle).
class ZPyramid {
 public:
  // A pyramid over the (width x height) depth buffer `depth`, whose rows
  // start `pitch` pixels apart (0: width, as DepthTarget), built from its
  // current contents (or, with `cleared`, knowing them to be all +inf),
  // keeping levels 0 and first_level and up.
  ZPyramid(const float* depth, int width, int height, int first_level = 1,
           bool cleared = false, int pitch = 0);

  int levels() const { return int(widths_.size()); }  // including level 0
  int first_level() const { return first_; }           // first kept level above 0
  int width(int level) const { return widths_[level]; }
  int height(int level) const { return heights_[level]; }
  // Cells from one row of a level to the next: the depth buffer's pitch at
  // level 0, the width above.
  size_t pitch(int level) const { return level == 0 ? pitch0_ : size_t(widths_[level]); }
  // Cells of a kept level (0, or first_level() and up).
  const float* level(int k) const { return k == 0 ? depth_ : cells_.data() + offset_[size_t(k)]; }
  // All kept levels above 0 lie in one array: level k (>= first_level)
  // starts at cells() + offset(k) (for lookups at several levels at once),
  // followed by one spare cell, so that two neighbouring cells can be read
  // at once anywhere (the second ignored past a row's end).
  const float* cells() const { return cells_.data(); }
  int64_t offset(int k) const { return int64_t(offset_[size_t(k)]); }

  // Bytes of depth storage: the W x H buffer and the levels kept above it.
  int64_t storage_bytes() const {
    int64_t cells = int64_t(widths_[0]) * heights_[0];
    for (int k = first_; k < levels(); ++k) cells += int64_t(widths_[k]) * heights_[k];
    return cells * int64_t(sizeof(float));
  }

  // Recompute every cell from level 0 (after the depth buffer was rewritten).
  void rebuild();

  // After depth writes inside pixels [x0, x1] x [y0, y1]: recompute the cells
  // above them, level by level, stopping as soon as no cell of a level
  // changed (depth only ever decreases, so an unchanged cell means unchanged
  // ancestors). Returns the number of cells recomputed.
  int64_t update(int x0, int y0, int x1, int y1);

  // After depth writes inside the given 16 x 16 pixel blocks (indices
  // by * ceil(width / 16) + bx, each listed once) of a pyramid keeping a
  // level from 1 to 3: recompute the kept levels up to 3 over each block,
  // then, above the blocks where level 3 changed, their ancestors level by
  // level -- each once, however many of its descendants changed -- as long
  // as anything changes. Returns the number of cells recomputed. `blocks` is
  // used as scratch.
  static constexpr int kBlockShift = 4;
  int64_t update_blocks(std::vector<int32_t>& blocks);

  // An upper bound of the depth over pixels [x0, x1] x [y0, y1] (inside the
  // image): the maximum of the at most 2 x 2 cells covering the rectangle at
  // the finest kept level where it spans no more than two cells a side
  // (query_level).
  float max_over(int x0, int y0, int x1, int y1) const;
  int query_level(int x0, int y0, int x1, int y1) const {
    int k = 0;
    while ((x1 >> k) - (x0 >> k) > 1 || (y1 >> k) - (y0 >> k) > 1) k = k == 0 ? first_ : k + 1;
    return k;
  }

  // Recording where tests culled (for display; off unless a map is given):
  // the algorithms that test against this pyramid call count_culled after
  // each test that culled, with the level and pixel rectangle it read.
  void record_culls(CullMap* map) { culls_ = map; }
  bool recording_culls() const { return culls_ != nullptr; }
  inline void count_culled(int level, int x0, int y0, int x1, int y1, int64_t triangles) const;

  // The same bound from the cells of kept level k (>= first_level) alone,
  // for a rectangle spanning at most 3 cells a side there.
  float max_over_at(int k, int x0, int y0, int x1, int y1) const {
    const float* cells = level(k);
    const int w = widths_[k];
    const int i0 = x0 >> k, i1 = x1 >> k, j0 = y0 >> k, j1 = y1 >> k;
    float m = cells[size_t(j0) * w + i0];
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) m = m < cells[size_t(j) * w + i] ? cells[size_t(j) * w + i] : m;
    return m;
  }
  // The same maximum for rectangles of many cells (the tree algorithms' node
  // tests: up to 16 a side), at level 0 or a kept level, a row of cells 16
  // (AVX2: 8) at a time. (max_over_at stays inline and scalar: it tests
  // the small triangles that vector builds test one by one -- with a
  // pyramid lacking level 3 -- and those the scalar build adds.)
  float max_over_cells(int k, int x0, int y0, int x1, int y1) const;

 private:
  // Recompute cell (i, j) of kept level k >= first_level from the kept
  // level below; returns true if its value changed.
  bool refresh(int k, int i, int j);
  // Recompute the kept levels up to `top` (<= 3) over block (bx, by);
  // returns the number of cells recomputed and sets `changed` if a cell of
  // level `top` changed.
  int refresh_block(int bx, int by, int top, bool& changed);
  // Recompute the given cells of level k and, while anything changes, their
  // ancestors (update_blocks). `cells` is used as scratch.
  int64_t climb(int k, std::vector<int32_t>& cells);

  const float* depth_;
  size_t pitch0_;  // of the depth buffer
  int first_;
  std::vector<uint32_t> stamp_;  // per cell of the parent level: the last round that listed it
  uint32_t round_ = 0;
  std::vector<int32_t> next_;
  std::vector<int> widths_, heights_;
  std::vector<float> cells_;     // the kept levels above 0, one after the other, and a spare
  std::vector<size_t> offset_;   // by level: where it starts in cells_ (0 for unkept levels)
  CullMap* culls_ = nullptr;
};

// Where the pyramid culled, cell by cell: for every level of a pyramid over
// a width x height image (levels as ZPyramid's, all of them), the number of
// triangles culled by tests that read the cell -- a triangle culled by the
// maximum of several cells (up to 3 x 3 for a small triangle, 2 x 2 for a
// large one) counts in each of them, a tree node culled whole counts its
// triangles in each of the up to 16 x 16 cells it was tested against. Filled
// only when a render asks for it (record_culls): the hot loops test one
// pointer and otherwise do nothing.
// Design decision: an int64 count per cell of every level, the levels a
// pyramid skips included, in arrays the caller provides (the binding's
// result arrays: counted in place, handed to numpy without a copy). Good:
// a test's counts are added where it read, whatever level that was, and
// the display needs no conversion. Bad: 8 bytes a cell over all levels,
// about 11 bytes a pixel of the image, while a render records (the binding
// allocates them as fresh zero pages, resident only where counted).
class CullMap {
 public:
  // Counts in arrays from `allocate(width, height)`, called once per level k
  // with its size (as pyramid_level_sizes gives them), returning its cells
  // (height x width, row-major), zeroed, to outlive the map.
  template <class Allocate>
  CullMap(int width, int height, Allocate allocate) {
    pyramid_level_sizes(width, height, widths_, heights_);
    for (size_t k = 0; k < widths_.size(); ++k) cells_.push_back(allocate(widths_[k], heights_[k]));
  }
  int levels() const { return int(widths_.size()); }
  int width(int level) const { return widths_[level]; }
  int height(int level) const { return heights_[level]; }
  const int64_t* level(int k) const { return cells_[size_t(k)]; }

  // `triangles` culled by a test that read the cells of `level` covering
  // pixels [x0, x1] x [y0, y1].
  void add(int level, int x0, int y0, int x1, int y1, int64_t triangles) {
    int64_t* cells = cells_[size_t(level)];
    const int w = widths_[size_t(level)];
    for (int j = y0 >> level; j <= (y1 >> level); ++j)
      for (int i = x0 >> level; i <= (x1 >> level); ++i) cells[size_t(j) * w + i] += triangles;
  }

 private:
  std::vector<int> widths_, heights_;
  std::vector<int64_t*> cells_;  // level k's cells
};

inline void ZPyramid::count_culled(int level, int x0, int y0, int x1, int y1,
                                   int64_t triangles) const {
  if (culls_) culls_->add(level, x0, y0, x1, y1, triangles);
}

}  // namespace zbuffer
