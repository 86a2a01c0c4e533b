// The scanline Z-buffer (Watkins 1970; the "scan-line Z-buffer" of the
// textbooks): the image is walked row by row, top to bottom, and only the
// polygons and edges that cross the current row are looked at. Depth is kept
// for one row only.
//
// It decides which triangles and which pixels of a row to visit; coverage,
// depth and the depth write are the raster core's (raster.h:
// rasterize_span), so its output is bit-identical to every other
// algorithm's. Exactness shapes the edge stepping: a span's first and last
// pixel come from the exact integer edge function under the top-left rule,
// stepped from row to row by an integer DDA (quotient and remainder), never
// from a float x += dx; depth comes from the shared formula of the exact
// edge values at each pixel, never from a float z += dz/dx.
#pragma once

#include <cstdint>
#include <vector>

#include "zbuffer/raster.h"
#include "zbuffer/types.h"
#include "zbuffer/vertex_stage.h"

namespace zbuffer {

// One edge of a triangle, as the edge table stores it and the active edge
// list steps it.
//
// Edge k of a triangle admits the pixels where its biased edge value is
// >= 0 (raster.h). Along a row the value is affine in x with slope step_x,
// so the edge bounds the row's span from one side: x >= x_first when
// step_x > 0 (a "lower" edge, on the left), x <= x_last when step_x < 0.
// The bound on row y is floor(N(y) / div) for an integer N(y) that changes
// by a constant from row to row; the DDA keeps N = q * div + r with
// 0 <= r < div and steps q and r.
//
// Design decision: one entry per edge, holding its own DDA state and the
// index of its polygon. Good: entering, stepping and leaving are local to
// the entry; the bound is exact on every row (integer arithmetic only).
// Bad: 48 bytes an edge with int64 fields, because a nearly horizontal edge
// can have bounds far outside the image (its q stays exact rather than
// clamped).
struct ScanEdge {
  int64_t q, r;    // bound on the current row, and the remainder
  int64_t div;     // > 0
  int64_t dq, dr;  // change of N from one row to the next, as dq * div + dr
  int32_t poly;    // index of its polygon in the polygon store
  int32_t last_row;  // leaves the active list after this row
  bool lower;      // bounds the span from the left (x >= q) or right (x <= q)

  // The next row: N += dq * div + dr.
  void step() {
    q += dq;
    r += dr;
    const bool carry = r >= div;
    r -= carry ? div : 0;
    q += carry;
  }
};

// The tables and active lists of one frame. Reused from frame to frame (the
// vectors keep their memory), one per thread.
class ScanlineTables {
 public:
  // Start a frame of width x height pixels.
  void reset(int width, int height);

  // Insert one assembled triangle (area > 0): an entry of the polygon table
  // and its edges in the edge table. Counts what it inserts. A triangle
  // whose box holds no pixel centre of the image is not inserted.
  void add_triangle(const ScreenTriangle& t, RenderStats& stats);

  // Sort the tables by starting row, walk the rows and draw into target
  // (already cleared to +inf and -1).
  void render(DepthTarget& target, RenderStats& stats);

 private:
  void add_edge(const TriangleSetup& s, int k, int64_t ya, int64_t yb, int32_t poly,
                RenderStats& stats);

  int width_ = 0, height_ = 0;

  // Polygon store and sorted polygon table.
  // Design decision: the store keeps each triangle's raster setup in the
  // order triangles arrive; the polygon table is a list of store indices
  // sorted by starting row (a counting sort: one bucket per row, found by
  // poly_start_[y] .. poly_start_[y + 1]). Good: O(n + H) to build, a row's
  // entering polygons are one contiguous run, and edges can name their
  // polygon before the sort. Bad: one indirection per polygon entering.
  std::vector<TriangleSetup> polys_;
  std::vector<int32_t> poly_row_;      // starting row of each stored polygon
  std::vector<int32_t> poly_table_;    // store indices, sorted by starting row
  std::vector<int32_t> poly_start_;    // (height + 1) bucket offsets

  // Edge table.
  // Design decision: edges are collected unsorted, each initialised for its
  // starting row, then counting-sorted into buckets by that row (like the
  // polygon table). Good: an edge enters the active list as a copy, ready to
  // step. Bad: the edge table holds every edge of the frame at once
  // (O(triangles) memory, as the polygon table; only depth is O(width)).
  std::vector<ScanEdge> edges_;        // unsorted
  std::vector<ScanEdge> edge_table_;   // sorted by starting row
  std::vector<int32_t> edge_row_;      // starting row of each unsorted edge
  std::vector<int32_t> edge_start_;    // (height + 1) bucket offsets

  // Active polygon list and active edge list.
  // Design decision: plain arrays compacted in place once per row (entries
  // whose last row was the current one are dropped while the row is
  // processed); the span of each active polygon lives in span_lo_/span_hi_,
  // indexed by store index, narrowed by its active edges. Good: no
  // allocation while walking, entries stay contiguous for the row loop, and
  // neither list needs to be kept sorted by x because each span is drawn
  // through the depth write, which is order-free. Bad: the span arrays are
  // as long as the polygon store.
  std::vector<int32_t> active_polys_;
  std::vector<ScanEdge> active_edges_;
  std::vector<int32_t> span_lo_, span_hi_;

  // The depth buffer of one row, and the id row written with it.
  // Design decision: O(width) depth storage; after each row its drawn range
  // is copied into the output image and reset. Good: the working depth
  // stays in L1 cache whatever the image size. Bad: a copy of every drawn
  // pixel, once.
  std::vector<float> depth_row_;
  std::vector<int32_t> id_row_;
};

}  // namespace zbuffer
