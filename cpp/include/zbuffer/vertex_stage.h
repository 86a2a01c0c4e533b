// The vertex stage shared by every algorithm: transform, outcodes, clipping
// in homogeneous clip space, perspective divide, viewport and snapping, then
// triangle assembly (orientation, degenerate and back-face culling).
//
// Each step is one written formula (docs/rasterization.md, "Vertex stage")
// that the numpy reference repeats operation by operation.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "zbuffer/conventions.h"
#include "zbuffer/types.h"

namespace zbuffer {

// A vertex in homogeneous clip space.
struct ClipVertex {
  double x, y, z, w;
};

// A vertex after divide, viewport and snapping: window x, y in fixed point
// (kSubpixelBits fractional bits), window depth in [0, 1].
struct ScreenVertex {
  int32_t x_fx, y_fx;
  uint32_t outcode;  // kOut* bits of the clip-space vertex
  double z;
};

// The transformed vertices of a mesh.
// Design decision: structure of arrays, except that x and y share one array
// as pairs. Good: the vector vertex stage stores one field for 8 vertices
// at a time (4 with AVX2), the vector triangle setup reads a field for 16
// faces' corners (8 with AVX2) by loads put together into vectors
// (setup16.h), and a corner's x and y come in one 64-bit load. Bad: scalar
// code touches three arrays per vertex.
struct ScreenVertices {
  std::vector<int32_t> xy;  // x_fx of vertex i at 2 i, y_fx at 2 i + 1
  std::vector<uint32_t> outcode;
  std::vector<double> z;
  // The OR of the outcodes of the vertices last transformed: 0 when every
  // one lies inside the view volume's guard band, so that no face needs
  // clipping or frustum culling (assembly then skips reading outcodes).
  uint32_t any_outcode = ~0u;

  // Make room for n vertices. Growing never shrinks, so a buffer reused
  // across frames is allocated once.
  void resize(size_t n) {
    if (z.size() >= n) return;
    xy.resize(2 * n);
    outcode.resize(n);
    z.resize(n);
  }
  ScreenVertex operator[](int64_t i) const { return {xy[2 * i], xy[2 * i + 1], outcode[i], z[i]}; }
};

// A triangle ready for the raster core: counter-clockwise on screen with y
// down, i.e. area > 0 (see raster.h), so inside means all edge values >= 0.
struct ScreenTriangle {
  ScreenVertex v[3];
  int64_t area;  // twice the signed area in fixed-point units squared, > 0
  int32_t id;    // index of the input face this triangle (or piece) came from
};

// Outcode bits: which side of which plane a clip-space vertex is on.
// The view planes decide culling (a triangle with all three vertices outside
// one of them is invisible); near, far and the guard band decide clipping.
enum : uint32_t {
  kOutLeft = 1u << 0,    // x < -w
  kOutRight = 1u << 1,   // x >  w
  kOutBottom = 1u << 2,  // y < -w
  kOutTop = 1u << 3,     // y >  w
  kOutNear = 1u << 4,    // z < -w (or w < kMinClipW: at or behind the eye)
  kOutFar = 1u << 5,     // z >  w
  kOutGuardLeft = 1u << 6,    // x < -g_x w
  kOutGuardRight = 1u << 7,   // x >  g_x w
  kOutGuardBottom = 1u << 8,  // y < -g_y w
  kOutGuardTop = 1u << 9,     // y >  g_y w
  kOutInvalid = 1u << 10,     // a clip coordinate overflowed to inf or NaN
  kOutView = kOutLeft | kOutRight | kOutBottom | kOutTop | kOutNear | kOutFar,
  kOutClip = kOutNear | kOutFar | kOutGuardLeft | kOutGuardRight |
             kOutGuardBottom | kOutGuardTop,
};

// The window and its guard band.
struct Viewport {
  int width = 0, height = 0;
  double half_w = 0, half_h = 0;  // W / 2, H / 2
  double guard_x = 0, guard_y = 0;  // g_x, g_y: guard band planes in NDC units

  Viewport() = default;
  Viewport(int w, int h)
      : width(w), height(h), half_w(0.5 * w), half_h(0.5 * h),
        guard_x(kGuardBandPx / (0.5 * w)), guard_y(kGuardBandPx / (0.5 * h)) {}
};

// Vertex Stage Formulas

// clip = mvp * (p, 1), each row summed left to right.
inline ClipVertex transform_point(const double* m, const double* p) {
  ClipVertex c;
  c.x = ((m[0] * p[0] + m[1] * p[1]) + m[2] * p[2]) + m[3];
  c.y = ((m[4] * p[0] + m[5] * p[1]) + m[6] * p[2]) + m[7];
  c.z = ((m[8] * p[0] + m[9] * p[1]) + m[10] * p[2]) + m[11];
  c.w = ((m[12] * p[0] + m[13] * p[1]) + m[14] * p[2]) + m[15];
  return c;
}

inline uint32_t outcode(const ClipVertex& c, const Viewport& vp) {
  // Finite positions times a finite matrix can still overflow. Such a vertex
  // is infinitely far away; its triangles are skipped (stats.culled_invalid).
  if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z) ||
      !std::isfinite(c.w))
    return kOutInvalid;
  const double gxw = vp.guard_x * c.w;
  const double gyw = vp.guard_y * c.w;
  uint32_t oc = 0;
  oc |= (c.x + c.w < 0.0) ? kOutLeft : 0u;
  oc |= (c.w - c.x < 0.0) ? kOutRight : 0u;
  oc |= (c.y + c.w < 0.0) ? kOutBottom : 0u;
  oc |= (c.w - c.y < 0.0) ? kOutTop : 0u;
  // !(w >= kMinClipW): a vertex at or behind the eye plane always goes
  // through the near clip, whatever rounding did to z.
  oc |= (c.z + c.w < 0.0 || !(c.w >= kMinClipW)) ? kOutNear : 0u;
  oc |= (c.w - c.z < 0.0) ? kOutFar : 0u;
  oc |= (c.x + gxw < 0.0) ? kOutGuardLeft : 0u;
  oc |= (gxw - c.x < 0.0) ? kOutGuardRight : 0u;
  oc |= (c.y + gyw < 0.0) ? kOutGuardBottom : 0u;
  oc |= (gyw - c.y < 0.0) ? kOutGuardTop : 0u;
  return oc;
}

// Divide, viewport, clamp depth, snap. Only called for vertices inside the
// near, far and guard-band planes with w >= kMinClipW, so 1 / w is finite and
// |x / w|, |y / w| <= g: the results are finite and |x_fx|, |y_fx| < 2^24.
inline ScreenVertex to_screen(const ClipVertex& c, const Viewport& vp) {
  const double inv_w = 1.0 / c.w;
  const double xn = c.x * inv_w;
  const double yn = c.y * inv_w;
  const double zn = c.z * inv_w;
  const double xw = (xn + 1.0) * vp.half_w;
  const double yw = (1.0 - yn) * vp.half_h;  // row 0 at the top
  double zw = zn * 0.5 + 0.5;
  zw = (zw < 0.0) ? 0.0 : zw;
  zw = (zw > 1.0) ? 1.0 : zw;
  ScreenVertex s;
  // nearbyint: round half to even in the default rounding mode, as np.rint.
  s.x_fx = static_cast<int32_t>(std::nearbyint(xw * kSubpixelScale));
  s.y_fx = static_cast<int32_t>(std::nearbyint(yw * kSubpixelScale));
  s.outcode = 0;
  s.z = zw;
  return s;
}

// Transform every vertex of the mesh: outcodes for all, window coordinates
// for those that need neither clipping nor are invalid (the others get 0).
// Grows out to at least mesh.n_vertices entries.
void transform_vertices(const MeshView& mesh, const double* mvp,
                        const Viewport& vp, ScreenVertices& out);

// The same for vertices begin .. end - 1 only, into `out` as it is (sized by
// the caller); returns the OR of their outcodes (out.any_outcode is left
// alone). Vertices come out the same whichever range they are part of.
uint32_t transform_vertex_range(const MeshView& mesh, const double* mvp, const Viewport& vp,
                                int64_t begin, int64_t end, ScreenVertices& out);

// The vertex stage of a whole render: every vertex of input.mesh once, into
// a buffer of the calling thread that is reused from frame to frame
// (allocating, zeroing and faulting in a new one cost more than the
// transform itself), timed into stats.vertex_ms. Valid until the thread's
// next call.
const ScreenVertices& transform_mesh(const RenderInput& input, const Viewport& vp,
                                     RenderStats& stats);

// Clip Space Polygon Clipping

// Signed distance of a clip-space vertex to clip plane `plane` (0 near,
// 1 far, 2..5 guard band left, right, bottom, top); inside where >= 0.
inline double plane_distance(int plane, const ClipVertex& c, const Viewport& vp) {
  switch (plane) {
    case 0: return c.z + c.w;
    case 1: return c.w - c.z;
    case 2: return c.x + vp.guard_x * c.w;
    case 3: return vp.guard_x * c.w - c.x;
    case 4: return c.y + vp.guard_y * c.w;
    default: return vp.guard_y * c.w - c.y;
  }
}

// The point where the edge from inside vertex a to outside vertex b meets the
// plane. Always computed from the inside end, so an edge shared by two
// triangles is cut at the same bits whichever way they list it.
inline ClipVertex clip_intersection(const ClipVertex& a, double da,
                                    const ClipVertex& b, double db) {
  const double t = da / (da - db);
  return {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y),
          a.z + t * (b.z - a.z), a.w + t * (b.w - a.w)};
}

constexpr int kMaxClipVertices = 3 + 6;

// Sutherland-Hodgman against near, far, then the four guard-band planes.
// Returns the number of polygon vertices left in poly (0 or >= 3). Returns 0
// as well if a vertex is left with !(w >= kMinClipW) or a non-finite
// coordinate, or if rounding ever grew the polygon past kMaxClipVertices;
// only absurd scales could produce these: such a face is dropped rather than
// divided by (almost) zero.
int clip_polygon(ClipVertex* poly, int n, const Viewport& vp);

// Triangle Assembly

// Orient, cull and hand on one triangle. Returns false if it was culled.
// The orientation test is the sign of the exact integer area: in window
// coordinates (y down) a triangle counter-clockwise in NDC has area < 0.
inline bool make_triangle(const ScreenVertex& a, const ScreenVertex& b,
                          const ScreenVertex& c, int32_t id,
                          bool cull_backfaces, ScreenTriangle& out,
                          RenderStats& stats) {
  const int64_t area =
      (int64_t(b.x_fx) - a.x_fx) * (int64_t(c.y_fx) - a.y_fx) -
      (int64_t(b.y_fx) - a.y_fx) * (int64_t(c.x_fx) - a.x_fx);
  if (area == 0) {
    ++stats.culled_degenerate;
    return false;
  }
  if (area > 0 && cull_backfaces) {  // clockwise in NDC: a back face
    ++stats.culled_backface;
    return false;
  }
  // Front faces (area < 0) swap b and c so that the raster core sees
  // area > 0. Selected by pointer, not by branch: about half the triangles
  // of a closed mesh face each way, which no branch predictor can guess.
  const bool front = area < 0;
  const ScreenVertex* second = front ? &c : &b;
  const ScreenVertex* third = front ? &b : &c;
  out.v[0] = a;
  out.v[1] = *second;
  out.v[2] = *third;
  out.area = front ? -area : area;
  out.id = id;
  return true;
}

// Assembles face `f` from transformed vertices and calls emit(const
// ScreenTriangle&) for each triangle that survives: the face itself, or the
// pieces of its clipped polygon (a fan from the polygon's first vertex).
// Pieces keep the face's id.
template <class Emit>
inline void assemble_triangle(const MeshView& mesh, const double* mvp,
                              const Viewport& vp, const ScreenVertices& sv,
                              int64_t f, bool cull_backfaces,
                              RenderStats& stats, Emit&& emit) {
  const int32_t* idx = mesh.faces + 3 * f;
  const ScreenVertex a = sv[idx[0]];
  const ScreenVertex b = sv[idx[1]];
  const ScreenVertex c = sv[idx[2]];
  const uint32_t all_out = a.outcode & b.outcode & c.outcode;
  const uint32_t any_out = a.outcode | b.outcode | c.outcode;
  if (any_out & kOutInvalid) {
    ++stats.culled_invalid;
    return;
  }
  if (all_out & kOutView) {  // wholly outside one plane of the view volume
    ++stats.culled_frustum;
    return;
  }
  const int32_t id = mesh.id(f);
  ScreenTriangle tri;
  if (!(any_out & kOutClip)) {  // the common case: no clipping
    if (make_triangle(a, b, c, id, cull_backfaces, tri, stats)) emit(tri);
    return;
  }
  // Clipping: recompute the clip-space vertices (same formula, same bits)
  // rather than keeping them for every vertex of the mesh.
  ++stats.clipped;
  ClipVertex poly[kMaxClipVertices];
  for (int k = 0; k < 3; ++k)
    poly[k] = transform_point(mvp, mesh.positions + 3 * int64_t(idx[k]));
  const int n = clip_polygon(poly, 3, vp);
  if (n < 3) {
    ++stats.clipped_away;
    return;
  }
  ScreenVertex s[kMaxClipVertices];
  for (int k = 0; k < n; ++k) s[k] = to_screen(poly[k], vp);
  for (int k = 1; k + 1 < n; ++k) {
    ++stats.clip_pieces;
    if (make_triangle(s[0], s[k], s[k + 1], id, cull_backfaces, tri, stats))
      emit(tri);
  }
}

}  // namespace zbuffer
