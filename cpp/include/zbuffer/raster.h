// THE shared triangle raster core. Every algorithm decides only which
// triangles and pixels to visit and in what order; coverage, depth and the
// depth write happen here and nowhere else. docs/rasterization.md is the
// written form of this file, and python/zbuffer/reference.py repeats it.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "zbuffer/conventions.h"
#include "zbuffer/types.h"
#include "zbuffer/vertex_stage.h"

namespace zbuffer {

// Fixed point <-> pixel indices.
// Pixel i has its centre at 256 i + 128. The first pixel whose centre is at or
// right of x_fx is ceil((x_fx - 128) / 256); the last at or left of it is
// floor((x_fx - 128) / 256). >> on a negative int64 is an arithmetic shift
// (floor) with every compiler zbuffer supports.
inline int64_t first_pixel_at_or_after(int64_t x_fx) {
  return (x_fx - kHalfPixel + (kSubpixelScale - 1)) >> kSubpixelBits;
}
inline int64_t last_pixel_at_or_before(int64_t x_fx) {
  return (x_fx - kHalfPixel) >> kSubpixelBits;
}
inline int64_t pixel_centre_fx(int64_t i) {
  return i * kSubpixelScale + kHalfPixel;
}

// Top-left rule. Edge k of a triangle with area > 0 (y down) runs from vertex
// k+1 to vertex k+2. The triangle lies to its right when walking it on screen;
// a top edge is horizontal and runs to +x, a left edge runs up (dy < 0).
inline bool is_top_left(int64_t dx, int64_t dy) {
  return dy < 0 || (dy == 0 && dx > 0);
}

// One triangle prepared for rasterization.
// Design decision: edge functions as integer start values at the pixel centre
// (x_min, y_min) of the clamped box plus integer steps per pixel. Good: exact
// incremental evaluation, identical to evaluating the written formula at every
// pixel. Bad: values reach 2^51, so the general loop needs int64 lanes; the
// vector loops use int32 lanes where a triangle's box allows it, and draw
// the others by exact spans (raster.cpp).
struct TriangleSetup {
  // Pixel box, clamped to the image; empty if x_min > x_max or y_min > y_max.
  int x_min, y_min, x_max, y_max;
  // Edge values at the centre of pixel (x_min, y_min), biased by the fill
  // rule: pixel covered <=> all three biased values are >= 0.
  int64_t w_origin[3];
  int64_t step_x[3];  // change of w_k from pixel i to i + 1
  int64_t step_y[3];  // change of w_k from row j to j + 1
  int64_t bias[3];    // w_k = biased w_k + bias[k]  (0 or 1)
  // Depth: z = z0 + (float(w1) * a1 + float(w2) * a2) in float32, clamped
  // to [z_lo, z_hi]. z_lo is the bound culling may use: no pixel is nearer.
  float z0, a1, a2, z_lo, z_hi;
  int32_t id;
};

inline TriangleSetup setup_triangle(const ScreenTriangle& t, int width, int height) {
  TriangleSetup s;
  const int64_t x[3] = {t.v[0].x_fx, t.v[1].x_fx, t.v[2].x_fx};
  const int64_t y[3] = {t.v[0].y_fx, t.v[1].y_fx, t.v[2].y_fx};

  // Pixel box
  const int64_t bx0 = first_pixel_at_or_after(std::min({x[0], x[1], x[2]}));
  const int64_t bx1 = last_pixel_at_or_before(std::max({x[0], x[1], x[2]}));
  const int64_t by0 = first_pixel_at_or_after(std::min({y[0], y[1], y[2]}));
  const int64_t by1 = last_pixel_at_or_before(std::max({y[0], y[1], y[2]}));
  s.x_min = int(std::max<int64_t>(bx0, 0));
  s.y_min = int(std::max<int64_t>(by0, 0));
  s.x_max = int(std::min<int64_t>(bx1, width - 1));
  s.y_max = int(std::min<int64_t>(by1, height - 1));

  // Edge functions: w_k(p) = (x_b - x_a)(p_y - y_a) - (y_b - y_a)(p_x - x_a)
  // for edge k from a = vertex k+1 to b = vertex k+2.
  const int64_t px = pixel_centre_fx(s.x_min);
  const int64_t py = pixel_centre_fx(s.y_min);
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    const int64_t dx = x[b] - x[a], dy = y[b] - y[a];
    s.bias[k] = is_top_left(dx, dy) ? 0 : 1;
    s.w_origin[k] = dx * (py - y[a]) - dy * (px - x[a]) - s.bias[k];
    s.step_x[k] = -dy * kSubpixelScale;
    s.step_y[k] = dx * kSubpixelScale;
  }

  // Depth plane in barycentric form: coefficients in double, rounded once
  // to float for the per-pixel evaluation.
  const double z0 = t.v[0].z, z1 = t.v[1].z, z2 = t.v[2].z;
  const double inv_area = 1.0 / double(t.area);
  s.z0 = float(z0);
  s.a1 = float((z1 - z0) * inv_area);
  s.a2 = float((z2 - z0) * inv_area);
  s.z_lo = float(std::min({z0, z1, z2}));
  s.z_hi = float(std::max({z0, z1, z2}));
  s.id = t.id;
  return s;
}

// The one depth formula. w1, w2 are the exact (unbiased) edge values, of
// any integer type (float(w) of one value is the same float from int32 or
// int64: it rounds to nearest even); each operation is one float32 IEEE
// operation, then the clamp to the triangle's own depth range.
template <typename Int>
inline float depth_at(float z0, float a1, float a2, float z_lo, float z_hi, Int w1, Int w2) {
  float z = z0 + (float(w1) * a1 + float(w2) * a2);
  z = (z < z_lo) ? z_lo : z;
  z = (z > z_hi) ? z_hi : z;
  return z;
}

inline float depth_at(const TriangleSetup& s, int64_t w1, int64_t w2) {
  return depth_at(s.z0, s.a1, s.a2, s.z_lo, s.z_hi, w1, w2);
}

// n = q * d + r with 0 <= r < d, for d > 0 and |n|, d < 2^53. The double
// quotient is within one of the true one; integer arithmetic corrects it
// (an int64 division costs several times as much).
inline void floor_divmod(int64_t n, int64_t d, int64_t& q, int64_t& r) {
  q = int64_t(std::floor(double(n) / double(d)));
  r = n - q * d;
  while (r < 0) {
    --q;
    r += d;
  }
  while (r >= d) {
    ++q;
    r -= d;
  }
}

// The exact spans of a triangle, row by row (docs/rasterization.md, 3.6).
// A triangle is convex, so the pixel centres it covers on a row are one run
// [lo, hi], and the run follows from the edge functions without testing a
// pixel: along a row the biased value of edge k is wb_k(x_min) + (x -
// x_min) * step_x, so it admits x >= x_min + ceil(-wb_k(x_min) / step_x)
// when step_x > 0 and x <= x_min + floor(wb_k(x_min) / -step_x) when
// step_x < 0 (a horizontal edge, step_x == 0, admits the whole row or none
// of it). Both bounds are floor(N / div) of exact integers, and N changes
// by a constant from one row to the next, so they are stepped with an
// integer DDA (quotient and remainder). All three edges are applied on
// every row: their half-planes meet exactly in the covered centres.
//
// Design decision: walk spans for large triangles instead of testing every
// pixel of their box. Good: no pixel outside the triangle is looked at (a
// box is half empty), no coverage test inside it, and the pixels of a span
// need only the depth formula, so huge triangles (int64 edge values) cost
// little more than small ones. Bad: three DDA steps a row, which only pay
// for themselves on rows of more than a few pixels; small triangles keep
// the box loops.
class TriangleSpans {
 public:
  // Start at row y (any row: rows outside the triangle give empty spans).
  TriangleSpans(const TriangleSetup& s, int y) : x_min_(s.x_min) {
    const int64_t dy = int64_t(y) - s.y_min;
    for (int k = 0; k < 3; ++k) {
      const int64_t wb = s.w_origin[k] + dy * s.step_y[k];  // biased, at (x_min, y)
      Bound& b = bound_[k];
      b.left = s.step_x[k] > 0;
      b.div = s.step_x[k] > 0 ? s.step_x[k] : -s.step_x[k];
      if (b.div == 0) {  // horizontal: wb itself, stepped exactly
        b.q = wb;
        b.dq = s.step_y[k];
        b.r = b.dr = 0;
        b.div = 1;
        b.gate = true;
        continue;
      }
      b.gate = false;
      // left: N = -wb + div - 1, N(y + 1) = N(y) - step_y; right: N = wb.
      floor_divmod(b.left ? -wb + b.div - 1 : wb, b.div, b.q, b.r);
      floor_divmod(b.left ? -s.step_y[k] : s.step_y[k], b.div, b.dq, b.dr);
    }
  }

  // The covered run of the current row within columns [x0, x1] (x0 <= x1):
  // lo > hi when it is empty.
  void span(int x0, int x1, int& lo, int& hi) const {
    int64_t l = x0, h = x1;
    for (const Bound& b : bound_) {
      if (b.gate) {
        h = b.q < 0 ? int64_t(x0) - 1 : h;  // the whole row out
      } else if (b.left) {
        l = std::max(l, x_min_ + b.q);
      } else {
        h = std::min(h, x_min_ + b.q);
      }
    }
    l = std::min(l, int64_t(x1) + 1);  // both now in [x0 - 1, x1 + 1]: fit int
    lo = int(l);
    hi = int(std::max(h, l - 1));
  }

  void next_row() {
    for (Bound& b : bound_) {
      b.r += b.dr;
      const bool carry = b.r >= b.div;
      b.r -= carry ? b.div : 0;
      b.q += b.dq + int64_t(carry);
    }
  }

 private:
  struct Bound {
    int64_t q, r, div, dq, dr;  // N = q * div + r; per row N += dq * div + dr
    bool left, gate;
  };
  int64_t x_min_;
  Bound bound_[3];
};

// The one depth write: smaller depth wins, an exact tie goes to the smaller id.
inline bool depth_write(float* depth, int32_t* ids, size_t p, float z, int32_t id) {
  const float d = depth[p];
  if (z < d || (z == d && id < ids[p])) {
    depth[p] = z;
    ids[p] = id;
    return true;
  }
  return false;
}

// The same depth write on (depth, id) keys, a pixel's depth bits above its
// id (the scanline keeps its row of depth so). Depths are never negative,
// -0 or NaN (docs/rasterization.md 3.3) and non-negative floats order as
// their bits do, so the smaller key wins exactly where depth_write writes;
// an empty pixel (+inf, id -1) is the largest key.
constexpr uint64_t kEmptyDepthKey = uint64_t(0x7F800000u) << 32 | 0xFFFFFFFFu;

inline uint64_t depth_key(float z, int32_t id) {
  uint32_t bits;
  std::memcpy(&bits, &z, sizeof bits);
  return uint64_t(bits) << 32 | uint32_t(id);
}

inline bool depth_write_key(uint64_t* keys, size_t p, uint64_t key) {
  const bool win = key < keys[p];
  keys[p] = win ? key : keys[p];
  return win;
}

// Rasterize the part of a triangle inside the pixel rectangle
// [x0, x1] x [y0, y1] (inclusive, already inside the triangle's box), with
// the fastest loop this build has (see raster_backend()): narrow rectangles
// by testing each of their pixels, wide ones (64 pixels or more) and those
// where an edge value reaches 2^30 in magnitude (huge triangles) by exact
// spans (TriangleSpans), which test only the covered pixels. The choice is
// the same in every build; pixels_tested counts the pixels tested either way.
// `spans`, if given, is the triangle's TriangleSpans at row y0: callers that
// draw many rectangles of one triangle (tiles) save its setup.
void rasterize_rect(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                    DepthTarget& target, RenderStats& stats,
                    const TriangleSpans* spans = nullptr);

// The plain scalar loop, one pixel at a time: the literal form of the rules,
// kept callable so that tests can hold the vector loop to it.
void rasterize_rect_scalar(const TriangleSetup& s, int x0, int y0, int x1, int y1,
                           DepthTarget& target, RenderStats& stats);

// Rasterize pixels [x0, x1] of row y of a triangle (inside its box) into a
// buffer holding that one row: depth_row[x] and id_row[x] are pixel (x, y).
// The scanline algorithm's primitive: the edge values at (x0, y) come from
// the setup, exactly as rasterize_rect would step to them, and every pixel
// goes through the same coverage test, depth formula and depth write, so a
// span that is exactly the covered pixels tests nothing else, and a wider
// one still draws nothing more.
void rasterize_span(const TriangleSetup& s, int y, int x0, int x1, float* depth_row,
                    int32_t* id_row, RenderStats& stats);

// The scalar form of rasterize_span, kept callable for tests.
void rasterize_span_scalar(const TriangleSetup& s, int y, int x0, int x1, float* depth_row,
                           int32_t* id_row, RenderStats& stats);

// Draw every pixel [x0, x1] of row y (coverage decided by the caller: the
// scanline's even-odd rule for polygons) with the depth plane of s: the
// depth formula of s's exact edge values at each pixel centre, which may lie
// outside s's triangle, then the depth write. Scalar: polygons are rare.
void rasterize_span_covered(const TriangleSetup& s, int y, int x0, int x1, float* depth_row,
                            int32_t* id_row, RenderStats& stats);

// Set up and rasterize a whole triangle (its box): the reference form the
// tests hold the batched loops to. Algorithms draw through a TriangleBatch
// (triangle_batch.h), which is faster.
void rasterize_triangle(const ScreenTriangle& t, DepthTarget& target, RenderStats& stats);

// "avx512", "avx2" or "scalar": which loops this build runs (simd.h).
const char* raster_backend();

}  // namespace zbuffer
