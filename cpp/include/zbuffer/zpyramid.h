// The Z-pyramid of Greene, Kass and Miller (SIGGRAPH 1993): a mip-map of the
// depth buffer in which every cell holds the farthest (largest) depth of the
// pixels under it, so that one lookup bounds the depth of a whole region.
#pragma once

#include <cstdint>
#include <vector>

namespace zbuffer {

// Design decision: level 0 is the depth buffer itself (not copied); level k
// (k >= 1) is an owned float array of ceil(w / 2^k) x ceil(h / 2^k) cells,
// each the maximum of its two-by-two children that lie inside the image.
// Never-written pixels are +inf, so regions with holes never cull. Good: a
// query costs at most four loads at the level where the rectangle spans two
// cells a side, and updates climb only while values change. Bad: a third
// again of the depth buffer's memory, and bounds are conservative (a query
// reads whole cells, which may reach past the rectangle).
class ZPyramid {
 public:
  // A pyramid over the (width x height) depth buffer `depth`, built from its
  // current contents.
  ZPyramid(const float* depth, int width, int height);

  int levels() const { return int(widths_.size()); }  // including level 0
  int width(int level) const { return widths_[level]; }
  int height(int level) const { return heights_[level]; }
  const float* level(int k) const { return k == 0 ? depth_ : cells_[k - 1].data(); }

  // Recompute every cell from level 0 (after the depth buffer was rewritten).
  void rebuild();

  // After depth writes inside pixels [x0, x1] x [y0, y1]: recompute the cells
  // above them, level by level, stopping as soon as no cell of a level
  // changed (depth only ever decreases, so an unchanged cell means unchanged
  // ancestors). Returns the number of cells recomputed.
  int64_t update(int x0, int y0, int x1, int y1);

  // An upper bound of the depth over pixels [x0, x1] x [y0, y1] (inside the
  // image): the maximum of the at most 2 x 2 cells covering the rectangle at
  // the finest level where it spans no more than two cells a side.
  float max_over(int x0, int y0, int x1, int y1) const;

 private:
  // Recompute cell (i, j) of level k >= 1 from level k - 1; returns true if
  // its value changed.
  bool refresh(int k, int i, int j);

  const float* depth_;
  std::vector<int> widths_, heights_;
  std::vector<std::vector<float>> cells_;  // levels 1 .. levels() - 1
};

}  // namespace zbuffer
