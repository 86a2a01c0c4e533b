// Private to the core: Morton (Z-order) codes and the radix sort that orders
// faces by them. The spatial visiting order (mesh_order.cpp), the octree and
// the BVH all start from faces sorted along this curve.
#pragma once

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "simd.h"  // (corner_words16, corner_words8)
#include "zbuffer/types.h"

namespace zbuffer {

// Spread the low 10 bits of v so that bit i lands on bit 3 i.
inline uint32_t spread_bits_10(uint32_t v) {
  v &= 0x3FF;
  v = (v | (v << 16)) & 0x030000FF;
  v = (v | (v << 8)) & 0x0300F00F;
  v = (v | (v << 4)) & 0x030C30C3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

// The 30-bit Morton code of a cell of a 1024^3 grid: x in bits 0, 3, 6 ...
// (by bit deposits in AVX-512 builds: a tree's build computes one or more
// per face. Not in AVX2 builds, which run on AMD's Zen 1 and 2 too, where
// pdep is microcoded, tens to hundreds of cycles).
inline uint32_t morton_30(uint32_t x, uint32_t y, uint32_t z) {
#ifdef ZBUFFER_AVX512  // (which has BMI2: simd.h)
  return _pdep_u32(x, 0x09249249u) | _pdep_u32(y, 0x12492492u) | _pdep_u32(z, 0x24924924u);
#else
  return spread_bits_10(x) | (spread_bits_10(y) << 1) | (spread_bits_10(z) << 2);
#endif
}

// Sorts 64-bit words by their bits [low, low + bits), stably (LSD radix
// sort, passes of up to 11 bits), for keys packed above their values: a
// face's 32-bit index below its key, so that one word moves per element.
// Design decision: LSD radix rather than a comparison sort, on packed
// words rather than a key array and a value array sorted alongside. Good:
// linear in the number of faces, one histogram pass for every digit, and a
// digit that every element shares costs no pass; one stream of 8-byte
// words per bucket instead of two (the scattered writes of 1024 buckets x
// 2 arrays missed L1 on every element: packing halved the sort of the
// 5 x 5 x 20 spot grid's 2.9M keys, 50 -> 23-27 ms). Bad: the caller packs
// and unpacks; a scratch copy, kept per thread so that the next sort does
// not fault its pages in again.
inline void radix_sort_bits(std::vector<uint64_t>& words, int low, int bits) {
  const size_t n = words.size();
  if (n < 2 || bits <= 0) return;
  constexpr int kMaxDigit = 11;
  const int passes = (bits + kMaxDigit - 1) / kMaxDigit;
  const int digit = (bits + passes - 1) / passes;
  const size_t buckets = size_t(1) << digit;
  // Each pass's digit: the last one may be narrower (bits above are not the key's).
  uint64_t mask[(64 + kMaxDigit - 1) / kMaxDigit];
  for (int p = 0; p < passes; ++p) mask[p] = (uint64_t(1) << std::min(digit, bits - p * digit)) - 1;
  std::vector<size_t> count(buckets * size_t(passes), 0);
  for (size_t i = 0; i < n; ++i) {
    const uint64_t key = words[i] >> low;
    for (int p = 0; p < passes; ++p) ++count[size_t(p) * buckets + ((key >> (p * digit)) & mask[p])];
  }
  thread_local std::vector<uint64_t> scratch;
  scratch.resize(n);
  for (int p = 0; p < passes; ++p) {
    size_t* c = &count[size_t(p) * buckets];
    if (std::find(c, c + buckets, n) != c + buckets) continue;  // one digit for all
    size_t sum = 0;
    for (size_t b = 0; b < buckets; ++b) {
      const size_t here = c[b];
      c[b] = sum;
      sum += here;
    }
    const int shift = low + p * digit;
    const uint64_t* in = words.data();
    uint64_t* out = scratch.data();
    for (size_t i = 0; i < n; ++i) out[c[(in[i] >> shift) & mask[p]]++] = in[i];
    words.swap(scratch);
  }
}

// A vector of this thread's, kept from build to build so that the next
// build does not fault its pages in again (the trees' sort keys and faces:
// one tree is built at a time on a thread, so the octree and the BVH share
// them).
template <class T>
std::vector<T>& thread_scratch() {
  thread_local std::vector<T> v;
  return v;
}

// The keys (high halves) and faces (low halves) of sorted words.
inline void unpack_words(const std::vector<uint64_t>& words, std::vector<uint32_t>& keys,
                         std::vector<int32_t>& faces) {
  const size_t n = words.size();
  keys.resize(n);
  faces.resize(n);
  for (size_t i = 0; i < n; ++i) {
    keys[i] = uint32_t(words[i] >> 32);
    faces[i] = int32_t(uint32_t(words[i]));
  }
}

// Every vertex of a mesh quantized to a grid of 1024^3 cubic cells over the
// vertices' bounding cube: cell x | y << 10 | z << 20 per vertex.
// Design decision: quantize each vertex once rather than each corner of
// each face. Good: a face's cell box is then three integer loads and
// min/max (a mesh has about half as many vertices as faces, and each vertex
// is shared by six). Bad: 4 bytes per vertex of scratch.
struct VertexGrid {
  static constexpr int kBits = 10;
  static constexpr uint32_t kMask = (1u << kBits) - 1;
  std::vector<uint32_t> cell;
  double origin[3] = {0, 0, 0};  // the cube's low corner
  double cell_size = 1.0;        // its side / 1024

  // A world-space box that contains every point of the cells lo .. hi
  // (inclusive) of axis a, with a cell of margin for rounding; unbounded
  // where the grid has no usable cells (see set_cube).
  double world_lo(uint32_t lo, int a) const {
    return unbounded_ ? -std::numeric_limits<double>::infinity()
                      : origin[a] + (double(lo) - 1.0) * cell_size;
  }
  double world_hi(uint32_t hi, int a) const {
    return unbounded_ ? std::numeric_limits<double>::infinity()
                      : origin[a] + (double(hi) + 2.0) * cell_size;
  }

  // `vector`: the AVX-512 loops, 8 vertices per step, or the AVX2 ones, 4
  // (same bits; false only for tests holding them to the scalar ones).
  //
  // Design decision: the grid depends on the vertices' bounds, which take a
  // pass of their own -- unless they are known. A grid that is built again
  // for the same positions array (a per-frame tree of a mesh rendered frame
  // after frame: the thread's grid is kept) quantizes with the bounds it
  // had the time before while it takes the bounds anew, and keeps the
  // result if they came out the same. Good: one pass over the positions
  // instead of two (measured per frame, one process per variant: the
  // 5 x 5 x 80 spot grid's 5.86M vertices, octree 0.92x and BVH 0.88x;
  // N = 20 0.96-0.99x). Bad:
  // when they changed (the array was edited, or another took its address),
  // that pass is wasted and the quantization done again -- with the bounds
  // it found, so the grid is the two-pass one either way.
  void build(const MeshView& mesh, bool vector = true) {
    const int64_t n = mesh.n_vertices;
    const double* p = mesh.positions;
    cell.resize(size_t(n));
    double lo[3], hi[3];
    if (n > 0 && p == known_positions_ && n == known_vertices_) {
      if (bound_and_quantize(p, n, vector, lo, hi, /*quantize=*/true) && same_bounds(lo, hi)) return;
    } else {
      bound_and_quantize(p, n, vector, lo, hi, /*quantize=*/false);
    }
    set_cube(lo, hi, n);
    bound_and_quantize(p, n, vector, lo, hi, /*quantize=*/true);
    known_positions_ = p;
    known_vertices_ = n;
  }
#ifdef ZBUFFER_AVX512
  // The x, y and z of 8 consecutive xyz vertices at p: double k of the 24
  // is axis k % 3 of vertex k / 3; those among the first 16 come from a and
  // b, the others from c.
  struct Split {
    alignas(64) int64_t ab[3][8];  // lanes from a (0..7) and b (8..15)
    alignas(64) int64_t tc[3][8];  // from that (0..7) and c (8..15)
    constexpr Split() : ab{}, tc{} {
      for (int axis = 0; axis < 3; ++axis)
        for (int i = 0; i < 8; ++i) {
          const int k = 3 * i + axis;
          ab[axis][i] = k < 16 ? k : 0;
          tc[axis][i] = k < 16 ? i : 8 + (k - 16);
        }
    }
  };
  static void load8(const double* p, __m512d xyz[3]) {
    static constexpr Split kSplit{};
    const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8), c = _mm512_loadu_pd(p + 16);
    for (int axis = 0; axis < 3; ++axis)
      xyz[axis] = _mm512_permutex2var_pd(
          _mm512_permutex2var_pd(a, _mm512_load_si512(kSplit.ab[axis]), b),
          _mm512_load_si512(kSplit.tc[axis]), c);
  }
#elif defined(ZBUFFER_AVX2)
  // The x, y and z of 4 consecutive xyz vertices at p: from a = x0 y0 z0 x1,
  // b = y1 z1 x2 y2 and c = z2 x3 y3 z3, lane by lane.
  static void load4(const double* p, __m256d xyz[3]) {
    const __m256d a = _mm256_loadu_pd(p), b = _mm256_loadu_pd(p + 4), c = _mm256_loadu_pd(p + 8);
    // x: a0 a3 b2 c1; y: a1 b0 b3 c2; z: a2 b1 c0 c3.
    xyz[0] = _mm256_blend_pd(_mm256_blend_pd(_mm256_permute4x64_pd(a, 0x0C),
                                             _mm256_permute4x64_pd(b, 0x20), 0x4),
                             _mm256_permute4x64_pd(c, 0x40), 0x8);
    xyz[1] = _mm256_blend_pd(_mm256_blend_pd(_mm256_permute4x64_pd(a, 0x01),
                                             _mm256_permute4x64_pd(b, 0x30), 0x6),
                             _mm256_permute4x64_pd(c, 0x80), 0x8);
    xyz[2] = _mm256_blend_pd(_mm256_blend_pd(_mm256_permute4x64_pd(a, 0x02),
                                             _mm256_permute4x64_pd(b, 0x04), 0x2),
                             _mm256_permute4x64_pd(c, 0xC0), 0xC);
  }
#endif
  static uint32_t axis(uint32_t packed, int a) { return (packed >> (kBits * a)) & kMask; }

  // The 30-bit Morton code of face `idx`'s centroid cell: per axis the mean
  // of its corners' cells, rounded down. The visiting order (mesh_order.cpp)
  // sorts faces by it and the per-frame BVH buckets them by its top bits,
  // so that a mesh visited in that order arrives at the BVH bucket by bucket.
  uint32_t centroid_code(const int32_t* idx) const {
    uint32_t q[3];
    centroid_cell(idx, q);
    return morton_30(q[0], q[1], q[2]);
  }
  // The centroid cell itself, per axis.
  void centroid_cell(const int32_t* idx, uint32_t* q) const {
    const uint32_t c0 = cell[size_t(idx[0])], c1 = cell[size_t(idx[1])], c2 = cell[size_t(idx[2])];
    for (int a = 0; a < 3; ++a) q[a] = (axis(c0, a) + axis(c1, a) + axis(c2, a)) / 3;
  }

 private:
  // The bounds lo .. hi of the n vertices at p, and (`quantize`) their cells
  // on the grid as it stands. Returns whether every vertex was inside the
  // grid's cube (then the cells are exact). The bounds are reduced in the
  // same order with or without quantization, so that the same positions
  // give the same bits either way.
  bool bound_and_quantize(const double* p, int64_t n, bool vector, double* lo, double* hi,
                          bool quantize) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::numeric_limits<double>::infinity();
      hi[a] = -lo[a];
    }
    int64_t v = 0;
#ifdef ZBUFFER_AVX512
    if (vector && n >= 8) {
      __m512d l[3], h[3], o[3], sc = _mm512_set1_pd(scale_);
      const __m512d zero = _mm512_setzero_pd(), top = _mm512_set1_pd(double(kMask));
      for (int a = 0; a < 3; ++a) {
        l[a] = _mm512_set1_pd(lo[a]);  // from +inf and -inf, as the scalar loop
        h[a] = _mm512_set1_pd(hi[a]);
        o[a] = _mm512_set1_pd(origin[a]);
      }
      for (; v + 8 <= n; v += 8) {
        __m512d xyz[3];
        load8(p + 3 * v, xyz);
        for (int a = 0; a < 3; ++a) {
          // (xyz first: a NaN coordinate leaves the bound, as std::min does)
          l[a] = _mm512_min_pd(xyz[a], l[a]);
          h[a] = _mm512_max_pd(xyz[a], h[a]);
        }
        if (!quantize) continue;
        // The scalar loop's cell: t clamped to [0, 1023] (max with 0 first:
        // it gives 0 for a NaN t, as `t > 0.0` does), then truncated.
        __m256i c[3];
        for (int a = 0; a < 3; ++a) {
          const __m512d t = _mm512_mul_pd(_mm512_sub_pd(xyz[a], o[a]), sc);
          c[a] = _mm512_cvttpd_epu32(_mm512_min_pd(_mm512_max_pd(t, zero), top));
        }
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(&cell[size_t(v)]),
                            _mm256_or_si256(c[0], _mm256_or_si256(_mm256_slli_epi32(c[1], kBits),
                                                                  _mm256_slli_epi32(c[2], 2 * kBits))));
      }
      for (int a = 0; a < 3; ++a) {
        lo[a] = _mm512_reduce_min_pd(l[a]);
        hi[a] = _mm512_reduce_max_pd(h[a]);
      }
    }
#elif defined(ZBUFFER_AVX2)
    if (vector && n >= 4) {  // as above, 4 vertices per step
      __m256d l[3], h[3], o[3], sc = _mm256_set1_pd(scale_);
      const __m256d zero = _mm256_setzero_pd(), top = _mm256_set1_pd(double(kMask));
      for (int a = 0; a < 3; ++a) {
        l[a] = _mm256_set1_pd(lo[a]);  // from +inf and -inf, as the scalar loop
        h[a] = _mm256_set1_pd(hi[a]);
        o[a] = _mm256_set1_pd(origin[a]);
      }
      for (; v + 4 <= n; v += 4) {
        __m256d xyz[3];
        load4(p + 3 * v, xyz);
        for (int a = 0; a < 3; ++a) {
          // (xyz first: a NaN coordinate leaves the bound, as std::min does)
          l[a] = _mm256_min_pd(xyz[a], l[a]);
          h[a] = _mm256_max_pd(xyz[a], h[a]);
        }
        if (!quantize) continue;
        __m128i c[3];  // as above
        for (int a = 0; a < 3; ++a) {
          const __m256d t = _mm256_mul_pd(_mm256_sub_pd(xyz[a], o[a]), sc);
          c[a] = _mm256_cvttpd_epi32(_mm256_min_pd(_mm256_max_pd(t, zero), top));
        }
        _mm_storeu_si128(reinterpret_cast<__m128i*>(&cell[size_t(v)]),
                         _mm_or_si128(c[0], _mm_or_si128(_mm_slli_epi32(c[1], kBits),
                                                         _mm_slli_epi32(c[2], 2 * kBits))));
      }
      for (int a = 0; a < 3; ++a) {
        alignas(32) double lv[4], hv[4];
        _mm256_store_pd(lv, l[a]);
        _mm256_store_pd(hv, h[a]);
        lo[a] = std::min(std::min(lv[0], lv[1]), std::min(lv[2], lv[3]));
        hi[a] = std::max(std::max(hv[0], hv[1]), std::max(hv[2], hv[3]));
      }
    }
#endif
    (void)vector;
    for (int64_t t = v; t < n; ++t)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], p[3 * t + a]);
        hi[a] = std::max(hi[a], p[3 * t + a]);
      }
    bool inside = true;
    for (int a = 0; a < 3; ++a) inside &= lo[a] >= origin[a] && hi[a] <= origin[a] + side_;
    if (!quantize) return inside;
    // Every vertex gets its cell, whether or not the cube held them all
    // (a vertex at the far end may round past it: cell 1023 holds it).
    for (; v < n; ++v) {
      uint32_t q[3];
      for (int a = 0; a < 3; ++a) {
        const double t = (p[3 * v + a] - origin[a]) * scale_;
        q[a] = t > 0.0 ? uint32_t(std::min(t, double(kMask))) : 0u;  // (NaN: 0)
      }
      cell[size_t(v)] = q[0] | q[1] << kBits | q[2] << (2 * kBits);
    }
    return inside;
  }

  // The grid's cube from the vertices' bounds. Where the vertices' extent
  // is 0, overflows, or is so small that 1024 / extent overflows, there are
  // no cells to speak of: every vertex is in cell 0 and every box is
  // unbounded (a tree over such a mesh culls no node, and stays exact).
  void set_cube(const double* lo, const double* hi, int64_t n) {
    const double side = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    const double scale = double(kMask + 1) / side;
    unbounded_ = !(side > 0.0 && std::isfinite(side) && std::isfinite(scale));
    scale_ = unbounded_ ? 0.0 : scale;
    for (int a = 0; a < 3; ++a) {
      origin[a] = n > 0 ? lo[a] : 0.0;
      known_lo_[a] = lo[a];
      known_hi_[a] = hi[a];
    }
    cell_size = scale_ > 0.0 ? 1.0 / scale_ : 1.0;
    side_ = scale_ > 0.0 ? side : 0.0;
  }

  bool same_bounds(const double* lo, const double* hi) const {
    for (int a = 0; a < 3; ++a)
      if (!(lo[a] == known_lo_[a] && hi[a] == known_hi_[a])) return false;
    return true;
  }

  double scale_ = 0.0;  // 1024 / side (0: no usable cells, every vertex in cell 0)
  bool unbounded_ = false;
  double side_ = 0.0;
  double known_lo_[3] = {}, known_hi_[3] = {};
  const double* known_positions_ = nullptr;  // the positions the grid was last built for
  int64_t known_vertices_ = 0;
};

// The face's box on the vertex grid.
inline void face_cells(const VertexGrid& grid, const int32_t* idx, uint32_t* lo, uint32_t* hi) {
  const uint32_t c0 = grid.cell[size_t(idx[0])], c1 = grid.cell[size_t(idx[1])],
                 c2 = grid.cell[size_t(idx[2])];
  for (int a = 0; a < 3; ++a) {
    const uint32_t v0 = VertexGrid::axis(c0, a), v1 = VertexGrid::axis(c1, a),
                   v2 = VertexGrid::axis(c2, a);
    lo[a] = std::min({v0, v1, v2});
    hi[a] = std::max({v0, v1, v2});
  }
}

#ifdef ZBUFFER_AVX512
// The grid cells of 16 faces' corners (c[j]: corner j), and each face's box
// lo .. hi per axis, as face_cells computes it.
inline void face_cells16(const VertexGrid& grid, const int32_t* faces, __m512i* c, __m512i* lo,
                         __m512i* hi) {
  // (By loads, as assembly reads the screen vertices: simd.h.)
  for (int j = 0; j < 3; ++j) c[j] = simd::corner_words16(grid.cell.data(), faces + j);
  const __m512i mask = _mm512_set1_epi32(int(VertexGrid::kMask));
  for (int a = 0; a < 3; ++a) {
    const int shift = VertexGrid::kBits * a;
    __m512i v[3];
    for (int j = 0; j < 3; ++j) v[j] = _mm512_and_si512(_mm512_srli_epi32(c[j], unsigned(shift)), mask);
    lo[a] = _mm512_min_epu32(_mm512_min_epu32(v[0], v[1]), v[2]);
    hi[a] = _mm512_max_epu32(_mm512_max_epu32(v[0], v[1]), v[2]);
  }
}

// spread_bits_10 on 16 lanes.
inline __m512i spread_bits_10_16(__m512i v) {
  auto step = [](__m512i x, unsigned s, int m) {
    return _mm512_and_si512(_mm512_or_si512(x, _mm512_slli_epi32(x, s)), _mm512_set1_epi32(m));
  };
  v = _mm512_and_si512(v, _mm512_set1_epi32(0x3FF));
  v = step(v, 16, 0x030000FF);
  v = step(v, 8, 0x0300F00F);
  v = step(v, 4, 0x030C30C3);
  return step(v, 2, 0x09249249);
}

// VertexGrid::centroid_cell (q, per axis) and centroid_code of 16 faces
// whose corners' cells are c (as face_cells16 gives them): the sum s of
// three 10-bit values is at most 3069, where s * 43691 (under 2^32) >> 17
// is s / 3 exactly.
inline void centroid_cells16(const __m512i* c, __m512i* q) {
  const __m512i third = _mm512_set1_epi32(43691), mask = _mm512_set1_epi32(int(VertexGrid::kMask));
  for (int a = 0; a < 3; ++a) {
    const unsigned shift = unsigned(VertexGrid::kBits * a);
    __m512i sum = _mm512_setzero_si512();
    for (int j = 0; j < 3; ++j)
      sum = _mm512_add_epi32(sum, _mm512_and_si512(_mm512_srli_epi32(c[j], shift), mask));
    q[a] = _mm512_srli_epi32(_mm512_mullo_epi32(sum, third), 17);
  }
}
inline __m512i centroid_codes16(const __m512i* c) {
  __m512i q[3];
  centroid_cells16(c, q);
  __m512i code = _mm512_setzero_si512();
  for (int a = 0; a < 3; ++a)
    code = _mm512_or_si512(code, _mm512_slli_epi32(spread_bits_10_16(q[a]), unsigned(a)));
  return code;
}

// 16 words key << 32 | face at out, in lane order.
inline void store_words16(uint64_t* out, __m512i key, __m512i face) {
  for (int half = 0; half < 2; ++half) {
    const __m512i k64 = _mm512_cvtepu32_epi64(_mm512_extracti32x8_epi32(key, half));
    const __m512i f64 = _mm512_cvtepu32_epi64(_mm512_extracti32x8_epi32(face, half));
    _mm512_storeu_si512(out + 8 * half, _mm512_or_si512(_mm512_slli_epi64(k64, 32), f64));
  }
}
#elif defined(ZBUFFER_AVX2)
// The functions above for 8 faces (AVX2 builds), with the same bits.
inline void face_cells8(const VertexGrid& grid, const int32_t* faces, __m256i* c, __m256i* lo,
                        __m256i* hi) {
  for (int j = 0; j < 3; ++j) c[j] = simd::corner_words8(grid.cell.data(), faces + j);  // (as above)
  const __m256i mask = _mm256_set1_epi32(int(VertexGrid::kMask));
  for (int a = 0; a < 3; ++a) {
    const int shift = VertexGrid::kBits * a;
    __m256i v[3];
    for (int j = 0; j < 3; ++j) v[j] = _mm256_and_si256(_mm256_srli_epi32(c[j], shift), mask);
    lo[a] = _mm256_min_epu32(_mm256_min_epu32(v[0], v[1]), v[2]);
    hi[a] = _mm256_max_epu32(_mm256_max_epu32(v[0], v[1]), v[2]);
  }
}

inline __m256i spread_bits_10_8(__m256i v) {
  auto step = [](__m256i x, int s, int m) {
    return _mm256_and_si256(_mm256_or_si256(x, _mm256_slli_epi32(x, s)), _mm256_set1_epi32(m));
  };
  v = _mm256_and_si256(v, _mm256_set1_epi32(0x3FF));
  v = step(v, 16, 0x030000FF);
  v = step(v, 8, 0x0300F00F);
  v = step(v, 4, 0x030C30C3);
  return step(v, 2, 0x09249249);
}

inline void centroid_cells8(const __m256i* c, __m256i* q) {
  const __m256i third = _mm256_set1_epi32(43691), mask = _mm256_set1_epi32(int(VertexGrid::kMask));
  for (int a = 0; a < 3; ++a) {
    const int shift = VertexGrid::kBits * a;
    __m256i sum = _mm256_setzero_si256();
    for (int j = 0; j < 3; ++j)
      sum = _mm256_add_epi32(sum, _mm256_and_si256(_mm256_srli_epi32(c[j], shift), mask));
    q[a] = _mm256_srli_epi32(_mm256_mullo_epi32(sum, third), 17);
  }
}
inline __m256i centroid_codes8(const __m256i* c) {
  __m256i q[3];
  centroid_cells8(c, q);
  __m256i code = _mm256_setzero_si256();
  for (int a = 0; a < 3; ++a) code = _mm256_or_si256(code, _mm256_slli_epi32(spread_bits_10_8(q[a]), a));
  return code;
}

inline void store_words8(uint64_t* out, __m256i key, __m256i face) {
  for (int half = 0; half < 2; ++half) {
    const __m128i k = half ? _mm256_extracti128_si256(key, 1) : _mm256_castsi256_si128(key);
    const __m128i f = half ? _mm256_extracti128_si256(face, 1) : _mm256_castsi256_si128(face);
    const __m256i word = _mm256_or_si256(_mm256_slli_epi64(_mm256_cvtepu32_epi64(k), 32),
                                         _mm256_cvtepu32_epi64(f));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + 4 * half), word);
  }
}
#endif

// The cells of a complete octree of depth D (1 .. 10) over the vertex grid,
// numbered in pre-order, children in Morton order: a subtree is a run of
// numbers, its root first. Sorted by number, references to cells come in
// the order an octree is built in (a cell's own, then each child's
// subtree). Under 2^31 numbers (D = 10: 1,227,133,513).
class OctreeCells {
 public:
  static constexpr int kMaxDepth = 10;
  // `loose`: faces go to cells by the loose rule, else by the simpler one
  // (octree.h; Greene's rule, which gives a face several cells, is octree.cpp's).
  OctreeCells(int depth, bool loose) : depth_(depth), loose_(loose) {
    assert(depth >= 1 && depth <= kMaxDepth);
    for (int l = depth_; l >= 0; --l) size_[l] = l == depth_ ? 1 : 1 + 8 * size_[l + 1];
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
    for (int l = 1; l <= depth_; ++l)
      for (int d = 0; d < 16; ++d) digit_steps_[l][d] = d < 8 ? int32_t(d * size_[l]) : 0;
#endif
  }
  int depth() const { return depth_; }
  // Cells in the subtree of a cell at `level` (itself included).
  int64_t subtree(int level) const { return size_[level]; }
  // Bits that hold every number.
  int bits() const { return 64 - __builtin_clzll(uint64_t(size_[0] - 1) | 1); }

  // The number of the cell (x, y, z) at `level` (coordinates at that
  // level): the sum over its octal digits d_l (l = 1 .. level, from the
  // top) of 1 + d_l subtree(l), where subtree(l) = (8^(D-l+1) - 1) / 7.
  // With m the cell's Morton code, sum d_l 8^(D-l+1) = 8^(D-level+1) m, so
  // the sum is level + (8^(D-level+1) m - digit_sum(m)) / 7, exactly.
  int64_t number(uint32_t x, uint32_t y, uint32_t z, int level) const {
    const uint64_t m = morton_30(x, y, z);
    const int64_t digit_sum = __builtin_popcountll(m & 0x249249249249ull) +
                              2 * __builtin_popcountll(m & 0x492492492492ull) +
                              4 * __builtin_popcountll(m & 0x924924924924ull);
    return level + (int64_t(m << (3 * (depth_ - level + 1))) - digit_sum) / 7;
  }

  // The number of the cell that holds a face with the grid box lo .. hi and
  // the centroid cell q (VertexGrid::centroid_cell). The simpler rule: the
  // smallest cell (at depth <= D) that encloses the box. The loose rule: the
  // cell of the centroid at the deepest level (<= D) whose cells are as wide
  // as the box or wider on every axis.
  int64_t holder(const uint32_t* q, const uint32_t* lo, const uint32_t* hi) const {
    const int coarsen = VertexGrid::kBits - depth_;
    const uint32_t* at = loose_ ? q : lo;
    const uint32_t x = at[0] >> coarsen, y = at[1] >> coarsen, z = at[2] >> coarsen;
    uint32_t span = 0;  // the loose rule: the box's widest extent, in depth-D cells (rounded down)
    for (int a = 0; loose_ && a < 3; ++a) span = std::max(span, (hi[a] - lo[a]) >> coarsen);
    const uint32_t differ = loose_ ? span
                                   : (x ^ (hi[0] >> coarsen)) | (y ^ (hi[1] >> coarsen)) |
                                         (z ^ (hi[2] >> coarsen));
    // Levels up from D: the bit length of `differ` (below 2^D either way:
    // a face as wide as the cube goes to the root, s = D).
    const int s = differ ? 32 - __builtin_clz(differ) : 0;
    return number(x >> s, y >> s, z >> s, depth_ - s);
  }
  // holder() of the face `idx`, and its grid box.
  int64_t holder(const VertexGrid& grid, const int32_t* idx, uint32_t* lo, uint32_t* hi) const {
    uint32_t q[3] = {0, 0, 0};
    face_cells(grid, idx, lo, hi);
    if (loose_) grid.centroid_cell(idx, q);
    return holder(q, lo, hi);
  }

#ifdef ZBUFFER_AVX512
  // holder() of 16 faces whose corners' cells are c and boxes lo .. hi (as
  // face_cells16 gives them), computed digit by digit: the cell at `level`
  // holding a face has the octal digits d_1 .. d_level of its depth-D cell
  // (x, y, z), digit l being bit D - l of x, y and z.
  __m512i holder16(const __m512i* c, const __m512i* lo, const __m512i* hi) const {
    const unsigned coarsen = unsigned(VertexGrid::kBits - depth_);
    __m512i cell[3], differ = _mm512_setzero_si512();
    if (loose_) {
      centroid_cells16(c, cell);
      for (int a = 0; a < 3; ++a) {
        cell[a] = _mm512_srli_epi32(cell[a], coarsen);
        differ = _mm512_max_epu32(differ, _mm512_srli_epi32(_mm512_sub_epi32(hi[a], lo[a]), coarsen));
      }
    } else {
      for (int a = 0; a < 3; ++a) {
        cell[a] = _mm512_srli_epi32(lo[a], coarsen);
        differ = _mm512_or_si512(differ, _mm512_xor_si512(cell[a], _mm512_srli_epi32(hi[a], coarsen)));
      }
    }
    // Levels up from depth D: the bit length of `differ` (at most D).
    const __m512i up = _mm512_sub_epi32(_mm512_set1_epi32(32), _mm512_lzcnt_epi32(differ));
    const __m512i level = _mm512_sub_epi32(_mm512_set1_epi32(depth_), up);
    const __m512i one = _mm512_set1_epi32(1);
    __m512i index = level;
    for (int l = 1; l <= depth_; ++l) {
      const unsigned bit = unsigned(depth_ - l);
      __m512i digit = _mm512_setzero_si512();
      for (int a = 0; a < 3; ++a)
        digit = _mm512_or_si512(digit, _mm512_slli_epi32(_mm512_and_si512(_mm512_srli_epi32(cell[a], bit), one), unsigned(a)));
      const __mmask16 in = _mm512_cmple_epi32_mask(_mm512_set1_epi32(l), level);
      // digit x subtree(l), looked up (a permutation costs less than a product)
      index = _mm512_mask_add_epi32(index, in, index,
                                    _mm512_permutexvar_epi32(digit, _mm512_load_si512(digit_steps_[l])));
    }
    return index;
  }
#elif defined(ZBUFFER_AVX2)
  // holder16 for 8 faces (face_cells8), with the same bits. The bit length
  // of `differ` (below 2^D, D <= 10: exact as a float) is read off its
  // float exponent (AVX2 has no lzcnt of lanes); 0 has exponent 0, clamped
  // to a length of 0.
  __m256i holder8(const __m256i* c, const __m256i* lo, const __m256i* hi) const {
    const int coarsen = VertexGrid::kBits - depth_;
    __m256i cell[3], differ = _mm256_setzero_si256();
    if (loose_) {
      centroid_cells8(c, cell);
      for (int a = 0; a < 3; ++a) {
        cell[a] = _mm256_srli_epi32(cell[a], coarsen);
        differ = _mm256_max_epu32(differ, _mm256_srli_epi32(_mm256_sub_epi32(hi[a], lo[a]), coarsen));
      }
    } else {
      for (int a = 0; a < 3; ++a) {
        cell[a] = _mm256_srli_epi32(lo[a], coarsen);
        differ = _mm256_or_si256(differ, _mm256_xor_si256(cell[a], _mm256_srli_epi32(hi[a], coarsen)));
      }
    }
    // differ > 0 is 2^e x 1.m with e = exponent - 127; its bit length e + 1.
    const __m256i exponent = _mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(differ)), 23);
    const __m256i up = _mm256_max_epi32(_mm256_sub_epi32(exponent, _mm256_set1_epi32(126)),
                                        _mm256_setzero_si256());
    const __m256i level = _mm256_sub_epi32(_mm256_set1_epi32(depth_), up);
    const __m256i one = _mm256_set1_epi32(1);
    __m256i index = level;
    for (int l = 1; l <= depth_; ++l) {
      const int bit = depth_ - l;
      __m256i digit = _mm256_setzero_si256();
      for (int a = 0; a < 3; ++a) {
        const __m256i bit_a = _mm256_and_si256(_mm256_srli_epi32(cell[a], bit), one);
        digit = _mm256_or_si256(digit, _mm256_slli_epi32(bit_a, a));
      }
      const __m256i above = _mm256_cmpgt_epi32(_mm256_set1_epi32(l), level);  // digit l not the face's
      const __m256i step = _mm256_permutevar8x32_epi32(
          _mm256_load_si256(reinterpret_cast<const __m256i*>(digit_steps_[l])), digit);
      index = _mm256_add_epi32(index, _mm256_andnot_si256(above, step));
    }
    return index;
  }
#endif

  // As face_words' keys: the number of the cell holding each face.
  uint32_t one(const VertexGrid& grid, const int32_t* idx) const {
    uint32_t lo[3], hi[3];
    return uint32_t(holder(grid, idx, lo, hi));
  }
#ifdef ZBUFFER_AVX512
  __m512i sixteen(const __m512i* c, const __m512i* lo, const __m512i* hi) const {
    return holder16(c, lo, hi);
  }
#elif defined(ZBUFFER_AVX2)
  __m256i eight(const __m256i* c, const __m256i* lo, const __m256i* hi) const {
    return holder8(c, lo, hi);
  }
#endif

 private:
  int depth_;
  bool loose_;
  int64_t size_[kMaxDepth + 1] = {};
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  alignas(64) int32_t digit_steps_[kMaxDepth + 1][16] = {};  // [l][d]: d x size_[l] (d < 8)
#endif
};

// words[f] = key << 32 | f for every face f of the mesh, `keys` giving a
// face's key from its vertex indices (keys.one(grid, idx)) and, in AVX-512
// builds, 16 faces' keys from their corners' cells and boxes
// (keys.sixteen(c, lo, hi), as face_cells16 gives them; AVX2 builds: 8,
// keys.eight and face_cells8).
template <class Keys>
void face_words(const VertexGrid& grid, const MeshView& mesh, const Keys& keys,
                std::vector<uint64_t>& words) {
  const int64_t n = mesh.n_faces;
  words.resize(size_t(n));
  int64_t f = 0;
#ifdef ZBUFFER_AVX512
  const __m512i lanes = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  for (; f + 16 <= n; f += 16) {
    __m512i c[3], lo[3], hi[3];
    face_cells16(grid, mesh.faces + 3 * f, c, lo, hi);
    store_words16(&words[size_t(f)], keys.sixteen(c, lo, hi),
                  _mm512_add_epi32(_mm512_set1_epi32(int32_t(f)), lanes));
  }
#elif defined(ZBUFFER_AVX2)
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (; f + 8 <= n; f += 8) {
    __m256i c[3], lo[3], hi[3];
    face_cells8(grid, mesh.faces + 3 * f, c, lo, hi);
    store_words8(&words[size_t(f)], keys.eight(c, lo, hi),
                 _mm256_add_epi32(_mm256_set1_epi32(int32_t(f)), lanes));
  }
#endif
  for (; f < n; ++f) words[size_t(f)] = uint64_t(keys.one(grid, mesh.faces + 3 * f)) << 32 | uint32_t(f);
}

// face_words' keys: the centroid's Morton code (VertexGrid::centroid_code).
struct CentroidKeys {
  uint32_t one(const VertexGrid& grid, const int32_t* idx) const { return grid.centroid_code(idx); }
#ifdef ZBUFFER_AVX512
  __m512i sixteen(const __m512i* c, const __m512i*, const __m512i*) const {
    return centroid_codes16(c);
  }
#elif defined(ZBUFFER_AVX2)
  __m256i eight(const __m256i* c, const __m256i*, const __m256i*) const { return centroid_codes8(c); }
#endif
};

// Words (centroid code << 32 | face) of the mesh's faces, sorted by code
// (stably: ties in face order) -- the order of the BVH and of the visiting
// order (mesh_order.cpp).
inline void sorted_centroid_codes(const VertexGrid& grid, const MeshView& mesh,
                                  std::vector<uint64_t>& words) {
  face_words(grid, mesh, CentroidKeys(), words);
  radix_sort_bits(words, 32, 3 * VertexGrid::kBits);
}

}  // namespace zbuffer

