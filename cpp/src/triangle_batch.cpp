// Triangle batches: assembly, setup and drawing, grouped by box shape.
//
// The scalar paths call vertex_stage.h's assemble_triangle and raster.h's
// setup_triangle. The AVX-512 paths (16 faces per instruction) and the AVX2
// ones (8) compute the same integers exactly (all fit in int32 or int64
// lanes) and the same IEEE operations on z, so a face ends up with the same
// edge values, fill-rule biases and depth coefficients whichever path set
// it up.
#include "zbuffer/triangle_batch.h"

#include <algorithm>
#include <limits>
#include <type_traits>

#include "zbuffer/mesh_order.h"

#include "setup16.h"
#include "setup8.h"
#include "simd.h"
#include "timing.h"

namespace zbuffer {


void render_faces_batched(const RenderInput& input, DepthTarget& target, RenderStats& stats,
                          ZPyramid* pyramid, int capacity, bool lazy_upkeep) {
  const Viewport vp(target.width, target.height);

  // Vertex stage: each vertex once, however many faces share it.
  const ScreenVertices& screen = transform_mesh(input, vp, stats);

  // Assembly, setup, (culling,) rasterization: every face, in batches.
  const auto t0 = Clock::now();
  TriangleBatch batch(target, stats, pyramid, capacity);
  batch.set_lazy_upkeep(lazy_upkeep);
  if (pyramid && input.cells.n > 0) {
    // Cell by cell, nearest first: the pyramid then culls the back of a
    // mesh behind its front. (Without one, this would only write fewer
    // pixels, and cost a partly filled vector of faces per cell.)
    std::vector<int32_t> visit;
    near_to_far(input.cells, input.mvp, visit);
    for (const int32_t k : visit)
      batch.add_faces(input.mesh, input.mvp, vp, screen, input.cells.start[k],
                      input.cells.start[k + 1], input.cull_backfaces);
  } else {
    batch.add_faces(input.mesh, input.mvp, vp, screen, 0, input.mesh.n_faces,
                    input.cull_backfaces);
  }
  batch.flush(TriangleBatch::Upkeep::kNone);
  stats.raster_ms += ms_since(t0);
}

TriangleBatch::TriangleBatch(DepthTarget& target, RenderStats& stats, ZPyramid* pyramid,
                             int capacity)
    : target_(target), stats_(stats), pyramid_(pyramid),
      capacity_(std::max(16, std::min(capacity, int(kCapacity)))) {
  large_.reserve(kCapacity);
  if (pyramid_) {
    blocks_wide_ = (target.width + (1 << kDirtyShift) - 1) >> kDirtyShift;
    const int blocks_high = (target.height + (1 << kDirtyShift) - 1) >> kDirtyShift;
    block_dirty_.assign(size_t(blocks_wide_) * size_t(blocks_high), 0);
    // The vector test indexes the kept levels with int32: they hold under a
    // third of the image's pixels, at most 2^27 (conventions.h), but a
    // larger target falls back to the rectangle queries.
    const int top = pyramid_->levels() - 1;
    tile_cells_ = pyramid_->first_level() <= kTileShift && top >= kTileShift &&
                  pyramid_->offset(top) < int64_t(std::numeric_limits<int32_t>::max());
    fine_ = tile_cells_ ? pyramid_->first_level() : kTileShift;
    if (tile_cells_)
      for (int l = fine_; l <= kTileShift; ++l) {
        level_width_[l] = pyramid_->width(l);
        level_offset_[l] = int32_t(pyramid_->offset(l));
      }
  }
}

// Scalar Entry Points

void TriangleBatch::add(const ScreenTriangle& t) {
  if (full(1)) flush();
  const TriangleSetup s = setup_triangle(t, target_.width, target_.height);
  const int bw = s.x_max - s.x_min + 1, bh = s.y_max - s.y_min + 1;
  if (bw <= 0 || bh <= 0) return;  // no pixel centre in its box
  int64_t lo_x = t.v[0].x_fx, hi_x = lo_x, lo_y = t.v[0].y_fx, hi_y = lo_y;
  for (int k = 1; k < 3; ++k) {
    lo_x = std::min<int64_t>(lo_x, t.v[k].x_fx);
    hi_x = std::max<int64_t>(hi_x, t.v[k].x_fx);
    lo_y = std::min<int64_t>(lo_y, t.v[k].y_fx);
    hi_y = std::max<int64_t>(hi_y, t.v[k].y_fx);
  }
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  if (hi_x - lo_x < simd::kSmallFx && hi_y - lo_y < simd::kSmallFx) {
    if (pyramid_ && cull_small(s.x_min, s.y_min, s.x_max, s.y_max, s.z_lo)) return;
    add_small(group_of(hi_x - lo_x < simd::kNarrowFx, bh), s);
    return;
  }
#endif
  large_.push_back(s);
}

void TriangleBatch::add_small(int group, const TriangleSetup& s) {
  // A triangle less than 16 pixels across in x and y: every edge value over
  // its box and every step is far below 2^31.
  const int i = n_small_++;
  x0_[i] = s.x_min;
  y0_[i] = s.y_min;
  box_w_[i] = s.x_max - s.x_min + 1;
  box_h_[i] = s.y_max - s.y_min + 1;
  const int64_t w0 = s.w_origin[0] + s.bias[0], w1 = s.w_origin[1] + s.bias[1],
                w2 = s.w_origin[2] + s.bias[2];
  w1_[i] = int32_t(w1);
  w2_[i] = int32_t(w2);
  area_b0_[i] = int32_t(w0 + w1 + w2 - s.bias[0]);
  sx1_[i] = int32_t(s.step_x[1]);
  sx2_[i] = int32_t(s.step_x[2]);
  sy1_[i] = int32_t(s.step_y[1]);
  sy2_[i] = int32_t(s.step_y[2]);
  bias1_[i] = int32_t(s.bias[1]);
  bias2_[i] = int32_t(s.bias[2]);
  z0_[i] = s.z0;
  a1_[i] = s.a1;
  a2_[i] = s.a2;
  z_lo_[i] = s.z_lo;
  z_hi_[i] = s.z_hi;
  id_[i] = s.id;
  group_[group][group_size_[group]++] = uint16_t(i);
  small_tested_ += int64_t(box_w_[i]) * box_h_[i];
}

#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
namespace {
// Assembly reads each face's corners from the screen vertices; on meshes
// of millions of them the reads wait on memory. Two steps ahead, the first
// corner of every other face of a step is fetched (neighbouring faces share
// vertices, numbered by first use): 2-4% off the 5 x 5 x 20 spot grid with
// every algorithm (benchmarks/ab.py), single meshes within noise.
inline void prefetch_corners(const MeshView& mesh, const ScreenVertices& sv, int64_t first,
                             int count) {
  for (int k = 0; k < count; k += 2) {
    const size_t v = size_t(mesh.faces[3 * (first + k)]);
    _mm_prefetch(reinterpret_cast<const char*>(sv.xy.data() + 2 * v), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(sv.z.data() + v), _MM_HINT_T0);
  }
}
}  // namespace
#endif

void TriangleBatch::add_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                              const ScreenVertices& sv, int64_t begin, int64_t end,
                              bool cull_backfaces) {
  add_faces_in_buckets(mesh, mvp, vp, sv, begin, end, cull_backfaces, nullptr, 0, 0);
}

void TriangleBatch::add_faces_in_buckets(const MeshView& mesh, const double* mvp,
                                         const Viewport& vp, const ScreenVertices& sv,
                                         int64_t begin, int64_t end, bool cull_backfaces,
                                         const int32_t* bucket, int32_t lo, int32_t hi) {
  int64_t f = begin;
  // Steps of 16 (8) faces through the vector path, the last few with lanes
  // masked off (small clusters of object-space trees end in such a
  // remainder), and with a bucket filter those outside [lo, hi).
#ifdef ZBUFFER_AVX512
  const __m512i vlo = _mm512_set1_epi32(lo), vhi = _mm512_set1_epi32(hi);
  for (; f < end && mesh.n_vertices > 0; f += 16) {
    const int count = int(std::min<int64_t>(16, end - f));
    if (f + 48 <= end) prefetch_corners(mesh, sv, f + 32, 16);
    const __mmask16 lanes = __mmask16((1u << count) - 1);
    unsigned keep = lanes;
    if (bucket) {
      const __m512i b = _mm512_maskz_loadu_epi32(lanes, bucket + f);
      keep = _mm512_mask_cmpge_epi32_mask(lanes, b, vlo) & _mm512_cmplt_epi32_mask(b, vhi);
      if (!keep) continue;
    }
    add_16_faces(mesh, mvp, vp, sv, f, cull_backfaces, count, keep);
  }
#elif defined(ZBUFFER_AVX2)
  const __m256i below = _mm256_set1_epi32(lo - 1), above = _mm256_set1_epi32(hi);
  for (; f < end && mesh.n_vertices > 0; f += 8) {
    const int count = int(std::min<int64_t>(8, end - f));
    if (f + 24 <= end) prefetch_corners(mesh, sv, f + 16, 8);
    unsigned keep = (1u << count) - 1;
    if (bucket) {
      const __m256i lanes =
          _mm256_cmpgt_epi32(_mm256_set1_epi32(count), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
      const __m256i b = _mm256_maskload_epi32(bucket + f, lanes);
      const __m256i in = _mm256_and_si256(
          _mm256_and_si256(_mm256_cmpgt_epi32(b, below), _mm256_cmpgt_epi32(above, b)), lanes);
      keep = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(in)));
      if (!keep) continue;
    }
    add_8_faces(mesh, mvp, vp, sv, f, cull_backfaces, count, keep);
  }
#endif
  for (; f < end; ++f)
    if (!bucket || (bucket[f] >= lo && bucket[f] < hi))
      add_face(mesh, mvp, vp, sv, f, cull_backfaces);
}

void TriangleBatch::add_face(const MeshView& mesh, const double* mvp, const Viewport& vp,
                             const ScreenVertices& sv, int64_t f, bool cull_backfaces) {
  assemble_triangle(mesh, mvp, vp, sv, f, cull_backfaces, stats_, [&](const ScreenTriangle& t) {
    ++stats_.rasterized;
    add(t);
  });
}

// The fields of vector-set-up faces (setup16.h, setup8.h), through `put`
// (int32 vectors) and `put_f` (float vectors), which store the lanes kept
// at the end of the structure of arrays.
template <class Put, class PutF, class Box, class Setup, class Vec>
void TriangleBatch::store_small(Put put, PutF put_f, const Box& box, const Setup& s, Vec area_b0,
                                Vec ids) {
  put(x0_, box.i0);
  put(y0_, box.j0);
  put(box_w_, box.box_w);
  put(box_h_, box.box_h);
  put(w1_, s.w[1]);
  put(w2_, s.w[2]);
  put(area_b0_, area_b0);
  put(sx1_, s.sx[1]);
  put(sx2_, s.sx[2]);
  put(sy1_, s.sy[1]);
  put(sy2_, s.sy[2]);
  put(bias1_, s.bias[1]);
  put(bias2_, s.bias[2]);
  put_f(z0_, s.z0);
  put_f(a1_, s.a1);
  put_f(a2_, s.a2);
  put_f(z_lo_, s.lo);
  put_f(z_hi_, s.hi);
  put(id_, ids);
}

template <class Lanes, class Faces>
void TriangleBatch::add_unbatched(const Faces& f, unsigned large, const MeshView& mesh,
                                  const double* mvp, const Viewport& vp, const ScreenVertices& sv,
                                  int64_t first, bool cull_backfaces) {
  auto set_up = [&](const ScreenTriangle& t) {
    large_.push_back(setup_triangle(t, target_.width, target_.height));
  };
  simd::for_each_left_over<Lanes>(f, large, mesh, first, set_up, [&](int64_t face) {
    add_face(mesh, mvp, vp, sv, face, cull_backfaces);
  });
}

// Drawing

void TriangleBatch::flush(Upkeep upkeep) {
  if (pyramid_) cull_large();
  const int64_t tested = pending() + batch_culled_;  // every triangle of this batch
  int64_t covered = 0, written = 0;
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  draw_narrow<1>(0, covered, written);
  draw_narrow<2>(1, covered, written);
  draw_narrow<3>(2, covered, written);
  draw_narrow<4>(3, covered, written);
  draw_narrow<5>(4, covered, written);
  draw_narrow<6>(5, covered, written);
  draw_narrow<7>(6, covered, written);
  draw_narrow<8>(7, covered, written);
  draw_wide<2>(8, covered, written);
  draw_wide<4>(9, covered, written);
  draw_wide<6>(10, covered, written);
  draw_wide<8>(11, covered, written);
  draw_wide<10>(12, covered, written);
  draw_wide<12>(13, covered, written);
  draw_wide<14>(14, covered, written);
  draw_wide<16>(15, covered, written);
#endif
  stats_.pixels_tested += small_tested_;
  stats_.pixels_covered += covered;
  stats_.pixels_written += written;
  for (const TriangleSetup& s : large_) {
    if (pyramid_)
      draw_large_by_tiles(s);
    else
      rasterize_rect(s, s.x_min, s.y_min, s.x_max, s.y_max, target_, stats_);
  }
  large_.clear();
  if (pyramid_) {
    // Adaptive upkeep: while the pyramid culls next to nothing (a single
    // unoccluded mesh), bring it up to date only every few batches -- the
    // blocks drawn into meanwhile stay marked and are recomputed once. A
    // pyramid that lags only culls less: depth never increases.
    // Only a test against an up-to-date pyramid says whether testing pays.
    const bool useless = pyramid_fresh_ && batch_culled_ * 64 < tested;
    batch_culled_ = 0;
    if (upkeep == Upkeep::kNone) {
      pyramid_fresh_ = false;  // (the blocks drawn stay marked)
    } else if (upkeep == Upkeep::kAsSet && lazy_upkeep_ &&
               (useless || (skipped_updates_ > 0 && skipped_updates_ < kMaxSkippedUpdates))) {
      ++skipped_updates_;
      pyramid_fresh_ = false;
    } else {
      update_pyramid();
      skipped_updates_ = 0;
      pyramid_fresh_ = true;
    }
  }
  n_small_ = 0;
  small_tested_ = 0;
  for (int& g : group_size_) g = 0;
}

// Occlusion Culling

inline void TriangleBatch::mark_blocks(int x0, int y0, int x1, int y1) {
  dirty_lo_ = std::min(dirty_lo_, y0 >> kDirtyShift);
  dirty_hi_ = std::max(dirty_hi_, y1 >> kDirtyShift);
  for (int ty = y0 >> kDirtyShift; ty <= (y1 >> kDirtyShift); ++ty)
    for (int tx = x0 >> kDirtyShift; tx <= (x1 >> kDirtyShift); ++tx)
      block_dirty_[size_t(ty) * blocks_wide_ + tx] = 1;
}

inline void TriangleBatch::drop_hidden(int n) {
  batch_culled_ += n;
  stats_.culled_hidden += n;
  stats_.rasterized -= n;  // counted when assembled: they are not drawn after all
}

inline void TriangleBatch::count_hidden(int level, int x0, int y0, int x1, int y1) {
  drop_hidden(1);
  pyramid_->count_culled(level, x0, y0, x1, y1, 1);
}

bool TriangleBatch::cull_small(int x0, int y0, int x1, int y1, float z_lo) {
  // Boxes under 16 pixels span at most 3 cells a side at level 3, so
  // test_level is at most 3.
  const int level = tile_cells_ ? test_level(x0, y0, x1, y1) : pyramid_->query_level(x0, y0, x1, y1);
  const float bound = tile_cells_ ? pyramid_->max_over_at(level, x0, y0, x1, y1)
                                  : pyramid_->max_over(x0, y0, x1, y1);
  if (z_lo > bound) {
    count_hidden(level, x0, y0, x1, y1);
    return true;
  }
  mark_blocks(x0, y0, x1, y1);
  return false;
}

unsigned TriangleBatch::cull_lanes(const int32_t* x0, const int32_t* y0, const int32_t* x1,
                                   const int32_t* y1, const float* z_lo, unsigned candidates) {
  unsigned hidden = 0;
  for (unsigned m = candidates; m; m &= m - 1) {
    const int k = __builtin_ctz(m);
    if (cull_small(x0[k], y0[k], x1[k], y1[k], z_lo[k])) hidden |= 1u << k;
  }
  return hidden;
}

void TriangleBatch::cull_large() {
  size_t kept = 0;
  for (const TriangleSetup& s : large_) {
    if (s.z_lo > pyramid_->max_over(s.x_min, s.y_min, s.x_max, s.y_max)) {
      // (The level the test read matters only to a cull map.)
      const int level = pyramid_->recording_culls()
                            ? pyramid_->query_level(s.x_min, s.y_min, s.x_max, s.y_max)
                            : 0;
      count_hidden(level, s.x_min, s.y_min, s.x_max, s.y_max);
      continue;
    }
    large_[kept++] = s;
  }
  large_.resize(kept);
}

#ifdef ZBUFFER_AVX512
namespace {
// The pixel boxes and nearest depths of 16 faces, stored by lane.
struct BoxLanes16 {
  alignas(64) int32_t x0[16], y0[16], x1[16], y1[16];
  alignas(64) float z_lo[16];
  BoxLanes16(const simd::Box16& box, __m512 z) {
    _mm512_store_si512(x0, box.i0);
    _mm512_store_si512(y0, box.j0);
    _mm512_store_si512(x1, box.i1);
    _mm512_store_si512(y1, box.j1);
    _mm512_store_ps(z_lo, z);
  }
};
}  // namespace

// The small boxes of 16 faces (lanes `candidates`) the pyramid proves hidden,
// counted; the blocks under the others are marked for the pyramid update.
// Each box is tested at its test_level: the maximum of the at most 3 x 3
// cells under it against the face's nearest depth.
template <class Box, class Vec, class Mask>
ZBUFFER_INLINE Mask TriangleBatch::cull_small16(const Box& box, Vec z_lo, Mask candidates) {
  if (!tile_cells_) {  // a pyramid without level 3 (a tiny image): one by one
    const BoxLanes16 lanes(box, z_lo);
    return Mask(cull_lanes(lanes.x0, lanes.y0, lanes.x1, lanes.y1, lanes.z_lo, candidates));
  }
  const __m512i one = _mm512_set1_epi32(1), two = _mm512_set1_epi32(2);
  // Each box's level, as test_level finds it.
  __m512i level = _mm512_set1_epi32(fine_);
  for (int l = fine_; l < kTileShift; ++l) {
    const __m512i shift = _mm512_set1_epi32(l);
    auto span = [&](__m512i lo, __m512i hi) {
      return _mm512_sub_epi32(_mm512_srav_epi32(hi, shift), _mm512_srav_epi32(lo, shift));
    };
    const __mmask16 too_wide = _mm512_cmpgt_epi32_mask(span(box.i0, box.i1), two) |
                               _mm512_cmpgt_epi32_mask(span(box.j0, box.j1), two);
    level = _mm512_mask_add_epi32(level, too_wide, level, one);
  }
  const __m512i cells_wide = _mm512_permutexvar_epi32(level, _mm512_load_si512(level_width_));
  const __m512i ci0 = _mm512_srav_epi32(box.i0, level), cj0 = _mm512_srav_epi32(box.j0, level);
  const __m512i ci1 = _mm512_srav_epi32(box.i1, level), cj1 = _mm512_srav_epi32(box.j1, level);
  const __m512i first = _mm512_add_epi32(_mm512_permutexvar_epi32(level, _mm512_load_si512(level_offset_)),
                                         _mm512_add_epi32(_mm512_mullo_epi32(cj0, cells_wide), ci0));
  const float* cells = pyramid_->cells();
  const __m512 none = _mm512_set1_ps(-std::numeric_limits<float>::infinity());
  // A row's first two cells as one 64-bit element (8 lanes a gather: half
  // the elements of two gathers of 16), its third by a gather of its own
  // where a box spans three. The second cell counts only where the box
  // spans it (a pair at a level's last cell reads one cell past it:
  // ZPyramid keeps one more). Lanes not read are -inf, so that no gather
  // waits on another.
  const __mmask16 two_cols = _mm512_cmpgt_epi32_mask(ci1, ci0);
  const __mmask16 three_cols = _mm512_cmpgt_epi32_mask(ci1, _mm512_add_epi32(ci0, one));
  const __m512i even = _mm512_set_epi32(30, 28, 26, 24, 22, 20, 18, 16, 14, 12, 10, 8, 6, 4, 2, 0);
  const __m512i odd = _mm512_add_epi32(even, one);
  const __m512i none_pair = _mm512_castps_si512(none);
  __m512 bound = none;
  __m512i row = first;
  for (int dy = 0; dy < 3; ++dy) {
    const __mmask16 in_rows =
        candidates & _mm512_cmple_epi32_mask(_mm512_add_epi32(cj0, _mm512_set1_epi32(dy)), cj1);
    if (!in_rows) break;
    const __m512i lo = _mm512_mask_i32gather_epi64(none_pair, __mmask8(in_rows),
                                                   _mm512_castsi512_si256(row), cells, 4);
    const __m512i hi = _mm512_mask_i32gather_epi64(none_pair, __mmask8(in_rows >> 8),
                                                   _mm512_extracti64x4_epi64(row, 1), cells, 4);
    bound = _mm512_max_ps(bound, _mm512_castsi512_ps(_mm512_permutex2var_epi32(lo, even, hi)));
    bound = _mm512_mask_max_ps(bound, two_cols, bound,
                               _mm512_castsi512_ps(_mm512_permutex2var_epi32(lo, odd, hi)));
    if (const __mmask16 third = in_rows & three_cols)
      bound = _mm512_max_ps(bound, _mm512_mask_i32gather_ps(none, third, _mm512_add_epi32(row, two),
                                                            cells, 4));
    row = _mm512_add_epi32(row, cells_wide);
  }
  const __mmask16 hidden = candidates & _mm512_cmp_ps_mask(z_lo, bound, _CMP_GT_OQ);
  const __mmask16 shown = candidates & __mmask16(~hidden);
  if (hidden) {
    if (pyramid_->recording_culls()) {  // one by one, with their boxes
      BoxLanes16 lanes(box, z_lo);
      alignas(64) int32_t lv[16];
      _mm512_store_si512(lv, level);
      for (unsigned m = hidden; m; m &= m - 1) {
        const int k = __builtin_ctz(m);
        count_hidden(lv[k], lanes.x0[k], lanes.y0[k], lanes.x1[k], lanes.y1[k]);
      }
    } else {
      drop_hidden(__builtin_popcount(hidden));
    }
  }
  // Mark the 16 x 16 blocks under the survivors' boxes: faces arrive in
  // spatial order, so the blocks of all sixteen mostly form a small
  // rectangle, marked whole (marking a block that was not drawn into only
  // costs its update); otherwise the (at most 2 x 2) blocks of each box.
  if (shown) {
    const __m512i bx0 = _mm512_srai_epi32(box.i0, kDirtyShift);
    const __m512i by0 = _mm512_srai_epi32(box.j0, kDirtyShift);
    const __m512i bx1 = _mm512_srai_epi32(box.i1, kDirtyShift);
    const __m512i by1 = _mm512_srai_epi32(box.j1, kDirtyShift);
    const int lo_x = _mm512_mask_reduce_min_epi32(shown, bx0);
    const int hi_x = _mm512_mask_reduce_max_epi32(shown, bx1);
    const int lo_y = _mm512_mask_reduce_min_epi32(shown, by0);
    const int hi_y = _mm512_mask_reduce_max_epi32(shown, by1);
    dirty_lo_ = std::min(dirty_lo_, lo_y);
    dirty_hi_ = std::max(dirty_hi_, hi_y);
    if ((hi_x - lo_x + 1) * (hi_y - lo_y + 1) <= 4) {
      for (int by = lo_y; by <= hi_y; ++by)
        for (int bx = lo_x; bx <= hi_x; ++bx) block_dirty_[size_t(by) * blocks_wide_ + bx] = 1;
    } else {
      const __m512i blocks_wide = _mm512_set1_epi32(blocks_wide_);
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const __m512i bx = _mm512_add_epi32(bx0, _mm512_set1_epi32(dx));
          const __m512i by = _mm512_add_epi32(by0, _mm512_set1_epi32(dy));
          const __mmask16 m =
              shown & _mm512_cmple_epi32_mask(bx, bx1) & _mm512_cmple_epi32_mask(by, by1);
          if (m)
            _mm512_mask_i32scatter_epi32(block_dirty_.data(), m,
                                         _mm512_add_epi32(_mm512_mullo_epi32(by, blocks_wide), bx),
                                         one, 4);
        }
    }
  }
  return hidden;
}
#elif defined(ZBUFFER_AVX2)
namespace {
// The pixel boxes and nearest depths of 8 faces, stored by lane.
struct BoxLanes8 {
  alignas(32) int32_t x0[8], y0[8], x1[8], y1[8];
  alignas(32) float z_lo[8];
  BoxLanes8(const simd::Box8& box, __m256 z) {
    _mm256_store_si256(reinterpret_cast<__m256i*>(x0), box.i0);
    _mm256_store_si256(reinterpret_cast<__m256i*>(y0), box.j0);
    _mm256_store_si256(reinterpret_cast<__m256i*>(x1), box.i1);
    _mm256_store_si256(reinterpret_cast<__m256i*>(y1), box.j1);
    _mm256_store_ps(z_lo, z);
  }
};
}  // namespace

// cull_small16 for the 8 lanes of an AVX2 assembly (setup8.h's Box8): the
// same levels, cells and comparison, with vector masks for mask registers
// and the blocks of the survivors marked lane by lane (AVX2 has no scatter).
template <class Box, class Vec>
ZBUFFER_INLINE unsigned TriangleBatch::cull_small8(const Box& box, Vec z_lo, unsigned candidates) {
  if (!tile_cells_) {  // a pyramid without level 3 (a tiny image): one by one
    const BoxLanes8 lanes(box, z_lo);
    return cull_lanes(lanes.x0, lanes.y0, lanes.x1, lanes.y1, lanes.z_lo, candidates);
  }
  const __m256i one = _mm256_set1_epi32(1), two = _mm256_set1_epi32(2);
  // Each box's level, as test_level finds it (too_wide lanes are -1).
  __m256i level = _mm256_set1_epi32(fine_);
  for (int l = fine_; l < kTileShift; ++l) {
    const __m128i shift = _mm_cvtsi32_si128(l);
    auto span = [&](__m256i lo, __m256i hi) {
      return _mm256_sub_epi32(_mm256_sra_epi32(hi, shift), _mm256_sra_epi32(lo, shift));
    };
    const __m256i too_wide = _mm256_or_si256(_mm256_cmpgt_epi32(span(box.i0, box.i1), two),
                                             _mm256_cmpgt_epi32(span(box.j0, box.j1), two));
    level = _mm256_sub_epi32(level, too_wide);
  }
  const __m256i cells_wide = _mm256_permutevar8x32_epi32(
      _mm256_load_si256(reinterpret_cast<const __m256i*>(level_width_)), level);
  const __m256i ci0 = _mm256_srav_epi32(box.i0, level), cj0 = _mm256_srav_epi32(box.j0, level);
  const __m256i ci1 = _mm256_srav_epi32(box.i1, level), cj1 = _mm256_srav_epi32(box.j1, level);
  const __m256i first = _mm256_add_epi32(
      _mm256_permutevar8x32_epi32(_mm256_load_si256(reinterpret_cast<const __m256i*>(level_offset_)),
                                  level),
      _mm256_add_epi32(_mm256_mullo_epi32(cj0, cells_wide), ci0));
  const float* cells = pyramid_->cells();
  const __m256i wanted = simd::mask8(candidates);
  const __m256 none = _mm256_set1_ps(-std::numeric_limits<float>::infinity());
  // As in cull_small16: a row's first two cells as one 64-bit element, the
  // second counting only where the box spans it, the third by a gather of
  // its own; lanes not read -inf.
  const __m256i two_cols = _mm256_cmpgt_epi32(ci1, ci0);
  const __m256i three_cols = _mm256_cmpgt_epi32(ci1, _mm256_add_epi32(ci0, one));
  const __m256i split = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
  __m256 bound = none;
  __m256i row = first;
  for (int dy = 0; dy < 3; ++dy) {
    const __m256i in_rows = _mm256_andnot_si256(
        _mm256_cmpgt_epi32(_mm256_add_epi32(cj0, _mm256_set1_epi32(dy)), cj1), wanted);
    if (_mm256_testz_si256(in_rows, in_rows)) break;
    // Each half's pairs, split into first cells (low 128 bits) and second.
    auto pairs = [&](__m128i index, __m128i in) {
      const __m256i mask = _mm256_cvtepi32_epi64(in);
      return _mm256_permutevar8x32_epi32(
          _mm256_mask_i32gather_epi64(_mm256_castps_si256(none),
                                      reinterpret_cast<const long long*>(cells), index, mask, 4),
          split);
    };
    const __m256i lo = pairs(_mm256_castsi256_si128(row), _mm256_castsi256_si128(in_rows));
    const __m256i hi = pairs(_mm256_extracti128_si256(row, 1), _mm256_extracti128_si256(in_rows, 1));
    const __m256 first_cells = _mm256_castsi256_ps(_mm256_permute2x128_si256(lo, hi, 0x20));
    const __m256 second_cells = _mm256_castsi256_ps(_mm256_permute2x128_si256(lo, hi, 0x31));
    bound = _mm256_max_ps(bound, first_cells);
    bound = _mm256_max_ps(bound, _mm256_blendv_ps(none, second_cells, _mm256_castsi256_ps(two_cols)));
    const __m256i third = _mm256_and_si256(in_rows, three_cols);
    if (!_mm256_testz_si256(third, third))
      bound = _mm256_max_ps(bound, _mm256_mask_i32gather_ps(none, cells, _mm256_add_epi32(row, two),
                                                            _mm256_castsi256_ps(third), 4));
    row = _mm256_add_epi32(row, cells_wide);
  }
  const unsigned hidden =
      candidates & unsigned(_mm256_movemask_ps(_mm256_cmp_ps(z_lo, bound, _CMP_GT_OQ)));
  const unsigned shown = candidates & ~hidden;
  const BoxLanes8 lanes(box, z_lo);
  const int32_t *x0 = lanes.x0, *y0 = lanes.y0, *x1 = lanes.x1, *y1 = lanes.y1;
  if (hidden) {
    if (pyramid_->recording_culls()) {  // one by one, with their boxes
      alignas(32) int32_t lv[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(lv), level);
      for (unsigned m = hidden; m; m &= m - 1) {
        const int k = __builtin_ctz(m);
        count_hidden(lv[k], x0[k], y0[k], x1[k], y1[k]);
      }
    } else {
      drop_hidden(__builtin_popcount(hidden));
    }
  }
  // The blocks under the survivors' boxes, as in cull_small16: their
  // rectangle whole when it is small, otherwise box by box.
  if (shown) {
    int lo_x = 1 << 30, hi_x = -1, lo_y = 1 << 30, hi_y = -1;
    for (unsigned m = shown; m; m &= m - 1) {
      const int k = __builtin_ctz(m);
      lo_x = std::min(lo_x, x0[k]);
      hi_x = std::max(hi_x, x1[k]);
      lo_y = std::min(lo_y, y0[k]);
      hi_y = std::max(hi_y, y1[k]);
    }
    if (((hi_x >> kDirtyShift) - (lo_x >> kDirtyShift) + 1) *
            ((hi_y >> kDirtyShift) - (lo_y >> kDirtyShift) + 1) <=
        4) {
      mark_blocks(lo_x, lo_y, hi_x, hi_y);
    } else {
      for (unsigned m = shown; m; m &= m - 1) {
        const int k = __builtin_ctz(m);
        mark_blocks(x0[k], y0[k], x1[k], y1[k]);
      }
    }
  }
  return hidden;
}
#endif

void TriangleBatch::draw_large_by_tiles(const TriangleSetup& s) {
  const int tx0 = s.x_min >> kTileShift, tx1 = s.x_max >> kTileShift;
  const int ty0 = s.y_min >> kTileShift, ty1 = s.y_max >> kTileShift;
  const float* tile_max = tile_cells_ ? pyramid_->level(kTileShift) : nullptr;
  const int tiles_wide = tile_cells_ ? pyramid_->width(kTileShift) : 0;
  // Drawn whole, as without a pyramid: without tiles to skip (no 8 x 8
  // cells kept, or a box in one tile), or where no tile is nearer than the
  // whole triangle (most of a mesh's large triangles). (Walking the latter
  // run by run of tiles regardless cost `hiz` 1.1-1.2x the time on meshes
  // of large triangles: the spans stepped row by row between the runs, and
  // a rectangle set up for every 8 rows; benchmarks/README.md.)
  bool any_nearer = false;
  if (tile_cells_ && (tx0 != tx1 || ty0 != ty1))
    for (int ty = ty0; ty <= ty1 && !any_nearer; ++ty) {
      const float* row = tile_max + size_t(ty) * tiles_wide;
      for (int tx = tx0; tx <= tx1; ++tx) any_nearer |= s.z_lo > row[tx];
    }
  if (!any_nearer) {
    rasterize_rect(s, s.x_min, s.y_min, s.x_max, s.y_max, target_, stats_);
    mark_blocks(s.x_min, s.y_min, s.x_max, s.y_max);
    return;
  }
  // The triangle's exact spans (raster.h), set up once and walked down the
  // rows of tiles: each run of tiles starts from a copy at its first row.
  TriangleSpans spans(s, s.y_min);
  for (int ty = ty0; ty <= ty1; ++ty) {
    const float* row = tile_max + size_t(ty) * tiles_wide;
    const int y0 = std::max(s.y_min, ty << kTileShift);
    const int y1 = std::min(s.y_max, ((ty + 1) << kTileShift) - 1);
    // Runs of tiles not already nearer, each drawn as one rectangle (wide
    // ones by exact spans).
    for (int tx = tx0; tx <= tx1;) {
      if (s.z_lo > row[tx]) {  // already nearer: skip
        ++stats_.tiles_skipped;
        ++tx;
        continue;
      }
      int end = tx + 1;
      while (end <= tx1 && !(s.z_lo > row[end])) ++end;
      const int x0 = std::max(s.x_min, tx << kTileShift);
      const int x1 = std::min(s.x_max, (end << kTileShift) - 1);
      rasterize_rect(s, x0, y0, x1, y1, target_, stats_, &spans);
      mark_blocks(x0, y0, x1, y1);
      tx = end;
    }
    for (int y = y0; y <= y1; ++y) spans.next_row();
  }
}

void TriangleBatch::update_pyramid() {
  const auto t0 = Clock::now();
  // Every 16 x 16 block drawn into since the last update, listed once; the
  // pyramid recomputes its cells from the pixels and climbs from there.
  static_assert(kDirtyShift == ZPyramid::kBlockShift, "dirt is tracked by the pyramid's blocks");
  dirty_list_.clear();
  const int block = 1 << kDirtyShift;
  for (int by = std::max(dirty_lo_, 0); by <= dirty_hi_; ++by) {
    int32_t* row = block_dirty_.data() + size_t(by) * blocks_wide_;
    for (int bx = 0; bx < blocks_wide_; ++bx) {
#ifdef ZBUFFER_AVX512
      // Most blocks are clean: skip them 16 at a time.
      while (bx + 16 <= blocks_wide_ &&
             !_mm512_test_epi32_mask(_mm512_loadu_si512(row + bx), _mm512_set1_epi32(-1)))
        bx += 16;
      if (bx >= blocks_wide_) break;
#endif
      if (!row[bx]) continue;
      row[bx] = 0;
      if (!tile_cells_) {  // a pyramid without level 3: update by rectangle
        const int x0 = bx * block, y0 = by * block;
        stats_.pyramid_cells_updated +=
            pyramid_->update(x0, y0, std::min(x0 + block, target_.width) - 1,
                             std::min(y0 + block, target_.height) - 1);
        continue;
      }
      dirty_list_.push_back(by * blocks_wide_ + bx);
    }
  }
  dirty_lo_ = 1 << 30;
  dirty_hi_ = -1;
  if (tile_cells_) stats_.pyramid_cells_updated += pyramid_->update_blocks(dirty_list_);
  stats_.pyramid_ms += ms_since(t0);
}

#ifdef ZBUFFER_AVX512

// One small triangle in the lanes of a pass: edge values (w0 biased, w1 and
// w2 not) at the pass's pixels, stepped pass by pass, and what the depth
// formula and the depth write need. `col` and `row` place each lane in the
// pass, which covers `rows` rows.
struct TriangleBatch::PassLanes16 {
  __m512i w0b, w1, w2, step0, step1, step2, bias1, bias2, id;
  simd::DepthPlane16 plane;
  float* depth;   // the box's first pixel
  int32_t* ids;
  PassLanes16(const TriangleBatch& b, int i, __m512i col, __m512i row, int rows)
      : plane(b.z0_[i], b.a1_[i], b.a2_[i], b.z_lo_[i], b.z_hi_[i]) {
    w1 = _mm512_add_epi32(_mm512_set1_epi32(b.w1_[i]),
                          _mm512_add_epi32(_mm512_mullo_epi32(col, _mm512_set1_epi32(b.sx1_[i])),
                                           _mm512_mullo_epi32(row, _mm512_set1_epi32(b.sy1_[i]))));
    w2 = _mm512_add_epi32(_mm512_set1_epi32(b.w2_[i]),
                          _mm512_add_epi32(_mm512_mullo_epi32(col, _mm512_set1_epi32(b.sx2_[i])),
                                           _mm512_mullo_epi32(row, _mm512_set1_epi32(b.sy2_[i]))));
    w0b = _mm512_sub_epi32(_mm512_sub_epi32(_mm512_set1_epi32(b.area_b0_[i]), w1), w2);
    step1 = _mm512_set1_epi32(rows * b.sy1_[i]);
    step2 = _mm512_set1_epi32(rows * b.sy2_[i]);
    step0 = _mm512_sub_epi32(_mm512_setzero_si512(), _mm512_add_epi32(step1, step2));
    bias1 = _mm512_set1_epi32(b.bias1_[i]);
    bias2 = _mm512_set1_epi32(b.bias2_[i]);
    id = _mm512_set1_epi32(b.id_[i]);
    const size_t first = size_t(b.x0_[i]) + size_t(b.y0_[i]) * b.target_.row_pitch();
    depth = b.target_.depth + first;
    ids = b.target_.triangle_id + first;
  }
  // Coverage of the lanes of `lanes` (all three biased edge values >= 0)
  // and the depth formula, at this pass.
  __mmask16 covered(__mmask16 lanes) const { return simd::covered16(lanes, w0b, w1, w2, bias1, bias2); }
  __m512 z() const { return simd::depth16(plane, w1, w2); }
  void next() {
    w0b = _mm512_add_epi32(w0b, step0);
    w1 = _mm512_add_epi32(w1, step1);
    w2 = _mm512_add_epi32(w2, step2);
  }
};

// kPasses passes of 8 x 2 pixels cover every box of a group: lanes 0-7 are
// row y, lanes 8-15 row y + 1.
//
// Masks: a pixel centre outside a triangle's box is outside the triangle,
// and a small triangle's edge values stay far inside int32 over its passes,
// so coverage alone masks the lanes wherever the 8 columns of a pass lie in
// the image; only a box at the image's right edge has its lanes masked to
// its columns (their neighbours would be the next row's pixels). A box of an
// odd number of rows has its last pass's second row masked off, at the
// first row's address, so that only rows of the box are addressed. Lanes
// past a row's end at the image's right edge (past the plane, on its last
// row) are masked off: masked moves never touch them (simd::write16_rows).
template <int kPasses>
void TriangleBatch::draw_narrow(int group, int64_t& covered_out, int64_t& written_out) {
  const __m512i lane = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  const __m512i col = _mm512_and_si512(lane, _mm512_set1_epi32(7));
  const __m512i second_row = _mm512_srli_epi32(lane, 3);
  const size_t pitch = target_.row_pitch();
  __m512i covered = _mm512_setzero_si512(), written = _mm512_setzero_si512();
  for (int n = 0; n < group_size_[group]; ++n) {
    const int i = group_[group][n];
    PassLanes16 t(*this, i, col, second_row, 2);
    const unsigned columns = x0_[i] + 8 <= target_.width ? 0xFFu : (1u << box_w_[i]) - 1;
    const __mmask16 box = __mmask16(columns | columns << 8);
    const bool odd = box_h_[i] & 1;
    for (int p = 0; p < kPasses; ++p) {
      const bool half = p == kPasses - 1 && odd;
      const __mmask16 inside = t.covered(half ? __mmask16(box & 0x00FF) : box);
      const size_t row0 = 2 * p * pitch, row1 = half ? row0 : row0 + pitch;
      const __mmask16 win = simd::write16_rows(inside, t.z(), t.id, t.depth + row0, t.depth + row1,
                                               t.ids + row0, t.ids + row1);
      covered = simd::count16(covered, inside);
      written = simd::count16(written, win);
      t.next();
    }
  }
  covered_out += _mm512_reduce_add_epi32(covered);
  written_out += _mm512_reduce_add_epi32(written);
}

// kRows passes of 16 x 1 pixels: lane k is pixel k of a row. Masks as in
// draw_narrow; a box of an odd number of rows has its last pass masked off,
// at the row before.
template <int kRows>
void TriangleBatch::draw_wide(int group, int64_t& covered_out, int64_t& written_out) {
  const __m512i col = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  const size_t pitch = target_.row_pitch();
  __m512i covered = _mm512_setzero_si512(), written = _mm512_setzero_si512();
  for (int n = 0; n < group_size_[group]; ++n) {
    const int i = group_[group][n];
    PassLanes16 t(*this, i, col, _mm512_setzero_si512(), 1);
    const __mmask16 box =
        x0_[i] + 16 <= target_.width ? __mmask16(0xFFFF) : __mmask16((1u << box_w_[i]) - 1);
    const bool odd = box_h_[i] & 1;
    for (int r = 0; r < kRows; ++r) {
      const bool off = r == kRows - 1 && odd;
      const size_t row = size_t(off ? r - 1 : r) * pitch;
      const __mmask16 inside = t.covered(off ? __mmask16(0) : box);
      const __mmask16 win = simd::write16(inside, t.z(), t.id, t.depth + row, t.ids + row);
      covered = simd::count16(covered, inside);
      written = simd::count16(written, win);
      t.next();
    }
  }
  covered_out += _mm512_reduce_add_epi32(covered);
  written_out += _mm512_reduce_add_epi32(written);
}

void TriangleBatch::add_16_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                                 const ScreenVertices& sv, int64_t first, bool cull_backfaces,
                                 int count, unsigned keep) {
  if (full(16)) flush();

  // Assembly and pixel boxes (setup16.h)
  simd::Faces16 f;
  simd::assemble16(mesh, sv, first, count, cull_backfaces, stats_, f, keep);
  simd::Box16 box;
  simd::box16(f, target_.width, target_.height, box);
  __mmask16 vector_setup = f.draw & box.nonempty & box.small;
  const __mmask16 scalar_setup = f.draw & box.nonempty & ~box.small;
  // With a pyramid, hidden small faces go no further.
  if (pyramid_ && vector_setup) vector_setup &= __mmask16(~cull_small16(box, simd::nearest16(f), vector_setup));

  if (vector_setup) {
    simd::Setup16 s;
    simd::setup16(f, box, s);

    // Append the vector-set-up faces to the structure of arrays.
    const int n = n_small_;
    const __mmask16 m = vector_setup;
    auto put = [&](int32_t* dst, __m512i v) {
      _mm512_storeu_si512(dst + n, _mm512_maskz_compress_epi32(m, v));
    };
    auto put_f = [&](float* dst, __m512 v) {
      _mm512_storeu_ps(dst + n, _mm512_maskz_compress_ps(m, v));
    };
    store_small(put, put_f, box, s, _mm512_sub_epi32(s.area32, s.bias[0]),
                simd::ids16(mesh, first, f.live));
    small_tested_ += _mm512_mask_reduce_add_epi32(m, _mm512_mullo_epi32(box.box_w, box.box_h));
    // Groups: narrow ones from 0, wide ones from kWideGroups, by row pairs.
    const __m512i group = _mm512_add_epi32(
        _mm512_maskz_set1_epi32(__mmask16(~box.narrow), kWideGroups),
        _mm512_srai_epi32(_mm512_sub_epi32(box.box_h, _mm512_set1_epi32(1)), 1));
    // Each group present (a few of the 16) takes its faces' slots in one
    // store: a face-by-face loop would chain on its group's size in memory.
    const __m512i slots = _mm512_add_epi32(
        _mm512_set1_epi32(n), _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0));
    const __m512i packed = _mm512_maskz_compress_epi32(m, group);
    const int n_set_up = __builtin_popcount(m);
    for (__mmask16 left = __mmask16((1u << n_set_up) - 1); left;) {
      const int g = _mm_cvtsi128_si32(_mm512_castsi512_si128(
          _mm512_maskz_compress_epi32(left, packed)));
      const __mmask16 in_g = _mm512_mask_cmpeq_epi32_mask(left, packed, _mm512_set1_epi32(g));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(group_[g] + group_size_[g]),
                          _mm512_cvtepi32_epi16(_mm512_maskz_compress_epi32(in_g, slots)));
      group_size_[g] += __builtin_popcount(in_g);
      left &= __mmask16(~in_g);
    }
    n_small_ += n_set_up;
  }

  add_unbatched<simd::Lanes16>(f, scalar_setup, mesh, mvp, vp, sv, first, cull_backfaces);
}

#else  // no AVX-512: AVX2 builds set up 8 faces at a time, scalar builds one

#ifdef ZBUFFER_AVX2

// The groups drawn 8 pixels per instruction. Narrow boxes (at most 8
// pixels wide): at most 4 pixels wide, kPasses passes of two rows of 4
// (lanes 0-3 row r, lanes 4-7 row r + 1); wider, one row a pass. Masks as
// in the AVX-512 loops: coverage alone where the pass's columns lie in the
// image, else lanes masked to the box's columns; a row past the box (the
// last of an odd number) is neither loaded nor stored. Loads and stores are
// of whole vectors (simd::write8: lanes that do not win store back what
// they loaded), except where they would reach past the end of the planes
// or, in planes with padded rows, past the end of the row.
template <int kPasses>
void TriangleBatch::draw_narrow(int group, int64_t& covered, int64_t& written) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i col4 = _mm256_and_si256(lane, _mm256_set1_epi32(3));
  const __m256i row4 = _mm256_srli_epi32(lane, 2);
  const __m256i low_half = _mm256_cmpgt_epi32(_mm256_set1_epi32(4), lane);
  const __m256i all = _mm256_set1_epi32(-1);
  const size_t pitch = target_.row_pitch(), pixels = target_.whole_pixels();
  for (int n = 0; n < group_size_[group]; ++n) {
    const int i = group_[group][n];
    const __m256i area_b0 = _mm256_set1_epi32(area_b0_[i]);
    const __m256i bias1 = _mm256_set1_epi32(bias1_[i]), bias2 = _mm256_set1_epi32(bias2_[i]);
    const simd::DepthPlane8 plane(z0_[i], a1_[i], a2_[i], z_lo_[i], z_hi_[i]);
    const __m256i id = _mm256_set1_epi32(id_[i]);
    const __m256i sx1 = _mm256_set1_epi32(sx1_[i]), sx2 = _mm256_set1_epi32(sx2_[i]);
    const __m256i sy1 = _mm256_set1_epi32(sy1_[i]), sy2 = _mm256_set1_epi32(sy2_[i]);
    const int rows = box_h_[i];
    const size_t first = size_t(x0_[i]) + size_t(y0_[i]) * pitch;
    // The loop twice over, with the passes' columns in the image or not
    // (`in_image`, a compile-time constant in each).
    auto draw = [&](auto in_image_t) {
      constexpr bool in_image = decltype(in_image_t)::value;
      // One pass at pixel `p`: coverage within `lanes`, depth, the depth
      // write (of one row of 8, or two of 4 with `second`), and the step.
      auto pass = [&](__m256i lanes, __m256i& w0b, __m256i& w1, __m256i& w2, size_t p,
                      bool two_rows, bool second, __m256i step0, __m256i step1, __m256i step2) {
        const __m256i inside = simd::covered8x32(lanes, w0b, _mm256_sub_epi32(w1, bias1),
                                                 _mm256_sub_epi32(w2, bias2));
        const __m256 z = simd::depth8x32(plane, w1, w2);
        float* const d = target_.depth + p;
        int32_t* const ids = target_.triangle_id + p;
        const size_t next = second ? pitch : 0;
        const __m256i win =
            two_rows ? simd::write8_rows(inside, z, id, d, d + next, ids, ids + next, second,
                                         in_image || p + next + 4 <= pixels)
                     : simd::write8(inside, z, id, d, ids, in_image || p + 8 <= pixels);
        covered += simd::lanes8(inside);
        written += simd::lanes8(win);
        w0b = _mm256_add_epi32(w0b, step0);
        w1 = _mm256_add_epi32(w1, step1);
        w2 = _mm256_add_epi32(w2, step2);
      };
      if (box_w_[i] <= 4) {
        __m256i w1 = _mm256_add_epi32(
            _mm256_set1_epi32(w1_[i]),
            _mm256_add_epi32(_mm256_mullo_epi32(col4, sx1), _mm256_mullo_epi32(row4, sy1)));
        __m256i w2 = _mm256_add_epi32(
            _mm256_set1_epi32(w2_[i]),
            _mm256_add_epi32(_mm256_mullo_epi32(col4, sx2), _mm256_mullo_epi32(row4, sy2)));
        __m256i w0b = _mm256_sub_epi32(_mm256_sub_epi32(area_b0, w1), w2);
        const __m256i step1 = _mm256_add_epi32(sy1, sy1), step2 = _mm256_add_epi32(sy2, sy2);
        const __m256i step0 = _mm256_sub_epi32(_mm256_setzero_si256(), _mm256_add_epi32(step1, step2));
        const __m256i in_row =
            in_image ? all : _mm256_cmpgt_epi32(_mm256_set1_epi32(box_w_[i]), col4);
        for (int r = 0; r < 2 * kPasses; r += 2) {
          const bool second = r + 1 < rows;
          pass(second ? in_row : _mm256_and_si256(in_row, low_half), w0b, w1, w2,
               first + size_t(r) * pitch, true, second, step0, step1, step2);
        }
      } else {
        __m256i w1 = _mm256_add_epi32(_mm256_set1_epi32(w1_[i]), _mm256_mullo_epi32(lane, sx1));
        __m256i w2 = _mm256_add_epi32(_mm256_set1_epi32(w2_[i]), _mm256_mullo_epi32(lane, sx2));
        __m256i w0b = _mm256_sub_epi32(_mm256_sub_epi32(area_b0, w1), w2);
        const __m256i step0 = _mm256_sub_epi32(_mm256_setzero_si256(), _mm256_add_epi32(sy1, sy2));
        const __m256i in_row =
            in_image ? all : _mm256_cmpgt_epi32(_mm256_set1_epi32(box_w_[i]), lane);
        for (int r = 0; r < 2 * kPasses; ++r) {
          if (r == rows) break;  // the last row of an odd number: past the box
          pass(in_row, w0b, w1, w2, first + size_t(r) * pitch, false, false, step0, sy1, sy2);
        }
      }
    };
    if (x0_[i] + 8 <= target_.width)
      draw(std::true_type{});
    else
      draw(std::false_type{});
  }
}

// Wide boxes (of triangles 8 to 16 pixels across: boxes up to 16 pixels
// wide): kRows passes of a row as two halves;
// masks as in draw_narrow.
template <int kRows>
void TriangleBatch::draw_wide(int group, int64_t& covered, int64_t& written) {
  const __m256i col = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const size_t pitch = target_.row_pitch(), pixels = target_.whole_pixels();
  for (int n = 0; n < group_size_[group]; ++n) {
    const int i = group_[group][n];
    const __m256i sx1 = _mm256_set1_epi32(sx1_[i]), sx2 = _mm256_set1_epi32(sx2_[i]);
    __m256i w0b[2], w1[2], w2[2];
    w1[0] = _mm256_add_epi32(_mm256_set1_epi32(w1_[i]), _mm256_mullo_epi32(col, sx1));
    w2[0] = _mm256_add_epi32(_mm256_set1_epi32(w2_[i]), _mm256_mullo_epi32(col, sx2));
    w1[1] = _mm256_add_epi32(w1[0], _mm256_slli_epi32(sx1, 3));  // 8 pixels on
    w2[1] = _mm256_add_epi32(w2[0], _mm256_slli_epi32(sx2, 3));
    const __m256i area_b0 = _mm256_set1_epi32(area_b0_[i]);
    for (int half = 0; half < 2; ++half)
      w0b[half] = _mm256_sub_epi32(_mm256_sub_epi32(area_b0, w1[half]), w2[half]);
    const __m256i step1 = _mm256_set1_epi32(sy1_[i]), step2 = _mm256_set1_epi32(sy2_[i]);
    const __m256i step0 = _mm256_sub_epi32(_mm256_setzero_si256(), _mm256_add_epi32(step1, step2));
    const __m256i bias1 = _mm256_set1_epi32(bias1_[i]), bias2 = _mm256_set1_epi32(bias2_[i]);
    const simd::DepthPlane8 plane(z0_[i], a1_[i], a2_[i], z_lo_[i], z_hi_[i]);
    const __m256i id = _mm256_set1_epi32(id_[i]);
    const int rows = box_h_[i];
    const size_t first = size_t(x0_[i]) + size_t(y0_[i]) * pitch;
    // The loop twice over, as in draw_narrow.
    auto draw = [&](auto in_image_t) {
      constexpr bool in_image = decltype(in_image_t)::value;
      const __m256i all = _mm256_set1_epi32(-1);
      const __m256i in_row[2] = {
          in_image ? all : _mm256_cmpgt_epi32(_mm256_set1_epi32(box_w_[i]), col),
          in_image ? all : _mm256_cmpgt_epi32(_mm256_set1_epi32(box_w_[i] - 8), col)};
      for (int r = 0; r < kRows; ++r) {
        if (r == rows) break;  // the last row of an odd number: past the box
        const size_t p = first + size_t(r) * pitch;
        const bool whole = in_image || p + 16 <= pixels;
        for (int half = 0; half < 2; ++half) {
          const __m256i inside = simd::covered8x32(in_row[half], w0b[half],
                                                   _mm256_sub_epi32(w1[half], bias1),
                                                   _mm256_sub_epi32(w2[half], bias2));
          const __m256 z = simd::depth8x32(plane, w1[half], w2[half]);
          const __m256i win = simd::write8(inside, z, id, target_.depth + p + 8 * half,
                                           target_.triangle_id + p + 8 * half, whole);
          covered += simd::lanes8(inside);
          written += simd::lanes8(win);
          w0b[half] = _mm256_add_epi32(w0b[half], step0);
          w1[half] = _mm256_add_epi32(w1[half], step1);
          w2[half] = _mm256_add_epi32(w2[half], step2);
        }
      }
    };
    if (x0_[i] + 16 <= target_.width)
      draw(std::true_type{});
    else
      draw(std::false_type{});
  }
}

void TriangleBatch::add_8_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                                const ScreenVertices& sv, int64_t first, bool cull_backfaces,
                                int count, unsigned keep) {
  if (full(8)) flush();

  // Assembly and pixel boxes (setup8.h)
  simd::Faces8 f;
  simd::assemble8(mesh, sv, first, count, cull_backfaces, stats_, f, keep);
  simd::Box8 box;
  simd::box8(f, target_.width, target_.height, box);
  unsigned vector_setup = f.draw & box.nonempty & box.small;
  const unsigned scalar_setup = f.draw & box.nonempty & ~box.small;
  // With a pyramid, hidden small faces go no further.
  if (pyramid_ && vector_setup) vector_setup &= ~cull_small8(box, simd::nearest8(f), vector_setup);

  if (vector_setup) {
    simd::Setup8 s;
    simd::setup8(f, box, s);

    // Append the vector-set-up faces to the structure of arrays.
    const int n = n_small_;
    const unsigned m = vector_setup;
    auto put = [&](int32_t* dst, __m256i v) {
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst + n), simd::compress8(m, v));
    };
    auto put_f = [&](float* dst, __m256 v) {
      put(reinterpret_cast<int32_t*>(dst), _mm256_castps_si256(v));
    };
    store_small(put, put_f, box, s, _mm256_sub_epi32(s.area32, s.bias[0]),
                simd::ids8(mesh, first, f.live));
    const int count_small = __builtin_popcount(m);
    for (int k = 0; k < count_small; ++k) {
      const int i = n + k;
      small_tested_ += int64_t(box_w_[i]) * box_h_[i];
      const int g = group_of(((box.narrow >> simd::kCompress8.lanes[m][k]) & 1u) != 0, box_h_[i]);
      group_[g][group_size_[g]++] = uint16_t(i);
    }
    n_small_ += count_small;
  }

  add_unbatched<simd::Lanes8>(f, scalar_setup, mesh, mvp, vp, sv, first, cull_backfaces);
}

#endif  // (scalar build: no triangle is batched, TriangleBatch::add)

#endif

}  // namespace zbuffer
