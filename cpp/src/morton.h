// Private to the core: Morton (Z-order) codes and the radix sort that orders
// faces by them. The spatial visiting order (mesh_order.cpp), the octree and
// the BVH all start from faces sorted along this curve.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "simd.h"
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
inline uint32_t morton_30(uint32_t x, uint32_t y, uint32_t z) {
  return spread_bits_10(x) | (spread_bits_10(y) << 1) | (spread_bits_10(z) << 2);
}

// Sorts (key, value) pairs by the low `key_bits` bits of key, stably, with
// passes of up to 12 bits (LSD radix sort). Both vectors are permuted.
// Design decision: LSD radix rather than a comparison sort. Good: linear in
// the number of faces (a few ns per face and pass), which keeps building a
// tree per frame affordable. Bad: a scratch copy of both arrays, kept per
// thread so that the next sort does not fault its pages in again.
template <class Key, class Value>
void radix_sort(std::vector<Key>& key, std::vector<Value>& value, int key_bits) {
  const size_t n = key.size();
  if (n < 2 || key_bits <= 0) return;
  const int passes = (key_bits + 11) / 12;
  const int bits = (key_bits + passes - 1) / passes;
  const Key mask = (Key(1) << bits) - 1;
  thread_local std::vector<Key> key_tmp;
  thread_local std::vector<Value> value_tmp;
  key_tmp.resize(n);
  value_tmp.resize(n);
  std::vector<size_t> count(size_t(1) << bits);
  for (int pass = 0; pass < passes; ++pass) {
    const int shift = pass * bits;
    std::fill(count.begin(), count.end(), 0);
    for (size_t i = 0; i < n; ++i) ++count[(key[i] >> shift) & mask];
    size_t sum = 0;
    for (size_t& c : count) {
      const size_t here = c;
      c = sum;
      sum += here;
    }
    for (size_t i = 0; i < n; ++i) {
      const size_t dst = count[(key[i] >> shift) & mask]++;
      key_tmp[dst] = key[i];
      value_tmp[dst] = value[i];
    }
    key.swap(key_tmp);
    value.swap(value_tmp);
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

  // `vector`: the AVX-512 loops, 8 vertices per step (same bits; false
  // only for tests holding them to the scalar ones).
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
#endif
  static uint32_t axis(uint32_t packed, int a) { return (packed >> (kBits * a)) & kMask; }

  // The 30-bit Morton code of face `idx`'s centroid cell: per axis the mean
  // of its corners' cells, rounded down. The visiting order (mesh_order.cpp)
  // sorts faces by it and the per-frame BVH buckets them by its top bits,
  // so that a mesh visited in that order arrives at the BVH bucket by bucket.
  uint32_t centroid_code(const int32_t* idx) const {
    const uint32_t c0 = cell[size_t(idx[0])], c1 = cell[size_t(idx[1])], c2 = cell[size_t(idx[2])];
    uint32_t q[3];
    for (int a = 0; a < 3; ++a) q[a] = (axis(c0, a) + axis(c1, a) + axis(c2, a)) / 3;
    return morton_30(q[0], q[1], q[2]);
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
      for (int a = 0; a < 3; ++a) {
        l[a] = h[a] = _mm512_set1_pd(p[a]);
        o[a] = _mm512_set1_pd(origin[a]);
      }
      const __m256i mask = _mm256_set1_epi32(int(kMask));
      for (; v + 8 <= n; v += 8) {
        __m512d xyz[3];
        load8(p + 3 * v, xyz);
        for (int a = 0; a < 3; ++a) {
          l[a] = _mm512_min_pd(l[a], xyz[a]);
          h[a] = _mm512_max_pd(h[a], xyz[a]);
        }
        if (!quantize) continue;
        // Within the cube, (p - origin) * scale is in [0, 1024]: truncation
        // is floor and only 1024 needs clamping (outside it, the bounds
        // differ and these cells are not kept).
        __m256i c[3];
        for (int a = 0; a < 3; ++a)
          c[a] = _mm256_min_epu32(_mm512_cvttpd_epu32(_mm512_mul_pd(_mm512_sub_pd(xyz[a], o[a]), sc)), mask);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(&cell[size_t(v)]),
                            _mm256_or_si256(c[0], _mm256_or_si256(_mm256_slli_epi32(c[1], kBits),
                                                                  _mm256_slli_epi32(c[2], 2 * kBits))));
      }
      for (int a = 0; a < 3; ++a) {
        lo[a] = _mm512_reduce_min_pd(l[a]);
        hi[a] = _mm512_reduce_max_pd(h[a]);
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

}  // namespace zbuffer

