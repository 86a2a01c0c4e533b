// The raster core's pixel loops.
//
// Transcriptions of docs/rasterization.md section 3: a scalar loop, AVX-512
// loops that evaluate 16 pixels at once with int32 edge values (huge
// triangles by exact spans, 16 pixels a step in int64 lanes; an 8-lane
// int64 loop backs up rasterize_span_avx512), and AVX2 loops of 8 pixels with int32
// edge values (rasterize_rect_avx2_i32, SpanRun8). They perform the same
// IEEE operations per pixel (integer -> float32 conversion, two products,
// two sums, clamp), so they produce the same bits; tests hold the vector
// loops to the scalar one, and every build's loops to the numpy reference.
#include "zbuffer/raster.h"

#include "simd.h"

namespace zbuffer {

namespace {

// Biased edge values at the first pixel (x0, y0) of the rectangle.
ZBUFFER_INLINE void rect_origin(const TriangleSetup& s, int x0, int y0, int64_t row[3]) {
  const int64_t dx = x0 - s.x_min, dy = y0 - s.y_min;
  for (int k = 0; k < 3; ++k)
    row[k] = s.w_origin[k] + dx * s.step_x[k] + dy * s.step_y[k];
}

// Rectangles at least this wide are drawn by exact spans (TriangleSpans)
// instead of testing every pixel, and so are all whose edge values reach
// 2^30 in magnitude (fits_int32). Narrower ones keep the box loops, whose fixed number of 16-pixel
// passes a row beat a span's DDA steps and varying trip count (measured on
// the models suite at 1024x1024: spans from 16 pixels across made meshes of
// medium triangles 10-35% slower; from 64, as fast as the box loops there,
// and 2-3x faster on boxes of hundreds of pixels).
constexpr int kSpanMinWidth = 64;

// Exact Spans
//
// The covered pixels of a rectangle of a triangle's box, row by row, from
// `spans` at row y0 (raster.h: TriangleSpans): `run(w1, w2, n, depth, ids, room)` draws the n
// pixels of a run, all covered, from the exact unbiased edge values w1, w2
// of its first pixel (the depth formula and the depth write only), with
// `room` pixels from its first one that it may load and store back whole
// (to the end of contiguous planes, of the row in padded ones); it returns
// how many it wrote. Only covered pixels are tested, so pixels_tested
// counts them.
template <class Run>
ZBUFFER_INLINE void rasterize_spans(const TriangleSetup& s, TriangleSpans spans, int x0, int y0,
                                    int x1, int y1, DepthTarget& target, RenderStats& stats,
                                    const Run& run) {
  const int64_t dy = int64_t(y0) - s.y_min;
  int64_t row1 = s.w_origin[1] + s.bias[1] + dy * s.step_y[1];  // exact, at (x_min, y)
  int64_t row2 = s.w_origin[2] + s.bias[2] + dy * s.step_y[2];
  const size_t pitch = target.row_pitch(), whole = target.whole_pixels();
  int64_t covered = 0, written = 0;
  for (int y = y0; y <= y1; ++y) {
    int lo, hi;
    spans.span(x0, x1, lo, hi);
    if (lo <= hi) {
      const int64_t dx = int64_t(lo) - s.x_min;
      const size_t p = size_t(y) * pitch + size_t(lo);
      written += run(row1 + dx * s.step_x[1], row2 + dx * s.step_x[2], hi - lo + 1,
                     target.depth + p, target.triangle_id + p,
                     p < whole ? whole - p : size_t(target.width - lo));
      covered += hi - lo + 1;
    }
    spans.next_row();
    row1 += s.step_y[1];
    row2 += s.step_y[2];
  }
  stats.pixels_tested += covered;
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}

// A run one pixel at a time: depth_at and depth_write, as the scalar loop.
struct ScalarRun {
  const TriangleSetup& s;
  int64_t operator()(int64_t w1, int64_t w2, int n, float* depth, int32_t* ids, size_t) const {
    int64_t written = 0;
    for (int i = 0; i < n; ++i) {
      written += depth_write(depth, ids, size_t(i), depth_at(s, w1, w2), s.id);
      w1 += s.step_x[1];
      w2 += s.step_x[2];
    }
    return written;
  }
};

// Whether an exact integer fits in int32.
ZBUFFER_INLINE bool in_int32(int64_t v) {
  return v >= -(int64_t(1) << 31) && v < (int64_t(1) << 31);
}

}  // namespace

void rasterize_rect_scalar(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                           DepthTarget& target, RenderStats& stats) {
  int64_t row[3];
  rect_origin(s, x0, y0, row);
  int64_t covered = 0, written = 0;
  for (int y = y0; y <= y1; ++y) {
    int64_t w0 = row[0], w1 = row[1], w2 = row[2];
    const size_t base = size_t(y) * target.row_pitch();
    for (int x = x0; x <= x1; ++x) {
      if ((w0 | w1 | w2) >= 0) {  // all biased edge values >= 0: inside
        ++covered;
        const float z = depth_at(s, w1 + s.bias[1], w2 + s.bias[2]);
        written += depth_write(target.depth, target.triangle_id, base + x, z, s.id);
      }
      w0 += s.step_x[0];
      w1 += s.step_x[1];
      w2 += s.step_x[2];
    }
    row[0] += s.step_y[0];
    row[1] += s.step_y[1];
    row[2] += s.step_y[2];
  }
  stats.pixels_tested += int64_t(x1 - x0 + 1) * (y1 - y0 + 1);
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}

void rasterize_span_scalar(const TriangleSetup& s, int y, int x0, int x1, float* depth_row,
                           int32_t* id_row, RenderStats& stats) {
  int64_t w[3];
  rect_origin(s, x0, y, w);
  int64_t covered = 0, written = 0;
  for (int x = x0; x <= x1; ++x) {
    if ((w[0] | w[1] | w[2]) >= 0) {  // all biased edge values >= 0: inside
      ++covered;
      const float z = depth_at(s, w[1] + s.bias[1], w[2] + s.bias[2]);
      written += depth_write(depth_row, id_row, size_t(x), z, s.id);
    }
    w[0] += s.step_x[0];
    w[1] += s.step_x[1];
    w[2] += s.step_x[2];
  }
  stats.pixels_tested += int64_t(x1 - x0 + 1);
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}

namespace {

// True if every edge value over the rectangle, and every step the int32
// loop takes, fits in int32 with room to spare (magnitudes below 2^30).
// Edge functions are affine, so their extremes over the rectangle are at
// its corners.
ZBUFFER_INLINE bool fits_int32(const TriangleSetup& s, const int64_t row[3], int width, int height) {
  constexpr int64_t kLimit = int64_t(1) << 30;
  for (int k = 0; k < 3; ++k) {
    const int64_t dx = int64_t(width - 1) * s.step_x[k], dy = int64_t(height - 1) * s.step_y[k];
    const int64_t corners[4] = {row[k], row[k] + dx, row[k] + dy, row[k] + dx + dy};
    for (int64_t c : corners)
      if (c >= kLimit || c <= -kLimit) return false;
    if (s.step_x[k] >= kLimit / 16 || s.step_x[k] <= -kLimit / 16) return false;
    if (s.step_y[k] >= kLimit / 2 || s.step_y[k] <= -kLimit / 2) return false;
  }
  return true;
}

// Whether rasterize_rect draws the rectangle by exact spans rather than
// testing each of its pixels: the same choice in every build, so that
// pixels_tested does not depend on the instruction set.
ZBUFFER_INLINE bool draw_by_spans(const TriangleSetup& s, const int64_t row[3], int width,
                                  int height) {
  return width >= kSpanMinWidth || !fits_int32(s, row, width, height);
}

#ifdef ZBUFFER_AVX512

// The Vector Loops
//
// Both loops evaluate the same operations as the scalar loop, lane by lane:
// exact integer edge values, float(w) conversions, two products, two sums,
// the clamp, and the depth write. They differ only in how many pixels share
// an instruction. Lanes outside the rectangle are masked off, and masked
// loads and stores never touch memory outside the row.

// The common case: every edge value in the rectangle fits in int32, so 16
// pixels share each instruction. A box at most 8 pixels wide is walked two
// rows at a time (lanes 0-7 row y, lanes 8-15 row y + 1), a wider one 16
// pixels of a row at a time.
ZBUFFER_INLINE void rasterize_rect_i32(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                        const int64_t row0[3], DepthTarget& target, RenderStats& stats) {
  const int width = x1 - x0 + 1;
  const bool pairs = width <= 8;
  const __m512i lane = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
  const __m512i col = pairs ? _mm512_and_si512(lane, _mm512_set1_epi32(7)) : lane;
  const __m512i rowsel = pairs ? _mm512_srli_epi32(lane, 3) : _mm512_setzero_si512();
  __m512i lane_w[3];
  // Edge values at the current row, stepped with unsigned (wrapping)
  // arithmetic: the fixed two passes of a short box may step past the rows
  // that fits_int32 bounded, into lanes that are masked off anyway.
  uint32_t row[3];
  for (int k = 0; k < 3; ++k) {
    lane_w[k] = _mm512_add_epi32(_mm512_mullo_epi32(col, _mm512_set1_epi32(int32_t(s.step_x[k]))),
                                 _mm512_mullo_epi32(rowsel, _mm512_set1_epi32(int32_t(s.step_y[k]))));
    row[k] = uint32_t(int32_t(row0[k]));
  }
  const __m512i bias1 = _mm512_set1_epi32(int32_t(s.bias[1]));
  const __m512i bias2 = _mm512_set1_epi32(int32_t(s.bias[2]));
  const simd::DepthPlane16 plane(s.z0, s.a1, s.a2, s.z_lo, s.z_hi);
  const __m512i id = _mm512_set1_epi32(s.id);
  const size_t pitch = target.row_pitch();
  int64_t covered = 0, written = 0;

  // Coverage (of the biased edge values) and depth (of the unbiased ones).
  auto cover_and_depth = [&](__m512i w0, __m512i w1, __m512i w2, __mmask16 in_rect, __m512& z) {
    z = simd::depth16(plane, _mm512_add_epi32(w1, bias1), _mm512_add_epi32(w2, bias2));
    return simd::covered16(in_rect, w0, w1, w2);
  };

  if (pairs) {
    const unsigned one_row = (1u << width) - 1;
    // Rows y and y + 1, each only if it is <= y1. A missing row gets an
    // empty mask and the address of row y1, so only rows of the image are
    // addressed (and masked-off lanes are never touched: simd::write16_rows).
    float* const depth_base = target.depth + x0;
    int32_t* const id_base = target.triangle_id + x0;
    auto row_pair = [&](int y) {
      const bool first = y <= y1, second = y + 1 <= y1;
      const __mmask16 in_rect =
          __mmask16((first ? one_row : 0u) | (second ? one_row << 8 : 0u));
      __m512 z;
      const __mmask16 inside =
          cover_and_depth(_mm512_add_epi32(_mm512_set1_epi32(int32_t(row[0])), lane_w[0]),
                          _mm512_add_epi32(_mm512_set1_epi32(int32_t(row[1])), lane_w[1]),
                          _mm512_add_epi32(_mm512_set1_epi32(int32_t(row[2])), lane_w[2]),
                          in_rect, z);
      const size_t r0 = size_t(first ? y : y1) * pitch, r1 = size_t(second ? y + 1 : y1) * pitch;
      const __mmask16 win = simd::write16_rows(inside, z, id, depth_base + r0, depth_base + r1,
                                               id_base + r0, id_base + r1);
      covered += __builtin_popcount(inside);
      written += __builtin_popcount(win);
      for (int k = 0; k < 3; ++k) row[k] += uint32_t(int32_t(2 * s.step_y[k]));
    };
    if (y1 - y0 < 4) {
      // Up to 4 rows, the most common box in detailed meshes: always two
      // passes, so the branch predictor never sees a varying trip count.
      row_pair(y0);
      row_pair(y0 + 2);
    } else {
      for (int y = y0; y <= y1; y += 2) row_pair(y);
    }
  } else {
    float* depth_row = target.depth + size_t(y0) * pitch + x0;
    int32_t* id_row = target.triangle_id + size_t(y0) * pitch + x0;
    const __m512i step16[3] = {_mm512_set1_epi32(int32_t(16 * s.step_x[0])),
                               _mm512_set1_epi32(int32_t(16 * s.step_x[1])),
                               _mm512_set1_epi32(int32_t(16 * s.step_x[2]))};
    for (int y = y0; y <= y1; ++y) {
      __m512i w0 = _mm512_add_epi32(_mm512_set1_epi32(int32_t(row[0])), lane_w[0]);
      __m512i w1 = _mm512_add_epi32(_mm512_set1_epi32(int32_t(row[1])), lane_w[1]);
      __m512i w2 = _mm512_add_epi32(_mm512_set1_epi32(int32_t(row[2])), lane_w[2]);
      for (int x = 0; x < width; x += 16) {
        const __mmask16 in_rect =
            width - x >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (width - x)) - 1);
        __m512 z;
        const __mmask16 inside = cover_and_depth(w0, w1, w2, in_rect, z);
        const __mmask16 win = simd::write16(inside, z, id, depth_row + x, id_row + x);
        covered += __builtin_popcount(inside);
        written += __builtin_popcount(win);
        w0 = _mm512_add_epi32(w0, step16[0]);
        w1 = _mm512_add_epi32(w1, step16[1]);
        w2 = _mm512_add_epi32(w2, step16[2]);
      }
      for (int k = 0; k < 3; ++k) row[k] += uint32_t(int32_t(s.step_y[k]));
      if (y < y1) {  // no pointer past the last row, not even unused
        depth_row += pitch;
        id_row += pitch;
      }
    }
  }
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}

// Any rectangle, with int64 edge values, 8 pixels of a row per step: what
// rasterize_span_avx512 falls back on where a span's values leave int32
// (rasterize_rect draws such triangles by exact spans instead).
ZBUFFER_INLINE void rasterize_rect_i64(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                        const int64_t row0[3], DepthTarget& target, RenderStats& stats) {
  const int width = x1 - x0 + 1;
  const __m512i lane = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
  __m512i lane_w[3], step8[3];
  int64_t row[3];
  for (int k = 0; k < 3; ++k) {
    lane_w[k] = _mm512_mullo_epi64(lane, _mm512_set1_epi64(s.step_x[k]));
    step8[k] = _mm512_set1_epi64(8 * s.step_x[k]);
    row[k] = row0[k];
  }
  const __m512i bias1 = _mm512_set1_epi64(s.bias[1]);
  const __m512i bias2 = _mm512_set1_epi64(s.bias[2]);
  const simd::DepthPlane16 plane(s.z0, s.a1, s.a2, s.z_lo, s.z_hi);
  const __m512i id = _mm512_set1_epi32(s.id);
  const size_t pitch = target.row_pitch();
  float* depth_row = target.depth + size_t(y0) * pitch + x0;
  int32_t* id_row = target.triangle_id + size_t(y0) * pitch + x0;
  int64_t covered = 0, written = 0;
  for (int y = y0; y <= y1; ++y) {
    __m512i w0 = _mm512_add_epi64(_mm512_set1_epi64(row[0]), lane_w[0]);
    __m512i w1 = _mm512_add_epi64(_mm512_set1_epi64(row[1]), lane_w[1]);
    __m512i w2 = _mm512_add_epi64(_mm512_set1_epi64(row[2]), lane_w[2]);
    for (int x = 0; x < width; x += 8) {
      const __mmask8 in_rect = width - x >= 8 ? __mmask8(0xFF) : __mmask8((1u << (width - x)) - 1);
      const __mmask8 inside = simd::covered8(in_rect, w0, w1, w2);
      if (inside) {  // wide boxes have many empty chunks: worth a branch here
        const __m256 z = simd::depth8(plane, _mm512_add_epi64(w1, bias1), _mm512_add_epi64(w2, bias2));
        // 8 lanes through the 16-lane write: the upper ones are masked off.
        const __mmask16 win = simd::write16(__mmask16(inside), _mm512_castps256_ps512(z), id,
                                            depth_row + x, id_row + x);
        covered += __builtin_popcount(inside);
        written += __builtin_popcount(win);
      }
      w0 = _mm512_add_epi64(w0, step8[0]);
      w1 = _mm512_add_epi64(w1, step8[1]);
      w2 = _mm512_add_epi64(w2, step8[2]);
    }
    for (int k = 0; k < 3; ++k) row[k] += s.step_y[k];
    if (y < y1) {
      depth_row += pitch;
      id_row += pitch;
    }
  }
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}

// A run 16 pixels per instruction. Where the run's edge values fit in
// int32 (affine along the run: its ends bound them), int32 lanes stepped
// with wrapping arithmetic, exact wherever the true value fits (lanes past
// the run are masked off); otherwise int64 lanes, two vectors per 16
// pixels, converted to float by one rounding each (float(int64)).
class SpanRun16 {
 public:
  explicit SpanRun16(const TriangleSetup& s)
      : plane_(s.z0, s.a1, s.a2, s.z_lo, s.z_hi), id_(_mm512_set1_epi32(s.id)),
        sx1_(s.step_x[1]), sx2_(s.step_x[2]) {
    const __m512i lane = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
    lane1_ = _mm512_mullo_epi32(lane, _mm512_set1_epi32(int32_t(uint32_t(sx1_))));
    lane2_ = _mm512_mullo_epi32(lane, _mm512_set1_epi32(int32_t(uint32_t(sx2_))));
    step1_ = _mm512_set1_epi32(int32_t(uint32_t(16 * sx1_)));
    step2_ = _mm512_set1_epi32(int32_t(uint32_t(16 * sx2_)));
    const __m512i lo = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
    const __m512i hi = _mm512_add_epi64(lo, _mm512_set1_epi64(8));
    lane64_[0] = _mm512_mullo_epi64(lo, _mm512_set1_epi64(sx1_));
    lane64_[1] = _mm512_mullo_epi64(hi, _mm512_set1_epi64(sx1_));
    lane64_[2] = _mm512_mullo_epi64(lo, _mm512_set1_epi64(sx2_));
    lane64_[3] = _mm512_mullo_epi64(hi, _mm512_set1_epi64(sx2_));
  }

  int64_t operator()(int64_t w1, int64_t w2, int n, float* depth, int32_t* ids, size_t) const {
    int64_t written = 0;
    auto write = [&](int i, __m512 z) {
      const __mmask16 in_run = n - i >= 16 ? __mmask16(0xFFFF) : __mmask16(_bzhi_u32(0xFFFF, n - i));
      written += __builtin_popcount(simd::write16(in_run, z, id_, depth + i, ids + i));
    };
    const int64_t e1 = w1 + int64_t(n - 1) * sx1_, e2 = w2 + int64_t(n - 1) * sx2_;
    if (in_int32(w1) && in_int32(e1) && in_int32(w2) && in_int32(e2)) {
      __m512i v1 = _mm512_add_epi32(_mm512_set1_epi32(int32_t(w1)), lane1_);
      __m512i v2 = _mm512_add_epi32(_mm512_set1_epi32(int32_t(w2)), lane2_);
      for (int i = 0; i < n; i += 16) {
        write(i, simd::depth16(plane_, v1, v2));
        v1 = _mm512_add_epi32(v1, step1_);
        v2 = _mm512_add_epi32(v2, step2_);
      }
    } else {
      const __m512i step1 = _mm512_set1_epi64(16 * sx1_), step2 = _mm512_set1_epi64(16 * sx2_);
      __m512i v1lo = _mm512_add_epi64(_mm512_set1_epi64(w1), lane64_[0]);
      __m512i v1hi = _mm512_add_epi64(_mm512_set1_epi64(w1), lane64_[1]);
      __m512i v2lo = _mm512_add_epi64(_mm512_set1_epi64(w2), lane64_[2]);
      __m512i v2hi = _mm512_add_epi64(_mm512_set1_epi64(w2), lane64_[3]);
      for (int i = 0; i < n; i += 16) {
        write(i, simd::depth16_of(plane_, simd::to_float16(v1lo, v1hi),
                                  simd::to_float16(v2lo, v2hi)));
        v1lo = _mm512_add_epi64(v1lo, step1);
        v1hi = _mm512_add_epi64(v1hi, step1);
        v2lo = _mm512_add_epi64(v2lo, step2);
        v2hi = _mm512_add_epi64(v2hi, step2);
      }
    }
    return written;
  }

 private:
  simd::DepthPlane16 plane_;
  __m512i id_;
  int64_t sx1_, sx2_;
  __m512i lane1_, lane2_, step1_, step2_;  // int32 lanes (wrapping)
  __m512i lane64_[4];                      // int64 lanes: w1 0-7, 8-15, w2 0-7, 8-15
};

ZBUFFER_INLINE void rasterize_rect_avx512(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                                          DepthTarget& target, RenderStats& stats,
                                          const TriangleSpans* spans) {
  const int width = x1 - x0 + 1, height = y1 - y0 + 1;
  int64_t row[3];
  rect_origin(s, x0, y0, row);
  if (draw_by_spans(s, row, width, height)) {
    rasterize_spans(s, spans ? *spans : TriangleSpans(s, y0), x0, y0, x1, y1, target, stats,
                    SpanRun16(s));
  } else {
    rasterize_rect_i32(s, x0, y0, x1, y1, row, target, stats);
    stats.pixels_tested += int64_t(width) * height;
  }
}

// One row: 16 pixels per step with int32 edge values when the span's values
// and the 16-pixel step fit (almost always), otherwise the int64 rectangle
// loop on a one-row rectangle. Spans are short (a few pixels in a detailed
// mesh), so the per-span setup is kept to three broadcasts and products.
ZBUFFER_INLINE void rasterize_span_avx512(const TriangleSetup& s, int y, int x0, int x1,
                                          float* depth_row, int32_t* id_row,
                                          RenderStats& stats) {
  int64_t w[3];
  rect_origin(s, x0, y, w);
  const int width = x1 - x0 + 1;
  constexpr int64_t kLimit = int64_t(1) << 30;
  bool fits = true;
  for (int k = 0; k < 3; ++k) {
    const int64_t end = w[k] + int64_t(width - 1) * s.step_x[k];
    fits &= w[k] < kLimit && w[k] > -kLimit && end < kLimit && end > -kLimit &&
            s.step_x[k] < kLimit / 16 && s.step_x[k] > -kLimit / 16;
  }
  stats.pixels_tested += width;
  if (!fits) {
    DepthTarget row{depth_row, id_row, x1 + 1, 1};
    rasterize_rect_i64(s, x0, 0, x1, 0, w, row, stats);
    return;
  }
  __m512i wv[3], step16[3];
  for (int k = 0; k < 3; ++k) {
    wv[k] = simd::row16(int32_t(w[k]), int32_t(s.step_x[k]));
    step16[k] = _mm512_set1_epi32(int32_t(16 * s.step_x[k]));
  }
  const simd::DepthPlane16 plane(s.z0, s.a1, s.a2, s.z_lo, s.z_hi);
  const __m512i id = _mm512_set1_epi32(s.id);
  const __m512i bias1 = _mm512_set1_epi32(int32_t(s.bias[1]));
  const __m512i bias2 = _mm512_set1_epi32(int32_t(s.bias[2]));
  int64_t covered = 0, written = 0;
  for (int x = 0; x < width; x += 16) {
    const __mmask16 in_span =
        width - x >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (width - x)) - 1);
    __mmask16 win;
    const __mmask16 inside = simd::span16(in_span, wv[0], wv[1], wv[2], bias1, bias2, plane, id,
                                          depth_row + x0 + x, id_row + x0 + x, win);
    covered += __builtin_popcount(inside);
    written += __builtin_popcount(win);
    for (int k = 0; k < 3; ++k) wv[k] = _mm512_add_epi32(wv[k], step16[k]);
  }
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}
#endif

#ifdef ZBUFFER_AVX2

// The AVX2 loop: the same operations as the scalar loop, 8 pixels per
// instruction with int32 edge values (rectangles whose values do not fit
// are drawn by spans). A box at most 4 pixels wide is walked two rows at a time
// (lanes 0-3 row y, lanes 4-7 row y + 1), a wider one 8 pixels of a row at
// a time. Loads and stores of 8 (or twice 4) pixels that lie inside the
// row, or inside contiguous planes, are whole (simd::write8); the others
// are masked.
ZBUFFER_INLINE void rasterize_rect_avx2_i32(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                                            const int64_t row0[3], DepthTarget& target,
                                            RenderStats& stats) {
  const int width = x1 - x0 + 1;
  const bool pairs = width <= 4;
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i col = pairs ? _mm256_and_si256(lane, _mm256_set1_epi32(3)) : lane;
  const __m256i rowsel = pairs ? _mm256_srli_epi32(lane, 2) : _mm256_setzero_si256();
  __m256i lane_w[3];
  // Stepped with unsigned (wrapping) arithmetic, as in the AVX-512 loop:
  // the lanes that leave the int32 range are masked off.
  uint32_t row[3];
  for (int k = 0; k < 3; ++k) {
    lane_w[k] = _mm256_add_epi32(_mm256_mullo_epi32(col, _mm256_set1_epi32(int32_t(s.step_x[k]))),
                                 _mm256_mullo_epi32(rowsel, _mm256_set1_epi32(int32_t(s.step_y[k]))));
    row[k] = uint32_t(int32_t(row0[k]));
  }
  const __m256i bias1 = _mm256_set1_epi32(int32_t(s.bias[1]));
  const __m256i bias2 = _mm256_set1_epi32(int32_t(s.bias[2]));
  const simd::DepthPlane8 plane(s.z0, s.a1, s.a2, s.z_lo, s.z_hi);
  const __m256i id = _mm256_set1_epi32(s.id);
  const size_t pitch = target.row_pitch(), pixels = target.whole_pixels();
  int64_t covered = 0, written = 0;
  auto edges = [&](int k) { return _mm256_add_epi32(_mm256_set1_epi32(int32_t(row[k])), lane_w[k]); };

  if (pairs) {
    const __m256i in_row = _mm256_cmpgt_epi32(_mm256_set1_epi32(width), col);
    const __m256i first_row = _mm256_cmpgt_epi32(_mm256_set1_epi32(4), lane);
    for (int y = y0; y <= y1; y += 2) {
      const bool second = y + 1 <= y1;
      const __m256i in_rect = second ? in_row : _mm256_and_si256(in_row, first_row);
      const __m256i w0 = edges(0), w1 = edges(1), w2 = edges(2);
      const __m256i inside = simd::covered8x32(in_rect, w0, w1, w2);
      const __m256 z = simd::depth8x32(plane, _mm256_add_epi32(w1, bias1), _mm256_add_epi32(w2, bias2));
      const size_t p0 = size_t(y) * pitch + size_t(x0), p1 = second ? p0 + pitch : p0;
      const __m256i win = simd::write8_rows(inside, z, id, target.depth + p0, target.depth + p1,
                                            target.triangle_id + p0, target.triangle_id + p1,
                                            second, x0 + 4 <= target.width || p1 + 4 <= pixels);
      covered += simd::lanes8(inside);
      written += simd::lanes8(win);
      for (int k = 0; k < 3; ++k) row[k] += uint32_t(int32_t(2 * s.step_y[k]));
    }
  } else {
    __m256i step8[3];
    for (int k = 0; k < 3; ++k) step8[k] = _mm256_set1_epi32(int32_t(8 * s.step_x[k]));
    for (int y = y0; y <= y1; ++y) {
      __m256i w0 = edges(0), w1 = edges(1), w2 = edges(2);
      const size_t p = size_t(y) * pitch + size_t(x0);
      for (int x = 0; x < width; x += 8) {
        const __m256i in_rect = _mm256_cmpgt_epi32(_mm256_set1_epi32(width - x), lane);
        const __m256i inside = simd::covered8x32(in_rect, w0, w1, w2);
        if (!_mm256_testz_si256(inside, inside)) {  // wide boxes have empty chunks
          const __m256 z = simd::depth8x32(plane, _mm256_add_epi32(w1, bias1),
                                           _mm256_add_epi32(w2, bias2));
          const __m256i win = simd::write8(inside, z, id, target.depth + p + x,
                                           target.triangle_id + p + x,
                                           x0 + x + 8 <= target.width || p + x + 8 <= pixels);
          covered += simd::lanes8(inside);
          written += simd::lanes8(win);
        }
        w0 = _mm256_add_epi32(w0, step8[0]);
        w1 = _mm256_add_epi32(w1, step8[1]);
        w2 = _mm256_add_epi32(w2, step8[2]);
      }
      for (int k = 0; k < 3; ++k) row[k] += uint32_t(int32_t(s.step_y[k]));
    }
  }
  stats.pixels_covered += covered;
  stats.pixels_written += written;
}

// A run 8 pixels per instruction: int32 lanes where its edge values fit
// (as SpanRun16), otherwise the exact integers in doubles (|w| < 2^53),
// each rounded once to float. Whole 8-pixel loads and stores wherever they
// stay inside the planes (simd::write8).
class SpanRun8 {
 public:
  explicit SpanRun8(const TriangleSetup& s)
      : plane_(s.z0, s.a1, s.a2, s.z_lo, s.z_hi), id_(_mm256_set1_epi32(s.id)),
        sx1_(s.step_x[1]), sx2_(s.step_x[2]) {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    lane1_ = _mm256_mullo_epi32(lane, _mm256_set1_epi32(int32_t(uint32_t(sx1_))));
    lane2_ = _mm256_mullo_epi32(lane, _mm256_set1_epi32(int32_t(uint32_t(sx2_))));
    step1_ = _mm256_set1_epi32(int32_t(uint32_t(8 * sx1_)));
    step2_ = _mm256_set1_epi32(int32_t(uint32_t(8 * sx2_)));
    const __m256d lo = _mm256_setr_pd(0, 1, 2, 3), hi = _mm256_setr_pd(4, 5, 6, 7);
    // i * step exactly: |step| < 2^34
    lane_d_[0] = _mm256_mul_pd(lo, _mm256_set1_pd(double(sx1_)));
    lane_d_[1] = _mm256_mul_pd(hi, _mm256_set1_pd(double(sx1_)));
    lane_d_[2] = _mm256_mul_pd(lo, _mm256_set1_pd(double(sx2_)));
    lane_d_[3] = _mm256_mul_pd(hi, _mm256_set1_pd(double(sx2_)));
  }

  int64_t operator()(int64_t w1, int64_t w2, int n, float* depth, int32_t* ids,
                     size_t room) const {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    int64_t written = 0;
    auto write = [&](int i, __m256 z) {
      const __m256i in_run = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - i), lane);
      written += simd::lanes8(
          simd::write8(in_run, z, id_, depth + i, ids + i, size_t(i) + 8 <= room));
    };
    const int64_t e1 = w1 + int64_t(n - 1) * sx1_, e2 = w2 + int64_t(n - 1) * sx2_;
    if (in_int32(w1) && in_int32(e1) && in_int32(w2) && in_int32(e2)) {
      __m256i v1 = _mm256_add_epi32(_mm256_set1_epi32(int32_t(w1)), lane1_);
      __m256i v2 = _mm256_add_epi32(_mm256_set1_epi32(int32_t(w2)), lane2_);
      for (int i = 0; i < n; i += 8) {
        write(i, simd::depth8x32(plane_, v1, v2));
        v1 = _mm256_add_epi32(v1, step1_);
        v2 = _mm256_add_epi32(v2, step2_);
      }
    } else {
      const __m256d step1 = _mm256_set1_pd(double(8 * sx1_));
      const __m256d step2 = _mm256_set1_pd(double(8 * sx2_));
      __m256d v1lo = _mm256_add_pd(_mm256_set1_pd(double(w1)), lane_d_[0]);
      __m256d v1hi = _mm256_add_pd(_mm256_set1_pd(double(w1)), lane_d_[1]);
      __m256d v2lo = _mm256_add_pd(_mm256_set1_pd(double(w2)), lane_d_[2]);
      __m256d v2hi = _mm256_add_pd(_mm256_set1_pd(double(w2)), lane_d_[3]);
      for (int i = 0; i < n; i += 8) {
        write(i, simd::depth8_of(plane_, simd::to_float8(v1lo, v1hi), simd::to_float8(v2lo, v2hi)));
        v1lo = _mm256_add_pd(v1lo, step1);
        v1hi = _mm256_add_pd(v1hi, step1);
        v2lo = _mm256_add_pd(v2lo, step2);
        v2hi = _mm256_add_pd(v2hi, step2);
      }
    }
    return written;
  }

 private:
  simd::DepthPlane8 plane_;
  __m256i id_;
  int64_t sx1_, sx2_;
  __m256i lane1_, lane2_, step1_, step2_;  // int32 lanes (wrapping)
  __m256d lane_d_[4];                      // exact integers: w1 0-3, 4-7, w2 0-3, 4-7
};

ZBUFFER_INLINE void rasterize_rect_avx2(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                                        DepthTarget& target, RenderStats& stats,
                                        const TriangleSpans* spans) {
  const int width = x1 - x0 + 1, height = y1 - y0 + 1;
  int64_t row[3];
  rect_origin(s, x0, y0, row);
  if (draw_by_spans(s, row, width, height)) {
    rasterize_spans(s, spans ? *spans : TriangleSpans(s, y0), x0, y0, x1, y1, target, stats,
                    SpanRun8(s));
  } else {
    rasterize_rect_avx2_i32(s, x0, y0, x1, y1, row, target, stats);
    stats.pixels_tested += int64_t(width) * height;
  }
}
#endif

}  // namespace


const char* raster_backend() {
#if defined(ZBUFFER_AVX512)
  return "avx512";
#elif defined(ZBUFFER_AVX2)
  return "avx2";
#else
  return "scalar";
#endif
}

void rasterize_rect(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                    DepthTarget& target, RenderStats& stats, const TriangleSpans* spans) {
#if defined(ZBUFFER_AVX512)
  rasterize_rect_avx512(s, x0, y0, x1, y1, target, stats, spans);
#elif defined(ZBUFFER_AVX2)
  rasterize_rect_avx2(s, x0, y0, x1, y1, target, stats, spans);
#else
  int64_t row[3];
  rect_origin(s, x0, y0, row);
  if (draw_by_spans(s, row, x1 - x0 + 1, y1 - y0 + 1))
    rasterize_spans(s, spans ? *spans : TriangleSpans(s, y0), x0, y0, x1, y1, target, stats,
                    ScalarRun{s});
  else
    rasterize_rect_scalar(s, x0, y0, x1, y1, target, stats);
#endif
}

void rasterize_span(const TriangleSetup& s, int y, int x0, int x1, float* depth_row,
                    int32_t* id_row, RenderStats& stats) {
#ifdef ZBUFFER_AVX512
  rasterize_span_avx512(s, y, x0, x1, depth_row, id_row, stats);
#else
  rasterize_span_scalar(s, y, x0, x1, depth_row, id_row, stats);
#endif
}

void rasterize_span_covered(const TriangleSetup& s, int y, int x0, int x1, float* depth_row,
                            int32_t* id_row, RenderStats& stats) {
  int64_t w[3];
  rect_origin(s, x0, y, w);
  int64_t w1 = w[1] + s.bias[1], w2 = w[2] + s.bias[2];  // exact, unbiased
  int64_t written = 0;
  for (int x = x0; x <= x1; ++x) {
    written += depth_write(depth_row, id_row, size_t(x), depth_at(s, w1, w2), s.id);
    w1 += s.step_x[1];
    w2 += s.step_x[2];
  }
  stats.pixels_tested += int64_t(x1 - x0 + 1);
  stats.pixels_covered += int64_t(x1 - x0 + 1);
  stats.pixels_written += written;
}

void rasterize_triangle(const ScreenTriangle& t, DepthTarget& target, RenderStats& stats) {
  const TriangleSetup s = setup_triangle(t, target.width, target.height);
  if (s.x_min <= s.x_max && s.y_min <= s.y_max)
    rasterize_rect(s, s.x_min, s.y_min, s.x_max, s.y_max, target, stats);
}

}  // namespace zbuffer
