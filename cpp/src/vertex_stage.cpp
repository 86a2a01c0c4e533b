// Vertex stage: per-vertex transform and Sutherland-Hodgman clipping.
//
// transform_vertex_range has a scalar loop, an AVX-512 loop (8 vertices per
// instruction) and an AVX2 loop (4). All three evaluate vertex_stage.h's
// formulas with the same IEEE operations in the same order, so they produce
// the same bits.
#include "zbuffer/vertex_stage.h"

#include <cmath>

#include "simd.h"
#include "timing.h"

namespace zbuffer {

namespace {

void transform_vertex(const MeshView& mesh, const double* mvp, const Viewport& vp, int64_t i,
                      ScreenVertices& out) {
  const ClipVertex c = transform_point(mvp, mesh.positions + 3 * i);
  const uint32_t oc = outcode(c, vp);
  ScreenVertex s{};
  // Vertices that need clipping get their window coordinates from the
  // clipped polygon instead; theirs could be unbounded here.
  if (!(oc & (kOutClip | kOutInvalid))) s = to_screen(c, vp);
  out.xy[2 * i] = s.x_fx;
  out.xy[2 * i + 1] = s.y_fx;
  out.outcode[i] = oc;
  out.z[i] = s.z;
}

#ifdef ZBUFFER_AVX512
// Eight vertices: deinterleave xyz, transform, outcodes, divide, viewport,
// snap. Lanes of vertices that need clipping or are invalid store zeros,
// exactly as the scalar loop does.
void transform_8(const double* p, const double* m, const Viewport& vp, int32_t* xy_out,
                 uint32_t* oc_out, double* z_out) {
  // Deinterleave 24 doubles (x0 y0 z0 x1 ...) into x, y and z.
  const __m512d a = _mm512_loadu_pd(p), b = _mm512_loadu_pd(p + 8), c = _mm512_loadu_pd(p + 16);
  const __m512d x = _mm512_permutex2var_pd(
      _mm512_permutex2var_pd(a, _mm512_set_epi64(0, 0, 15, 12, 9, 6, 3, 0), b),
      _mm512_set_epi64(13, 10, 5, 4, 3, 2, 1, 0), c);
  const __m512d y = _mm512_permutex2var_pd(
      _mm512_permutex2var_pd(a, _mm512_set_epi64(0, 0, 0, 13, 10, 7, 4, 1), b),
      _mm512_set_epi64(14, 11, 8, 4, 3, 2, 1, 0), c);
  const __m512d z = _mm512_permutex2var_pd(
      _mm512_permutex2var_pd(a, _mm512_set_epi64(0, 0, 0, 14, 11, 8, 5, 2), b),
      _mm512_set_epi64(15, 12, 9, 4, 3, 2, 1, 0), c);

  __m512d clip[4];
  simd::transform8(m, x, y, z, clip);
  const __m512d cx = clip[0], cy = clip[1], cz = clip[2], cw = clip[3];

  // Outcodes, as outcode() computes them.
  const __mmask8 invalid = simd::nonfinite8(clip);
  const __m512d zero = _mm512_setzero_pd();
  const __m512d gxw = _mm512_mul_pd(_mm512_set1_pd(vp.guard_x), cw);
  const __m512d gyw = _mm512_mul_pd(_mm512_set1_pd(vp.guard_y), cw);
  auto below_zero = [&](__m512d v) { return _mm512_cmp_pd_mask(v, zero, _CMP_LT_OQ); };
  auto bit = [](__mmask8 k, uint32_t b) { return _mm256_maskz_set1_epi32(k, int(b)); };
  __m256i oc = bit(below_zero(_mm512_add_pd(cx, cw)), kOutLeft);
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_sub_pd(cw, cx)), kOutRight));
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_add_pd(cy, cw)), kOutBottom));
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_sub_pd(cw, cy)), kOutTop));
  const __mmask8 behind =  // !(w >= kMinClipW)
      _mm512_cmp_pd_mask(cw, _mm512_set1_pd(kMinClipW), _CMP_NGE_UQ);
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_add_pd(cz, cw)) | behind, kOutNear));
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_sub_pd(cw, cz)), kOutFar));
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_add_pd(cx, gxw)), kOutGuardLeft));
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_sub_pd(gxw, cx)), kOutGuardRight));
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_add_pd(cy, gyw)), kOutGuardBottom));
  oc = _mm256_or_si256(oc, bit(below_zero(_mm512_sub_pd(gyw, cy)), kOutGuardTop));
  oc = _mm256_mask_set1_epi32(oc, invalid, int(kOutInvalid));
  const __mmask8 direct =
      _mm256_testn_epi32_mask(oc, _mm256_set1_epi32(int(kOutClip | kOutInvalid)));

  // Divide, viewport, clamp depth, snap (to_screen).
  const __m512d one = _mm512_set1_pd(1.0), half = _mm512_set1_pd(0.5);
  const __m512d inv_w = _mm512_div_pd(one, cw);
  const __m512d xn = _mm512_mul_pd(cx, inv_w);
  const __m512d yn = _mm512_mul_pd(cy, inv_w);
  const __m512d zn = _mm512_mul_pd(cz, inv_w);
  const __m512d xw = _mm512_mul_pd(_mm512_add_pd(xn, one), _mm512_set1_pd(vp.half_w));
  const __m512d yw = _mm512_mul_pd(_mm512_sub_pd(one, yn), _mm512_set1_pd(vp.half_h));
  __m512d zw = _mm512_add_pd(_mm512_mul_pd(zn, half), half);
  zw = _mm512_mask_mov_pd(zw, _mm512_cmp_pd_mask(zw, zero, _CMP_LT_OQ), zero);
  zw = _mm512_mask_mov_pd(zw, _mm512_cmp_pd_mask(zw, one, _CMP_GT_OQ), one);
  const __m512d scale = _mm512_set1_pd(double(kSubpixelScale));
  // cvtpd_epi32 rounds in the current mode (to nearest even), like nearbyint.
  const __m256i xf = _mm256_maskz_mov_epi32(direct, _mm512_cvtpd_epi32(_mm512_mul_pd(xw, scale)));
  const __m256i yf = _mm256_maskz_mov_epi32(direct, _mm512_cvtpd_epi32(_mm512_mul_pd(yw, scale)));
  const __m512i pairs = _mm512_permutexvar_epi32(
      _mm512_set_epi32(15, 7, 14, 6, 13, 5, 12, 4, 11, 3, 10, 2, 9, 1, 8, 0),
      _mm512_inserti64x4(_mm512_castsi256_si512(xf), yf, 1));  // x0 y0 x1 y1 ...
  _mm512_storeu_si512(xy_out, pairs);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(oc_out), oc);
  _mm512_storeu_pd(z_out, _mm512_maskz_mov_pd(direct, zw));
}
#endif

#ifdef ZBUFFER_AVX2
// Four vertices, AVX2: transform_8's operations with 4 binary64 lanes.
void transform_4(const double* p, const double* m, const Viewport& vp, int32_t* xy_out,
                 uint32_t* oc_out, double* z_out) {
  const __m256d x = _mm256_setr_pd(p[0], p[3], p[6], p[9]);
  const __m256d y = _mm256_setr_pd(p[1], p[4], p[7], p[10]);
  const __m256d z = _mm256_setr_pd(p[2], p[5], p[8], p[11]);
  __m256d clip[4];
  for (int r = 0; r < 4; ++r) {  // as simd::transform8 (and transform_point)
    const __m256d xy = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(m[4 * r]), x),
                                     _mm256_mul_pd(_mm256_set1_pd(m[4 * r + 1]), y));
    clip[r] = _mm256_add_pd(_mm256_add_pd(xy, _mm256_mul_pd(_mm256_set1_pd(m[4 * r + 2]), z)),
                            _mm256_set1_pd(m[4 * r + 3]));
  }
  const __m256d cx = clip[0], cy = clip[1], cz = clip[2], cw = clip[3];
  const __m256d zero = _mm256_setzero_pd();

  // Outcodes, as outcode() computes them; lane masks narrowed to int32.
  const __m256i narrow = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
  auto lanes32 = [&](__m256d mask) {
    return _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(mask), narrow));
  };
  auto below_zero = [&](__m256d v) { return lanes32(_mm256_cmp_pd(v, zero, _CMP_LT_OQ)); };
  auto bit = [](__m128i lanes, uint32_t b) { return _mm_and_si128(lanes, _mm_set1_epi32(int(b))); };
  __m256d finite = _mm256_cmp_pd(_mm256_sub_pd(cx, cx), zero, _CMP_EQ_OQ);  // v - v == 0
  for (int r = 1; r < 4; ++r)
    finite = _mm256_and_pd(finite, _mm256_cmp_pd(_mm256_sub_pd(clip[r], clip[r]), zero, _CMP_EQ_OQ));
  const __m128i invalid = _mm_xor_si128(lanes32(finite), _mm_set1_epi32(-1));
  const __m256d gxw = _mm256_mul_pd(_mm256_set1_pd(vp.guard_x), cw);
  const __m256d gyw = _mm256_mul_pd(_mm256_set1_pd(vp.guard_y), cw);
  __m128i oc = bit(below_zero(_mm256_add_pd(cx, cw)), kOutLeft);
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_sub_pd(cw, cx)), kOutRight));
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_add_pd(cy, cw)), kOutBottom));
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_sub_pd(cw, cy)), kOutTop));
  const __m128i behind = lanes32(_mm256_cmp_pd(cw, _mm256_set1_pd(kMinClipW), _CMP_NGE_UQ));
  oc = _mm_or_si128(oc, bit(_mm_or_si128(below_zero(_mm256_add_pd(cz, cw)), behind), kOutNear));
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_sub_pd(cw, cz)), kOutFar));
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_add_pd(cx, gxw)), kOutGuardLeft));
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_sub_pd(gxw, cx)), kOutGuardRight));
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_add_pd(cy, gyw)), kOutGuardBottom));
  oc = _mm_or_si128(oc, bit(below_zero(_mm256_sub_pd(gyw, cy)), kOutGuardTop));
  oc = _mm_blendv_epi8(oc, _mm_set1_epi32(int(kOutInvalid)), invalid);
  const __m128i direct =
      _mm_cmpeq_epi32(_mm_and_si128(oc, _mm_set1_epi32(int(kOutClip | kOutInvalid))), _mm_setzero_si128());

  // Divide, viewport, clamp depth, snap (to_screen).
  const __m256d one = _mm256_set1_pd(1.0), half = _mm256_set1_pd(0.5);
  const __m256d inv_w = _mm256_div_pd(one, cw);
  const __m256d xn = _mm256_mul_pd(cx, inv_w);
  const __m256d yn = _mm256_mul_pd(cy, inv_w);
  const __m256d zn = _mm256_mul_pd(cz, inv_w);
  const __m256d xw = _mm256_mul_pd(_mm256_add_pd(xn, one), _mm256_set1_pd(vp.half_w));
  const __m256d yw = _mm256_mul_pd(_mm256_sub_pd(one, yn), _mm256_set1_pd(vp.half_h));
  __m256d zw = _mm256_add_pd(_mm256_mul_pd(zn, half), half);
  zw = _mm256_blendv_pd(zw, zero, _mm256_cmp_pd(zw, zero, _CMP_LT_OQ));
  zw = _mm256_blendv_pd(zw, one, _mm256_cmp_pd(zw, one, _CMP_GT_OQ));
  const __m256d scale = _mm256_set1_pd(double(kSubpixelScale));
  // cvtpd_epi32 rounds in the current mode (to nearest even), like nearbyint.
  const __m128i xf = _mm_and_si128(direct, _mm256_cvtpd_epi32(_mm256_mul_pd(xw, scale)));
  const __m128i yf = _mm_and_si128(direct, _mm256_cvtpd_epi32(_mm256_mul_pd(yw, scale)));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(xy_out), _mm_unpacklo_epi32(xf, yf));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(xy_out + 4), _mm_unpackhi_epi32(xf, yf));
  _mm_storeu_si128(reinterpret_cast<__m128i*>(oc_out), oc);
  _mm256_storeu_pd(z_out, _mm256_and_pd(_mm256_castsi256_pd(_mm256_cvtepi32_epi64(direct)), zw));
}
#endif

}  // namespace

void transform_vertices(const MeshView& mesh, const double* mvp, const Viewport& vp,
                        ScreenVertices& out) {
  out.resize(size_t(mesh.n_vertices));
  out.any_outcode = transform_vertex_range(mesh, mvp, vp, 0, mesh.n_vertices, out);
}

uint32_t transform_vertex_range(const MeshView& mesh, const double* mvp, const Viewport& vp,
                                int64_t begin, int64_t end, ScreenVertices& out) {
  int64_t i = begin;
#if defined(ZBUFFER_AVX512)
  for (; i + 8 <= end; i += 8)
    transform_8(mesh.positions + 3 * i, mvp, vp, &out.xy[2 * i], &out.outcode[i], &out.z[i]);
#elif defined(ZBUFFER_AVX2)
  for (; i + 4 <= end; i += 4)
    transform_4(mesh.positions + 3 * i, mvp, vp, &out.xy[2 * i], &out.outcode[i], &out.z[i]);
#endif
  for (; i < end; ++i) transform_vertex(mesh, mvp, vp, i, out);
  uint32_t any = 0;
  const uint32_t* oc = out.outcode.data();
  for (int64_t v = begin; v < end; ++v) any |= oc[v];
  return any;
}

int clip_polygon(ClipVertex* poly, int n, const Viewport& vp) {
  // A plane cuts a convex polygon into at most one more vertex; tmp has room
  // for twice as many in case rounding ever made one non-convex.
  ClipVertex tmp[2 * kMaxClipVertices];
  double d[kMaxClipVertices];
  for (int plane = 0; plane < 6 && n >= 3; ++plane) {
    bool any_out = false;
    for (int k = 0; k < n; ++k) {
      d[k] = plane_distance(plane, poly[k], vp);
      any_out |= d[k] < 0.0;
    }
    if (!any_out) continue;  // clipping would return the polygon unchanged

    // Walk the edges (prev -> cur); keep inside vertices and add a vertex
    // where an edge crosses the plane.
    int m = 0;
    for (int k = 0; k < n; ++k) {
      const int prev = (k + n - 1) % n;
      const bool prev_in = d[prev] >= 0.0, cur_in = d[k] >= 0.0;
      if (cur_in != prev_in) {
        tmp[m++] = cur_in ? clip_intersection(poly[k], d[k], poly[prev], d[prev])
                          : clip_intersection(poly[prev], d[prev], poly[k], d[k]);
      }
      if (cur_in) tmp[m++] = poly[k];
    }
    if (m > kMaxClipVertices) return 0;
    for (int k = 0; k < m; ++k) poly[k] = tmp[k];
    n = m;
  }
  if (n < 3) return 0;
  for (int k = 0; k < n; ++k) {
    const ClipVertex& c = poly[k];
    if (!(c.w >= kMinClipW) || !std::isfinite(c.x) || !std::isfinite(c.y) ||
        !std::isfinite(c.z) || !std::isfinite(c.w))
      return 0;
  }
  // Rounding in the intersections (a + t (b - a) with |b| around 1e21 and
  // beyond) can leave a vertex outside a guard-band plane, even by many
  // bands, where its fixed-point coordinates would not fit: such a vertex
  // goes onto the plane (docs/rasterization.md, 2.3).
  for (int k = 0; k < n; ++k) {
    ClipVertex& c = poly[k];
    if (plane_distance(2, c, vp) < 0.0) c.x = -(vp.guard_x * c.w);
    else if (plane_distance(3, c, vp) < 0.0) c.x = vp.guard_x * c.w;
    if (plane_distance(4, c, vp) < 0.0) c.y = -(vp.guard_y * c.w);
    else if (plane_distance(5, c, vp) < 0.0) c.y = vp.guard_y * c.w;
  }
  return n;
}

const ScreenVertices& transform_mesh(const RenderInput& input, const Viewport& vp,
                                     RenderStats& stats) {
  const auto t0 = Clock::now();
  thread_local ScreenVertices screen;
  transform_vertices(input.mesh, input.mvp, vp, screen);
  stats.vertex_ms += ms_since(t0);
  return screen;
}

}  // namespace zbuffer
