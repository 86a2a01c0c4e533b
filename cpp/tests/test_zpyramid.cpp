// The Z-pyramid: cells are the maximum of their children after any sequence
// of writes and updates, and queries bound the depth of their rectangle.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "check.h"
#include "zbuffer/algorithms.h"
#include "zbuffer/zpyramid.h"

using namespace zbuffer;

namespace {

// Every cell of every kept level equals the max of the pixels of its block.
bool consistent(const ZPyramid& p) {
  const float* depth = p.level(0);
  const int w = p.width(0), h = p.height(0);
  for (int k = p.first_level(); k < p.levels(); ++k) {
    const float* cells = p.level(k);
    for (int j = 0; j < p.height(k); ++j)
      for (int i = 0; i < p.width(k); ++i) {
        float m = -std::numeric_limits<float>::infinity();
        for (int y = j << k; y < std::min(h, (j + 1) << k); ++y)
          for (int x = i << k; x < std::min(w, (i + 1) << k); ++x)
            m = std::max(m, depth[size_t(y) * w + x]);
        if (cells[size_t(j) * p.width(k) + i] != m) return false;
      }
  }
  return true;
}

// Lower the depth at random over a random box of at most extent + 1
// pixels a side (depth only decreases, as under the depth write); returns
// the box as {x0, y0, x1, y1}.
std::array<int, 4> lower_random_box(std::vector<float>& depth, int w, int h, Lcg& next,
                                    int extent) {
  const int x0 = int(next(0, w - 1)), y0 = int(next(0, h - 1));
  const int x1 = std::min(w - 1, x0 + int(next(0, extent)));
  const int y1 = std::min(h - 1, y0 + int(next(0, extent)));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      float& d = depth[size_t(y) * w + x];
      d = std::min(d, float(next(0, 1000)) / 1000.0f);
    }
  return {x0, y0, x1, y1};
}

void test_updates_keep_every_cell_the_max_of_its_children() {
  for (int first : {1, 3})
  for (int size : {1, 2, 3, 17, 64, 93}) {
    const int w = size, h = size * 2 / 3 + 1;
    std::vector<float> depth(size_t(w) * h, std::numeric_limits<float>::infinity());
    ZPyramid p(depth.data(), w, h, first);
    CHECK(consistent(p));
    CHECK(p.width(p.levels() - 1) == 1 && p.height(p.levels() - 1) == 1);
    Lcg next{uint64_t(size)};
    for (int t = 0; t < 300; ++t) {
      const auto [x0, y0, x1, y1] = lower_random_box(depth, w, h, next, 9);
      p.update(x0, y0, x1, y1);
    }
    CHECK(consistent(p));
    // Queries bound the true maximum of their rectangle.
    bool bounded = true;
    for (int t = 0; t < 300; ++t) {
      const int x0 = int(next(0, w - 1)), y0 = int(next(0, h - 1));
      const int x1 = int(next(x0, w - 1)), y1 = int(next(y0, h - 1));
      float m = -std::numeric_limits<float>::infinity();
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) m = std::max(m, depth[size_t(y) * w + x]);
      bounded &= p.max_over(x0, y0, x1, y1) >= m;
    }
    CHECK(bounded);
  }
}

// update_blocks, as the triangle batch calls it: depth written anywhere in
// some 16 x 16 blocks, then those blocks listed once. Sizes with and without
// partial blocks at the right and bottom, and images smaller than a block.
void test_block_updates_keep_every_cell_the_max_of_its_children() {
  for (int first : {1, 2, 3})
    for (int size : {5, 9, 16, 37, 64, 100}) {
      const int w = size, h = size * 3 / 4 + 2;
      std::vector<float> depth(size_t(w) * h, std::numeric_limits<float>::infinity());
      ZPyramid p(depth.data(), w, h, first, /*cleared=*/true);
      CHECK(p.first_level() <= first);
      const int blocks_wide = (w + 15) / 16, blocks_high = (h + 15) / 16;
      Lcg next{uint64_t(size * 10 + first)};
      int64_t updated = 0;
      for (int round = 0; round < 60; ++round) {
        std::vector<char> dirty(size_t(blocks_wide) * blocks_high, 0);
        for (int t = 0; t < 8; ++t) {
          const auto [x0, y0, x1, y1] = lower_random_box(depth, w, h, next, 6);
          for (int by = y0 / 16; by <= y1 / 16; ++by)
            for (int bx = x0 / 16; bx <= x1 / 16; ++bx) dirty[size_t(by) * blocks_wide + bx] = 1;
        }
        std::vector<int32_t> blocks;
        for (int b = 0; b < blocks_wide * blocks_high; ++b)
          if (dirty[size_t(b)]) blocks.push_back(b);
        updated += p.update_blocks(blocks);
        CHECK(blocks.empty());
      }
      CHECK(consistent(p));
      CHECK(updated > 0);
    }
}

// max_over_cells reads exactly the cells of its level under the rectangle:
// with every other cell of the level +inf, it returns the maximum of those
// (a read past a row's end, or of another row, would return +inf), for
// rectangles of 1 to 40 cells a side, at each level, on images whose widths
// are and are not multiples of the cells and of the 16 (8) lanes.
void test_max_over_cells_reads_exactly_its_rectangle() {
  Lcg next{7};
  for (const auto& [w, h] : std::vector<std::pair<int, int>>{
           {1, 1}, {3, 2}, {17, 5}, {64, 64}, {93, 61}, {640, 33}, {1029, 7}, {4099, 3}}) {
    std::vector<float> depth(size_t(w) * h, std::numeric_limits<float>::infinity());
    ZPyramid p(depth.data(), w, h, 2);
    std::vector<int> levels = {0};
    for (int k = p.first_level(); k < p.levels(); ++k) levels.push_back(k);
    for (int k : levels) {
      float* cells = k == 0 ? depth.data() : const_cast<float*>(p.level(k));
      const int cw = p.width(k), ch = p.height(k);
      for (int t = 0; t < 200; ++t) {
        const int i0 = int(next(0, cw - 1)), j0 = int(next(0, ch - 1));
        const int i1 = int(next(i0, std::min(cw - 1, i0 + 39)));
        const int j1 = int(next(j0, std::min(ch - 1, j0 + 39)));
        std::fill(cells, cells + size_t(cw) * ch, std::numeric_limits<float>::infinity());
        float want = -std::numeric_limits<float>::infinity();
        for (int j = j0; j <= j1; ++j)
          for (int i = i0; i <= i1; ++i) {
            const float v = next(0, 9) == 0 ? -0.0f : float(next.uniform(0.0, 1.0));
            cells[size_t(j) * cw + i] = v;
            want = std::max(want, v);
          }
        // Any pixel rectangle whose cells at k are i0..i1 x j0..j1.
        const int x0 = std::min(w - 1, (i0 << k) + int(next(0, (1 << k) - 1)));
        const int y0 = std::min(h - 1, (j0 << k) + int(next(0, (1 << k) - 1)));
        const int x1 = std::min(w - 1, (i1 << k) + int(next(0, (1 << k) - 1)));
        const int y1 = std::min(h - 1, (j1 << k) + int(next(0, (1 << k) - 1)));
        CHECK(p.max_over_cells(k, std::max(x0, i0 << k), std::max(y0, j0 << k), x1, y1) == want);
      }
    }
  }
}

// A cull map counts a culled test's triangles in exactly the cells of the
// level it read that cover the test's rectangle, into the caller's arrays,
// and a pyramid with no map records nothing.
void test_cull_map_counts_the_cells_read() {
  const int w = 37, h = 21;  // odd sizes: partial cells at the edges
  std::vector<int> widths, heights;
  pyramid_level_sizes(w, h, widths, heights);
  std::vector<std::vector<int64_t>> counts;
  counts.reserve(widths.size());  // (pointers into them must stay valid)
  std::vector<std::pair<int, int>> asked;
  CullMap map(w, h, [&](int level_w, int level_h) {
    asked.emplace_back(level_w, level_h);
    return counts.emplace_back(size_t(level_w) * level_h, 0).data();
  });
  CHECK(map.levels() == int(widths.size()) && asked.size() == widths.size());
  for (size_t k = 0; k < widths.size(); ++k)
    CHECK(asked[k] == std::make_pair(widths[k], heights[k]) && map.width(int(k)) == widths[k] &&
          map.height(int(k)) == heights[k] && map.level(int(k)) == counts[k].data());

  std::vector<float> depth(size_t(w) * h, 0.5f);
  ZPyramid pyramid(depth.data(), w, h, 1);
  pyramid.count_culled(2, 5, 3, 13, 9, 7);  // no map yet: nothing
  pyramid.record_culls(&map);
  CHECK(pyramid.recording_culls());
  pyramid.count_culled(2, 5, 3, 13, 9, 7);   // cells 1..3 x 0..2 of level 2
  pyramid.count_culled(0, 36, 20, 36, 20, 1);  // the last pixel
  pyramid.count_culled(2, 12, 8, 15, 11, 2);   // cells 3 x 2: overlaps the first
  for (size_t k = 0; k < counts.size(); ++k)
    for (int j = 0; j < heights[k]; ++j)
      for (int i = 0; i < widths[k]; ++i) {
        int64_t expected = 0;
        if (k == 2) expected = (i >= 1 && i <= 3 && j >= 0 && j <= 2 ? 7 : 0) + (i == 3 && j == 2 ? 2 : 0);
        if (k == 0 && i == w - 1 && j == h - 1) expected = 1;
        CHECK(counts[k][size_t(j) * widths[k] + i] == expected);
      }
}

}  // namespace

int main() {
  test_cull_map_counts_the_cells_read();
  test_updates_keep_every_cell_the_max_of_its_children();
  test_block_updates_keep_every_cell_the_max_of_its_children();
  test_max_over_cells_reads_exactly_its_rectangle();
  return check_report("test_zpyramid");
}
