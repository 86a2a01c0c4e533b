// Private to the core: which vector instructions this build uses, and the
// vector form of the raster core (coverage, depth, depth write) that every
// vector loop shares.
//
// A build with AVX-512 F/DQ/VL/BW/CD and BMI2 (e.g. -march=native on a
// recent x86, or -march=x86-64-v4) gets the 16-lane loops (8 lanes for the
// binary64 vertex stage and shading's face preparation); a build with AVX2
// but not all of those (most AMD processors before Zen 4, Intel's client
// cores) gets 8-lane loops for the vertex stage, face setup (the
// scanline's too), rasterization and shading (4 lanes for the binary64
// ones; the scanline's row walk and the per-frame trees' face pass stay
// scalar there); any other build gets the scalar loops. All perform the same IEEE
// operations per pixel and per vertex, so they produce the same bits; tests
// hold the vector loops to the scalar ones.
#pragma once

#if defined(__AVX512F__) && defined(__AVX512DQ__) && defined(__AVX512VL__) && \
    defined(__AVX512BW__) && defined(__AVX512CD__) && defined(__BMI2__)
#if defined(__GNUC__) && !defined(__clang__)
// GCC 12's own avx512fintrin.h trips this warning (_mm512_undefined_*).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
#include <immintrin.h>
#define ZBUFFER_AVX512 1
#elif defined(__AVX2__)
#if defined(__GNUC__) && !defined(__clang__)
// GCC 12's own avx2intrin.h trips these warnings (gathers' _mm256_undefined_*).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
#include <immintrin.h>
#define ZBUFFER_AVX2 1
#endif

#if defined(__GNUC__)
#define ZBUFFER_INLINE inline __attribute__((always_inline))
#else
#define ZBUFFER_INLINE inline
#endif

#include <cstdint>

#include "zbuffer/conventions.h"

namespace zbuffer {

// A hint to bring the line holding p into the caches (no-op elsewhere).
inline void prefetch(const void* p) {
#if defined(__GNUC__)
  __builtin_prefetch(p);
#else
  (void)p;
#endif
}

namespace simd {

// Faces drawn by the batched small-triangle loops (triangle_batch.cpp) and
// kept in the scanline's int32 records: less than kSmallFx across in x and
// y (their edge values fit int32); narrow ones: less than kNarrowFx in x.
constexpr int kSmallFx = 16 * kSubpixelScale;
constexpr int kNarrowFx = 8 * kSubpixelScale;

// Lane permutations that move the lanes of a bit mask to the front, in
// order (what AVX-512's compress does).
struct Compress8 {
  alignas(32) int32_t lanes[256][8];
  constexpr Compress8() : lanes{} {
    for (int m = 0; m < 256; ++m) {
      int n = 0;
      for (int lane = 0; lane < 8; ++lane)
        if (m & (1 << lane)) lanes[m][n++] = lane;
      while (n < 8) lanes[m][n++] = 0;
    }
  }
};
inline constexpr Compress8 kCompress8{};

#ifdef ZBUFFER_AVX512
// The vertex stage's transform (vertex_stage.h: transform_point) for 8
// points: clip = mvp * (p, 1), each row summed left to right.
ZBUFFER_INLINE void transform8(const double* m, __m512d x, __m512d y, __m512d z, __m512d* clip) {
  for (int r = 0; r < 4; ++r) {
    const __m512d xy = _mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(m[4 * r]), x),
                                     _mm512_mul_pd(_mm512_set1_pd(m[4 * r + 1]), y));
    clip[r] = _mm512_add_pd(_mm512_add_pd(xy, _mm512_mul_pd(_mm512_set1_pd(m[4 * r + 2]), z)),
                            _mm512_set1_pd(m[4 * r + 3]));
  }
}

// Lanes where any of the four clip coordinates is NaN or infinite.
ZBUFFER_INLINE __mmask8 nonfinite8(const __m512d* clip) {
  constexpr int kNanOrInf = 0x01 | 0x80 | 0x08 | 0x10;  // QNaN, SNaN, +inf, -inf
  return _mm512_fpclass_pd_mask(clip[0], kNanOrInf) | _mm512_fpclass_pd_mask(clip[1], kNanOrInf) |
         _mm512_fpclass_pd_mask(clip[2], kNanOrInf) | _mm512_fpclass_pd_mask(clip[3], kNanOrInf);
}
#endif

#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
// Vectors put together from scalar loads: the elements of a vertex table
// at one corner of consecutive faces (lane j is table[p[3 j]], p pointing
// at the corner's index in the first face), and int lanes from a function
// of the lane. 8-lane forms for AVX2 builds, 16-lane ones (two halves) for
// AVX-512 builds.
// Design decision: loads, not gathers, for a whole step's vertex data and
// per-face fields. Good: on the benchmark machine (AMD EPYC, 48K L1d) a
// gather costs about as much per lane as a load and an insert (5 ns for 16
// floats, 4.5 ns for 8 doubles), 64-bit elements come two values a load,
// and the indices are read straight from the faces, with no
// deinterleaving (benchmarks/README.md, "Loads instead of gathers":
// assembly 0.93-1.01x the time, the trees' face pass 0.84-1.00x). Bad:
// dozens of instructions where a gather was one, and only whole steps may
// use them (lanes past the last face must not be read: tails keep gathers).

// Lane k of f(0 .. 7) / f(0 .. 15), ints.
template <class F>
ZBUFFER_INLINE __m256i ints8(F f) {
  return _mm256_inserti128_si256(_mm256_castsi128_si256(_mm_setr_epi32(f(0), f(1), f(2), f(3))),
                                 _mm_setr_epi32(f(4), f(5), f(6), f(7)), 1);
}
// table[p[3 j]] for faces j = 0 .. 7 (4 byte elements).
ZBUFFER_INLINE __m256i corner_words8(const uint32_t* table, const int32_t* p) {
  return ints8([&](int j) { return int(table[p[3 * j]]); });
}
// The same for 8-byte elements (a vertex's x, y pair of int32: movq, no
// aliasing as int64), 4 faces; `stride`: ints between the indices.
template <int stride = 3>
ZBUFFER_INLINE __m256i corner_pairs4(const int32_t* pairs, const int32_t* p) {
  auto pair = [&](int j) {
    return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(pairs + 2 * size_t(p[stride * j])));
  };
  return _mm256_inserti128_si256(_mm256_castsi128_si256(_mm_unpacklo_epi64(pair(0), pair(1))),
                                 _mm_unpacklo_epi64(pair(2), pair(3)), 1);
}
ZBUFFER_INLINE __m256d corner_doubles4(const double* table, const int32_t* p) {
  auto two = [&](int j) { return _mm_loadh_pd(_mm_load_sd(table + p[3 * j]), table + p[3 * j + 3]); };
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(two(0)), two(2), 1);
}
#endif

#ifdef ZBUFFER_AVX512
template <class F>
ZBUFFER_INLINE __m512i ints16(F f) {
  return _mm512_inserti64x4(_mm512_castsi256_si512(ints8(f)), ints8([&](int k) { return f(8 + k); }), 1);
}
ZBUFFER_INLINE __m512i corner_words16(const uint32_t* table, const int32_t* p) {
  return _mm512_inserti64x4(_mm512_castsi256_si512(corner_words8(table, p)),
                            corner_words8(table, p + 24), 1);
}
template <int stride = 3>
ZBUFFER_INLINE __m512i corner_pairs8(const int32_t* pairs, const int32_t* p) {
  return _mm512_inserti64x4(_mm512_castsi256_si512(corner_pairs4<stride>(pairs, p)),
                            corner_pairs4<stride>(pairs, p + 4 * stride), 1);
}
// pairs[2 index[k]] and the next int, k = 0 .. 7 (consecutive indices).
ZBUFFER_INLINE __m512i pairs8(const int32_t* pairs, const int32_t* index) {
  return corner_pairs8<1>(pairs, index);
}
ZBUFFER_INLINE __m512d corner_doubles8(const double* table, const int32_t* p) {
  return _mm512_insertf64x4(_mm512_castpd256_pd512(corner_doubles4(table, p)),
                            corner_doubles4(table, p + 12), 1);
}
#endif

#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
// 8 x 8 floats held as 8 rows: afterwards r[j] holds what was column j.
ZBUFFER_INLINE void transpose8(__m256* r) {
  const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
  const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
  const __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
  const __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
  const __m256 s0 = _mm256_shuffle_ps(t0, t2, 0x44), s1 = _mm256_shuffle_ps(t0, t2, 0xEE);
  const __m256 s2 = _mm256_shuffle_ps(t1, t3, 0x44), s3 = _mm256_shuffle_ps(t1, t3, 0xEE);
  const __m256 s4 = _mm256_shuffle_ps(t4, t6, 0x44), s5 = _mm256_shuffle_ps(t4, t6, 0xEE);
  const __m256 s6 = _mm256_shuffle_ps(t5, t7, 0x44), s7 = _mm256_shuffle_ps(t5, t7, 0xEE);
  r[0] = _mm256_permute2f128_ps(s0, s4, 0x20);
  r[1] = _mm256_permute2f128_ps(s1, s5, 0x20);
  r[2] = _mm256_permute2f128_ps(s2, s6, 0x20);
  r[3] = _mm256_permute2f128_ps(s3, s7, 0x20);
  r[4] = _mm256_permute2f128_ps(s0, s4, 0x31);
  r[5] = _mm256_permute2f128_ps(s1, s5, 0x31);
  r[6] = _mm256_permute2f128_ps(s2, s6, 0x31);
  r[7] = _mm256_permute2f128_ps(s3, s7, 0x31);
}
#endif

#ifdef ZBUFFER_AVX512
// r[c] lane k becomes r[k] lane c: a 16 x 16 transposition, in four rounds
// of shuffles (32-bit, 64-bit, then 128-bit lanes twice).
ZBUFFER_INLINE void transpose16(__m512 r[16]) {
  __m512 t[16], u[16];
  for (int k = 0; k < 16; k += 2) {
    t[k] = _mm512_unpacklo_ps(r[k], r[k + 1]);      // a0 b0 a1 b1 per 128-bit lane
    t[k + 1] = _mm512_unpackhi_ps(r[k], r[k + 1]);  // a2 b2 a3 b3
  }
  for (int k = 0; k < 16; k += 4)
    for (int h = 0; h < 2; ++h) {
      const __m512d x = _mm512_castps_pd(t[k + h]), y = _mm512_castps_pd(t[k + 2 + h]);
      u[k + 2 * h] = _mm512_castpd_ps(_mm512_unpacklo_pd(x, y));      // a0 b0 c0 d0
      u[k + 2 * h + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(x, y));  // a1 b1 c1 d1
    }
  // u[4 g + m], 128-bit lane L: element 4 L + m of rows 4 g .. 4 g + 3.
  for (int m = 0; m < 4; ++m) {
    const __m512 ab_lo = _mm512_shuffle_f32x4(u[m], u[4 + m], 0x88);  // lanes 0, 2 of each
    const __m512 ab_hi = _mm512_shuffle_f32x4(u[m], u[4 + m], 0xDD);  // lanes 1, 3
    const __m512 cd_lo = _mm512_shuffle_f32x4(u[8 + m], u[12 + m], 0x88);
    const __m512 cd_hi = _mm512_shuffle_f32x4(u[8 + m], u[12 + m], 0xDD);
    r[m] = _mm512_shuffle_f32x4(ab_lo, cd_lo, 0x88);
    r[4 + m] = _mm512_shuffle_f32x4(ab_hi, cd_hi, 0x88);
    r[8 + m] = _mm512_shuffle_f32x4(ab_lo, cd_lo, 0xDD);
    r[12 + m] = _mm512_shuffle_f32x4(ab_hi, cd_hi, 0xDD);
  }
}

// The raster core (raster.h) in vector form: coverage, the depth formula and
// the depth write, for 16 pixels at a time. Every vector loop goes through
// these, so that the rules live in one place per instruction set.

// Coverage: the lanes of `lanes` whose three biased edge values are all
// >= 0 (the sign bit of their OR is clear).
ZBUFFER_INLINE __mmask16 covered16(__mmask16 lanes, __m512i w0b, __m512i w1b, __m512i w2b) {
  const __m512i any = _mm512_ternarylogic_epi32(w0b, w1b, w2b, 0xFE);  // a | b | c
  return _mm512_mask_cmpge_epi32_mask(lanes, any, _mm512_setzero_si512());
}

// The same from the unbiased values w1, w2 and their biases (0 or 1): w_k
// - bias_k >= 0 is w_k >= bias_k, tested by masked compares.
ZBUFFER_INLINE __mmask16 covered16(__mmask16 lanes, __m512i w0b, __m512i w1, __m512i w2,
                                   __m512i bias1, __m512i bias2) {
  const __mmask16 k = _mm512_mask_cmpge_epi32_mask(lanes, w0b, _mm512_setzero_si512());
  return _mm512_mask_cmpge_epi32_mask(_mm512_mask_cmpge_epi32_mask(k, w1, bias1), w2, bias2);
}

// The same for 8 lanes of int64 edge values (triangles too big for int32).
ZBUFFER_INLINE __mmask8 covered8(__mmask8 lanes, __m512i w0b, __m512i w1b, __m512i w2b) {
  const __m512i any = _mm512_ternarylogic_epi64(w0b, w1b, w2b, 0xFE);  // a | b | c
  return _mm512_mask_cmpge_epi64_mask(lanes, any, _mm512_setzero_si512());
}

// Adds 1 to the lanes of `count` in `lanes` (per-lane counters of pixels,
// summed once a loop is done: cheaper than a popcount per mask).
ZBUFFER_INLINE __m512i count16(__m512i count, __mmask16 lanes) {
  return _mm512_mask_sub_epi32(count, lanes, count, _mm512_set1_epi32(-1));
}

// An optimisation barrier: v is in a register here, so that the compiler
// cannot fold the instruction that made it into a later store (see
// write16_rows). Costs no instruction.
template <class V>
ZBUFFER_INLINE void keep_in_register(V& v) {
#if defined(__GNUC__)
  asm("" : "+v"(v));
#else
  (void)v;
#endif
}

// One triangle's depth plane (raster.h: TriangleSetup) in every lane.
struct DepthPlane16 {
  __m512 z0, a1, a2, lo, hi;
  DepthPlane16(float z0_, float a1_, float a2_, float lo_, float hi_)
      : z0(_mm512_set1_ps(z0_)), a1(_mm512_set1_ps(a1_)), a2(_mm512_set1_ps(a2_)),
        lo(_mm512_set1_ps(lo_)), hi(_mm512_set1_ps(hi_)) {}
  // A different triangle's plane in each lane.
  DepthPlane16(__m512 z0_, __m512 a1_, __m512 a2_, __m512 lo_, __m512 hi_)
      : z0(z0_), a1(a1_), a2(a2_), lo(lo_), hi(hi_) {}
};

// The depth formula: z0 + (f1 * a1 + f2 * a2), clamped, for f1, f2 the
// exact unbiased edge values w1, w2 rounded to float.
ZBUFFER_INLINE __m512 depth16_of(const DepthPlane16& p, __m512 f1, __m512 f2) {
  const __m512 z =
      _mm512_add_ps(p.z0, _mm512_add_ps(_mm512_mul_ps(f1, p.a1), _mm512_mul_ps(f2, p.a2)));
  return _mm512_min_ps(_mm512_max_ps(z, p.lo), p.hi);  // clamp (no NaN, no -0 here)
}

// The same for exact unbiased int32 edge values w1, w2.
ZBUFFER_INLINE __m512 depth16(const DepthPlane16& p, __m512i w1, __m512i w2) {
  return depth16_of(p, _mm512_cvtepi32_ps(w1), _mm512_cvtepi32_ps(w2));
}

// float(w) of 16 exact int64 values, lanes 0-7 in lo and 8-15 in hi
// (rounded to nearest even, as float(int64) in scalar code).
ZBUFFER_INLINE __m512 to_float16(__m512i lo, __m512i hi) {
  return _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtepi64_ps(lo)),
                            _mm512_cvtepi64_ps(hi), 1);
}

// The same for 8 lanes of int64 edge values (triangles too big for int32).
ZBUFFER_INLINE __m256 depth8(const DepthPlane16& p, __m512i w1, __m512i w2) {
  const __m256 z0 = _mm512_castps512_ps256(p.z0), a1 = _mm512_castps512_ps256(p.a1),
               a2 = _mm512_castps512_ps256(p.a2);
  const __m256 z = _mm256_add_ps(z0, _mm256_add_ps(_mm256_mul_ps(_mm512_cvtepi64_ps(w1), a1),
                                                   _mm256_mul_ps(_mm512_cvtepi64_ps(w2), a2)));
  return _mm256_min_ps(_mm256_max_ps(z, _mm512_castps512_ps256(p.lo)),
                       _mm512_castps512_ps256(p.hi));
}

// The depth write for up to 16 pixels of a row: of the lanes `inside`,
// those nearer than the stored depth, or equal to it with a smaller id.
// Masked loads and stores touch only the lanes in `inside`; the stored ids
// are read only where the depths tie (rarely), the only lanes where the
// decision looks at them.
ZBUFFER_INLINE __mmask16 write16(__mmask16 inside, __m512 z, __m512i id, float* d_ptr,
                                 int32_t* id_ptr) {
  const __m512 d = _mm512_mask_loadu_ps(_mm512_setzero_ps(), inside, d_ptr);
  __mmask16 win = _mm512_mask_cmp_ps_mask(inside, z, d, _CMP_LT_OQ);
  const __mmask16 tie = _mm512_mask_cmp_ps_mask(inside, z, d, _CMP_EQ_OQ);
  if (tie)  // rare: the stored ids are read only where depths tie
    win |= _mm512_mask_cmplt_epi32_mask(
        tie, id, _mm512_mask_loadu_epi32(_mm512_setzero_si512(), tie, id_ptr));
  _mm512_mask_storeu_ps(d_ptr, win, z);
  _mm512_mask_storeu_epi32(id_ptr, win, id);
  return win;
}

// Dword permutations between 8 + 8 (a, b) pairs and 16 lanes.
alignas(64) inline constexpr int32_t kEven[16] = {0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30};
alignas(64) inline constexpr int32_t kOdd[16] = {1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31};
alignas(64) inline constexpr int32_t kPairsLo[16] = {0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23};
alignas(64) inline constexpr int32_t kPairsHi[16] = {8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31};

// The pairs (a_k, b_k) of lanes 0-7 and of lanes 8-15, as 64-bit elements
// with a_k in the low half.
ZBUFFER_INLINE void pairs16(__m512i a, __m512i b, __m512i& lo, __m512i& hi) {
  lo = _mm512_permutex2var_epi32(a, _mm512_load_si512(kPairsLo), b);
  hi = _mm512_permutex2var_epi32(a, _mm512_load_si512(kPairsHi), b);
}

// depth_write_key (raster.h) for 16 lanes, the lanes of `inside`, at pixels
// x of a row of keys: a gather and a scatter of keys (two of 8 elements
// each). The lanes must name distinct pixels (a gather reads all lanes
// before the scatter writes any: two lanes at one pixel would both compare
// with its old key).
ZBUFFER_INLINE __mmask16 write16_keys_at(__mmask16 inside, __m512 z, __m512i id, __m512i x,
                                         uint64_t* row) {
  __m512i key[2];
  pairs16(id, _mm512_castps_si512(z), key[0], key[1]);
  const __m256i at[2] = {_mm512_castsi512_si256(x), _mm512_extracti64x4_epi64(x, 1)};
  __mmask16 win = 0;
  for (int h = 0; h < 2; ++h) {
    const __mmask8 in = __mmask8(inside >> (8 * h));
    if (!in) continue;  // a gather and a scatter cost the same whatever their mask
    const __m512i old = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), in, at[h], row, 8);
    const __mmask8 won = _mm512_mask_cmplt_epu64_mask(in, key[h], old);
    _mm512_mask_i32scatter_epi64(row, won, at[h], key[h], 8);
    win |= __mmask16(won) << (8 * h);
  }
  return win;
}

// The same for 16 consecutive pixels from row[0].
ZBUFFER_INLINE __mmask16 write16_keys(__mmask16 inside, __m512 z, __m512i id, uint64_t* row) {
  __m512i key[2];
  pairs16(id, _mm512_castps_si512(z), key[0], key[1]);
  __mmask16 win = 0;
  for (int h = 0; h < 2; ++h) {
    const __mmask8 in = __mmask8(inside >> (8 * h));
    const __m512i old = _mm512_maskz_loadu_epi64(in, row + 8 * h);
    const __mmask8 won = _mm512_mask_cmplt_epu64_mask(in, key[h], old);
    _mm512_mask_storeu_epi64(row + 8 * h, won, key[h]);
    win |= __mmask16(won) << (8 * h);
  }
  return win;
}

// Edge values of 16 consecutive pixels of a row: w at the first, `step` from
// one pixel to the next (wrapping int32 arithmetic: lanes that leave the
// range of exact values must be masked off by the caller).
ZBUFFER_INLINE __m512i row16(int32_t w, int32_t step) {
  const __m512i lane = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  return _mm512_add_epi32(_mm512_set1_epi32(w), _mm512_mullo_epi32(lane, _mm512_set1_epi32(step)));
}

// The raster core on up to 16 consecutive pixels of one row (the lanes of
// `in_span`): coverage of the biased edge values w0b, w1b, w2b, the depth
// formula of the unbiased ones, and the depth write at (d_ptr, id_ptr).
// Returns the covered lanes; `win` gets those written.
ZBUFFER_INLINE __mmask16 span16(__mmask16 in_span, __m512i w0b, __m512i w1b, __m512i w2b,
                                __m512i bias1, __m512i bias2, const DepthPlane16& plane,
                                __m512i id, float* d_ptr, int32_t* id_ptr, __mmask16& win) {
  const __mmask16 inside = covered16(in_span, w0b, w1b, w2b);
  const __m512 z = depth16(plane, _mm512_add_epi32(w1b, bias1), _mm512_add_epi32(w2b, bias2));
  win = write16(inside, z, id, d_ptr, id_ptr);
  return inside;
}

// The depth write for two rows of up to 8 pixels: lanes 0-7 at (d0, i0),
// lanes 8-15 at (d1, i1). Ids are read only where the depths tie, as in
// write16.
ZBUFFER_INLINE __mmask16 write16_rows(__mmask16 inside, __m512 z, __m512i id, float* d0,
                                      float* d1, int32_t* i0, int32_t* i1) {
  const __mmask8 lo = __mmask8(inside), hi = __mmask8(inside >> 8);
  const __m512 d = _mm512_insertf32x8(
      _mm512_castps256_ps512(_mm256_mask_loadu_ps(_mm256_setzero_ps(), lo, d0)),
      _mm256_mask_loadu_ps(_mm256_setzero_ps(), hi, d1), 1);
  __mmask16 win = _mm512_mask_cmp_ps_mask(inside, z, d, _CMP_LT_OQ);
  const __mmask16 tie = _mm512_mask_cmp_ps_mask(inside, z, d, _CMP_EQ_OQ);
  if (tie) {
    const __m512i ids = _mm512_inserti64x4(
        _mm512_castsi256_si512(_mm256_mask_loadu_epi32(_mm256_setzero_si256(), __mmask8(tie), i0)),
        _mm256_mask_loadu_epi32(_mm256_setzero_si256(), __mmask8(tie >> 8), i1), 1);
    win |= _mm512_mask_cmplt_epi32_mask(tie, id, ids);
  }
  const __m256i id8 = _mm512_castsi512_si256(id);
  _mm256_mask_storeu_ps(d0, __mmask8(win), _mm512_castps512_ps256(z));
  // The second row's depths extracted into a register first: compilers
  // fuse an extract and a masked store into vextractf32x8 to memory under a
  // mask, which faults on Zen 4 where its masked-off bytes cross into an
  // unmapped page (past the end of a plane); a masked move does not.
  __m256 z1 = _mm512_extractf32x8_ps(z, 1);
  keep_in_register(z1);
  _mm256_mask_storeu_ps(d1, __mmask8(win >> 8), z1);
  _mm256_mask_storeu_epi32(i0, __mmask8(win), id8);
  _mm256_mask_storeu_epi32(i1, __mmask8(win >> 8), id8);
  return win;
}
#endif

#ifdef ZBUFFER_AVX2
// The raster core in AVX2 form, 8 pixels at a time. AVX2 has no mask
// registers: a lane mask is a vector of int32 lanes that are all ones (in)
// or all zeros (out).

// Coverage: the lanes of `lanes` whose three biased edge values are all >= 0.
ZBUFFER_INLINE __m256i covered8x32(__m256i lanes, __m256i w0b, __m256i w1b, __m256i w2b) {
  const __m256i any = _mm256_or_si256(_mm256_or_si256(w0b, w1b), w2b);
  return _mm256_andnot_si256(_mm256_srai_epi32(any, 31), lanes);  // sign clear, and in lanes
}

// One triangle's depth plane in every lane.
struct DepthPlane8 {
  __m256 z0, a1, a2, lo, hi;
  DepthPlane8(float z0_, float a1_, float a2_, float lo_, float hi_)
      : z0(_mm256_set1_ps(z0_)), a1(_mm256_set1_ps(a1_)), a2(_mm256_set1_ps(a2_)),
        lo(_mm256_set1_ps(lo_)), hi(_mm256_set1_ps(hi_)) {}
};

// The depth formula: z0 + (f1 * a1 + f2 * a2), clamped, for f1, f2 the
// exact unbiased edge values w1, w2 rounded to float (no fused multiply-add).
ZBUFFER_INLINE __m256 depth8_of(const DepthPlane8& p, __m256 f1, __m256 f2) {
  const __m256 z =
      _mm256_add_ps(p.z0, _mm256_add_ps(_mm256_mul_ps(f1, p.a1), _mm256_mul_ps(f2, p.a2)));
  return _mm256_min_ps(_mm256_max_ps(z, p.lo), p.hi);  // clamp (no NaN, no -0 here)
}

// The same for exact unbiased int32 edge values w1, w2.
ZBUFFER_INLINE __m256 depth8x32(const DepthPlane8& p, __m256i w1, __m256i w2) {
  return depth8_of(p, _mm256_cvtepi32_ps(w1), _mm256_cvtepi32_ps(w2));
}

// float(w) of 8 integers held exactly in doubles (|w| < 2^53), lanes 0-3
// in lo and 4-7 in hi: one rounding from the exact value, as float(int64).
ZBUFFER_INLINE __m256 to_float8(__m256d lo, __m256d hi) {
  return _mm256_set_m128(_mm256_cvtpd_ps(hi), _mm256_cvtpd_ps(lo));
}

// The depth write's decision: of the lanes `inside`, those nearer than the
// stored depth, or equal to it with a smaller id.
ZBUFFER_INLINE __m256i wins8(__m256i inside, __m256 z, __m256i id, __m256 old_depth,
                             __m256i old_ids) {
  const __m256i nearer = _mm256_castps_si256(_mm256_cmp_ps(z, old_depth, _CMP_LT_OQ));
  const __m256i tie = _mm256_castps_si256(_mm256_cmp_ps(z, old_depth, _CMP_EQ_OQ));
  const __m256i smaller = _mm256_cmpgt_epi32(old_ids, id);
  return _mm256_and_si256(inside, _mm256_or_si256(nearer, _mm256_and_si256(tie, smaller)));
}

ZBUFFER_INLINE int lanes8(__m256i mask) {
  return __builtin_popcount(unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(mask))));
}

// The depth write for 8 pixels of one row at (d_ptr, id_ptr). With `whole`,
// all 8 pixels lie inside the buffer: they are loaded and stored whole (the
// lanes that do not win store back what they loaded), which is much faster
// than AVX2's masked stores on some processors; otherwise only the lanes in
// `inside` are touched.
ZBUFFER_INLINE __m256i write8(__m256i inside, __m256 z, __m256i id, float* d_ptr,
                              int32_t* id_ptr, bool whole) {
  if (whole) {
    const __m256 d = _mm256_loadu_ps(d_ptr);
    const __m256i ids = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(id_ptr));
    const __m256i win = wins8(inside, z, id, d, ids);
    if (!_mm256_testz_si256(win, win)) {
      _mm256_storeu_ps(d_ptr, _mm256_blendv_ps(d, z, _mm256_castsi256_ps(win)));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(id_ptr), _mm256_blendv_epi8(ids, id, win));
    }
    return win;
  }
  const __m256 d = _mm256_maskload_ps(d_ptr, inside);
  const __m256i ids = _mm256_maskload_epi32(id_ptr, inside);
  const __m256i win = wins8(inside, z, id, d, ids);
  _mm256_maskstore_ps(d_ptr, win, z);
  _mm256_maskstore_epi32(id_ptr, win, id);
  return win;
}

// The depth write for two rows of 4 pixels: lanes 0-3 at (d0, i0), lanes
// 4-7 at (d1, i1); `whole` as for write8 (4 pixels of each row inside the
// buffer). Without `second`, lanes 4-7 are off and their row is not touched.
ZBUFFER_INLINE __m256i write8_rows(__m256i inside, __m256 z, __m256i id, float* d0, float* d1,
                                   int32_t* i0, int32_t* i1, bool second, bool whole) {
  if (whole) {
    const __m256 d = _mm256_set_m128(second ? _mm_loadu_ps(d1) : _mm_setzero_ps(), _mm_loadu_ps(d0));
    const __m256i ids = _mm256_set_m128i(
        second ? _mm_loadu_si128(reinterpret_cast<const __m128i*>(i1)) : _mm_setzero_si128(),
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(i0)));
    const __m256i win = wins8(inside, z, id, d, ids);
    const __m256 new_d = _mm256_blendv_ps(d, z, _mm256_castsi256_ps(win));
    const __m256i new_ids = _mm256_blendv_epi8(ids, id, win);
    _mm_storeu_ps(d0, _mm256_castps256_ps128(new_d));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(i0), _mm256_castsi256_si128(new_ids));
    if (second) {
      _mm_storeu_ps(d1, _mm256_extractf128_ps(new_d, 1));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(i1), _mm256_extracti128_si256(new_ids, 1));
    }
    return win;
  }
  const __m128i in0 = _mm256_castsi256_si128(inside), in1 = _mm256_extracti128_si256(inside, 1);
  const __m256 d = _mm256_set_m128(_mm_maskload_ps(d1, in1), _mm_maskload_ps(d0, in0));
  const __m256i ids = _mm256_set_m128i(_mm_maskload_epi32(i1, in1), _mm_maskload_epi32(i0, in0));
  const __m256i win = wins8(inside, z, id, d, ids);
  const __m128i win0 = _mm256_castsi256_si128(win), win1 = _mm256_extracti128_si256(win, 1);
  _mm_maskstore_ps(d0, win0, _mm256_castps256_ps128(z));
  _mm_maskstore_ps(d1, win1, _mm256_extractf128_ps(z, 1));
  _mm_maskstore_epi32(i0, win0, _mm256_castsi256_si128(id));
  _mm_maskstore_epi32(i1, win1, _mm256_castsi256_si128(id));
  return win;
}
#endif

// The faces of a vector step (16 or 8 lanes of assembled faces f, the first
// face `first`) that the vector setup leaves to scalar code: each lane of
// `large` as its assembled triangle, on_triangle(ScreenTriangle), through a
// `Lanes` copy of f made only when there are any; each lane of f.clip by its
// face index, on_clip(face), for the scalar assembly, which clips.
template <class Lanes, class Faces, class Mesh, class OnTriangle, class OnClip>
ZBUFFER_INLINE void for_each_left_over(const Faces& f, unsigned large, const Mesh& mesh,
                                       int64_t first, OnTriangle on_triangle, OnClip on_clip) {
  if (large) {
    const Lanes lanes(f);
    for (unsigned m = large; m; m &= m - 1) {
      const int lane = __builtin_ctz(m);
      on_triangle(lanes.triangle(lane, mesh.id(first + lane)));
    }
  }
  for (unsigned m = f.clip; m; m &= m - 1) on_clip(first + __builtin_ctz(m));
}

}  // namespace simd
}  // namespace zbuffer
