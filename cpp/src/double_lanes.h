// Private to the core: binary64 lanes for code written once for two
// instruction sets -- 8 lanes of AVX-512 (Doubles8) or 4 of AVX2 (Doubles4),
// with the same operations, so that a loop over faces reads like its
// scalar form and gives the same bits lane by lane (IEEE basic operations,
// no contraction: -ffp-contract=off). shading.cpp's face preparations use
// them.
//
// Each policy has: D (doubles, with + - * / and the functions below), Mask
// (a bit per lane in AVX-512, a lane of all ones in AVX2; & | ^ and
// andnot), Index (int32 per lane) and IndexMask (the mask the callers
// hold: AVX-512's bits, AVX2's int32 lanes of all ones), F (floats, one
// per lane).
#pragma once

#include <cstdint>
#include <limits>

#include "simd.h"

namespace zbuffer {
namespace lanes {

#ifdef ZBUFFER_AVX512
struct Doubles8 {
  static constexpr int kWidth = 8;
  using Index = __m256i;
  using IndexMask = __mmask8;
  using Mask = __mmask8;
  using F = __m256;
  struct D {
    __m512d v;
    friend ZBUFFER_INLINE D operator+(D a, D b) { return {_mm512_add_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE D operator-(D a, D b) { return {_mm512_sub_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE D operator*(D a, D b) { return {_mm512_mul_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE D operator/(D a, D b) { return {_mm512_div_pd(a.v, b.v)}; }
  };

  static ZBUFFER_INLINE D set(double x) { return {_mm512_set1_pd(x)}; }
  static ZBUFFER_INLINE D sqrt(D a) { return {_mm512_sqrt_pd(a.v)}; }
  static ZBUFFER_INLINE D abs(D a) { return {_mm512_abs_pd(a.v)}; }
  // (max and min return b where either is NaN, as maxpd does)
  static ZBUFFER_INLINE D max(D a, D b) { return {_mm512_max_pd(a.v, b.v)}; }
  static ZBUFFER_INLINE D min(D a, D b) { return {_mm512_min_pd(a.v, b.v)}; }
  static ZBUFFER_INLINE D floor(D a) {
    return {_mm512_roundscale_pd(a.v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC)};
  }

  static ZBUFFER_INLINE Mask lt(D a, D b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_LT_OQ); }
  static ZBUFFER_INLINE Mask le(D a, D b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_LE_OQ); }
  static ZBUFFER_INLINE Mask gt(D a, D b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_GT_OQ); }
  static ZBUFFER_INLINE Mask ge(D a, D b) { return _mm512_cmp_pd_mask(a.v, b.v, _CMP_GE_OQ); }
  static ZBUFFER_INLINE Mask andnot(Mask a, Mask b) { return Mask(~a & b); }  // b and not a
  static ZBUFFER_INLINE unsigned bits(Mask m) { return m; }
  // m ? b : a, lane by lane
  static ZBUFFER_INLINE D blend(Mask m, D a, D b) { return {_mm512_mask_blend_pd(m, a.v, b.v)}; }

  static ZBUFFER_INLINE Mask widen(IndexMask m) { return m; }
  static ZBUFFER_INLINE Index index(int32_t k) { return _mm256_set1_epi32(k); }
  static ZBUFFER_INLINE Index add(Index a, Index b) { return _mm256_add_epi32(a, b); }
  static ZBUFFER_INLINE Index times3(Index a) {
    return _mm256_mullo_epi32(a, _mm256_set1_epi32(3));
  }
  // base[i] of the lanes of m, 0 in the others
  static ZBUFFER_INLINE D gather(const float* base, Index i, IndexMask m) {
    return {_mm512_cvtps_pd(_mm256_mmask_i32gather_ps(_mm256_setzero_ps(), m, i, base, 4))};
  }

  static ZBUFFER_INLINE void store(double* p, D a) { _mm512_storeu_pd(p, a.v); }
  // The x, y, z of vertices v[0 .. 7] of a table of xyz triples, lane j
  // vertex v[j]: a load of each triple (masked: nothing past it is read)
  // and a transposition (prepare_faces in shading.cpp: why not gathers).
  static ZBUFFER_INLINE void load_xyz(const double* table, const int32_t* v, D out[3]) {
    auto vertex = [&](int j) { return _mm256_maskz_loadu_pd(0x7, table + 3 * size_t(v[j])); };
    auto two = [&](int j) {  // x_j y_j z_j 0 x_j+1 y_j+1 z_j+1 0
      return _mm512_insertf64x4(_mm512_castpd256_pd512(vertex(j)), vertex(j + 1), 1);
    };
    const __m512d q01 = two(0), q23 = two(2), q45 = two(4), q67 = two(6);
    const __m512i xy = _mm512_setr_epi64(0, 4, 8, 12, 1, 5, 9, 13);
    const __m512i zz = _mm512_setr_epi64(2, 6, 10, 14, 2, 6, 10, 14);
    const __m512d a = _mm512_permutex2var_pd(q01, xy, q23);  // x0-3 y0-3
    const __m512d b = _mm512_permutex2var_pd(q45, xy, q67);  // x4-7 y4-7
    const __m512d c = _mm512_permutex2var_pd(q01, zz, q23);  // z0-3
    const __m512d d = _mm512_permutex2var_pd(q45, zz, q67);  // z4-7
    const __m512i lo = _mm512_setr_epi64(0, 1, 2, 3, 8, 9, 10, 11);
    const __m512i hi = _mm512_setr_epi64(4, 5, 6, 7, 12, 13, 14, 15);
    out[0] = {_mm512_permutex2var_pd(a, lo, b)};
    out[1] = {_mm512_permutex2var_pd(a, hi, b)};
    out[2] = {_mm512_permutex2var_pd(c, lo, d)};
  }
  static ZBUFFER_INLINE F to_float(D a) { return _mm512_cvtpd_ps(a.v); }
  static ZBUFFER_INLINE F zero_float() { return _mm256_setzero_ps(); }
  // The whole numbers r, g, b (0 .. 255) as 0x00BBGGRR at out[j] for the
  // lanes j of m. (By value: an array of them went through the stack.)
  static ZBUFFER_INLINE void store_rgb(int32_t* out, IndexMask m, D r, D g, D b) {
    const __m512i rgb = _mm512_or_si512(
        _mm512_cvtpd_epi64(r.v), _mm512_or_si512(_mm512_slli_epi64(_mm512_cvtpd_epi64(g.v), 8),
                                                 _mm512_slli_epi64(_mm512_cvtpd_epi64(b.v), 16)));
    _mm256_mask_storeu_epi32(out, m, _mm512_cvtepi64_epi32(rgb));
  }
  // Fields g .. g + 7 of lanes 0 .. 7 (field[g + k], lane j) as rows: lane
  // j's into row + n j + g (for the lanes of `lanes`), for every g < n.
  static ZBUFFER_INLINE void store_rows(float* rows, int n, F* field, unsigned lanes) {
    for (int g = 0; g < n; g += 8) {
      simd::transpose8(field + g);
      for (unsigned l = lanes; l; l &= l - 1) {
        const int j = __builtin_ctz(l);
        _mm256_storeu_ps(rows + size_t(n) * size_t(j) + size_t(g), field[g + j]);
      }
    }
  }
};
#endif

#ifdef ZBUFFER_AVX2
struct Doubles4 {
  static constexpr int kWidth = 4;
  using Index = __m128i;
  using IndexMask = __m128i;  // int32 lanes of all ones or zeros
  using F = __m128;
  struct D {
    __m256d v;
    friend ZBUFFER_INLINE D operator+(D a, D b) { return {_mm256_add_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE D operator-(D a, D b) { return {_mm256_sub_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE D operator*(D a, D b) { return {_mm256_mul_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE D operator/(D a, D b) { return {_mm256_div_pd(a.v, b.v)}; }
  };
  struct Mask {  // binary64 lanes of all ones or zeros
    __m256d v;
    friend ZBUFFER_INLINE Mask operator&(Mask a, Mask b) { return {_mm256_and_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE Mask operator|(Mask a, Mask b) { return {_mm256_or_pd(a.v, b.v)}; }
    friend ZBUFFER_INLINE Mask operator^(Mask a, Mask b) { return {_mm256_xor_pd(a.v, b.v)}; }
    Mask& operator&=(Mask b) { return *this = *this & b; }
    Mask& operator|=(Mask b) { return *this = *this | b; }
  };
  static ZBUFFER_INLINE D set(double x) { return {_mm256_set1_pd(x)}; }
  static ZBUFFER_INLINE D sqrt(D a) { return {_mm256_sqrt_pd(a.v)}; }
  static ZBUFFER_INLINE D abs(D a) { return {_mm256_andnot_pd(_mm256_set1_pd(-0.0), a.v)}; }
  static ZBUFFER_INLINE D max(D a, D b) { return {_mm256_max_pd(a.v, b.v)}; }
  static ZBUFFER_INLINE D min(D a, D b) { return {_mm256_min_pd(a.v, b.v)}; }
  static ZBUFFER_INLINE D floor(D a) { return {_mm256_floor_pd(a.v)}; }

  static ZBUFFER_INLINE Mask lt(D a, D b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_LT_OQ)}; }
  static ZBUFFER_INLINE Mask le(D a, D b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_LE_OQ)}; }
  static ZBUFFER_INLINE Mask gt(D a, D b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_GT_OQ)}; }
  static ZBUFFER_INLINE Mask ge(D a, D b) { return {_mm256_cmp_pd(a.v, b.v, _CMP_GE_OQ)}; }
  static ZBUFFER_INLINE Mask andnot(Mask a, Mask b) { return {_mm256_andnot_pd(a.v, b.v)}; }
  static ZBUFFER_INLINE unsigned bits(Mask m) { return unsigned(_mm256_movemask_pd(m.v)); }
  static ZBUFFER_INLINE D blend(Mask m, D a, D b) { return {_mm256_blendv_pd(a.v, b.v, m.v)}; }

  static ZBUFFER_INLINE Mask widen(IndexMask m) {
    return {_mm256_castsi256_pd(_mm256_cvtepi32_epi64(m))};
  }
  static ZBUFFER_INLINE Index index(int32_t k) { return _mm_set1_epi32(k); }
  static ZBUFFER_INLINE Index add(Index a, Index b) { return _mm_add_epi32(a, b); }
  static ZBUFFER_INLINE Index times3(Index a) { return _mm_mullo_epi32(a, _mm_set1_epi32(3)); }
  static ZBUFFER_INLINE D gather(const float* base, Index i, IndexMask m) {
    return {_mm256_cvtps_pd(
        _mm_mask_i32gather_ps(_mm_setzero_ps(), base, i, _mm_castsi128_ps(m), 4))};
  }

  static ZBUFFER_INLINE void store(double* p, D a) { _mm256_storeu_pd(p, a.v); }
  // Doubles8's load_xyz for vertices v[0 .. 3].
  static ZBUFFER_INLINE void load_xyz(const double* table, const int32_t* v, D out[3]) {
    const __m256i first3 = _mm256_setr_epi64x(-1, -1, -1, 0);
    auto vertex = [&](int j) { return _mm256_maskload_pd(table + 3 * size_t(v[j]), first3); };
    const __m256d r0 = vertex(0), r1 = vertex(1), r2 = vertex(2), r3 = vertex(3);
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1);  // x0 x1 z0 z1
    const __m256d t1 = _mm256_unpackhi_pd(r0, r1);  // y0 y1 0 0
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3);  // x2 x3 z2 z3
    const __m256d t3 = _mm256_unpackhi_pd(r2, r3);  // y2 y3 0 0
    out[0] = {_mm256_permute2f128_pd(t0, t2, 0x20)};
    out[1] = {_mm256_permute2f128_pd(t1, t3, 0x20)};
    out[2] = {_mm256_permute2f128_pd(t0, t2, 0x31)};
  }
  static ZBUFFER_INLINE F to_float(D a) { return _mm256_cvtpd_ps(a.v); }
  static ZBUFFER_INLINE F zero_float() { return _mm_setzero_ps(); }
  static ZBUFFER_INLINE void store_rgb(int32_t* out, IndexMask m, D r, D g, D b) {
    const __m128i rgb = _mm_or_si128(
        _mm256_cvtpd_epi32(r.v), _mm_or_si128(_mm_slli_epi32(_mm256_cvtpd_epi32(g.v), 8),
                                              _mm_slli_epi32(_mm256_cvtpd_epi32(b.v), 16)));
    _mm_maskstore_epi32(out, m, rgb);
  }
  static ZBUFFER_INLINE void store_rows(float* rows, int n, F* field, unsigned lanes) {
    for (int g = 0; g < n; g += 4) {
      _MM_TRANSPOSE4_PS(field[g], field[g + 1], field[g + 2], field[g + 3]);
      for (int j = 0; j < 4; ++j)
        if (lanes & (1u << j))
          _mm_storeu_ps(rows + size_t(n) * size_t(j) + size_t(g), field[g + j]);
    }
  }
};
#endif

}  // namespace lanes
}  // namespace zbuffer
