// Private to the core: the ids that start runs of one id along a row of a
// triangle_id plane -- what the shading pass's face scan and temporal
// coherence's cluster scan look up (neighbouring pixels mostly show the
// same triangle, so a lookup per run instead of per pixel).
#pragma once

#include <cstddef>
#include <cstdint>

#include "simd.h"

namespace zbuffer {

// Writes to `out` the id of every run of one id among the `count` ids at
// `ids` (`left`: the id before the first, which continues its run if
// equal), skipping ids below 0; returns how many it wrote. `out` needs room
// for count + 16 ids (whole-vector stores). 16 ids per instruction in
// AVX-512 builds (the run starts packed by a compress), 8 in AVX2 builds (by
// a permutation per mask), else one at a time.
inline size_t id_run_starts(const int32_t* ids, size_t count, int32_t left, int32_t* out) {
  size_t n = 0, p = 0;
#ifdef ZBUFFER_AVX512
  __m512i before = _mm512_set1_epi32(left);
  for (; p + 16 <= count; p += 16) {
    const __m512i f = _mm512_loadu_si512(ids + p);
    const __m512i shifted = _mm512_alignr_epi32(f, before, 15);  // lane k: id p + k - 1
    const __mmask16 start = _mm512_cmpneq_epi32_mask(f, shifted) &
                            _mm512_cmpge_epi32_mask(f, _mm512_setzero_si512());
    _mm512_storeu_si512(out + n, _mm512_maskz_compress_epi32(start, f));
    n += size_t(__builtin_popcount(start));
    before = f;
  }
#elif defined(ZBUFFER_AVX2)
  if (count >= 9) {
    if (ids[0] != left && ids[0] >= 0) out[n++] = ids[0];
    auto load = [](const int32_t* q) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(q)); };
    for (p = 1; p + 8 <= count; p += 8) {
      const __m256i f = load(ids + p);
      const __m256i start = _mm256_andnot_si256(_mm256_cmpeq_epi32(f, load(ids + p - 1)),
                                                _mm256_cmpgt_epi32(f, _mm256_set1_epi32(-1)));
      const unsigned bits = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(start)));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + n),
                          _mm256_permutevar8x32_epi32(f, load(simd::kCompress8.lanes[bits])));
      n += size_t(__builtin_popcount(bits));
    }
  }
#endif
  for (int32_t previous = p ? ids[p - 1] : left; p < count; ++p) {
    const int32_t f = ids[p];
    if (f != previous && f >= 0) out[n++] = f;
    previous = f;
  }
  return n;
}

}  // namespace zbuffer
