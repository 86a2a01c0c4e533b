// The scanline Z-buffer (Watkins 1970; the "scan-line Z-buffer" of the
// textbooks): the image is walked row by row, top to bottom, and only the
// polygons and edges that cross the current row are looked at. Depth is kept
// for one row only.
//
// It decides which triangles and which pixels of a row to visit; coverage
// and depth are the raster core's (raster.h: rasterize_span, and the same
// integers and IEEE operations in its own loops), and the depth write is
// the core's rule on a row of (depth, id) keys (row_ below), so its output
// is bit-identical to every other algorithm's. Exactness shapes the edge
// stepping: a span's first and last pixel come from the exact integer edge
// function under the top-left rule, stepped from row to row by an integer
// DDA (quotient and remainder), never from a float x += dx; depth comes
// from the shared formula of the exact edge values at each pixel, never
// from a float z += dz/dx.
//
// AVX-512 builds run the same steps 16 at a time: faces assembled and set
// up 16 per instruction (setup16.h, shared with TriangleBatch), edges
// started, applied and stepped 16 per instruction, and a row's active
// polygons drawn 16 at a time, a polygon per lane (draw_active). AVX2
// builds assemble and set up 8 faces per instruction (setup8.h) and walk
// the rows with the scalar lists. The structures and their order of events
// are the same; tests hold these paths to the scalar ones
// (cpp/tests/test_scanline.cpp).
#pragma once

#include <cstdint>
#include <vector>

#include "zbuffer/raster.h"
#include "zbuffer/types.h"
#include "zbuffer/vertex_stage.h"

namespace zbuffer {

// An edge in the active edge list, stepped from row to row. (General
// polygons' edges use the same DDA for their crossings: slot is then the
// polygon, and q the first pixel at or right of the edge; see
// ScanlineTables::add_polygon.)
//
// Edge k of a triangle admits the pixels where its biased edge value is
// >= 0 (raster.h). Along a row the value is affine in x with slope step_x,
// so the edge bounds the row's span from one side: x >= x_first when
// step_x > 0 (a left edge), x <= x_last when step_x < 0 (a right edge).
// With div = |step_x| and wb0 the biased value at the centre of pixel
// (0, y), both bounds are one formula,
//     q = ceil(-wb0 / div) = floor(N / div),  N = -wb0 + div - 1,
// a left edge admitting x >= q and a right edge x <= -q; from one row to
// the next N changes by the constant -step_y. The DDA keeps
// N = q * div + r with 0 <= r < div and steps q and r: exact integers only.
//
// Design decision: one entry per active edge, holding its DDA state and the
// slot of its polygon's span bound it tightens (bounds[2 p] = first pixel,
// bounds[2 p + 1] = minus the last pixel, each tightened by max; the vector
// lists of AVX-512 builds write them instead, see aedge_ below). Good:
// entering, stepping and leaving are local to the entry, and left and right
// edges are applied by the same branch-free code. Bad: 40 bytes an edge,
// since remainders of edges spanning more than 2^23 sub-pixel rows need
// int64 (q itself fits int32 on every row where the edge is active: the
// bound lies within the edge's x range there).
struct ScanEdge {
  int64_t r;         // remainder, 0 <= r < div
  int64_t div;       // |step_x| > 0
  int64_t dr;        // N changes by dq * div + dr from one row to the next
  int32_t q, dq;     // bound on the current row, and its change
  int32_t slot;      // index into the span bounds: 2 * polygon (+ 1 if right)
  int32_t last_row;  // leaves the active list after this row

  // The next row: N += dq * div + dr.
  void step() {
    r += dr;
    const bool carry = r >= div;
    r -= carry ? div : 0;
    q += dq + int32_t(carry);
  }
};

// An entry of the edge table: which edge of which polygon, and until which
// row it stays active.
//
// Design decision: 12 bytes naming the edge; its DDA state (ScanEdge) is
// computed when it enters the active edge list, from its polygon's record,
// which is in cache then (the polygon entered on the same row or earlier).
// Good: the table that holds every edge of the frame is small, so filling
// and sorting it moves little memory. Bad: the division that starts the
// DDA happens during the row walk rather than before it (in AVX-512 builds
// 16 edges at a time, in binary64: enter_edges).
struct EdgeEntry {
  // Left uninitialised: the vector path grows the table by resize() and
  // fills every field (zeroing it first cost 3% of the render).
  EdgeEntry() {}
  int32_t poly;      // index in the polygon store
  int32_t last_row;  // active through this row
  int32_t k;         // edge k of the triangle, or kKillRow
  static constexpr int32_t kKillRow = 3;  // a bottom edge exactly on a row of centres
};

// A triangle in the polygon store: what the row walk needs to draw its span
// on any row.
//
// Design decision: the raster setup (raster.h: TriangleSetup) cut down to
// int32 edge values at the box's first pixel with int32 steps, when every
// edge value in the box fits (nearly always); the full setup, kept apart,
// otherwise. Good: 88 bytes instead of 136, a span needs no int64
// arithmetic, and every build (the scalar one too) draws spans and starts
// edges from this one record, with no second, random fetch of the full
// setup (bunny_69k, scalar build: 2.6x -> 1.85x the plain Z-buffer). Bad: two
// forms of one triangle; the int32 one is only a faster evaluation of the
// same exact integers. AVX-512 and AVX2 builds write
// the records of faces under 16 pixels across from the vector setups of
// setup16.h and setup8.h (the same integers and floats as setup_triangle's,
// tested), all others through setup_triangle.
struct ScanPolygon {
  ScanPolygon() {}  // uninitialised, as EdgeEntry: every field is written
  int32_t x_min, x_max, y_min, y_max;  // pixel box, inside the image
  int32_t w[3];                        // biased edge values at (x_min, y_min)
  int32_t step_x[3], step_y[3];
  int32_t bias1, bias2;
  float z0, a1, a2, z_lo, z_hi;
  int32_t id;
  int32_t large;  // index into the full setups, or -1 for the int32 form
};
// A record's fields, all 4 bytes: the vector paths move records as rows of
// this many int32.
constexpr int kScanPolygonInts = 22;
static_assert(sizeof(ScanPolygon) == kScanPolygonInts * sizeof(int32_t),
              "ScanPolygon: kScanPolygonInts fields of 4 bytes");

// A polygon face drawn natively (docs/rasterization.md, "Polygons"): its
// coverage is the even-odd rule over its snapped edges, its depth the plane
// of one of its fan triangles.
//
// Design decision: a general polygon keeps its full edge list in the edge
// table, and on each row the crossings of its active edges are sorted and
// paired (even-odd), rather than bounded by one left and one right edge as
// a triangle is. Good: concave polygons, n-gons and self-intersecting
// outlines are drawn by their written definition, not by edge pairs (which
// hold only for convex polygons). Bad: a sort of the crossings per row; the
// cheaper left/right bounds stay for triangles, which are nearly all faces
// of a typical mesh.
struct ScanGeneralPolygon {
  TriangleSetup plane;  // depth plane (a fan triangle), z range and id of the polygon
  int32_t last_row;
};

// Polygons with more corners than this are drawn as their triangles (their
// exact signed area could overflow int64 beyond).
constexpr int kMaxScanPolygonCorners = 4096;

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

  // Assemble faces [begin, end) of the mesh (vertex_stage.h: culling,
  // clipping, orientation) and insert the triangles that survive, counting
  // them in stats. AVX-512 builds assemble and set up 16 faces per
  // instruction (setup16.h), AVX2 builds 8 (setup8.h); the tables end up
  // with the same entries as
  // through assemble_triangle and add_triangle, in another order where
  // faces need clipping or are 16 pixels or more across.
  void add_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                 const ScreenVertices& sv, int64_t begin, int64_t end, bool cull_backfaces,
                 RenderStats& stats);

  // Insert one polygon face (n >= 3 snapped vertices, none needing
  // clipping) with twice its signed area `area` (!= 0), drawn with id `id`
  // (docs/rasterization.md, "Polygons").
  void add_polygon(const ScreenVertex* v, int n, int64_t area, int32_t id, RenderStats& stats);

  // The vector lists gather from the polygon store at int32 offsets (index
  // x 22 ints): a frame with more polygons than this (about 97.6 million)
  // keeps every polygon and edge in the scalar lists instead, as builds
  // without AVX-512 do. (A lower limit may be set, for tests.)
  static constexpr size_t kVectorPolygons = size_t(INT32_MAX) / (sizeof(ScanPolygon) / 4);
  void limit_vector_lists(size_t polygons) { vector_limit_ = polygons; }

  // Sort the tables by starting row, walk the rows and draw into target
  // (already cleared to +inf and -1: rows are written where drawn only).
  void render(DepthTarget& target, RenderStats& stats);

  // Bytes the tables' arrays hold (their capacity), between frames too.
  size_t bytes_held() const;

 private:
  void add_edge(int64_t y_min, int64_t y_max, int64_t step_x, int64_t bias, int k, int64_t ya,
                int64_t yb, int32_t poly, RenderStats& stats);
  void start_edge(const EdgeEntry& entry, int y, ScanEdge& e) const;
  void add_16_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                    const ScreenVertices& sv, int64_t first, int count, bool cull_backfaces,
                    RenderStats& stats);
  void add_8_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                   const ScreenVertices& sv, int64_t first, int count, bool cull_backfaces,
                   RenderStats& stats);
  void add_face(const MeshView& mesh, const double* mvp, const Viewport& vp,
                const ScreenVertices& sv, int64_t f, bool cull_backfaces, RenderStats& stats);
  template <class Lanes, class Faces>
  void add_left_over(const Faces& f, unsigned large, const MeshView& mesh, const double* mvp,
                     const Viewport& vp, const ScreenVertices& sv, int64_t first,
                     bool cull_backfaces, RenderStats& stats);
  void enter_scalar_list(int32_t p);
  struct Counts {
    int64_t tested = 0, covered = 0, written = 0;
  };
  void draw_span(const ScanPolygon& p, int y, int lo, int hi, Counts& counts);

  int width_ = 0, height_ = 0;

  // Polygon store and sorted polygon table.
  // Design decision: the store keeps the triangles in the order they
  // arrive; the polygon table is a list of store indices sorted by starting
  // row (a counting sort: one bucket per row, poly_start_[y] ..
  // poly_start_[y + 1]). Good: O(n + H) to build, a row's entering
  // polygons are one contiguous run, edges can name their polygon before
  // the sort, and meshes in a spatial order keep neighbours near each other
  // in the store. Bad: one indirection per polygon entering.
  std::vector<ScanPolygon> polys_;
  std::vector<TriangleSetup> large_;  // full setups of triangles too big for int32
  std::vector<int32_t> poly_row_;     // starting row of each stored polygon
  std::vector<int32_t> poly_table_;   // store indices, sorted by starting row
  std::vector<int32_t> poly_start_;   // (height + 1) bucket offsets

  // Edge table.
  // Design decision: edges are collected unsorted, then counting-sorted
  // into buckets by starting row (like the polygon table). Good: O(n + H),
  // and a row's entering edges are one contiguous run. Bad: the edge table
  // holds every edge of the frame at once (O(triangles) memory, as the
  // polygon table; only depth is O(width)).
  std::vector<EdgeEntry> edges_;       // unsorted
  std::vector<EdgeEntry> edge_table_;  // sorted by starting row
  std::vector<int32_t> edge_row_;     // starting row of each unsorted edge
  std::vector<int32_t> edge_start_;   // (height + 1) bucket offsets
  std::vector<int32_t> position_;     // scratch of the counting sorts

  // Active polygon list and active edge list: all of them in builds
  // without AVX-512; in AVX-512 builds only the large triangles' (int64
  // setups), the others are in the vector lists below.
  // Design decision: plain arrays compacted in place once per row (entries
  // whose last row was the current one are dropped while the row is
  // processed, without a branch); the span of each active polygon lives in
  // bounds_, indexed by store index: the image's columns, narrowed by its
  // active edges to exactly the covered pixels (add_edge). Good: no
  // allocation while walking, entries stay contiguous, and neither list
  // needs to be kept sorted by x because each span is drawn through the
  // depth write, which is order-free. Bad: the bounds are as long as the
  // polygon store.
  std::vector<int32_t> active_polys_;
  std::vector<ScanEdge> active_edges_;
  std::vector<int32_t> bounds_;

  // The active polygon list of AVX-512 builds, for triangles in the int32
  // form: one array per field (kActiveFields), 16 polygons per step, a
  // polygon in each lane (active_polys_ then keeps only the large ones).
  // Design decision: only what a span's depth needs is copied out of the
  // store when the polygon enters: the unbiased edge values w1, w2 at the
  // centre of pixel (0, y) (wrapping int32: exact wherever the true value
  // fits, as on every pixel of a span), stepped by step_y from row to row,
  // their steps, the depth plane and the id. The span itself comes from the
  // edges (bounds_), exactly: every pixel of it is covered, so no edge value
  // is tested and edge 0 is not kept at all. Good: 14 fields a polygon
  // loaded and compacted per row instead of 21; a row's polygons are loaded
  // by plain vector loads, their short spans drawn 16 at a time pixel by
  // pixel (lane k at pixel lo_k + j: a span of 2 pixels fills 2 passes of
  // 16 lanes, not 2 lanes of a 16-lane pass), the others (longer, or
  // starting at one column with another of the group: their pixels would
  // collide in a scatter) a span at a time, 16 consecutive pixels per pass,
  // from the same fields; compacted by compress. Bad: a record copied once
  // per polygon.
  enum ActiveField {
    kIndex, kYMax, kW1, kW2, kSx1, kSx2, kSy1, kSy2, kZ0, kA1, kA2, kZLo, kZHi, kId,
    kActiveFields
  };
  std::vector<int32_t> active_[kActiveFields];  // floats stored by their bits
  size_t n_active_ = 0;

  // The active edge list of AVX-512 builds, for the edges of triangles in
  // the int32 form (active_edges_ then keeps those of the large ones).
  // Design decision: ScanEdge's fields in int32, one array per field, 16
  // edges started, applied to their bounds and stepped per instruction.
  // int32 holds the DDA of these edges: div = |step_x| < 2^30, so r + dr <
  // 2^31. The bounds are written, not tightened by max: on every row of a
  // triangle's box an edge of each side is active (each side's edges cover
  // its y range), and where two are (the row through their shared vertex,
  // which lies on it) both give the same bound -- the two edges of a side
  // have one sign of dy, hence one bias, and cross the row at the vertex.
  // Only kill entries must win over the edge on their row: they wait in a
  // list of their own (kills_) applied after the edges. Good: 28 bytes an
  // edge instead of 40, no branch, the two divisions that start a DDA done
  // 16 lanes at a time, and a bound costs a scatter -- no gather of the old
  // value, no conflict test, no reset by the polygon (ab.py: bunny_69k
  // 0.95, bunny_10k 0.93, spot 0.95, armadillo_86k 0.99); draw_active
  // clamps the span to the image's columns. Bad: the large triangles'
  // lists, in int64 form, keep the max and the reset.
  enum EdgeField { kER, kEDiv, kEDr, kEQ, kEDq, kESlot, kELast, kEdgeFields };
  std::vector<int32_t> aedge_[kEdgeFields];
  size_t n_aedges_ = 0;
  // Kill entries of the vector list's polygons, entered on this row (the
  // only one they are active on): the left bounds they set past any column
  // once the edges have written theirs.
  std::vector<int32_t> kills_;
  size_t n_kills_ = 0;
  size_t vector_limit_ = kVectorPolygons;
  bool vector_lists_ = false;  // this frame uses the vector lists
  void enter_edges(int y, int32_t begin, int32_t end);
  void step_edges(int y);
  void enter_polygons(int32_t begin, int32_t end);
  void draw_active(int y, Counts& counts, int64_t& spans, int& touched_lo, int& touched_hi);

  // General polygons: their store, sorted table and edge table (full DDA
  // entries: polygon meshes are small), the active lists, and the sorted
  // crossings of the current row, keyed (polygon << 32) | (x + 2^31).
  std::vector<ScanGeneralPolygon> gpolys_;
  std::vector<int32_t> gpoly_row_, gpoly_table_, gpoly_start_;
  std::vector<ScanEdge> gedges_, gedge_table_;
  std::vector<int32_t> gedge_row_, gedge_start_;
  std::vector<int32_t> active_gpolys_;
  std::vector<ScanEdge> active_gedges_;
  std::vector<uint64_t> crossings_;

  // The depth buffer of one row, with the ids written with it: one 64-bit
  // key per pixel, the depth's bits above the id.
  // Design decision: the depth write (the smaller depth, on a tie the
  // smaller id; docs/rasterization.md 3.4) is then the smaller key, compared
  // as unsigned integers (raster.h: depth_write_key; simd.h: write16_keys,
  // write16_keys_at) -- depths are never negative, -0 or NaN, and
  // non-negative floats order as their bits do; an empty pixel (+inf, -1)
  // is the largest key. Good: a row's pixels drawn a polygon per lane
  // (draw_active) cost one gather and one scatter of keys a pass, where
  // separate depth and id rows took a gather and two scatters, and a gather
  // of ids on every tie. Bad: the raster core's span functions write depth
  // and id planes, so the spans of large triangles and general polygons are
  // drawn into the image's row instead (cleared, and written by nothing
  // else), and the key row is merged into it at the row's end rather than
  // copied. O(width) storage either way: after each row its drawn range is
  // copied out and reset, and the working row stays in L1 cache whatever the
  // image size -- drawing every span into the image's own row instead
  // (cold: cleared long before the walk reaches it) was 5-11% slower on
  // bunny_69k and armadillo_86k at 1024x1024 in AVX-512 builds, prefetching
  // it a row ahead won back only 2-3%.
  std::vector<uint64_t> row_;
  float* image_depth_ = nullptr;     // the image's current row: depth
  int32_t* image_ids_ = nullptr;     // ... and ids
  bool drawn_in_image_ = false;      // the raster core drew into it this row
};

// Memory. The tables take 300-550 bytes for each triangle inserted (a
// record, three edge entries, their sorted copies, the active lists'
// fields, and the arrays' growth), so render_scanline refuses
// (std::length_error) a mesh of more than kMaxScanlineTriangles faces (as
// triangles: a polygon of n corners counts n - 2), up to about 9 GB of
// tables, before reading any of it (check_scanline_faces; the Python
// package calls it before preparing the mesh). Each thread
// keeps its tables for its next frame, whose arrays then need neither
// growing nor faulting in (giving them back after every frame made the
// 5 x 5 x 10 spot grid 3.6x slower): up to kKeptScanlineBytes; tables that
// grew past that (frames of more than about 3.5 million triangles inserted)
// are given back when the frame ends, or fails.
constexpr int64_t kMaxScanlineTriangles = int64_t(1) << 24;
constexpr size_t kKeptScanlineBytes = size_t(1) << 30;

// Throws std::length_error, naming the limit and what to use instead, for
// more than kMaxScanlineTriangles faces.
void check_scanline_faces(int64_t n_faces);

// The bytes this thread's tables hold between frames, and (for tests) a
// lower limit than kKeptScanlineBytes for this thread.
size_t scanline_tables_held();
void limit_kept_scanline_bytes(size_t bytes);

}  // namespace zbuffer
