// The scanline Z-buffer (scanline.h): sorted polygon and edge tables, an
// active polygon list and an active edge list, one row of depth.
#include "zbuffer/scanline.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "setup16.h"
#include "setup8.h"
#include "simd.h"
#include "timing.h"
#include "zbuffer/algorithms.h"

namespace zbuffer {

namespace {

#ifdef ZBUFFER_AVX512
// The lanes of a polygon record's fields past its first 16.
constexpr __mmask16 kRecordTail = __mmask16((1u << (kScanPolygonInts - 16)) - 1);

// Transposes a 16 x 16 matrix of int32 held as 16 rows: afterwards r[j]
// holds what was column j (element k of r[j] = old element j of r[k]).
inline void transpose16(__m512i* r) {
  __m512i a[16], b[16];
  for (int k = 0; k < 8; ++k) {  // pairs of rows, 32-bit interleave within 128-bit lanes
    a[2 * k] = _mm512_unpacklo_epi32(r[2 * k], r[2 * k + 1]);
    a[2 * k + 1] = _mm512_unpackhi_epi32(r[2 * k], r[2 * k + 1]);
  }
  for (int m = 0; m < 4; ++m) {  // b[4 m + c], lane L: column 4 L + c of rows 4 m .. 4 m + 3
    b[4 * m] = _mm512_unpacklo_epi64(a[4 * m], a[4 * m + 2]);
    b[4 * m + 1] = _mm512_unpackhi_epi64(a[4 * m], a[4 * m + 2]);
    b[4 * m + 2] = _mm512_unpacklo_epi64(a[4 * m + 1], a[4 * m + 3]);
    b[4 * m + 3] = _mm512_unpackhi_epi64(a[4 * m + 1], a[4 * m + 3]);
  }
  for (int c = 0; c < 4; ++c) {  // 4 x 4 transpose of 128-bit lanes
    const __m512i s0 = _mm512_shuffle_i32x4(b[c], b[4 + c], _MM_SHUFFLE(1, 0, 1, 0));
    const __m512i s1 = _mm512_shuffle_i32x4(b[c], b[4 + c], _MM_SHUFFLE(3, 2, 3, 2));
    const __m512i s2 = _mm512_shuffle_i32x4(b[8 + c], b[12 + c], _MM_SHUFFLE(1, 0, 1, 0));
    const __m512i s3 = _mm512_shuffle_i32x4(b[8 + c], b[12 + c], _MM_SHUFFLE(3, 2, 3, 2));
    r[c] = _mm512_shuffle_i32x4(s0, s2, _MM_SHUFFLE(2, 0, 2, 0));
    r[4 + c] = _mm512_shuffle_i32x4(s0, s2, _MM_SHUFFLE(3, 1, 3, 1));
    r[8 + c] = _mm512_shuffle_i32x4(s1, s3, _MM_SHUFFLE(2, 0, 2, 0));
    r[12 + c] = _mm512_shuffle_i32x4(s1, s3, _MM_SHUFFLE(3, 1, 3, 1));
  }
}
#endif

// Stable counting sort by row: fills start[0 .. height] with bucket offsets
// and position[i] with item i's place in the sorted order.
//
// The items are cut into four blocks, counted and placed side by side, each
// block with counters of its own: consecutive items of a mesh in spatial
// order often share a row, and one counter incremented item after item
// chains every increment to the one before (a store forwarded to the next
// load); four blocks run four chains at once. A row's items stay in their
// order: block by block, each block in order.
void bucket_by_row(const std::vector<int32_t>& row, int height, std::vector<int32_t>& start,
                   std::vector<int32_t>& position) {
  constexpr int kBlocks = 4;
  const size_t n = row.size(), h = size_t(height);
  const size_t block = (n + kBlocks - 1) / kBlocks;
  thread_local std::vector<int32_t> counters;
  counters.assign(kBlocks * h, 0);
  int32_t* c[kBlocks];
  const int32_t* r[kBlocks];
  size_t len[kBlocks];
  for (int b = 0; b < kBlocks; ++b) {
    c[b] = counters.data() + size_t(b) * h;
    const size_t first = std::min(n, size_t(b) * block);
    r[b] = row.data() + first;
    len[b] = std::min(n, first + block) - first;
  }
  const size_t common = len[kBlocks - 1];  // the shortest: the blocks before are full
  // Counts per block and row: the four blocks together, then their rests.
  for (size_t j = 0; j < common; ++j)
    for (int b = 0; b < kBlocks; ++b) ++c[b][r[b][j]];
  for (int b = 0; b < kBlocks; ++b)
    for (size_t j = common; j < len[b]; ++j) ++c[b][r[b][j]];
  // Each block's first place in each row, row by row.
  start.resize(h + 1);
  int32_t at = 0;
  for (size_t y = 0; y < h; ++y) {
    start[y] = at;
    for (int b = 0; b < kBlocks; ++b) {
      const int32_t count = c[b][y];
      c[b][y] = at;
      at += count;
    }
  }
  start[h] = at;
  position.resize(n);
  int32_t* p[kBlocks];
  for (int b = 0; b < kBlocks; ++b) p[b] = position.data() + (r[b] - row.data());
  for (size_t j = 0; j < common; ++j)
    for (int b = 0; b < kBlocks; ++b) p[b][j] = c[b][r[b][j]]++;
  for (int b = 0; b < kBlocks; ++b)
    for (size_t j = common; j < len[b]; ++j) p[b][j] = c[b][r[b][j]]++;
}

// Row pixels [lo, hi] into the image's row (depth, ids) and reset: copied,
// or, where the raster core drew into the image's row too (`merge`), the
// smaller of the two.
void flush_row(uint64_t* row, int lo, int hi, float* depth, int32_t* ids, bool merge) {
  int x = lo;
#ifdef ZBUFFER_AVX512
  const __m512i empty = _mm512_set1_epi64(int64_t(kEmptyDepthKey));
  for (; x <= hi; x += 16) {
    const __mmask16 m = __mmask16(_bzhi_u32(0xFFFF, uint32_t(std::min(hi - x + 1, 16))));
    const __mmask8 m_lo = __mmask8(m), m_hi = __mmask8(m >> 8);
    __m512i k_lo = _mm512_maskz_loadu_epi64(m_lo, row + x);
    __m512i k_hi = _mm512_maskz_loadu_epi64(m_hi, row + x + 8);
    if (merge) {
      __m512i t_lo, t_hi;
      simd::pairs16(_mm512_maskz_loadu_epi32(m, ids + x), _mm512_maskz_loadu_epi32(m, depth + x), t_lo, t_hi);
      k_lo = _mm512_min_epu64(k_lo, t_lo);
      k_hi = _mm512_min_epu64(k_hi, t_hi);
    }
    _mm512_mask_storeu_epi32(depth + x, m, _mm512_permutex2var_epi32(k_lo, _mm512_load_si512(simd::kOdd), k_hi));
    _mm512_mask_storeu_epi32(ids + x, m, _mm512_permutex2var_epi32(k_lo, _mm512_load_si512(simd::kEven), k_hi));
    _mm512_mask_storeu_epi64(row + x, m_lo, empty);
    _mm512_mask_storeu_epi64(row + x + 8, m_hi, empty);
  }
#endif
  for (; x <= hi; ++x) {
    uint64_t key = row[x];
    if (merge) key = std::min(key, depth_key(depth[x], ids[x]));
    const uint32_t bits = uint32_t(key >> 32);
    std::memcpy(&depth[x], &bits, sizeof bits);
    ids[x] = int32_t(uint32_t(key));
    row[x] = kEmptyDepthKey;
  }
}

}  // namespace

size_t ScanlineTables::bytes_held() const {
  size_t bytes = 0;
  auto add = [&](const auto& v) { bytes += v.capacity() * sizeof(v[0]); };
  for (const auto* v : {&poly_row_, &poly_table_, &poly_start_, &edge_row_, &edge_start_,
                        &position_, &active_polys_, &bounds_, &kills_, &gpoly_row_, &gpoly_table_,
                        &gpoly_start_, &gedge_row_, &gedge_start_, &active_gpolys_})
    add(*v);
  for (const auto& v : active_) add(v);
  for (const auto& v : aedge_) add(v);
  add(polys_);
  add(large_);
  add(edges_);
  add(edge_table_);
  add(active_edges_);
  add(gpolys_);
  add(gedges_);
  add(gedge_table_);
  add(active_gedges_);
  add(crossings_);
  add(row_);
  return bytes;
}

void ScanlineTables::reset(int width, int height) {
  width_ = width;
  height_ = height;
  polys_.clear();
  large_.clear();
  poly_row_.clear();
  edges_.clear();
  edge_row_.clear();
  gpolys_.clear();
  gpoly_row_.clear();
  gedges_.clear();
  gedge_row_.clear();
}

// Edge Table Entries

void ScanlineTables::add_edge(int64_t y_min, int64_t y_max, int64_t step_x, int64_t bias, int k,
                              int64_t ya, int64_t yb, int32_t poly, RenderStats& stats) {
  // Rows whose centres lie on the edge's closed y range, within the box.
  // On such a row the edges spanning it give the span exactly; an edge not
  // spanning the row is > 0 all along the span (a zero would be a point of
  // the closed triangle on that edge, at a y outside its range), so its
  // constraint holds without being applied.
  const int64_t first = std::max<int64_t>(first_pixel_at_or_after(std::min(ya, yb)), y_min);
  const int64_t last = std::min<int64_t>(last_pixel_at_or_before(std::max(ya, yb)), y_max);
  if (first > last) return;
  // A horizontal edge exactly on a row of pixel centres: a top edge (bias
  // 0) admits the whole row, a bottom edge (bias 1, edge value 0 there)
  // none of it. Only the latter needs an entry.
  if (step_x == 0 && bias == 0) return;
  EdgeEntry& e = edges_.emplace_back();
  e.poly = poly;
  e.last_row = int32_t(last);
  e.k = step_x == 0 ? EdgeEntry::kKillRow : k;
  edge_row_.push_back(int32_t(first));
  ++stats.edges_inserted;
}

// The DDA of an edge entering the active list at row y (its first row),
// written into e field by field (a returned struct copied whole into the
// list stalled on store forwarding).
void ScanlineTables::start_edge(const EdgeEntry& entry, int y, ScanEdge& e) const {
  e.last_row = entry.last_row;
  if (entry.k == EdgeEntry::kKillRow) {
    // A left bound beyond any column, for this one row.
    e.slot = 2 * entry.poly;
    e.q = int32_t(1) << 30;
    e.dq = 0;
    e.r = e.dr = 0;
    e.div = 1;
    return;
  }
  const ScanPolygon& p = polys_[size_t(entry.poly)];
  const int k = entry.k;
  int64_t w, sx, sy;
  if (p.large >= 0) {
    const TriangleSetup& s = large_[size_t(p.large)];
    w = s.w_origin[k];
    sx = s.step_x[k];
    sy = s.step_y[k];
  } else {
    w = p.w[k];
    sx = p.step_x[k];
    sy = p.step_y[k];
  }
  // q = floor(N / div) with N = -wb0 + div - 1, wb0 the biased edge value
  // at the centre of pixel (0, y); N changes by -step_y a row.
  const int64_t wb0 = w + (0 - int64_t(p.x_min)) * sx + (int64_t(y) - p.y_min) * sy;
  e.slot = 2 * entry.poly + (sx > 0 ? 0 : 1);
  e.div = sx > 0 ? sx : -sx;
  int64_t q, dq;
  floor_divmod(-wb0 + e.div - 1, e.div, q, e.r);
  floor_divmod(-sy, e.div, dq, e.dr);
  e.q = int32_t(q);    // in the edge's x range on its active rows: fits
  e.dq = int32_t(dq);  // |dq| <= |dx| + 1 < 2^25
}

// Polygon Table Entries

void ScanlineTables::add_triangle(const ScreenTriangle& t, RenderStats& stats) {
  const TriangleSetup s = setup_triangle(t, width_, height_);
  if (s.x_min > s.x_max || s.y_min > s.y_max) return;  // no pixel centre of the image
  const int32_t poly = int32_t(polys_.size());
  ScanPolygon& p = polys_.emplace_back();  // in place, as the edges
  p.x_min = s.x_min;
  p.x_max = s.x_max;
  p.y_min = s.y_min;
  p.y_max = s.y_max;
  // The int32 form if every edge value in the box (an affine function:
  // extremes at the corners) fits with room to spare.
  constexpr int64_t kLimit = int64_t(1) << 30;
  bool fits = true;
  for (int k = 0; k < 3; ++k) {
    const int64_t dx = int64_t(s.x_max - s.x_min) * s.step_x[k];
    const int64_t dy = int64_t(s.y_max - s.y_min) * s.step_y[k];
    for (int64_t c : {s.w_origin[k], s.w_origin[k] + dx, s.w_origin[k] + dy,
                      s.w_origin[k] + dx + dy})
      fits &= c < kLimit && c > -kLimit;
    fits &= s.step_x[k] < kLimit && s.step_x[k] > -kLimit && s.step_y[k] < kLimit &&
            s.step_y[k] > -kLimit;
    p.w[k] = int32_t(s.w_origin[k]);
    p.step_x[k] = int32_t(s.step_x[k]);
    p.step_y[k] = int32_t(s.step_y[k]);
  }
  p.bias1 = int32_t(s.bias[1]);
  p.bias2 = int32_t(s.bias[2]);
  p.z0 = s.z0;
  p.a1 = s.a1;
  p.a2 = s.a2;
  p.z_lo = s.z_lo;
  p.z_hi = s.z_hi;
  p.id = s.id;
  p.large = -1;
  if (!fits) {
    p.large = int32_t(large_.size());
    large_.push_back(s);
  }
  poly_row_.push_back(s.y_min);
  ++stats.polygons_inserted;
  for (int k = 0; k < 3; ++k)
    add_edge(s.y_min, s.y_max, s.step_x[k], s.bias[k], k, t.v[(k + 1) % 3].y_fx,
             t.v[(k + 2) % 3].y_fx, poly, stats);
}

// Faces, 16 (AVX2: 8) at a Time

void ScanlineTables::add_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                               const ScreenVertices& sv, int64_t begin, int64_t end,
                               bool cull_backfaces, RenderStats& stats) {
  int64_t f = begin;
#ifdef ZBUFFER_AVX512
  if (mesh.n_vertices > 0)
    for (; f < end; f += 16)
      add_16_faces(mesh, mvp, vp, sv, f, int(std::min<int64_t>(end - f, 16)), cull_backfaces,
                   stats);
#elif defined(ZBUFFER_AVX2)
  if (mesh.n_vertices > 0)
    for (; f < end; f += 8)
      add_8_faces(mesh, mvp, vp, sv, f, int(std::min<int64_t>(end - f, 8)), cull_backfaces, stats);
#endif
  for (; f < end; ++f) add_face(mesh, mvp, vp, sv, f, cull_backfaces, stats);
}

// Face f through the scalar assembly (culling, clipping) into the tables.
void ScanlineTables::add_face(const MeshView& mesh, const double* mvp, const Viewport& vp,
                              const ScreenVertices& sv, int64_t f, bool cull_backfaces,
                              RenderStats& stats) {
  assemble_triangle(mesh, mvp, vp, sv, f, cull_backfaces, stats, [&](const ScreenTriangle& t) {
    ++stats.rasterized;
    add_triangle(t, stats);
  });
}

#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
// The faces of a vector step (16 or 8) that the vector setup leaves: those
// 16 pixels or more across (lanes of `large`) through the scalar setup of
// their assembled triangle, those that need clipping through add_face.
template <class Lanes, class Faces>
void ScanlineTables::add_left_over(const Faces& f, unsigned large, const MeshView& mesh,
                                   const double* mvp, const Viewport& vp, const ScreenVertices& sv,
                                   int64_t first, bool cull_backfaces, RenderStats& stats) {
  simd::for_each_left_over<Lanes>(
      f, large, mesh, first, [&](const ScreenTriangle& t) { add_triangle(t, stats); },
      [&](int64_t face) { add_face(mesh, mvp, vp, sv, face, cull_backfaces, stats); });
}
#endif

#ifdef ZBUFFER_AVX512
// add_triangle for the faces of 16 lanes: setup16.h's setup for those less
// than 16 pixels across (int32 records), then add_triangle itself for the
// others and the scalar assembly for those that need clipping.
void ScanlineTables::add_16_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                                  const ScreenVertices& sv, int64_t first, int count,
                                  bool cull_backfaces, RenderStats& stats) {
  simd::Faces16 f;
  simd::assemble16(mesh, sv, first, count, cull_backfaces, stats, f);
  simd::Box16 box;
  simd::box16(f, width_, height_, box);
  const __mmask16 vector_setup = f.draw & box.nonempty & box.small;
  const __mmask16 scalar_setup = f.draw & box.nonempty & ~box.small;

  if (vector_setup) {
    simd::Setup16 s;
    simd::setup16(f, box, s);
    // The records (ScanPolygon's kScanPolygonInts fields, one vector per
    // field, a face per lane), transposed into a record per register and
    // stored whole, the faces of vector_setup in order.
    constexpr auto field = [](size_t offset) { return int(offset / 4); };
    __m512i r[32];
    r[field(offsetof(ScanPolygon, x_min))] = box.i0;
    r[field(offsetof(ScanPolygon, x_max))] = box.i1;
    r[field(offsetof(ScanPolygon, y_min))] = box.j0;
    r[field(offsetof(ScanPolygon, y_max))] = box.j1;
    for (int k = 0; k < 3; ++k) {
      r[field(offsetof(ScanPolygon, w)) + k] = _mm512_sub_epi32(s.w[k], s.bias[k]);  // biased
      r[field(offsetof(ScanPolygon, step_x)) + k] = s.sx[k];
      r[field(offsetof(ScanPolygon, step_y)) + k] = s.sy[k];
    }
    r[field(offsetof(ScanPolygon, bias1))] = s.bias[1];
    r[field(offsetof(ScanPolygon, bias2))] = s.bias[2];
    r[field(offsetof(ScanPolygon, z0))] = _mm512_castps_si512(s.z0);
    r[field(offsetof(ScanPolygon, a1))] = _mm512_castps_si512(s.a1);
    r[field(offsetof(ScanPolygon, a2))] = _mm512_castps_si512(s.a2);
    r[field(offsetof(ScanPolygon, z_lo))] = _mm512_castps_si512(s.lo);
    r[field(offsetof(ScanPolygon, z_hi))] = _mm512_castps_si512(s.hi);
    r[field(offsetof(ScanPolygon, id))] = simd::ids16(mesh, first, f.live);
    r[field(offsetof(ScanPolygon, large))] = _mm512_set1_epi32(-1);  // every edge value fits int32
    for (int k = kScanPolygonInts; k < 32; ++k) r[k] = _mm512_setzero_si512();
    transpose16(r);
    transpose16(r + 16);
    const __mmask16 m = vector_setup;
    const int n = __builtin_popcount(m);
    const size_t base = polys_.size();
    polys_.resize(base + size_t(n));
    int32_t* rec = reinterpret_cast<int32_t*>(polys_.data() + base);
    for (unsigned left = m; left; left &= left - 1, rec += kScanPolygonInts) {
      const int lane = __builtin_ctz(left);
      _mm512_storeu_si512(rec, r[lane]);
      _mm512_mask_storeu_epi32(rec + 16, kRecordTail, r[16 + lane]);
    }
    const __mmask16 first_n = __mmask16((1u << n) - 1);
    poly_row_.resize(base + size_t(n));
    _mm512_mask_storeu_epi32(poly_row_.data() + base, first_n, _mm512_maskz_compress_epi32(m, box.j0));

    // Edge table entries (add_edge): edge k, from vertex k+1 to k+2, on
    // the rows whose centres lie on its closed y range within the box; a
    // horizontal top edge needs none, a horizontal bottom edge one that
    // kills its row. Written edge by edge (the 16 faces' edges 0, then
    // their edges 1, then 2): their order in the table changes nothing.
    const __m512i half = _mm512_set1_epi32(kHalfPixel);
    const __m512i round_up = _mm512_set1_epi32(kHalfPixel - (kSubpixelScale - 1));
    const __m512i zero = _mm512_setzero_si512();
    // Each face's place in the store: base + its rank among the lanes of m.
    const __m512i poly = _mm512_add_epi32(
        _mm512_set1_epi32(int32_t(base)),
        _mm512_maskz_expand_epi32(m, _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)));
    size_t ne = edges_.size();
    const size_t ne0 = ne;
    edges_.resize(ne + 3 * size_t(n));
    edge_row_.resize(ne + 3 * size_t(n));
    for (int k = 0; k < 3; ++k) {
      const __m512i ya = f.y[(k + 1) % 3], yb = f.y[(k + 2) % 3];
      const __m512i e_first = _mm512_max_epi32(
          _mm512_srai_epi32(_mm512_sub_epi32(_mm512_min_epi32(ya, yb), round_up), kSubpixelBits),
          box.j0);
      const __m512i e_last = _mm512_min_epi32(
          _mm512_srai_epi32(_mm512_sub_epi32(_mm512_max_epi32(ya, yb), half), kSubpixelBits),
          box.j1);
      const __mmask16 horizontal = _mm512_cmpeq_epi32_mask(s.sx[k], zero);
      const __mmask16 top = horizontal & _mm512_cmpeq_epi32_mask(s.bias[k], zero);
      const __mmask16 in = m & _mm512_cmple_epi32_mask(e_first, e_last) & ~top;
      const int n_in = __builtin_popcount(in);
      const __m512i entry[3] = {
          _mm512_maskz_compress_epi32(in, poly), _mm512_maskz_compress_epi32(in, e_last),
          _mm512_maskz_compress_epi32(in, _mm512_mask_blend_epi32(horizontal, _mm512_set1_epi32(k),
                                                                  _mm512_set1_epi32(EdgeEntry::kKillRow)))};
      static_assert(sizeof(EdgeEntry) == 3 * sizeof(int32_t), "entries are written as 3 ints");
      simd::interleave16(entry, n_in, reinterpret_cast<int32_t*>(edges_.data() + ne));
      _mm512_mask_storeu_epi32(edge_row_.data() + ne, __mmask16((1u << n_in) - 1),
                               _mm512_maskz_compress_epi32(in, e_first));
      ne += size_t(n_in);
    }
    edges_.resize(ne);
    edge_row_.resize(ne);
    stats.polygons_inserted += n;
    stats.edges_inserted += int64_t(ne - ne0);
  }

  add_left_over<simd::Lanes16>(f, scalar_setup, mesh, mvp, vp, sv, first, cull_backfaces, stats);
}
#endif

#ifdef ZBUFFER_AVX2
// add_triangle for the faces of 8 lanes (AVX2 builds): setup8.h's assembly
// and setup for those less than 16 pixels across (int32 records, written
// lane by lane), then add_triangle itself for the others and the scalar
// assembly for those that need clipping -- as add_16_faces does with 16.
void ScanlineTables::add_8_faces(const MeshView& mesh, const double* mvp, const Viewport& vp,
                                 const ScreenVertices& sv, int64_t first, int count,
                                 bool cull_backfaces, RenderStats& stats) {
  simd::Faces8 f;
  simd::assemble8(mesh, sv, first, count, cull_backfaces, stats, f);
  simd::Box8 box;
  simd::box8(f, width_, height_, box);
  const unsigned vector_setup = f.draw & box.nonempty & box.small;
  const unsigned scalar_setup = f.draw & box.nonempty & ~box.small;

  if (vector_setup) {
    simd::Setup8 s;
    simd::setup8(f, box, s);
    // ScanPolygon's kScanPolygonInts fields, a row per field and a column
    // per lane; the edges' biases and the vertices' y for the edge table.
    constexpr auto field = [](size_t offset) { return int(offset / 4); };
    alignas(32) int32_t rec[kScanPolygonInts][8], bias[3][8], ys[3][8];
    auto put = [](int32_t* row, __m256i v) { _mm256_store_si256(reinterpret_cast<__m256i*>(row), v); };
    auto put_f = [&](int32_t* row, __m256 v) { put(row, _mm256_castps_si256(v)); };
    put(rec[field(offsetof(ScanPolygon, x_min))], box.i0);
    put(rec[field(offsetof(ScanPolygon, x_max))], box.i1);
    put(rec[field(offsetof(ScanPolygon, y_min))], box.j0);
    put(rec[field(offsetof(ScanPolygon, y_max))], box.j1);
    for (int k = 0; k < 3; ++k) {
      put(rec[field(offsetof(ScanPolygon, w)) + k], _mm256_sub_epi32(s.w[k], s.bias[k]));  // biased
      put(rec[field(offsetof(ScanPolygon, step_x)) + k], s.sx[k]);
      put(rec[field(offsetof(ScanPolygon, step_y)) + k], s.sy[k]);
      put(bias[k], s.bias[k]);
      put(ys[k], f.y[k]);
    }
    put(rec[field(offsetof(ScanPolygon, bias1))], s.bias[1]);
    put(rec[field(offsetof(ScanPolygon, bias2))], s.bias[2]);
    put_f(rec[field(offsetof(ScanPolygon, z0))], s.z0);
    put_f(rec[field(offsetof(ScanPolygon, a1))], s.a1);
    put_f(rec[field(offsetof(ScanPolygon, a2))], s.a2);
    put_f(rec[field(offsetof(ScanPolygon, z_lo))], s.lo);
    put_f(rec[field(offsetof(ScanPolygon, z_hi))], s.hi);
    put(rec[field(offsetof(ScanPolygon, id))], simd::ids8(mesh, first, f.live));
    put(rec[field(offsetof(ScanPolygon, large))], _mm256_set1_epi32(-1));  // every edge value fits int32
    for (unsigned m = vector_setup; m; m &= m - 1) {
      const int lane = __builtin_ctz(m);
      int32_t record[kScanPolygonInts];
      for (int q = 0; q < kScanPolygonInts; ++q) record[q] = rec[q][lane];
      const int32_t poly = int32_t(polys_.size());
      std::memcpy(&polys_.emplace_back(), record, sizeof record);
      const ScanPolygon& p = polys_.back();
      poly_row_.push_back(p.y_min);
      ++stats.polygons_inserted;
      for (int k = 0; k < 3; ++k)
        add_edge(p.y_min, p.y_max, p.step_x[k], bias[k][lane], k, ys[(k + 1) % 3][lane],
                 ys[(k + 2) % 3][lane], poly, stats);
    }
  }

  add_left_over<simd::Lanes8>(f, scalar_setup, mesh, mvp, vp, sv, first, cull_backfaces, stats);
}
#endif

// General Polygons

void ScanlineTables::add_polygon(const ScreenVertex* v, int n, int64_t area, int32_t id,
                                 RenderStats& stats) {
  // Rows: centres on the half-open range [min y, max y), the rows where an
  // edge can cross (docs/rasterization.md).
  int64_t y_lo = v[0].y_fx, y_hi = v[0].y_fx;
  double z_min = v[0].z, z_max = v[0].z;
  for (int i = 1; i < n; ++i) {
    y_lo = std::min<int64_t>(y_lo, v[i].y_fx);
    y_hi = std::max<int64_t>(y_hi, v[i].y_fx);
    z_min = std::min(z_min, v[i].z);
    z_max = std::max(z_max, v[i].z);
  }
  const int64_t first = std::max<int64_t>(first_pixel_at_or_after(y_lo), 0);
  const int64_t last = std::min<int64_t>(first_pixel_at_or_after(y_hi) - 1, height_ - 1);
  if (first > last) return;

  // Depth plane: the fan triangle (v0, v_k, v_k+1) of the largest area with
  // the polygon's orientation (the first such k on a tie), oriented to
  // area > 0 as assembly orients triangles; z clamped to the polygon's range.
  const int64_t x0 = v[0].x_fx, y0 = v[0].y_fx;
  int best = 1;
  int64_t best_area = 0;
  for (int k = 1; k + 1 < n; ++k) {
    const int64_t a = (int64_t(v[k].x_fx) - x0) * (int64_t(v[k + 1].y_fx) - y0) -
                      (int64_t(v[k].y_fx) - y0) * (int64_t(v[k + 1].x_fx) - x0);
    const int64_t oriented = area > 0 ? a : -a;
    if (oriented > best_area) {
      best_area = oriented;
      best = k;
    }
  }
  ScreenTriangle t;
  t.v[0] = v[0];
  t.v[1] = area > 0 ? v[best] : v[best + 1];
  t.v[2] = area > 0 ? v[best + 1] : v[best];
  t.area = best_area;
  t.id = id;
  const int32_t poly = int32_t(gpolys_.size());
  ScanGeneralPolygon& g = gpolys_.emplace_back();
  g.plane = setup_triangle(t, width_, height_);
  g.plane.z_lo = float(z_min);
  g.plane.z_hi = float(z_max);
  g.last_row = int32_t(last);
  gpoly_row_.push_back(int32_t(first));
  ++stats.polygons_inserted;

  // Edge Table: every non-horizontal edge, from its upper end t to its lower
  // end u, on the rows with centres in [y_t, y_u). Its crossing on row y is
  // the first pixel whose centre is at or right of the edge:
  //   x_first = ceil(C / D),  C = (x_u - x_t)(py - y_t) - (y_u - y_t)(128 - x_t),
  //   D = 256 (y_u - y_t),    py = 256 y + 128;
  // q = floor(N / D) with N = C + D - 1, and N grows by 256 (x_u - x_t) a row.
  for (int i = 0; i < n; ++i) {
    const ScreenVertex& a = v[i];
    const ScreenVertex& b = v[i + 1 < n ? i + 1 : 0];
    if (a.y_fx == b.y_fx) continue;  // horizontal: crosses no row
    const ScreenVertex& top = a.y_fx < b.y_fx ? a : b;
    const ScreenVertex& bottom = a.y_fx < b.y_fx ? b : a;
    const int64_t e_first = std::max<int64_t>(first_pixel_at_or_after(top.y_fx), 0);
    const int64_t e_last =
        std::min<int64_t>(first_pixel_at_or_after(bottom.y_fx) - 1, height_ - 1);
    if (e_first > e_last) continue;
    const int64_t dx = int64_t(bottom.x_fx) - top.x_fx, dy = int64_t(bottom.y_fx) - top.y_fx;
    const int64_t c = dx * (pixel_centre_fx(e_first) - top.y_fx) - dy * (kHalfPixel - top.x_fx);
    ScanEdge& e = gedges_.emplace_back();
    e.div = dy * kSubpixelScale;
    int64_t q, dq;
    floor_divmod(c + e.div - 1, e.div, q, e.r);
    floor_divmod(dx * kSubpixelScale, e.div, dq, e.dr);
    e.q = int32_t(q);    // within the edge's x range on its rows: fits
    e.dq = int32_t(dq);  // |dq| <= |dx| + 1 < 2^25
    e.slot = poly;
    e.last_row = int32_t(e_last);
    gedge_row_.push_back(int32_t(e_first));
    ++stats.edges_inserted;
  }
}

// Spans

// Pixels [lo, hi] of row y of polygon p (none if lo > hi), into the key
// row: the raster core's coverage and depth, with the edge values at (lo, y)
// stepped from the box's first pixel in exact (wrapping) int32 arithmetic.
// (AVX-512 builds draw the int32 form in draw_active, except in frames too
// large for the vector lists; otherwise only large triangles come here.)
inline void ScanlineTables::draw_span(const ScanPolygon& p, int y, int lo, int hi,
                                      Counts& counts) {
  if (p.large >= 0) {  // rare: a triangle too big for int32 edge values
    if (lo <= hi) {    // the raster core's own span, into the image's row
      RenderStats s;
      rasterize_span(large_[size_t(p.large)], y, lo, hi, image_depth_, image_ids_, s);
      drawn_in_image_ = true;
      counts.tested += s.pixels_tested;
      counts.covered += s.pixels_covered;
      counts.written += s.pixels_written;
    }
    return;
  }
  // The scalar loop of the raster core (rasterize_span_scalar) on the
  // int32 form: the same integers, and float(int32) is float(int64) of the
  // same value, so the same bits; no second record to fetch.
  if (lo > hi) return;
  uint64_t* const row = row_.data();
  const uint32_t dx = uint32_t(lo - p.x_min), dy = uint32_t(y - p.y_min);
  int32_t w[3];
  for (int k = 0; k < 3; ++k)
    w[k] = int32_t(uint32_t(p.w[k]) + dx * uint32_t(p.step_x[k]) + dy * uint32_t(p.step_y[k]));
  int64_t covered = 0, written = 0;
  for (int x = lo; x <= hi; ++x) {
    if ((w[0] | w[1] | w[2]) >= 0) {  // all biased edge values >= 0: inside
      ++covered;
      const float z = depth_at(p.z0, p.a1, p.a2, p.z_lo, p.z_hi, w[1] + p.bias1, w[2] + p.bias2);
      written += depth_write_key(row, size_t(x), depth_key(z, p.id));
    }
    w[0] += p.step_x[0];
    w[1] += p.step_x[1];
    w[2] += p.step_x[2];
  }
  counts.tested += hi - lo + 1;
  counts.covered += covered;
  counts.written += written;
}

// The Active Polygon List, 16 at a Time

// Polygon table entries [begin, end), those entering at the current row:
// those in the int32 form are copied into the vector active list, 16
// records loaded and transposed at a time (their span bounds are written by
// their edges on every row: step_edges), the others listed in
// active_polys_, their span bounds starting as the image's columns.
void ScanlineTables::enter_polygons(int32_t begin, int32_t end) {
#ifdef ZBUFFER_AVX512
  const int32_t* recs = reinterpret_cast<const int32_t*>(polys_.data());
  // A record is kScanPolygonInts int32 fields; 16 records are loaded whole
  // (their first 16 fields, then the rest: kRecordTail) and transposed into
  // a field per register.
  constexpr auto field = [](size_t offset) { return int(offset / 4); };
  constexpr int kXMinF = field(offsetof(ScanPolygon, x_min)), kYMaxF = field(offsetof(ScanPolygon, y_max)),
                kWF = field(offsetof(ScanPolygon, w)), kSxF = field(offsetof(ScanPolygon, step_x)),
                kSyF = field(offsetof(ScanPolygon, step_y)), kB1F = field(offsetof(ScanPolygon, bias1)),
                kB2F = field(offsetof(ScanPolygon, bias2)), kZ0F = field(offsetof(ScanPolygon, z0)),
                kA1F = field(offsetof(ScanPolygon, a1)), kA2F = field(offsetof(ScanPolygon, a2)),
                kZLoF = field(offsetof(ScanPolygon, z_lo)), kZHiF = field(offsetof(ScanPolygon, z_hi)),
                kIdF = field(offsetof(ScanPolygon, id)), kLargeF = field(offsetof(ScanPolygon, large));
  const __m512i zero = _mm512_setzero_si512();
  const __mmask16 vector_lanes = vector_lists_ ? 0xFFFF : 0;  // else all to active_polys_
  for (int32_t i = begin; i < end; i += 16) {
    const int count = std::min(end - i, 16);
    const __mmask16 live = __mmask16(_bzhi_u32(0xFFFF, uint32_t(count)));
    // Lanes past the end load the first lane's record (and are not kept).
    const __m512i p = _mm512_mask_loadu_epi32(_mm512_set1_epi32(poly_table_[size_t(i)]), live,
                                              poly_table_.data() + i);
    alignas(64) int32_t idx[16];
    _mm512_store_si512(idx, p);
    __m512i f[32];  // fields 0-15 of the 16 records, then fields 16-21 (and zeros)
    for (int k = 0; k < 16; ++k) {
      const int32_t* rec = recs + size_t(idx[k]) * kScanPolygonInts;
      f[k] = _mm512_loadu_si512(rec);
      f[16 + k] = _mm512_maskz_loadu_epi32(kRecordTail, rec + 16);
    }
    transpose16(f);
    transpose16(f + 16);
    const __mmask16 vec = _mm512_mask_cmplt_epi32_mask(live & vector_lanes, f[kLargeF], zero);
    for (unsigned m = live & ~vec; m; m &= m - 1) enter_scalar_list(idx[__builtin_ctz(m)]);
    // The unbiased edge values at pixel (0, y_min) from the biased ones at
    // (x_min, y_min), in wrapping int32.
    auto at_column_0 = [&](int k, int bias_field) {
      return _mm512_sub_epi32(_mm512_add_epi32(f[kWF + k], f[bias_field]),
                              _mm512_mullo_epi32(f[kXMinF], f[kSxF + k]));
    };
    __m512i a[kActiveFields];
    a[kIndex] = p;
    a[kYMax] = f[kYMaxF];
    a[kW1] = at_column_0(1, kB1F);
    a[kW2] = at_column_0(2, kB2F);
    a[kSx1] = f[kSxF + 1];
    a[kSx2] = f[kSxF + 2];
    a[kSy1] = f[kSyF + 1];
    a[kSy2] = f[kSyF + 2];
    a[kZ0] = f[kZ0F];
    a[kA1] = f[kA1F];
    a[kA2] = f[kA2F];
    a[kZLo] = f[kZLoF];
    a[kZHi] = f[kZHiF];
    a[kId] = f[kIdF];
    for (int k = 0; k < kActiveFields; ++k)
      _mm512_storeu_si512(active_[k].data() + n_active_, _mm512_maskz_compress_epi32(vec, a[k]));
    n_active_ += size_t(__builtin_popcount(vec));
  }
#else
  for (int32_t i = begin; i < end; ++i) enter_scalar_list(poly_table_[size_t(i)]);
#endif
}

// Polygon p into the scalar active list, its span bounds the image's columns.
void ScanlineTables::enter_scalar_list(int32_t p) {
  active_polys_.push_back(p);
  bounds_[2 * size_t(p)] = 0;
  bounds_[2 * size_t(p) + 1] = -(width_ - 1);
}

// Draw row y of every polygon in the vector active list (their bounds
// written by the active edges), step their edge values to the next row and
// drop those that end here.
void ScanlineTables::draw_active(int y, Counts& counts, int64_t& spans, int& touched_lo,
                                 int& touched_hi) {
#ifdef ZBUFFER_AVX512
  // Spans up to this long are drawn a pixel per lane; longer ones one span
  // at a time, 16 pixels per pass. A group of 16 takes as many passes as
  // its longest span, and a pass costs its gather and scatter whatever its
  // mask: since a pass writes keys (a gather and a scatter, not a gather
  // and two scatters), 4 is faster than 8 (ab.py, 41 frames: bunny_10k
  // 0.95, spot 0.92, dragon_20k 0.93, armadillo_86k 0.98, bunny_69k 1.00).
  constexpr int kLaneSpan = 4;
  const __m512i zero = _mm512_setzero_si512();
  const __m512i one = _mm512_set1_epi32(1);
  int32_t* bounds = bounds_.data();
  const size_t n = n_active_;
  size_t kept = 0;
  __m512i lo_min = _mm512_set1_epi32(width_), hi_max = _mm512_set1_epi32(-1);
  for (size_t i = 0; i < n; i += 16) {
    const __mmask16 live = __mmask16(_bzhi_u32(0xFFFF, uint32_t(std::min<size_t>(n - i, 16))));
    __m512i f[kActiveFields];
    for (int k = 0; k < kActiveFields; ++k)
      f[k] = _mm512_maskz_loadu_epi32(live, active_[k].data() + i);

    // Spans: the bounds the edges wrote. A polygon's two bounds are
    // adjacent: read as one 64-bit pair (first pixel, minus the last).
    __m512i pairs_lo, pairs_hi;
    if (live == 0xFFFF) {  // by loads, as assembly reads vertices (simd.h)
      const int32_t* index = active_[kIndex].data() + i;
      pairs_lo = simd::pairs8(bounds, index);
      pairs_hi = simd::pairs8(bounds, index + 8);
    } else {
      const __m256i index_lo = _mm512_castsi512_si256(f[kIndex]);
      const __m256i index_hi = _mm512_extracti64x4_epi64(f[kIndex], 1);
      const __mmask8 live_lo = __mmask8(live), live_hi = __mmask8(live >> 8);
      pairs_lo = _mm512_mask_i32gather_epi64(zero, live_lo, index_lo, bounds, 8);
      pairs_hi = _mm512_mask_i32gather_epi64(zero, live_hi, index_hi, bounds, 8);
    }
    // (Within the image's columns: an edge's bound may lie outside them.)
    const __m512i lo = _mm512_max_epi32(
        _mm512_permutex2var_epi32(pairs_lo, _mm512_load_si512(simd::kEven), pairs_hi), zero);
    const __m512i hi = _mm512_min_epi32(
        _mm512_sub_epi32(zero, _mm512_permutex2var_epi32(pairs_lo, _mm512_load_si512(simd::kOdd), pairs_hi)),
        _mm512_set1_epi32(width_ - 1));
    const __m512i width = _mm512_add_epi32(_mm512_sub_epi32(hi, lo), one);
    const __mmask16 drawn = _mm512_mask_cmpgt_epi32_mask(live, width, zero);
    spans += __builtin_popcount(drawn);
    // Every pixel of a span is covered (its bounds are exact).
    const int64_t span_pixels = _mm512_mask_reduce_add_epi32(drawn, width);
    counts.tested += span_pixels;
    counts.covered += span_pixels;
    lo_min = _mm512_mask_min_epi32(lo_min, drawn, lo_min, lo);
    hi_max = _mm512_mask_max_epi32(hi_max, drawn, hi_max, hi);

    // Short spans a pixel per lane: lane k draws pixel lo_k + j in pass j.
    // Lanes starting at one column would write one pixel in one scatter:
    // all but the first of them go the one-span way.
    const __mmask16 short_span =
        _mm512_mask_cmple_epi32_mask(drawn, width, _mm512_set1_epi32(kLaneSpan));
    const __m512i earlier_same =
        _mm512_and_si512(_mm512_maskz_conflict_epi32(short_span, lo),
                         _mm512_set1_epi32(int32_t(short_span)));
    const __mmask16 lanes = short_span & ~_mm512_test_epi32_mask(earlier_same, earlier_same);
    if (lanes) {
      __m512i w1 = _mm512_add_epi32(f[kW1], _mm512_mullo_epi32(lo, f[kSx1]));
      __m512i w2 = _mm512_add_epi32(f[kW2], _mm512_mullo_epi32(lo, f[kSx2]));
      const simd::DepthPlane16 plane(
          _mm512_castsi512_ps(f[kZ0]), _mm512_castsi512_ps(f[kA1]), _mm512_castsi512_ps(f[kA2]),
          _mm512_castsi512_ps(f[kZLo]), _mm512_castsi512_ps(f[kZHi]));
      __m512i x = lo;
      const int passes = _mm512_mask_reduce_max_epi32(lanes, width);
      __m512i left = width;  // pixels left to draw in each lane
      int64_t written = 0;
      for (int j = 0; j < passes; ++j) {
        const __mmask16 in_span = _mm512_mask_cmpgt_epi32_mask(lanes, left, zero);
        const __m512 z = simd::depth16(plane, w1, w2);
        const __mmask16 win = simd::write16_keys_at(in_span, z, f[kId], x, row_.data());
        written += __builtin_popcount(win);
        w1 = _mm512_add_epi32(w1, f[kSx1]);
        w2 = _mm512_add_epi32(w2, f[kSx2]);
        x = _mm512_add_epi32(x, one);
        left = _mm512_sub_epi32(left, one);
      }
      counts.written += written;
    }
    // The others one span at a time, 16 consecutive pixels per pass, from
    // the lanes' own fields (every pixel of a span is covered)
    const __mmask16 one_by_one = drawn & ~lanes;
    if (one_by_one) {
      alignas(64) int32_t at[kActiveFields][16], los[16], widths[16];
      for (int k = kW1; k < kActiveFields; ++k) _mm512_store_si512(at[k], f[k]);
      _mm512_store_si512(at[kW1], _mm512_add_epi32(f[kW1], _mm512_mullo_epi32(lo, f[kSx1])));
      _mm512_store_si512(at[kW2], _mm512_add_epi32(f[kW2], _mm512_mullo_epi32(lo, f[kSx2])));
      _mm512_store_si512(los, lo);
      _mm512_store_si512(widths, width);
      int64_t written = 0;
      for (unsigned m = one_by_one; m; m &= m - 1) {
        const int k = __builtin_ctz(m);
        float z0, a1, a2, z_lo, z_hi;
        std::memcpy(&z0, &at[kZ0][k], 4);
        std::memcpy(&a1, &at[kA1][k], 4);
        std::memcpy(&a2, &at[kA2][k], 4);
        std::memcpy(&z_lo, &at[kZLo][k], 4);
        std::memcpy(&z_hi, &at[kZHi][k], 4);
        const simd::DepthPlane16 plane(z0, a1, a2, z_lo, z_hi);
        const __m512i id = _mm512_set1_epi32(at[kId][k]);
        __m512i w1 = simd::row16(at[kW1][k], at[kSx1][k]), w2 = simd::row16(at[kW2][k], at[kSx2][k]);
        const __m512i step1 = _mm512_set1_epi32(int32_t(16u * uint32_t(at[kSx1][k])));
        const __m512i step2 = _mm512_set1_epi32(int32_t(16u * uint32_t(at[kSx2][k])));
        uint64_t* const row = row_.data() + los[k];
        for (int x = 0; x < widths[k]; x += 16) {
          const __mmask16 in_span = __mmask16(_bzhi_u32(0xFFFF, uint32_t(std::min(widths[k] - x, 16))));
          written += __builtin_popcount(simd::write16_keys(in_span, simd::depth16(plane, w1, w2), id, row + x));
          w1 = _mm512_add_epi32(w1, step1);
          w2 = _mm512_add_epi32(w2, step2);
        }
      }
      counts.written += written;
    }

    // Next row: step the edge values, keep the polygons that go on
    f[kW1] = _mm512_add_epi32(f[kW1], f[kSy1]);
    f[kW2] = _mm512_add_epi32(f[kW2], f[kSy2]);
    const __mmask16 keep =
        _mm512_mask_cmpneq_epi32_mask(live, f[kYMax], _mm512_set1_epi32(y));
    // Compress in registers, store whole vectors: the lanes past the kept
    // ones land on entries of this group, already loaded.
    for (int k = 0; k < kActiveFields; ++k)
      _mm512_storeu_si512(active_[k].data() + kept, _mm512_maskz_compress_epi32(keep, f[k]));
    kept += size_t(__builtin_popcount(keep));
  }
  n_active_ = kept;
  if (n > 0) {
    touched_lo = std::min(touched_lo, _mm512_reduce_min_epi32(lo_min));
    touched_hi = std::max(touched_hi, _mm512_reduce_max_epi32(hi_max));
  }
#else
  (void)y, (void)counts, (void)spans, (void)touched_lo, (void)touched_hi;
#endif
}

// The Active Edge List, 16 at a Time

// Start the DDAs of edge table entries [begin, end), all entering at row y
// (start_edge, 16 lanes at a time): those of int32-form triangles into the
// vector list, the others into active_edges_.
void ScanlineTables::enter_edges(int y, int32_t begin, int32_t end) {
#ifdef ZBUFFER_AVX512
  static_assert(sizeof(EdgeEntry) == 3 * sizeof(int32_t), "entries are read as 3 ints");
  const int32_t* table = reinterpret_cast<const int32_t*>(edge_table_.data());
  const int32_t* recs = reinterpret_cast<const int32_t*>(polys_.data());
  constexpr int kWOff = offsetof(ScanPolygon, w) / 4, kSxOff = offsetof(ScanPolygon, step_x) / 4,
                kSyOff = offsetof(ScanPolygon, step_y) / 4,
                kYMinOff = offsetof(ScanPolygon, y_min) / 4,
                kLargeOff = offsetof(ScanPolygon, large) / 4;
  const __m512i zero = _mm512_setzero_si512();
  for (int32_t i = begin; i < end; i += 16) {
    const int count = std::min(end - i, 16);
    const __mmask16 live = __mmask16(_bzhi_u32(0xFFFF, uint32_t(count)));
    // The entries (poly, last_row, k), deinterleaved
    __m512i field[3];
    simd::deinterleave16(table + 3 * size_t(i), count, field);
    const __m512i poly = field[0], last = field[1], k = field[2];
    const __m512i rec = _mm512_mullo_epi32(poly, _mm512_set1_epi32(kScanPolygonInts));
    const __m512i large = _mm512_mask_i32gather_epi32(
        zero, live, _mm512_add_epi32(rec, _mm512_set1_epi32(kLargeOff)), recs, 4);
    const __mmask16 vec = _mm512_mask_cmplt_epi32_mask(live, large, zero);
    for (unsigned m = live & ~vec; m; m &= m - 1)  // large triangles: int64 DDAs
      start_edge(edge_table_[size_t(i) + __builtin_ctz(m)], y, active_edges_.emplace_back());
    if (!vec) continue;
    const __mmask16 kill = _mm512_mask_cmpeq_epi32_mask(vec, k, _mm512_set1_epi32(EdgeEntry::kKillRow));
    const __mmask16 edge = vec & ~kill;

    // q = floor(N / div), N = -wb0 + div - 1, wb0 the biased edge value at
    // pixel (0, y); dq, dr from -step_y. In binary64, exact: every value
    // is an integer below 2^53; the quotient, within one of the true one,
    // is corrected once each way (floor_divmod).
    auto gather = [&](int off, __m512i plus) {
      return _mm512_mask_i32gather_epi32(
          zero, edge, _mm512_add_epi32(_mm512_add_epi32(rec, plus), _mm512_set1_epi32(off)), recs, 4);
    };
    const __m512i x_min = gather(0, zero), y_min = gather(kYMinOff, zero);
    const __m512i w = gather(kWOff, k), sx = gather(kSxOff, k), sy = gather(kSyOff, k);
    __m512i q32[2], r32[2], dq32[2], dr32[2];
    for (int h = 0; h < 2; ++h) {
      auto half = [&](__m512i v) {
        return _mm512_cvtepi32_pd(h ? _mm512_extracti64x4_epi64(v, 1) : _mm512_castsi512_si256(v));
      };
      const __m512d sxd = half(sx), syd = half(sy);
      const __m512d wb0 = _mm512_add_pd(
          _mm512_sub_pd(half(w), _mm512_mul_pd(half(x_min), sxd)),
          _mm512_mul_pd(_mm512_sub_pd(_mm512_set1_pd(double(y)), half(y_min)), syd));
      const __m512d div = _mm512_abs_pd(sxd);
      const __m512d div_safe = _mm512_max_pd(div, _mm512_set1_pd(1.0));  // masked-off lanes
      auto divmod = [&](__m512d n, __m512i& q_out, __m512i& r_out) {
        __m512d q = _mm512_roundscale_pd(_mm512_div_pd(n, div_safe), _MM_FROUND_TO_NEG_INF);
        __m512d r = _mm512_sub_pd(n, _mm512_mul_pd(q, div_safe));
        const __mmask8 low = _mm512_cmp_pd_mask(r, _mm512_setzero_pd(), _CMP_LT_OQ);
        q = _mm512_mask_sub_pd(q, low, q, _mm512_set1_pd(1.0));
        r = _mm512_mask_add_pd(r, low, r, div_safe);
        const __mmask8 high = _mm512_cmp_pd_mask(r, div_safe, _CMP_GE_OQ);
        q = _mm512_mask_add_pd(q, high, q, _mm512_set1_pd(1.0));
        r = _mm512_mask_sub_pd(r, high, r, div_safe);
        q_out = _mm512_castsi256_si512(_mm512_cvtpd_epi32(q));
        r_out = _mm512_castsi256_si512(_mm512_cvtpd_epi32(r));
      };
      divmod(_mm512_sub_pd(_mm512_add_pd(_mm512_sub_pd(_mm512_setzero_pd(), wb0), div_safe),
                           _mm512_set1_pd(1.0)),
             q32[h], r32[h]);
      divmod(_mm512_sub_pd(_mm512_setzero_pd(), syd), dq32[h], dr32[h]);
    }
    auto join = [](const __m512i* v) {
      return _mm512_inserti64x4(v[0], _mm512_castsi512_si256(v[1]), 1);
    };
    // Kill entries (a left bound beyond any column, for their one row) into
    // their own list, applied after the edges' bounds (step_edges).
    const __m512i left_slot = _mm512_add_epi32(poly, poly);
    _mm512_storeu_si512(kills_.data() + n_kills_, _mm512_maskz_compress_epi32(kill, left_slot));
    n_kills_ += size_t(__builtin_popcount(kill));
    __m512i f[kEdgeFields];
    f[kER] = join(r32);
    f[kEDiv] = _mm512_abs_epi32(sx);
    f[kEDr] = join(dr32);
    f[kEQ] = join(q32);
    f[kEDq] = join(dq32);
    f[kESlot] = _mm512_add_epi32(left_slot, _mm512_maskz_set1_epi32(_mm512_cmple_epi32_mask(sx, zero), 1));
    f[kELast] = last;
    for (int j = 0; j < kEdgeFields; ++j)
      _mm512_storeu_si512(aedge_[j].data() + n_aedges_, _mm512_maskz_compress_epi32(edge, f[j]));
    n_aedges_ += size_t(__builtin_popcount(edge));
  }
#else
  (void)y, (void)begin, (void)end;
#endif
}

// The vector active edge list on row y: write the bounds of their
// polygons' spans, step to the next row, drop those that end here; then the
// row's kill entries.
void ScanlineTables::step_edges(int y) {
#ifdef ZBUFFER_AVX512
  int32_t* bounds = bounds_.data();
  const size_t n = n_aedges_;
  size_t kept = 0;
  const __m512i one = _mm512_set1_epi32(1);
  for (size_t i = 0; i < n; i += 16) {
    const __mmask16 live = __mmask16(_bzhi_u32(0xFFFF, uint32_t(std::min<size_t>(n - i, 16))));
    __m512i f[kEdgeFields];
    for (int j = 0; j < kEdgeFields; ++j)
      f[j] = _mm512_maskz_loadu_epi32(live, aedge_[j].data() + i);
    // Bounds: q, written (scanline.h: bounds_; two edges writing one bound
    // on one row write the same q).
    _mm512_mask_i32scatter_epi32(bounds, live, f[kESlot], f[kEQ], 4);
    // ScanEdge::step(), 16 lanes
    __m512i r = _mm512_add_epi32(f[kER], f[kEDr]);
    const __mmask16 carry = _mm512_cmpge_epi32_mask(r, f[kEDiv]);
    f[kER] = _mm512_mask_sub_epi32(r, carry, r, f[kEDiv]);
    const __m512i q = _mm512_add_epi32(f[kEQ], f[kEDq]);
    f[kEQ] = _mm512_mask_add_epi32(q, carry, q, one);
    const __mmask16 keep = _mm512_mask_cmpneq_epi32_mask(live, f[kELast], _mm512_set1_epi32(y));
    for (int j = 0; j < kEdgeFields; ++j)
      _mm512_storeu_si512(aedge_[j].data() + kept, _mm512_maskz_compress_epi32(keep, f[j]));
    kept += size_t(__builtin_popcount(keep));
  }
  n_aedges_ = kept;
  for (size_t i = 0; i < n_kills_; ++i) bounds[kills_[i]] = int32_t(1) << 30;
  n_kills_ = 0;
#else
  (void)y;
#endif
}

// The Row Walk

void ScanlineTables::render(DepthTarget& target, RenderStats& stats) {
  const int width = target.width, height = target.height;
  // The tables number polygons and edges in int32 (rows of the sorted
  // tables, an edge's polygon, and a triangle's two span bounds at 2 p and
  // 2 p + 1): past that, refuse before using a number that wrapped. (Memory
  // runs out first on most machines: 2^30 triangles take tens of GB.)
  constexpr size_t kMaxEntries = size_t(std::numeric_limits<int32_t>::max());
  constexpr size_t kMaxTriangles = kMaxEntries / 2;  // 2 p + 1 <= kMaxEntries
  if (polys_.size() > kMaxTriangles || edges_.size() > kMaxEntries ||
      gpolys_.size() > kMaxEntries || gedges_.size() > kMaxEntries)
    throw std::length_error("the scanline's tables hold at most 2**30 - 1 triangles, 2**31 - 1 "
                            "polygons and 2**31 - 1 edges of each: too many faces for "
                            "algo='scanline'");

  // Sorted Polygon Table and Edge Table
  bucket_by_row(poly_row_, height, poly_start_, position_);
  poly_table_.resize(polys_.size());
  for (size_t i = 0; i < polys_.size(); ++i) poly_table_[size_t(position_[i])] = int32_t(i);
  bucket_by_row(edge_row_, height, edge_start_, position_);
  edge_table_.resize(edges_.size());
  for (size_t i = 0; i < edges_.size(); ++i) edge_table_[size_t(position_[i])] = edges_[i];

  bucket_by_row(gpoly_row_, height, gpoly_start_, position_);
  gpoly_table_.resize(gpolys_.size());
  for (size_t i = 0; i < gpolys_.size(); ++i) gpoly_table_[size_t(position_[i])] = int32_t(i);
  bucket_by_row(gedge_row_, height, gedge_start_, position_);
  gedge_table_.resize(gedges_.size());
  for (size_t i = 0; i < gedges_.size(); ++i) gedge_table_[size_t(position_[i])] = gedges_[i];
  active_gpolys_.clear();
  active_gedges_.clear();

  bounds_.resize(2 * polys_.size());
#ifdef ZBUFFER_AVX512
  // Room for every polygon plus the 16 entries a vector store may write
  // past the last one (only the AVX-512 paths use these lists: builds
  // without AVX-512 would hold ~150 bytes a triangle here for nothing).
  for (auto& field : active_)
    if (field.size() < polys_.size() + 16) field.resize(polys_.size() + 16);
  for (auto& field : aedge_)
    if (field.size() < edges_.size() + 16) field.resize(edges_.size() + 16);
  if (kills_.size() < edges_.size() + 16) kills_.resize(edges_.size() + 16);
#endif
#ifdef ZBUFFER_AVX512
  vector_lists_ = polys_.size() <= vector_limit_;
#endif
  n_active_ = 0;
  n_aedges_ = 0;
  n_kills_ = 0;
  active_polys_.clear();
  active_edges_.clear();
  row_.assign(size_t(width), kEmptyDepthKey);
  stats.depth_storage_bytes = int64_t(width) * int64_t(sizeof(float));
  Counts counts;

  drawn_in_image_ = false;
  for (int y = 0; y < height; ++y) {
    image_depth_ = target.depth + size_t(y) * target.row_pitch();
    image_ids_ = target.triangle_id + size_t(y) * target.row_pitch();
    // Polygons and edges entering at this row
    enter_polygons(poly_start_[size_t(y)], poly_start_[size_t(y) + 1]);
    if (vector_lists_) {
      enter_edges(y, edge_start_[size_t(y)], edge_start_[size_t(y) + 1]);
    } else {  // (every build without AVX-512, and huge frames)
      for (int32_t i = edge_start_[size_t(y)]; i < edge_start_[size_t(y) + 1]; ++i)
        start_edge(edge_table_[size_t(i)], y, active_edges_.emplace_back());
    }
    // The polygons entering two rows down, into cache meanwhile: the store
    // is in arrival order, so they are scattered over it.
    if (y + 2 < height)
      for (int32_t i = poly_start_[size_t(y) + 2]; i < poly_start_[size_t(y) + 3]; ++i) {
        const char* rec = reinterpret_cast<const char*>(&polys_[size_t(poly_table_[size_t(i)])]);
        prefetch(rec);
        prefetch(rec + sizeof(ScanPolygon) - 1);
      }
    for (int32_t i = gpoly_start_[size_t(y)]; i < gpoly_start_[size_t(y) + 1]; ++i)
      active_gpolys_.push_back(gpoly_table_[size_t(i)]);
    active_gedges_.insert(active_gedges_.end(), gedge_table_.begin() + gedge_start_[size_t(y)],
                          gedge_table_.begin() + gedge_start_[size_t(y) + 1]);
    ++stats.scanline_rows;
    const int64_t n_polys = int64_t(n_active_ + active_polys_.size() + active_gpolys_.size());
    const int64_t n_edges =
        int64_t(n_aedges_ + n_kills_ + active_edges_.size() + active_gedges_.size());
    stats.active_polygons_sum += n_polys;
    stats.active_edges_sum += n_edges;
    stats.active_polygons_max = std::max(stats.active_polygons_max, n_polys);
    stats.active_edges_max = std::max(stats.active_edges_max, n_edges);
    if (n_polys == 0) continue;
    int touched_lo = width, touched_hi = -1;

    // General polygons: the crossings of their active edges, sorted by
    // polygon then x and paired (even-odd): each pair [x_a, x_b) is a span
    if (!active_gpolys_.empty()) {
      crossings_.clear();
      size_t kept_edges = 0;
      for (size_t i = 0; i < active_gedges_.size(); ++i) {
        ScanEdge e = active_gedges_[i];
        crossings_.push_back((uint64_t(uint32_t(e.slot)) << 32) |
                             uint64_t(uint32_t(e.q) ^ 0x80000000u));  // x + 2^31
        if (e.last_row == y) continue;
        e.step();
        active_gedges_[kept_edges++] = e;
      }
      active_gedges_.resize(kept_edges);
      std::sort(crossings_.begin(), crossings_.end());
      for (size_t i = 0; i + 1 < crossings_.size(); i += 2) {
        const TriangleSetup& plane = gpolys_[size_t(crossings_[i] >> 32)].plane;
        const int64_t x_a = int64_t(uint32_t(crossings_[i])) - (int64_t(1) << 31);
        const int64_t x_b = int64_t(uint32_t(crossings_[i + 1])) - (int64_t(1) << 31);
        const int lo = int(std::max<int64_t>(x_a, 0));
        const int hi = int(std::min<int64_t>(x_b - 1, width - 1));
        if (lo > hi) continue;
        RenderStats s;  // the raster core's own span, into the image's row
        rasterize_span_covered(plane, y, lo, hi, image_depth_, image_ids_, s);
        drawn_in_image_ = true;
        counts.tested += s.pixels_tested;
        counts.covered += s.pixels_covered;
        counts.written += s.pixels_written;
        ++stats.spans_drawn;
        touched_lo = std::min(touched_lo, lo);
        touched_hi = std::max(touched_hi, hi);
      }
      size_t kept_polys = 0;
      for (int32_t g : active_gpolys_)
        if (gpolys_[size_t(g)].last_row != y) active_gpolys_[kept_polys++] = g;
      active_gpolys_.resize(kept_polys);
    }

    step_edges(y);

    // Active edges: tighten their polygons' spans, step to the next row,
    // drop those that end here: the vector list, then the large triangles'. Branch-free: left and right edges, and
    // edges ending or not, are mixed at random.
    // (Field by field: copying the struct whole after changing two fields
    // stalled on store forwarding and cost a third of the row walk.)
    size_t kept = 0;
    ScanEdge* const edges = active_edges_.data();
    for (size_t i = 0; i < active_edges_.size(); ++i) {
      const int64_t div = edges[i].div, dr = edges[i].dr;
      const int32_t q = edges[i].q, dq = edges[i].dq;
      const int32_t slot = edges[i].slot, last_row = edges[i].last_row;
      int32_t& b = bounds_[size_t(slot)];
      b = std::max(b, q);
      // ScanEdge::step(), written out
      int64_t r = edges[i].r + dr;
      const bool carry = r >= div;
      r -= carry ? div : 0;
      ScanEdge& out = edges[kept];
      out.r = r;
      out.div = div;
      out.dr = dr;
      out.q = q + dq + int32_t(carry);
      out.dq = dq;
      out.slot = slot;
      out.last_row = last_row;
      kept += last_row != y;
    }
    active_edges_.resize(kept);

    // Active polygons: draw their spans into the row, drop those that end
    // here: the vector list, then the large ones (branch-free, likewise)
    draw_active(y, counts, stats.spans_drawn, touched_lo, touched_hi);
    kept = 0;
    for (size_t i = 0; i < active_polys_.size(); ++i) {
      const int32_t p = active_polys_[i];
      const ScanPolygon& poly = polys_[size_t(p)];
      const int lo = bounds_[2 * size_t(p)], hi = -bounds_[2 * size_t(p) + 1];
      draw_span(poly, y, lo, hi, counts);
      const bool drawn = lo <= hi;
      stats.spans_drawn += drawn;
      touched_lo = std::min(touched_lo, drawn ? lo : width);
      touched_hi = std::max(touched_hi, drawn ? hi : -1);
      bounds_[2 * size_t(p)] = 0;
      bounds_[2 * size_t(p) + 1] = -(width - 1);
      active_polys_[kept] = p;
      kept += poly.y_max != y;
    }
    active_polys_.resize(kept);

    // The finished row into the image; the row buffer cleared behind it
    if (touched_lo <= touched_hi)
      flush_row(row_.data(), touched_lo, touched_hi, image_depth_, image_ids_, drawn_in_image_);
    drawn_in_image_ = false;
  }
  stats.pixels_tested += counts.tested;
  stats.pixels_covered += counts.covered;
  stats.pixels_written += counts.written;
}

// The Algorithm

namespace {
thread_local ScanlineTables tables;
thread_local size_t kept_bytes = kKeptScanlineBytes;

// Gives this thread's tables back if they grew past kept_bytes, when the
// frame ends or fails (scanline.h, "Memory").
struct TrimTables {
  ~TrimTables() {
    if (tables.bytes_held() > kept_bytes) tables = ScanlineTables();
  }
};
}  // namespace

size_t scanline_tables_held() { return tables.bytes_held(); }
void limit_kept_scanline_bytes(size_t bytes) { kept_bytes = bytes; }

void check_scanline_faces(int64_t n_faces) {
  if (n_faces > kMaxScanlineTriangles)
    throw std::length_error(
        "algo='scanline' draws at most 2**24 (16,777,216) triangles (its tables take up to about "
        "550 bytes a triangle), got " + std::to_string(n_faces) +
        ": use 'zbuffer', 'hiz' or a tree algorithm for meshes this large");
}

void render_scanline(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  check_scanline_faces(input.mesh.n_faces);
  const TrimTables trim;
  const Viewport vp(target.width, target.height);

  // Vertex stage: shared with every algorithm, each vertex once.
  const ScreenVertices& screen = transform_mesh(input, vp, stats);

  // Assembly into the tables, then the row walk.
  const auto t0 = Clock::now();
  tables.reset(target.width, target.height);
  auto add_faces = [&](int64_t begin, int64_t end) {
    tables.add_faces(input.mesh, input.mvp, vp, screen, begin, end, input.cull_backfaces, stats);
  };
  const PolygonView& polys = input.polygons;
  if (polys.n_polygons == 0) {
    add_faces(0, input.mesh.n_faces);
  } else {
    // Polygons (docs/rasterization.md, "Polygons"). Each decision about a
    // polygon counts all its size - 2 triangles, so that the triangle
    // counters add up as for any algorithm.
    std::vector<ScreenVertex> v;
    int64_t face = 0;  // the polygon's first triangle
    for (int64_t p = 0; p < polys.n_polygons; ++p) {
      const int32_t* idx = polys.indices + polys.offsets[p];
      const int n = int(polys.offsets[p + 1] - polys.offsets[p]);
      const int64_t triangles = n - 2, next_face = face + triangles;
      uint32_t any_out = 0, all_out = ~0u;
      for (int i = 0; i < n; ++i) {
        any_out |= screen.outcode[size_t(idx[i])];
        all_out &= screen.outcode[size_t(idx[i])];
      }
      if (any_out & kOutInvalid) {
        stats.culled_invalid += triangles;
      } else if (all_out & kOutView) {
        stats.culled_frustum += triangles;
      } else if ((any_out & kOutClip) || n > kMaxScanPolygonCorners) {
        add_faces(face, next_face);  // clipped: drawn as its triangles
      } else {
        v.resize(size_t(n));
        for (int i = 0; i < n; ++i) v[size_t(i)] = screen[idx[i]];
        // Twice the signed area, as the fan (v0, v_k, v_k+1) sums it: exact.
        int64_t area = 0;
        for (int k = 1; k + 1 < n; ++k)
          area += (int64_t(v[size_t(k)].x_fx) - v[0].x_fx) * (int64_t(v[size_t(k) + 1].y_fx) - v[0].y_fx) -
                  (int64_t(v[size_t(k)].y_fx) - v[0].y_fx) * (int64_t(v[size_t(k) + 1].x_fx) - v[0].x_fx);
        if (area == 0) {
          stats.culled_degenerate += triangles;
        } else if (area > 0 && input.cull_backfaces) {
          stats.culled_backface += triangles;
        } else {
          stats.rasterized += triangles;
          tables.add_polygon(v.data(), n, area, input.mesh.id(face), stats);
        }
      }
      face = next_face;
    }
  }
  tables.render(target, stats);
  stats.raster_ms += ms_since(t0);
}

}  // namespace zbuffer
