// Private to the core: assembly and setup of 16 faces per instruction
// (AVX-512 builds), shared by TriangleBatch and the scanline's tables (and
// its interleave helpers by the trees: object_tree.cpp, morton.h).
//
// The vector form of vertex_stage.h's assemble_triangle (for faces that need
// no clipping) and of raster.h's setup_triangle (for faces less than 16
// pixels across, whose edge values fit int32): the same integers exactly and
// the same IEEE operations on z, so a face ends up with the same edge values,
// biases and depth coefficients whichever path set it up. Tests hold both
// users' vector paths to the scalar ones.
#pragma once

#include "simd.h"
#include "zbuffer/raster.h"
#include "zbuffer/types.h"
#include "zbuffer/vertex_stage.h"

#ifdef ZBUFFER_AVX512

namespace zbuffer {
namespace simd {

// Lane permutations that split 48 interleaved face indices (i0 i1 i2 i0 ...)
// held in three vectors a, b, c into the 16 first, second and third indices.
struct Deinterleave {
  alignas(64) int32_t ab[3][16];  // from a (0..15) and b (16..31)
  alignas(64) int32_t tc[3][16];  // from that (0..15) and c (16..31)
  constexpr Deinterleave() : ab{}, tc{} {
    for (int k = 0; k < 3; ++k)
      for (int lane = 0; lane < 16; ++lane) {
        const int global = 3 * lane + k;  // position in the 48 indices
        ab[k][lane] = global < 32 ? global : 0;
        tc[k][lane] = global < 32 ? lane : 16 + (global - 32);
      }
  }
};
inline constexpr Deinterleave kDeinterleave{};

// The first `count` (<= 16) int32 triples at p (a face's vertex indices, or
// any record of three int32), one vector per position; lanes past `count`
// are 0 and nothing past the triples is read.
ZBUFFER_INLINE void deinterleave16(const int32_t* p, int count, __m512i out[3]) {
  auto first_lanes = [](int n) { return __mmask16(n >= 16 ? 0xFFFF : n <= 0 ? 0 : (1u << n) - 1); };
  const int ints = 3 * count;
  const __m512i a = _mm512_maskz_loadu_epi32(first_lanes(ints), p),
                b = _mm512_maskz_loadu_epi32(first_lanes(ints - 16), p + 16),
                c = _mm512_maskz_loadu_epi32(first_lanes(ints - 32), p + 32);
  for (int k = 0; k < 3; ++k)
    out[k] = _mm512_permutex2var_epi32(
        _mm512_permutex2var_epi32(a, _mm512_load_si512(kDeinterleave.ab[k]), b),
        _mm512_load_si512(kDeinterleave.tc[k]), c);
}

// The inverse of deinterleave16: the three vectors in[k] (lane j: face j's
// corner k) stored as the interleaved indices of `count` faces at p.
struct Interleave {
  alignas(64) int32_t ab[3][16];  // corner 0 or 1 into place
  alignas(64) int32_t tc[3][16];  // then corner 2
  constexpr Interleave() : ab{}, tc{} {
    for (int part = 0; part < 3; ++part)
      for (int e = 0; e < 16; ++e) {
        const int p = 16 * part + e, face = p / 3, corner = p % 3;
        ab[part][e] = corner == 1 ? 16 + face : face;
        tc[part][e] = corner == 2 ? 16 + face : e;
      }
  }
};
inline constexpr Interleave kInterleave{};

ZBUFFER_INLINE void interleave16(const __m512i in[3], int count, int32_t* p) {
  auto first_lanes = [](int n) { return __mmask16(n >= 16 ? 0xFFFF : n <= 0 ? 0 : (1u << n) - 1); };
  const int ints = 3 * count;
  for (int part = 0; part < 3; ++part)
    _mm512_mask_storeu_epi32(p + 16 * part, first_lanes(ints - 16 * part),
                             _mm512_permutex2var_epi32(
                                 _mm512_permutex2var_epi32(in[0], _mm512_load_si512(kInterleave.ab[part]), in[1]),
                                 _mm512_load_si512(kInterleave.tc[part]), in[2]));
}

// The 16 int64 products a * b of the sign-extended int32 lanes, as two halves.
ZBUFFER_INLINE void mul_wide(__m512i a, __m512i b, __m512i& lo, __m512i& hi) {
  lo = _mm512_mul_epi32(_mm512_cvtepi32_epi64(_mm512_castsi512_si256(a)),
                        _mm512_cvtepi32_epi64(_mm512_castsi512_si256(b)));
  hi = _mm512_mul_epi32(_mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64(a, 1)),
                        _mm512_cvtepi32_epi64(_mm512_extracti64x4_epi64(b, 1)));
}

ZBUFFER_INLINE __m512 join(__m256 lo, __m256 hi) {
  return _mm512_insertf32x8(_mm512_castps256_ps512(lo), hi, 1);
}

// Sixteen faces after assembly: the lanes of `draw` are triangles with
// area > 0 (vertices 1 and 2 of front faces swapped), those of `clip` need
// the scalar assembly (clipping).
struct Faces16 {
  __mmask16 live, clip, draw;
  __m512i x[3], y[3];
  __m512d z_lo[3], z_hi[3];   // z of lanes 0-7 and 8-15
  __m512i area_lo, area_hi;   // |twice the area|, int64, lanes 0-7 and 8-15
};

// Assemble faces first .. first + count - 1 (count <= 16) of `keep` (bit k:
// face first + k), counting the culled ones and the rasterized ones in
// stats as assemble_triangle does (clipped faces are left to the caller).
ZBUFFER_INLINE void assemble16(const MeshView& mesh, const ScreenVertices& sv, int64_t first,
                               int count, bool cull_backfaces, RenderStats& stats, Faces16& f,
                               unsigned keep = 0xFFFFu) {
  // The three vertices of `count` faces; lanes past them load index 0 (a
  // valid vertex) and are masked off below, as are those not kept.
  f.live = __mmask16(((1u << count) - 1) & keep);
  const __mmask16 live = f.live;
  __m512i* x = f.x;
  __m512i* y = f.y;
  __m512d* z_lo = f.z_lo;
  __m512d* z_hi = f.z_hi;
  __m512i oc[3];
  const bool all_inside = sv.any_outcode == 0;  // then every outcode is 0: not read
  // A corner's (x, y) pair is one 64-bit element, split into x and y.
  const __m512i even = _mm512_set_epi32(30, 28, 26, 24, 22, 20, 18, 16, 14, 12, 10, 8, 6, 4, 2, 0);
  const __m512i odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
  const int32_t* faces = mesh.faces + 3 * first;
  if (count == 16) {
    // A whole step: each corner's elements by scalar loads, indices read
    // where the faces lie (simd.h's corner_pairs4).
    const int32_t* xy = sv.xy.data();
    for (int k = 0; k < 3; ++k) {
      const __m512i lo = corner_pairs8(xy, faces + k), hi = corner_pairs8(xy, faces + 24 + k);
      x[k] = _mm512_permutex2var_epi32(lo, even, hi);
      y[k] = _mm512_permutex2var_epi32(lo, odd, hi);
      oc[k] = all_inside ? _mm512_setzero_si512() : corner_words16(sv.outcode.data(), faces + k);
      z_lo[k] = corner_doubles8(sv.z.data(), faces + k);
      z_hi[k] = corner_doubles8(sv.z.data(), faces + 24 + k);
    }
  } else {
    // The last faces of a run: gathers (lanes past `count` read vertex 0).
    __m512i corner[3];
    deinterleave16(faces, count, corner);
    for (int k = 0; k < 3; ++k) {
      const __m512i idx = corner[k];
      const __m512i lo = _mm512_i32gather_epi64(_mm512_castsi512_si256(idx), sv.xy.data(), 8);
      const __m512i hi = _mm512_i32gather_epi64(_mm512_extracti64x4_epi64(idx, 1), sv.xy.data(), 8);
      x[k] = _mm512_permutex2var_epi32(lo, even, hi);
      y[k] = _mm512_permutex2var_epi32(lo, odd, hi);
      oc[k] = all_inside ? _mm512_setzero_si512() : _mm512_i32gather_epi32(idx, sv.outcode.data(), 4);
      z_lo[k] = _mm512_i32gather_pd(_mm512_castsi512_si256(idx), sv.z.data(), 8);
      z_hi[k] = _mm512_i32gather_pd(_mm512_extracti64x4_epi64(idx, 1), sv.z.data(), 8);
    }
  }

  // Culling and clipping decisions, as assemble_triangle makes them.
  const __m512i any_out = _mm512_ternarylogic_epi32(oc[0], oc[1], oc[2], 0xFE);  // a | b | c
  const __m512i all_out = _mm512_ternarylogic_epi32(oc[0], oc[1], oc[2], 0x80);  // a & b & c
  const __mmask16 invalid =
      live & _mm512_test_epi32_mask(any_out, _mm512_set1_epi32(int(kOutInvalid)));
  const __mmask16 outside =
      live & _mm512_test_epi32_mask(all_out, _mm512_set1_epi32(int(kOutView))) & ~invalid;
  f.clip =
      live & _mm512_test_epi32_mask(any_out, _mm512_set1_epi32(int(kOutClip))) & ~invalid & ~outside;
  const __mmask16 simple = live & __mmask16(~(invalid | outside | f.clip));
  stats.culled_invalid += __builtin_popcount(invalid);
  stats.culled_frustum += __builtin_popcount(outside);

  // Exact integer area (int64 halves): area > 0 is clockwise in NDC.
  __m512i p_lo, p_hi, q_lo, q_hi;
  mul_wide(_mm512_sub_epi32(x[1], x[0]), _mm512_sub_epi32(y[2], y[0]), p_lo, p_hi);
  mul_wide(_mm512_sub_epi32(y[1], y[0]), _mm512_sub_epi32(x[2], x[0]), q_lo, q_hi);
  const __m512i area_lo = _mm512_sub_epi64(p_lo, q_lo), area_hi = _mm512_sub_epi64(p_hi, q_hi);
  const __m512i zero64 = _mm512_setzero_si512();
  const __mmask16 degenerate = _mm512_kunpackb(_mm512_cmpeq_epi64_mask(area_hi, zero64),
                                               _mm512_cmpeq_epi64_mask(area_lo, zero64));
  const __mmask16 back = _mm512_kunpackb(_mm512_cmpgt_epi64_mask(area_hi, zero64),
                                         _mm512_cmpgt_epi64_mask(area_lo, zero64));
  const __mmask16 front_lo = _mm512_cmplt_epi64_mask(area_lo, zero64);
  const __mmask16 front_hi = _mm512_cmplt_epi64_mask(area_hi, zero64);
  const __mmask16 front = __mmask16(front_lo | (front_hi << 8));
  const __mmask16 culled_back = cull_backfaces ? __mmask16(simple & back & ~degenerate) : 0;
  f.draw = simple & ~degenerate & ~culled_back;
  stats.culled_degenerate += __builtin_popcount(simple & degenerate);
  stats.culled_backface += __builtin_popcount(culled_back);
  stats.rasterized += __builtin_popcount(f.draw);

  // Front faces swap vertices 1 and 2 so that area > 0.
  {
    const __m512i x1 = x[1], y1 = y[1];
    x[1] = _mm512_mask_blend_epi32(front, x[1], x[2]);
    x[2] = _mm512_mask_blend_epi32(front, x[2], x1);
    y[1] = _mm512_mask_blend_epi32(front, y[1], y[2]);
    y[2] = _mm512_mask_blend_epi32(front, y[2], y1);
    const __m512d zl = z_lo[1], zh = z_hi[1];
    z_lo[1] = _mm512_mask_blend_pd(__mmask8(front_lo), z_lo[1], z_lo[2]);
    z_lo[2] = _mm512_mask_blend_pd(__mmask8(front_lo), z_lo[2], zl);
    z_hi[1] = _mm512_mask_blend_pd(__mmask8(front_hi), z_hi[1], z_hi[2]);
    z_hi[2] = _mm512_mask_blend_pd(__mmask8(front_hi), z_hi[2], zh);
  }
  f.area_lo = _mm512_abs_epi64(area_lo);
  f.area_hi = _mm512_abs_epi64(area_hi);
}

// The pixel box of 16 assembled faces (raster.h: setup_triangle), clamped to
// a width x height image, and which faces are small or narrow (simd.h:
// kSmallFx, kNarrowFx).
struct Box16 {
  __m512i i0, i1, j0, j1, box_w, box_h;
  __mmask16 nonempty, small, narrow;
};

ZBUFFER_INLINE void box16(const Faces16& f, int width, int height, Box16& b) {
  const __m512i* x = f.x;
  const __m512i* y = f.y;
  const __m512i min_x = _mm512_min_epi32(x[0], _mm512_min_epi32(x[1], x[2]));
  const __m512i max_x = _mm512_max_epi32(x[0], _mm512_max_epi32(x[1], x[2]));
  const __m512i min_y = _mm512_min_epi32(y[0], _mm512_min_epi32(y[1], y[2]));
  const __m512i max_y = _mm512_max_epi32(y[0], _mm512_max_epi32(y[1], y[2]));
  const __m512i half = _mm512_set1_epi32(kHalfPixel);
  const __m512i round_up = _mm512_set1_epi32(kHalfPixel - (kSubpixelScale - 1));
  const __m512i zero = _mm512_setzero_si512();
  b.i0 = _mm512_max_epi32(_mm512_srai_epi32(_mm512_sub_epi32(min_x, round_up), kSubpixelBits), zero);
  b.i1 = _mm512_min_epi32(_mm512_srai_epi32(_mm512_sub_epi32(max_x, half), kSubpixelBits),
                          _mm512_set1_epi32(width - 1));
  b.j0 = _mm512_max_epi32(_mm512_srai_epi32(_mm512_sub_epi32(min_y, round_up), kSubpixelBits), zero);
  b.j1 = _mm512_min_epi32(_mm512_srai_epi32(_mm512_sub_epi32(max_y, half), kSubpixelBits),
                          _mm512_set1_epi32(height - 1));
  b.box_w = _mm512_add_epi32(_mm512_sub_epi32(b.i1, b.i0), _mm512_set1_epi32(1));
  b.box_h = _mm512_add_epi32(_mm512_sub_epi32(b.j1, b.j0), _mm512_set1_epi32(1));
  b.nonempty = _mm512_cmpgt_epi32_mask(b.box_w, zero) & _mm512_cmpgt_epi32_mask(b.box_h, zero);
  // Extents compared unsigned: they are never negative, and a wrapped one
  // could only come from coordinates the vertex stage never produces.
  const __m512i extent_x = _mm512_sub_epi32(max_x, min_x);
  b.small = _mm512_cmplt_epu32_mask(extent_x, _mm512_set1_epi32(kSmallFx)) &
            _mm512_cmplt_epu32_mask(_mm512_sub_epi32(max_y, min_y), _mm512_set1_epi32(kSmallFx));
  b.narrow = _mm512_cmplt_epu32_mask(extent_x, _mm512_set1_epi32(kNarrowFx));
}

// The nearest depth of each of 16 assembled faces, rounded to binary32 (the
// z_lo of setup_triangle).
ZBUFFER_INLINE __m512 nearest16(const Faces16& f) {
  auto nearest = [](const __m512d* z) {
    return _mm512_cvtpd_ps(_mm512_min_pd(z[0], _mm512_min_pd(z[1], z[2])));
  };
  return join(nearest(f.z_lo), nearest(f.z_hi));
}

// Edge functions and depth plane of 16 small faces (raster.h:
// setup_triangle): w[k] the exact unbiased edge value at the centre of the
// box's first pixel, bias[k] 0 or 1 by the top-left rule, steps per pixel
// and per row; area32 = twice the area.
struct Setup16 {
  __m512i w[3], bias[3], sx[3], sy[3], area32;
  __m512 z0, a1, a2, lo, hi;
};

ZBUFFER_INLINE void setup16(const Faces16& f, const Box16& b, Setup16& s) {
  // Edge functions at the centre of the box's first pixel (raster.h), exact
  // in int32 for faces less than 16 pixels across. Edge k runs from vertex
  // k+1 to vertex k+2.
  const __m512i half = _mm512_set1_epi32(kHalfPixel);
  const __m512i zero = _mm512_setzero_si512();
  const __m512i px = _mm512_add_epi32(_mm512_slli_epi32(b.i0, kSubpixelBits), half);
  const __m512i py = _mm512_add_epi32(_mm512_slli_epi32(b.j0, kSubpixelBits), half);
  for (int k = 0; k < 3; ++k) {
    const int from = (k + 1) % 3, to = (k + 2) % 3;
    const __m512i dx = _mm512_sub_epi32(f.x[to], f.x[from]), dy = _mm512_sub_epi32(f.y[to], f.y[from]);
    s.w[k] = _mm512_sub_epi32(_mm512_mullo_epi32(dx, _mm512_sub_epi32(py, f.y[from])),
                              _mm512_mullo_epi32(dy, _mm512_sub_epi32(px, f.x[from])));
    // Top-left: dy < 0, or dy == 0 and dx > 0. Bias 1 for the others.
    const __mmask16 top_left =
        _mm512_cmplt_epi32_mask(dy, zero) |
        (_mm512_cmpeq_epi32_mask(dy, zero) & _mm512_cmpgt_epi32_mask(dx, zero));
    s.bias[k] = _mm512_maskz_set1_epi32(__mmask16(~top_left), 1);
    s.sx[k] = _mm512_slli_epi32(_mm512_sub_epi32(zero, dy), kSubpixelBits);
    s.sy[k] = _mm512_slli_epi32(dx, kSubpixelBits);
  }
  s.area32 = _mm512_inserti64x4(_mm512_castsi256_si512(_mm512_cvtepi64_epi32(f.area_lo)),
                                _mm512_cvtepi64_epi32(f.area_hi), 1);

  // Depth coefficients: binary64, rounded once to binary32 (raster.h).
  const __m512d one = _mm512_set1_pd(1.0);
  auto coefficients = [&](__m512i area64, const __m512d* z, __m256& z0f, __m256& a1f,
                          __m256& a2f, __m256& hi) {
    const __m512d inv_area = _mm512_div_pd(one, _mm512_cvtepi64_pd(area64));
    a1f = _mm512_cvtpd_ps(_mm512_mul_pd(_mm512_sub_pd(z[1], z[0]), inv_area));
    a2f = _mm512_cvtpd_ps(_mm512_mul_pd(_mm512_sub_pd(z[2], z[0]), inv_area));
    z0f = _mm512_cvtpd_ps(z[0]);
    hi = _mm512_cvtpd_ps(_mm512_max_pd(z[0], _mm512_max_pd(z[1], z[2])));
  };
  __m256 z0l, a1l, a2l, hil, z0h, a1h, a2h, hih;
  coefficients(f.area_lo, f.z_lo, z0l, a1l, a2l, hil);
  coefficients(f.area_hi, f.z_hi, z0h, a1h, a2h, hih);
  s.z0 = join(z0l, z0h);
  s.a1 = join(a1l, a1h);
  s.a2 = join(a2l, a2h);
  s.lo = nearest16(f);
  s.hi = join(hil, hih);
}

// The ids of faces first .. first + 15 (lanes of `live` only).
ZBUFFER_INLINE __m512i ids16(const MeshView& mesh, int64_t first, __mmask16 live) {
  const __m512i lane = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  return mesh.face_ids ? _mm512_maskz_loadu_epi32(live, mesh.face_ids + first)
                       : _mm512_add_epi32(_mm512_set1_epi32(int32_t(first)), lane);
}

// The assembled triangle in lane `lane` (for the scalar setup of large faces).
struct Lanes16 {
  alignas(64) int32_t xs[3][16], ys[3][16];
  alignas(64) double zs[3][16];
  alignas(64) int64_t areas[16];
  explicit Lanes16(const Faces16& f) {
    for (int k = 0; k < 3; ++k) {
      _mm512_store_si512(xs[k], f.x[k]);
      _mm512_store_si512(ys[k], f.y[k]);
      _mm512_store_pd(zs[k], f.z_lo[k]);
      _mm512_store_pd(zs[k] + 8, f.z_hi[k]);
    }
    _mm512_store_si512(areas, f.area_lo);
    _mm512_store_si512(areas + 8, f.area_hi);
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
