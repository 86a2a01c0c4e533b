// Private to the core: which vector instructions this build uses, and the
// vector form of the depth write shared by every vector loop.
//
// A build with AVX-512 F/DQ/VL/BW (e.g. -march=native on a recent x86) gets
// the vector loops; any other build gets the scalar ones. Both perform the
// same IEEE operations per pixel and per vertex, so they produce the same
// bits; tests hold the vector loops to the scalar ones.
#pragma once

#if defined(__AVX512F__) && defined(__AVX512DQ__) && defined(__AVX512VL__) && \
    defined(__AVX512BW__)
#if defined(__GNUC__) && !defined(__clang__)
// GCC 12's own avx512fintrin.h trips this warning (_mm512_undefined_*).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#endif
#include <immintrin.h>
#define ZBUFFER_AVX512 1
#endif

#if defined(__GNUC__)
#define ZBUFFER_INLINE inline __attribute__((always_inline))
#else
#define ZBUFFER_INLINE inline
#endif

#include <cstdint>

namespace zbuffer {
namespace simd {

#ifdef ZBUFFER_AVX512
// The depth write (raster.h) for 8 pixels of a row: nearer, or equal with a
// smaller id. Masked loads and stores touch only the lanes in `inside`.
ZBUFFER_INLINE __mmask8 write8(__mmask8 inside, __m256 z, __m256i id, float* d_ptr,
                               int32_t* id_ptr) {
  const __m256 d = _mm256_mask_loadu_ps(_mm256_setzero_ps(), inside, d_ptr);
  const __m256i ids = _mm256_mask_loadu_epi32(_mm256_setzero_si256(), inside, id_ptr);
  const __mmask8 nearer = _mm256_mask_cmp_ps_mask(inside, z, d, _CMP_LT_OQ);
  const __mmask8 tie =
      _mm256_mask_cmp_ps_mask(inside, z, d, _CMP_EQ_OQ) & _mm256_cmplt_epi32_mask(id, ids);
  const __mmask8 win = nearer | tie;
  _mm256_mask_storeu_ps(d_ptr, win, z);
  _mm256_mask_storeu_epi32(id_ptr, win, id);
  return win;
}

// The same for 16 pixels of a row.
ZBUFFER_INLINE __mmask16 write16(__mmask16 inside, __m512 z, __m512i id, float* d_ptr,
                                 int32_t* id_ptr) {
  const __m512 d = _mm512_mask_loadu_ps(_mm512_setzero_ps(), inside, d_ptr);
  const __m512i ids = _mm512_mask_loadu_epi32(_mm512_setzero_si512(), inside, id_ptr);
  const __mmask16 nearer = _mm512_mask_cmp_ps_mask(inside, z, d, _CMP_LT_OQ);
  const __mmask16 tie =
      _mm512_mask_cmp_ps_mask(inside, z, d, _CMP_EQ_OQ) & _mm512_cmplt_epi32_mask(id, ids);
  const __mmask16 win = nearer | tie;
  _mm512_mask_storeu_ps(d_ptr, win, z);
  _mm512_mask_storeu_epi32(id_ptr, win, id);
  return win;
}
#endif

}  // namespace simd
}  // namespace zbuffer
