// Triangle batches: the fast path from faces to pixels.
//
// A batch takes faces (or already assembled triangles), runs the vertex
// stage's assembly and the raster core's setup on them, and draws them with
// the raster core. It changes nothing about *what* is drawn: the rules are
// those of vertex_stage.h and raster.h, and the depth write makes the result
// independent of the order triangles are drawn in. It changes *how fast*.
#pragma once

#include <cstdint>
#include <vector>

#include "zbuffer/raster.h"
#include "zbuffer/types.h"
#include "zbuffer/vertex_stage.h"
#include "zbuffer/zpyramid.h"

namespace zbuffer {

// Design decision: set-up triangles are kept in structure-of-arrays storage
// and sorted into groups by the size of their box, each drawn by a loop of
// fixed length with int32 edge values: triangles less than 8 pixels wide by
// passes of 8 x 2 pixels, less than 16 pixels wide by passes of 16 x 1, in
// both cases with boxes up to 16 rows tall, grouped by their number of row
// pairs. A box whose passes' columns lie in the image (all but those at its
// right edge) needs no masks of its own: a pixel centre outside it is
// outside the triangle, so coverage alone masks the lanes; a row a pass
// covers past the box is masked off at an address of the box's own (AVX2
// builds skip it). Any other triangle keeps its full TriangleSetup and goes
// through rasterize_rect. With AVX-512, sixteen faces are assembled and set
// up per instruction (eight with AVX2). Good: no branch mispredicted per
// triangle (a per-triangle box loop has a varying trip count, and in a
// detailed mesh about half the faces are front faces and half back faces),
// and setting up one triangle never waits for the previous one to be drawn.
// Bad: triangles are drawn in another order than they come in -- harmless
// for depth and ids, but pixels_written depends on it -- and a batch holds
// about 56 KB.
class TriangleBatch {
 public:
  static constexpr int kCapacity = 512;

  // With a pyramid (over target.depth), the batch is a hierarchical Z-buffer:
  // it culls triangles the pyramid proves hidden (strictly: their nearest
  // depth beyond the farthest depth under their box) -- small ones as they
  // are added, before their setup, large ones when drawing --, skips hidden
  // 8x8 tiles of large triangles, and after drawing brings the pyramid up to
  // date over the 16 x 16 blocks it drew into. The pyramid then lags by at
  // most one batch (with set_lazy_upkeep, up to 1 + kMaxSkippedUpdates),
  // which only makes it cull less. Small boxes are tested
  // against the at most 3 x 3 cells of the finest kept level (1 to 3) where
  // they span at most three cells a side: a pyramid kept from level 2 culls
  // more small triangles than one kept from level 3, for more upkeep.
  //
  // `capacity` (16 .. kCapacity) is how many triangles a batch gathers before
  // drawing them; a hierarchical Z-buffer wants small batches so that its
  // pyramid lags little.
  TriangleBatch(DepthTarget& target, RenderStats& stats, ZPyramid* pyramid = nullptr,
                int capacity = kCapacity);
  TriangleBatch(const TriangleBatch&) = delete;
  TriangleBatch& operator=(const TriangleBatch&) = delete;

  // Assemble faces [begin, end) of the mesh (vertex_stage.h: culling,
  // clipping, orientation) and add what survives, counting it in stats.
  void add_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                 const ScreenVertices& sv, int64_t begin, int64_t end, bool cull_backfaces);
  // The same for the faces f in [begin, end) with bucket[f] in [lo, hi)
  // (the others are masked off in the vector steps and never counted);
  // add_faces is this without a bucket filter (bucket null).
  void add_faces_in_buckets(const MeshView& mesh, const double* mvp, const Viewport& vp,
                            const ScreenVertices& sv, int64_t begin, int64_t end,
                            bool cull_backfaces, const int32_t* bucket, int32_t lo, int32_t hi);

  // Add one assembled triangle (area > 0); the caller counts it.
  void add(const ScreenTriangle& t);

  // What a flush does about the pyramid (with one) after drawing: bring it
  // up to date over the blocks drawn into, or not when the lazy upkeep set
  // below says it does not pay (kAsSet); bring it up to date whatever that
  // put off (kNow: a caller about to test against all of it); leave it
  // (kNone: the end of a render -- nothing tests against it any more, and
  // RenderResult.pyramid() is computed from the final depth).
  enum class Upkeep { kAsSet, kNow, kNone };
  // Draw everything added so far and empty the batch. Call before reading
  // the target.
  void flush(Upkeep upkeep = Upkeep::kAsSet);

  // With a pyramid: let flush() skip bringing the pyramid up to date (for
  // up to kMaxSkippedUpdates batches in a row) after a batch tested against
  // an up-to-date pyramid culled under 1/64 of its triangles (a single
  // unoccluded mesh). `hiz` and the tree traversals use it; a traversal then
  // tests nodes against a pyramid a few batches old, which only culls less
  // (where batches cull, every flush brings it up to date).
  void set_lazy_upkeep(bool lazy) { lazy_upkeep_ = lazy; }
  static constexpr int kMaxSkippedUpdates = 3;

  // Triangles added and not drawn yet.
  int pending() const { return n_small_ + int(large_.size()); }

 private:
  // Groups 0-7: narrow (< 8 px wide), 1-8 passes of 8 x 2 pixels.
  // Groups 8-15: wide (< 16 px wide), 2-16 passes of 16 x 1 pixels.
  static constexpr int kGroups = 16;
  static constexpr int kWideGroups = 8;
  static constexpr int kSlack = 16;  // vector stores write 16 entries

  // The group of a box of `rows` rows, narrow or not.
  static int group_of(bool narrow, int rows) { return (narrow ? 0 : kWideGroups) + ((rows - 1) >> 1); }

  // The scalar assembly of face f (vertex_stage.h), counted and added.
  void add_face(const MeshView& mesh, const double* mvp, const Viewport& vp,
                const ScreenVertices& sv, int64_t f, bool cull_backfaces);
  void add_small(int group, const TriangleSetup& s);
  template <int kPasses>
  void draw_narrow(int group, int64_t& covered, int64_t& written);
  template <int kRows>
  void draw_wide(int group, int64_t& covered, int64_t& written);
  struct PassLanes16;  // a small triangle in the lanes of a pass (AVX-512 builds)
  // Whether the batch must be drawn before `incoming` more faces are added:
  // its small triangles stored and culled reach `capacity`, or its large
  // ones (tested when drawn) would pass it.
  bool full(int incoming) const {
    return n_small_ + batch_culled_ + kSlack > capacity_ ||
           large_.size() + size_t(incoming) > size_t(capacity_);
  }
  // Occlusion culling and pyramid upkeep (with a pyramid only). A small
  // triangle is tested as it is added, so a hidden one is never set up for
  // drawing; large ones are tested when the batch is drawn. Both test
  // against the pyramid as the previous batch left it.
  // cull_small: true if the box [x0, x1] x [y0, y1] with nearest depth z_lo
  // is hidden (counted); otherwise marks the blocks under it.
  bool cull_small(int x0, int y0, int x1, int y1, float z_lo);
  // The level small boxes are tested at: the finest kept one (fine_ .. 3)
  // where the box spans at most 3 cells a side.
  int test_level(int x0, int y0, int x1, int y1) const {
    int l = fine_;
    while (l < kTileShift && ((x1 >> l) - (x0 >> l) > 2 || (y1 >> l) - (y0 >> l) > 2)) ++l;
    return l;
  }
  // cull_small for the lanes `candidates` of boxes and depths stored by
  // lane; returns the hidden lanes.
  unsigned cull_lanes(const int32_t* x0, const int32_t* y0, const int32_t* x1, const int32_t* y1,
                      const float* z_lo, unsigned candidates);
  // The same for the small lanes `candidates` of 16 vector-assembled faces
  // (AVX-512 builds, setup16.h's Box16): returns the hidden lanes.
  template <class Box, class Vec, class Mask>
  Mask cull_small16(const Box& box, Vec z_lo, Mask candidates);
  // The same for the 8 lanes of an AVX2 assembly (setup8.h's Box8).
  template <class Box, class Vec>
  unsigned cull_small8(const Box& box, Vec z_lo, unsigned candidates);
  void cull_large();
  // `n` triangles of this batch found hidden (drop_hidden), one of
  // them with its box and level for a cull map (count_hidden).
  void drop_hidden(int n);
  void count_hidden(int level, int x0, int y0, int x1, int y1);
  void draw_large_by_tiles(const TriangleSetup& s);
  void mark_blocks(int x0, int y0, int x1, int y1);
  void update_pyramid();
  // Vector assembly and setup of faces first .. first + count - 1, count
  // <= 16 (AVX-512 builds); only those of `keep` (bit k: face first + k).
  void add_16_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                    const ScreenVertices& sv, int64_t first, bool cull_backfaces, int count,
                    unsigned keep = 0xFFFFu);
  // The same for count <= 8 faces (AVX2 builds).
  void add_8_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                   const ScreenVertices& sv, int64_t first, bool cull_backfaces, int count,
                   unsigned keep = 0xFFu);
  // Vector-set-up faces appended to the structure of arrays (both of the above).
  template <class Put, class PutF, class Box, class Setup, class Vec>
  void store_small(Put put, PutF put_f, const Box& box, const Setup& s, Vec area_b0, Vec ids);
  // What a vector assembly `f` leaves to scalar code (both of the above;
  // simd.h, for_each_left_over): the `large` lanes set up one by one, the
  // faces that need clipping through the scalar assembly.
  template <class Lanes, class Faces>
  void add_unbatched(const Faces& f, unsigned large, const MeshView& mesh, const double* mvp,
                     const Viewport& vp, const ScreenVertices& sv, int64_t first,
                     bool cull_backfaces);

  DepthTarget& target_;
  RenderStats& stats_;
  ZPyramid* pyramid_;
  int capacity_;
  bool lazy_upkeep_ = false;
  int skipped_updates_ = 0;
  bool pyramid_fresh_ = false;  // updated at the end of the last flush
  static constexpr int kTileShift = 3;   // 8 x 8 pixel tiles (pyramid level 3)
  static constexpr int kDirtyShift = 4;  // dirt is tracked by 16 x 16 blocks
  int blocks_wide_ = 0;                   // blocks of 16 x 16 pixels a row
  int dirty_lo_ = 1 << 30, dirty_hi_ = -1;  // rows of blocks marked since the last update
  bool tile_cells_ = false;             // the pyramid keeps 8x8 cells (level 3)
  int fine_ = kTileShift;               // with them: its finest kept level (1 .. 3)
  alignas(64) int32_t level_width_[16] = {};   // by level fine_ .. 3: cells a row
  alignas(64) int32_t level_offset_[16] = {};  // and where it starts in pyramid_->cells()
  int batch_culled_ = 0;                // triangles of this batch found hidden
  std::vector<int32_t> block_dirty_;     // per 16 x 16 block: drawn into since the last update
  std::vector<int32_t> dirty_list_;     // those blocks, listed at update time

  // Small boxes, structure of arrays. Edge values are exact, unbiased, and
  // taken at the centre of the box's first pixel; w0 = area - w1 - w2.
  int n_small_ = 0;
  int64_t small_tested_ = 0;
  alignas(64) int32_t x0_[kCapacity + kSlack], y0_[kCapacity + kSlack];
  alignas(64) int32_t box_w_[kCapacity + kSlack], box_h_[kCapacity + kSlack];
  alignas(64) int32_t w1_[kCapacity + kSlack], w2_[kCapacity + kSlack];
  alignas(64) int32_t area_b0_[kCapacity + kSlack];  // area minus edge 0's bias
  alignas(64) int32_t sx1_[kCapacity + kSlack], sx2_[kCapacity + kSlack];  // steps in x
  alignas(64) int32_t sy1_[kCapacity + kSlack], sy2_[kCapacity + kSlack];  // steps in y
  alignas(64) int32_t bias1_[kCapacity + kSlack], bias2_[kCapacity + kSlack];
  alignas(64) float z0_[kCapacity + kSlack], a1_[kCapacity + kSlack], a2_[kCapacity + kSlack];
  alignas(64) float z_lo_[kCapacity + kSlack], z_hi_[kCapacity + kSlack];
  alignas(64) int32_t id_[kCapacity + kSlack];
  uint16_t group_[kGroups][kCapacity + kSlack];
  int group_size_[kGroups] = {};

  // Everything else: large or wide boxes, int64 edge values.
  std::vector<TriangleSetup> large_;
};

// The pipeline the image-space algorithms share: the vertex stage over all
// vertices, then every face through a TriangleBatch (with `pyramid`, a
// hierarchical Z-buffer, which visits input.cells nearest first if there are
// any). Adds vertex_ms and raster_ms to stats.
void render_faces_batched(const RenderInput& input, DepthTarget& target, RenderStats& stats,
                          ZPyramid* pyramid = nullptr, int capacity = TriangleBatch::kCapacity,
                          bool lazy_upkeep = false);

}  // namespace zbuffer
