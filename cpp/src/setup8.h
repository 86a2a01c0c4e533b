// Private to the core: assembly and setup of 8 faces per instruction in
// AVX2 builds (setup16.h is the AVX-512 form, 16 faces).
//
// The same integers exactly and the same IEEE operations on z as
// vertex_stage.h's assemble_triangle (for faces that need no clipping) and
// raster.h's setup_triangle (for faces less than 16 pixels across, whose
// edge values and twice-areas fit int32), so a face gets the same edge
// values, biases and depth coefficients on either path. AVX2 has no mask
// registers: lane masks are int bit masks (bit k: lane k) where decisions
// are counted, and vectors of all-ones / all-zeros lanes where they select.
#pragma once

#include <algorithm>

#include "simd.h"
#include "zbuffer/raster.h"
#include "zbuffer/types.h"
#include "zbuffer/vertex_stage.h"

#ifdef ZBUFFER_AVX2

namespace zbuffer {
namespace simd {

// The bit mask of the lanes of a vector mask of int32 lanes.
ZBUFFER_INLINE unsigned bits8(__m256i mask) {
  return unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(mask)));
}

// The vector mask (all-ones lanes) of a bit mask.
ZBUFFER_INLINE __m256i mask8(unsigned bits) {
  const __m256i lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  return _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(bits)), lane_bit), lane_bit);
}

// Lanes of int32 vector v with any of `bits` set.
ZBUFFER_INLINE unsigned test8(__m256i v, int bits) {
  const __m256i none = _mm256_cmpeq_epi32(_mm256_and_si256(v, _mm256_set1_epi32(bits)),
                                          _mm256_setzero_si256());
  return ~bits8(none) & 0xFFu;
}

// The bit masks of 8 int64 lanes held as two halves (lanes 0-3, 4-7).
ZBUFFER_INLINE unsigned bits8_64(__m256i lo, __m256i hi) {
  return unsigned(_mm256_movemask_pd(_mm256_castsi256_pd(lo))) |
         (unsigned(_mm256_movemask_pd(_mm256_castsi256_pd(hi))) << 4);
}

ZBUFFER_INLINE __m256i compress8(unsigned bits, __m256i v) {
  return _mm256_permutevar8x32_epi32(
      v, _mm256_load_si256(reinterpret_cast<const __m256i*>(kCompress8.lanes[bits])));
}

// The first `count` (<= 8) int32 triples at p (a face's vertex indices),
// one vector per position, as setup16.h's deinterleave16: lanes past
// `count` are 0 and nothing past the triples is read. Eight triples are
// three loads, a blend of each with the lanes of the others that hold its
// position's values, and a permutation into order (AVX2 gathers of every
// third int cost more: on the N = 20 spot grid, half of a per-frame
// octree's build).
ZBUFFER_INLINE void deinterleave8(const int32_t* p, int count, __m256i out[3]) {
  alignas(32) int32_t tail[24];  // (zeroed only when used: this runs every 8 faces)
  if (count < 8) {
    std::fill_n(std::copy(p, p + 3 * std::max(count, 0), tail), 24 - 3 * std::max(count, 0), 0);
    p = tail;
  }
  const __m256i a = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p));
  const __m256i b = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + 8));
  const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + 16));
  // Position k of face j is int 3j + k: in a, b or c at lane (3j + k) % 8.
  // Blended, lane l holds the value of the one of a, b, c that has position
  // k there; the permutation puts face j in lane j.
  out[0] = _mm256_permutevar8x32_epi32(_mm256_blend_epi32(_mm256_blend_epi32(a, b, 0x92), c, 0x24),
                                       _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
  out[1] = _mm256_permutevar8x32_epi32(_mm256_blend_epi32(_mm256_blend_epi32(a, b, 0x24), c, 0x49),
                                       _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
  out[2] = _mm256_permutevar8x32_epi32(_mm256_blend_epi32(_mm256_blend_epi32(a, b, 0x49), c, 0x92),
                                       _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
}

// Eight faces after assembly: the lanes of `draw` are triangles with
// area > 0 (vertices 1 and 2 of front faces swapped), those of `clip` need
// the scalar assembly (clipping).
struct Faces8 {
  unsigned live, clip, draw;
  __m256i x[3], y[3];
  __m256d z_lo[3], z_hi[3];   // z of lanes 0-3 and 4-7
  __m256i area_lo, area_hi;   // |twice the area|, int64, lanes 0-3 and 4-7
};

// The 8 int64 products a * b of int32 lanes, as two halves.
ZBUFFER_INLINE void mul_wide8(__m256i a, __m256i b, __m256i& lo, __m256i& hi) {
  lo = _mm256_mul_epi32(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(a)),
                        _mm256_cvtepi32_epi64(_mm256_castsi256_si128(b)));
  hi = _mm256_mul_epi32(_mm256_cvtepi32_epi64(_mm256_extracti128_si256(a, 1)),
                        _mm256_cvtepi32_epi64(_mm256_extracti128_si256(b, 1)));
}

ZBUFFER_INLINE __m256i abs64(__m256i v) {
  const __m256i negative = _mm256_cmpgt_epi64(_mm256_setzero_si256(), v);
  return _mm256_blendv_epi8(v, _mm256_sub_epi64(_mm256_setzero_si256(), v), negative);
}

// Assemble faces first .. first + count - 1 (count <= 8) of `keep` (bit k:
// face first + k), counting the culled ones and the rasterized ones in
// stats as assemble_triangle does (clipped faces are left to the caller).
// The mesh has at least one vertex: lanes past `count` use vertex 0, and
// they and the lanes not kept are masked off.
ZBUFFER_INLINE void assemble8(const MeshView& mesh, const ScreenVertices& sv, int64_t first,
                              int count, bool cull_backfaces, RenderStats& stats, Faces8& f,
                              unsigned keep = 0xFFu) {
  f.live = ((1u << count) - 1) & keep;
  const __m256i live = mask8(f.live);
  __m256i oc[3];
  const bool all_inside = sv.any_outcode == 0;  // then every outcode is 0: not read
  // A corner's (x, y) pair is one 64-bit element (as in setup16.h): 4 pairs
  // at a time, each split into its x and y halves.
  const __m256i split = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
  const int32_t* faces = mesh.faces + 3 * first;
  if (count == 8) {
    // A whole step: by scalar loads (simd.h's corner_pairs4).
    for (int k = 0; k < 3; ++k) {
      const __m256i lo = _mm256_permutevar8x32_epi32(corner_pairs4(sv.xy.data(), faces + k), split);
      const __m256i hi = _mm256_permutevar8x32_epi32(corner_pairs4(sv.xy.data(), faces + 12 + k), split);
      f.x[k] = _mm256_permute2x128_si256(lo, hi, 0x20);
      f.y[k] = _mm256_permute2x128_si256(lo, hi, 0x31);
      oc[k] = all_inside ? _mm256_setzero_si256() : corner_words8(sv.outcode.data(), faces + k);
      f.z_lo[k] = corner_doubles4(sv.z.data(), faces + k);
      f.z_hi[k] = corner_doubles4(sv.z.data(), faces + 12 + k);
    }
  } else {
    // The last faces of a run: gathers.
    __m256i corner[3];
    deinterleave8(faces, count, corner);
    const long long* xy = reinterpret_cast<const long long*>(sv.xy.data());
    for (int k = 0; k < 3; ++k) {
      const __m256i idx = _mm256_and_si256(corner[k], live);  // (lanes not live: vertex 0)
      const __m256i lo = _mm256_permutevar8x32_epi32(
          _mm256_i32gather_epi64(xy, _mm256_castsi256_si128(idx), 8), split);  // x0-3, y0-3
      const __m256i hi = _mm256_permutevar8x32_epi32(
          _mm256_i32gather_epi64(xy, _mm256_extracti128_si256(idx, 1), 8), split);  // x4-7, y4-7
      f.x[k] = _mm256_permute2x128_si256(lo, hi, 0x20);
      f.y[k] = _mm256_permute2x128_si256(lo, hi, 0x31);
      oc[k] = all_inside ? _mm256_setzero_si256()
                         : _mm256_i32gather_epi32(reinterpret_cast<const int*>(sv.outcode.data()), idx, 4);
      f.z_lo[k] = _mm256_i32gather_pd(sv.z.data(), _mm256_castsi256_si128(idx), 8);
      f.z_hi[k] = _mm256_i32gather_pd(sv.z.data(), _mm256_extracti128_si256(idx, 1), 8);
    }
  }

  // Culling and clipping decisions, as assemble_triangle makes them.
  const __m256i any_out = _mm256_or_si256(_mm256_or_si256(oc[0], oc[1]), oc[2]);
  const __m256i all_out = _mm256_and_si256(_mm256_and_si256(oc[0], oc[1]), oc[2]);
  const unsigned invalid = f.live & test8(any_out, int(kOutInvalid));
  const unsigned outside = f.live & test8(all_out, int(kOutView)) & ~invalid;
  f.clip = f.live & test8(any_out, int(kOutClip)) & ~invalid & ~outside;
  const unsigned simple = f.live & ~(invalid | outside | f.clip);
  stats.culled_invalid += __builtin_popcount(invalid);
  stats.culled_frustum += __builtin_popcount(outside);

  // Exact integer area (int64 halves): area > 0 is clockwise in NDC.
  __m256i p_lo, p_hi, q_lo, q_hi;
  mul_wide8(_mm256_sub_epi32(f.x[1], f.x[0]), _mm256_sub_epi32(f.y[2], f.y[0]), p_lo, p_hi);
  mul_wide8(_mm256_sub_epi32(f.y[1], f.y[0]), _mm256_sub_epi32(f.x[2], f.x[0]), q_lo, q_hi);
  const __m256i area_lo = _mm256_sub_epi64(p_lo, q_lo), area_hi = _mm256_sub_epi64(p_hi, q_hi);
  const __m256i zero = _mm256_setzero_si256();
  const unsigned degenerate =
      bits8_64(_mm256_cmpeq_epi64(area_lo, zero), _mm256_cmpeq_epi64(area_hi, zero));
  const unsigned back =
      bits8_64(_mm256_cmpgt_epi64(area_lo, zero), _mm256_cmpgt_epi64(area_hi, zero));
  const __m256i front_lo = _mm256_cmpgt_epi64(zero, area_lo);
  const __m256i front_hi = _mm256_cmpgt_epi64(zero, area_hi);
  const unsigned front = bits8_64(front_lo, front_hi);
  const unsigned culled_back = cull_backfaces ? (simple & back & ~degenerate) : 0u;
  f.draw = simple & ~degenerate & ~culled_back;
  stats.culled_degenerate += __builtin_popcount(simple & degenerate);
  stats.culled_backface += __builtin_popcount(culled_back);
  stats.rasterized += __builtin_popcount(f.draw);

  // Front faces swap vertices 1 and 2 so that area > 0.
  {
    const __m256i swap = mask8(front);
    const __m256i x1 = f.x[1], y1 = f.y[1];
    f.x[1] = _mm256_blendv_epi8(f.x[1], f.x[2], swap);
    f.x[2] = _mm256_blendv_epi8(f.x[2], x1, swap);
    f.y[1] = _mm256_blendv_epi8(f.y[1], f.y[2], swap);
    f.y[2] = _mm256_blendv_epi8(f.y[2], y1, swap);
    const __m256d swap_lo = _mm256_castsi256_pd(front_lo), swap_hi = _mm256_castsi256_pd(front_hi);
    const __m256d zl = f.z_lo[1], zh = f.z_hi[1];
    f.z_lo[1] = _mm256_blendv_pd(f.z_lo[1], f.z_lo[2], swap_lo);
    f.z_lo[2] = _mm256_blendv_pd(f.z_lo[2], zl, swap_lo);
    f.z_hi[1] = _mm256_blendv_pd(f.z_hi[1], f.z_hi[2], swap_hi);
    f.z_hi[2] = _mm256_blendv_pd(f.z_hi[2], zh, swap_hi);
  }
  f.area_lo = abs64(area_lo);
  f.area_hi = abs64(area_hi);
}

// The pixel box of 8 assembled faces (raster.h: setup_triangle), clamped to
// a width x height image, and which faces are small or narrow (simd.h:
// kSmallFx, kNarrowFx), as bit masks.
struct Box8 {
  __m256i i0, i1, j0, j1, box_w, box_h;
  unsigned nonempty, small, narrow;
};

ZBUFFER_INLINE void box8(const Faces8& f, int width, int height, Box8& b) {
  const __m256i* x = f.x;
  const __m256i* y = f.y;
  const __m256i min_x = _mm256_min_epi32(x[0], _mm256_min_epi32(x[1], x[2]));
  const __m256i max_x = _mm256_max_epi32(x[0], _mm256_max_epi32(x[1], x[2]));
  const __m256i min_y = _mm256_min_epi32(y[0], _mm256_min_epi32(y[1], y[2]));
  const __m256i max_y = _mm256_max_epi32(y[0], _mm256_max_epi32(y[1], y[2]));
  const __m256i half = _mm256_set1_epi32(kHalfPixel);
  const __m256i round_up = _mm256_set1_epi32(kHalfPixel - (kSubpixelScale - 1));
  const __m256i zero = _mm256_setzero_si256();
  const __m256i one = _mm256_set1_epi32(1);
  b.i0 = _mm256_max_epi32(_mm256_srai_epi32(_mm256_sub_epi32(min_x, round_up), kSubpixelBits), zero);
  b.i1 = _mm256_min_epi32(_mm256_srai_epi32(_mm256_sub_epi32(max_x, half), kSubpixelBits),
                          _mm256_set1_epi32(width - 1));
  b.j0 = _mm256_max_epi32(_mm256_srai_epi32(_mm256_sub_epi32(min_y, round_up), kSubpixelBits), zero);
  b.j1 = _mm256_min_epi32(_mm256_srai_epi32(_mm256_sub_epi32(max_y, half), kSubpixelBits),
                          _mm256_set1_epi32(height - 1));
  b.box_w = _mm256_add_epi32(_mm256_sub_epi32(b.i1, b.i0), one);
  b.box_h = _mm256_add_epi32(_mm256_sub_epi32(b.j1, b.j0), one);
  b.nonempty = bits8(_mm256_and_si256(_mm256_cmpgt_epi32(b.box_w, zero),
                                      _mm256_cmpgt_epi32(b.box_h, zero)));
  // Extents compared unsigned (e < limit <=> min_epu32(e, limit - 1) == e),
  // as setup16.h does: they are never negative.
  auto below = [](__m256i extent, int limit) {
    return _mm256_cmpeq_epi32(_mm256_min_epu32(extent, _mm256_set1_epi32(limit - 1)), extent);
  };
  const __m256i extent_x = _mm256_sub_epi32(max_x, min_x);
  b.small = bits8(_mm256_and_si256(below(extent_x, kSmallFx),
                                   below(_mm256_sub_epi32(max_y, min_y), kSmallFx)));
  b.narrow = bits8(below(extent_x, kNarrowFx));
}

// Edge functions and depth plane of 8 small faces (raster.h:
// setup_triangle): w[k] the exact unbiased edge value at the centre of the
// box's first pixel, bias[k] 0 or 1 by the top-left rule, steps per pixel
// and per row; area32 = twice the area. Lanes that are not small hold
// values nobody reads.
struct Setup8 {
  __m256i w[3], bias[3], sx[3], sy[3], area32;
  __m256 z0, a1, a2, lo, hi;
};

// The nearest depth of each of 8 assembled faces, rounded to binary32 (the
// z_lo of setup_triangle).
ZBUFFER_INLINE __m256 nearest8(const Faces8& f) {
  auto nearest = [](const __m256d* z) {
    return _mm256_cvtpd_ps(_mm256_min_pd(z[0], _mm256_min_pd(z[1], z[2])));
  };
  return _mm256_set_m128(nearest(f.z_hi), nearest(f.z_lo));
}

ZBUFFER_INLINE void setup8(const Faces8& f, const Box8& b, Setup8& s) {
  const __m256i half = _mm256_set1_epi32(kHalfPixel);
  const __m256i zero = _mm256_setzero_si256();
  const __m256i px = _mm256_add_epi32(_mm256_slli_epi32(b.i0, kSubpixelBits), half);
  const __m256i py = _mm256_add_epi32(_mm256_slli_epi32(b.j0, kSubpixelBits), half);
  for (int k = 0; k < 3; ++k) {
    const int from = (k + 1) % 3, to = (k + 2) % 3;
    const __m256i dx = _mm256_sub_epi32(f.x[to], f.x[from]), dy = _mm256_sub_epi32(f.y[to], f.y[from]);
    s.w[k] = _mm256_sub_epi32(_mm256_mullo_epi32(dx, _mm256_sub_epi32(py, f.y[from])),
                              _mm256_mullo_epi32(dy, _mm256_sub_epi32(px, f.x[from])));
    // Top-left: dy < 0, or dy == 0 and dx > 0. Bias 1 for the others.
    const __m256i top_left = _mm256_or_si256(
        _mm256_cmpgt_epi32(zero, dy),
        _mm256_and_si256(_mm256_cmpeq_epi32(dy, zero), _mm256_cmpgt_epi32(dx, zero)));
    s.bias[k] = _mm256_andnot_si256(top_left, _mm256_set1_epi32(1));
    s.sx[k] = _mm256_slli_epi32(_mm256_sub_epi32(zero, dy), kSubpixelBits);
    s.sy[k] = _mm256_slli_epi32(dx, kSubpixelBits);
  }
  // The low 32 bits of each int64 twice-area (exact for small faces).
  const __m256i evens = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
  s.area32 = _mm256_permute2x128_si256(_mm256_permutevar8x32_epi32(f.area_lo, evens),
                                       _mm256_permutevar8x32_epi32(f.area_hi, evens), 0x20);

  // Depth coefficients: binary64, rounded once to binary32 (raster.h).
  const __m256d one = _mm256_set1_pd(1.0);
  auto coefficients = [&](__m128i area, const __m256d* z, __m128& z0f, __m128& a1f, __m128& a2f,
                          __m128& hi) {
    const __m256d inv_area = _mm256_div_pd(one, _mm256_cvtepi32_pd(area));
    a1f = _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_sub_pd(z[1], z[0]), inv_area));
    a2f = _mm256_cvtpd_ps(_mm256_mul_pd(_mm256_sub_pd(z[2], z[0]), inv_area));
    z0f = _mm256_cvtpd_ps(z[0]);
    hi = _mm256_cvtpd_ps(_mm256_max_pd(z[0], _mm256_max_pd(z[1], z[2])));
  };
  __m128 z0l, a1l, a2l, hil, z0h, a1h, a2h, hih;
  coefficients(_mm256_castsi256_si128(s.area32), f.z_lo, z0l, a1l, a2l, hil);
  coefficients(_mm256_extracti128_si256(s.area32, 1), f.z_hi, z0h, a1h, a2h, hih);
  s.z0 = _mm256_set_m128(z0h, z0l);
  s.a1 = _mm256_set_m128(a1h, a1l);
  s.a2 = _mm256_set_m128(a2h, a2l);
  s.lo = nearest8(f);
  s.hi = _mm256_set_m128(hih, hil);
}

// The ids of faces first .. first + 7 (lanes of `live` only).
ZBUFFER_INLINE __m256i ids8(const MeshView& mesh, int64_t first, unsigned live) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  return mesh.face_ids ? _mm256_maskload_epi32(mesh.face_ids + first, mask8(live))
                       : _mm256_add_epi32(_mm256_set1_epi32(int32_t(first)), lane);
}

// The assembled triangle in lane `lane` (for the scalar setup of large faces).
struct Lanes8 {
  alignas(32) int32_t xs[3][8], ys[3][8];
  alignas(32) double zs[3][8];
  alignas(32) int64_t areas[8];
  explicit Lanes8(const Faces8& f) {
    for (int k = 0; k < 3; ++k) {
      _mm256_store_si256(reinterpret_cast<__m256i*>(xs[k]), f.x[k]);
      _mm256_store_si256(reinterpret_cast<__m256i*>(ys[k]), f.y[k]);
      _mm256_store_pd(zs[k], f.z_lo[k]);
      _mm256_store_pd(zs[k] + 4, f.z_hi[k]);
    }
    _mm256_store_si256(reinterpret_cast<__m256i*>(areas), f.area_lo);
    _mm256_store_si256(reinterpret_cast<__m256i*>(areas + 4), f.area_hi);
  }
  ScreenTriangle triangle(int lane, int32_t id) const {
    ScreenTriangle t;
    for (int k = 0; k < 3; ++k) t.v[k] = {xs[k][lane], ys[k][lane], 0u, zs[k][lane]};
    t.area = areas[lane];
    t.id = id;
    return t;
  }
};

}  // namespace simd
}  // namespace zbuffer

#endif
