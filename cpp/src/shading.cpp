// Lambert shading of a visibility result. See shading.h for the model.
//
// Per-face work (normal, facing, perspective-correct barycentric functions,
// and for flat faces the final colour) is done once per face, before the
// pixels are visited; per-pixel work is then a handful of multiply-adds.
#include "zbuffer/shading.h"

#include "zbuffer/buffer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include "double_lanes.h"
#include "id_runs.h"
#include "simd.h"

namespace zbuffer {

namespace {

struct Vec3 {
  double x, y, z;
};
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline Vec3 normalized(Vec3 a) {
  const double len = std::sqrt(dot(a, a));
  return len > 0.0 ? (1.0 / len) * a : Vec3{0, 0, 0};
}
inline Vec3 load3(const double* p) { return {p[0], p[1], p[2]}; }
inline double largest(Vec3 v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

// v times the power of two that brings its largest component into [1, 2)
// (exact: the same direction), or v itself where that is 0 or not finite.
inline Vec3 power_scaled(Vec3 v) {
  const double m = largest(v);
  if (!(m > 0.0) || !std::isfinite(m)) return v;
  const int e = std::ilogb(m);
  return {std::scalbn(v.x, -e), std::scalbn(v.y, -e), std::scalbn(v.z, -e)};
}

// A face normal whose largest component lies in [2^-400, 2^400] is used as
// the cross product gives it; outside, squaring it would underflow to 0 or
// overflow to inf (coordinates below about 1e-81 or above 1e77 lost their
// normal so), and it is computed from edges scaled by powers of two.
constexpr double kNormalLow = 0x1p-400, kNormalHigh = 0x1p400;

// The direction of the normal of the face with corners p: cross(p1 - p0,
// p2 - p0) where its largest component lies in [kNormalLow, kNormalHigh]
// (the vector preparations compute only that, and leave other faces to
// prepare_face), else the cross product of the edges each scaled by a power
// of two, scaled again -- the same direction, with nothing on the way
// overflowing or underflowing.
inline Vec3 face_normal_direction(const Vec3 (&p)[3]) {
  const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  const Vec3 ng = cross(e1, e2);
  const double m = largest(ng);
  if (m >= kNormalLow && m <= kNormalHigh) return ng;
  return power_scaled(cross(power_scaled(e1), power_scaled(e2)));
}

inline uint8_t to_byte(double c) {
  return uint8_t(std::floor(std::min(1.0, std::max(0.0, c)) * 255.0 + 0.5));
}

// Ambient plus Lambert diffuse for the unit normal n (lit from its side only;
// callers turn n towards the viewer first).
inline double intensity(const ShadingInput& in, Vec3 n, Vec3 to_light) {
  return in.ambient + in.diffuse * std::max(0.0, dot(n, to_light));
}

// What a face needs at every pixel it covers, in double. The scalar pass
// computes it lazily, the first time a pixel shows the face; the vector
// passes keep it in float32 in a FaceTable prepared before their pixels.
struct FaceShade {
  // Perspective-correct barycentrics: with clip-space corners (x_k, y_k, w_k)
  // as the columns of M, adj(M) (x_ndc, y_ndc, 1) is proportional to them.
  double bary[9];
  Vec3 normal;   // flat: the unit face normal, facing the viewer
  double side;   // +1 or -1: which way the face turns towards the viewer
  uint8_t rgb[3];  // flat shading with a per-face colour: the final colour
  // Smooth shading in the vector passes: the interpolated normal before its
  // normalisation, as a linear map of (x_ndc, y_ndc, 1) (row c: component
  // c). With barycentrics b_k = (adj(M) p)_k / sum, the interpolated normal
  // sum_k b_k N_k is (sum_k N_k adj(M)_k) p / sum, and sum = det(M) / w has
  // det's sign wherever w > 0: the map is sign(det) sum_k N_k adj(M)_k,
  // turned to the viewer's side and scaled to a largest entry of 1 (only
  // the direction counts). A pixel then costs 6 multiply-adds and the
  // normalisation: no barycentric division and no corner normals.
  // Barycentrics are not clamped into [0, 1] here: a snapped pixel centre a
  // hair outside the triangle extrapolates by that hair. A face without
  // usable barycentrics (det 0 or not finite) maps every pixel to its
  // corners' mean normal, as the scalar pass does.
  double normal_map[9];
  // Interpolated shading in the vector passes: true where their float32
  // evaluation could stray from the scalar pass by about a level, and they
  // shade the face's pixels again after each row the scalar pass's way, in
  // double (finish_exact). First, the barycentrics: their sum at a pixel
  // of the face is at least |det| / max w_k (det from the scaled
  // coefficients), and float32 loses 2e-7 of the coefficients' scale (1)
  // in each: under 1e-3 that is 5e-4 of a barycentric (0.14 of a level
  // between corners of opposite colours). Then smooth shading's map: it
  // does not clamp, and a covered pixel centre lies within 2^-9 px (the
  // snapping) of the triangle in each axis, so up to 0.0028 px outside an
  // edge, where the map extrapolates the normal by 0.0028 x spread / h (h:
  // the altitude onto that edge, in pixels; spread: the largest difference
  // of two corners' normals) -- with spread <= h, at most 0.0028 x 255 x
  // diffuse (0.8) = 0.56 of a level for a white face (twice that only
  // within 0.003 px of a corner, outside both its edges). And corners'
  // normals more than 90 degrees apart can cancel inside the face, where
  // float32 then fails. Hence: a corner at or behind the camera plane,
  // |det| < 1e-3 max w_k, and for smooth shading spread > h, two corners'
  // normals with a negative dot product, the map's length at a corner
  // under 1e-3 of its largest entry, or that entry under 1e-9 before the
  // scaling (a map of rounding noise). Found by fuzzing helpers: up to 73
  // levels off on slivers of 1e-4 px^2, on faces collinear within rounding
  // and on a prism's cap seen end-on, 3-14 on slivers at 4000 x 3000. The
  // flags cost 12-25% of smooth shading at 1024 x 1024 on bunny_69k,
  // armadillo_86k and lucy_20k (0.5-8% of their faces); spread <= h / 2
  // instead would cost 26-77% (8-21% of their faces).
  bool exact = false;
};

// The bounds FaceShade::exact holds the map to.
constexpr double kSpreadPerPixel = 1.0;
constexpr double kLeastCornerLength = 1e-3;
constexpr double kLeastMapEntry = 1e-9;
constexpr double kLeastSum = 1e-3;

// Whether the barycentrics may be evaluated in float32 (FaceShade::exact
// false): every corner in front of the camera and |det| >= kLeastSum max w.
// The vector preparations compute the same.
bool sums_are_close(const double cw[3], double det) {
  const double w = std::max(std::max(cw[0], cw[1]), cw[2]);
  return cw[0] > 0.0 && cw[1] > 0.0 && cw[2] > 0.0 && std::abs(det) >= kLeastSum * w;
}

// Whether smooth shading's map may be evaluated in float32, for a face
// whose sums_are_close (so every w_k > 0): no two corners' normals more
// than 90 degrees apart, their spread within the smallest altitude
// (squared: spread^2 lmax^2 <= kSpreadPerPixel^2 (2 area)^2, in pixels),
// the map's length at each corner at least kLeastCornerLength, and its
// largest entry before the scaling (`largest`) at least kLeastMapEntry.
// The vector preparations compute the same, in the same order.
bool map_is_close(const ShadingInput& in, const double cx[3], const double cy[3],
                  const double cw[3], const double vn[3][3], const double map[9],
                  double largest) {
  if (!(largest >= kLeastMapEntry)) return false;
  // Without divisions, in homogeneous pixels (x, y, w): the map's length at
  // corner k is |map (x_k, y_k, w_k)| / w_k, twice the area in pixels
  // area / (w_0 w_1 w_2) (area: the determinant of the corners), and an
  // edge from a to k is the length of (x_a w_k - x_k w_a, y_a w_k - y_k w_a)
  // over w_a w_k; both sides of the bounds are multiplied out.
  constexpr double kLeast2 = kLeastCornerLength * kLeastCornerLength;
  constexpr double kSpread2 = kSpreadPerPixel * kSpreadPerPixel;
  const double half_w = 0.5 * in.width, half_h = 0.5 * in.height;
  double x[3], y[3];
  bool close = true;
  for (int k = 0; k < 3; ++k) {
    x[k] = cx[k] * half_w;
    y[k] = cy[k] * half_h;
    double len2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double v = map[3 * c] * cx[k] + map[3 * c + 1] * cy[k] + map[3 * c + 2] * cw[k];
      len2 = len2 + v * v;
    }
    close = close && len2 >= kLeast2 * (cw[k] * cw[k]);
  }
  const double area = x[0] * (y[1] * cw[2] - y[2] * cw[1]) - x[1] * (y[0] * cw[2] - y[2] * cw[0]) +
                      x[2] * (y[0] * cw[1] - y[1] * cw[0]);
  double edge2 = 0.0, spread2 = 0.0;  // edge2: times the third corner's w^2
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, m = (k + 2) % 3;
    const double ex = x[a] * cw[k] - x[k] * cw[a], ey = y[a] * cw[k] - y[k] * cw[a];
    edge2 = std::max(edge2, (ex * ex + ey * ey) * (cw[m] * cw[m]));
    double d2 = 0.0, along = 0.0;
    for (int c = 0; c < 3; ++c) {
      d2 = d2 + (vn[a][c] - vn[k][c]) * (vn[a][c] - vn[k][c]);
      along = along + vn[a][c] * vn[k][c];
    }
    spread2 = std::max(spread2, d2);
    close = close && along >= 0.0;
  }
  return close && spread2 * edge2 <= kSpread2 * (area * area);
}

// Everything about one face that the pass needs, computed once.
FaceShade prepare_face(const ShadingInput& in, int32_t f, bool need_bary, bool need_map = false) {
  FaceShade s;
  const double* m = in.mvp;
  const Vec3 viewer = load3(in.viewer);
  const int32_t* idx = in.mesh.faces + 3 * int64_t(f);
  Vec3 p[3];
  for (int k = 0; k < 3; ++k) p[k] = load3(in.mesh.positions + 3 * int64_t(idx[k]));
  const Vec3 ng = face_normal_direction(p);
  s.side = dot(ng, viewer - in.viewer[3] * p[0]) < 0.0 ? -1.0 : 1.0;
  s.normal = s.side * normalized(ng);
  for (double& b : s.bary) b = 0.0;
  if (need_bary) {
    double cx[3], cy[3], cw[3];
    for (int k = 0; k < 3; ++k) {
      cx[k] = m[0] * p[k].x + m[1] * p[k].y + m[2] * p[k].z + m[3];
      cy[k] = m[4] * p[k].x + m[5] * p[k].y + m[6] * p[k].z + m[7];
      cw[k] = m[12] * p[k].x + m[13] * p[k].y + m[14] * p[k].z + m[15];
    }
    // Rows of the adjugate of [[x0 x1 x2], [y0 y1 y2], [w0 w1 w2]].
    for (int k = 0; k < 3; ++k) {
      const int a = (k + 1) % 3, b = (k + 2) % 3;
      s.bary[3 * k + 0] = cy[a] * cw[b] - cy[b] * cw[a];
      s.bary[3 * k + 1] = cw[a] * cx[b] - cw[b] * cx[a];
      s.bary[3 * k + 2] = cx[a] * cy[b] - cx[b] * cy[a];
    }
    // Scale so that the largest coefficient is about 1: the vector pass
    // evaluates them in float32, whose range the raw products can exceed.
    double big = 0.0;
    for (double b : s.bary) big = std::max(big, std::abs(b));
    const bool scaled = big > 0.0 && std::isfinite(big);
    if (scaled) {
      const double scale = 1.0 / big;
      for (double& b : s.bary) b *= scale;
    }
    const double det = s.bary[0] * cx[0] + s.bary[1] * cy[0] + s.bary[2] * cw[0];
    s.exact = !sums_are_close(cw, det);
    if (need_map) {
      double vn[3][3];  // corner k, component c
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) vn[k][c] = in.vertex_normals[3 * int64_t(idx[k]) + c];
      if (scaled && det != 0.0 && std::isfinite(det)) {
        const double sign = (det < 0.0) == (s.side < 0.0) ? 1.0 : -1.0;
        for (int c = 0; c < 3; ++c)
          for (int j = 0; j < 3; ++j)
            s.normal_map[3 * c + j] = sign * (vn[0][c] * s.bary[j] + vn[1][c] * s.bary[3 + j] +
                                              vn[2][c] * s.bary[6 + j]);
      } else {
        for (int c = 0; c < 3; ++c) {
          s.normal_map[3 * c + 0] = s.normal_map[3 * c + 1] = 0.0;
          s.normal_map[3 * c + 2] = s.side * (vn[0][c] + vn[1][c] + vn[2][c]);
        }
      }
      double largest = 0.0;
      for (double v : s.normal_map) largest = std::max(largest, std::abs(v));
      if (largest > 0.0 && std::isfinite(largest)) {
        const double scale = 1.0 / largest;
        for (double& v : s.normal_map) v *= scale;
      }
      s.exact = s.exact || !map_is_close(in, cx, cy, cw, vn, s.normal_map, largest);
    }
  }
  const Vec3 to_light = -1.0 * load3(in.light_dir);
  const double light = intensity(in, s.normal, to_light);
  for (int c = 0; c < 3; ++c) {
    const double albedo = in.color_source == ColorSource::kPerFace
                              ? in.colors[3 * int64_t(f) + c]
                              : in.uniform_color[c];
    s.rgb[c] = to_byte(albedo * light);
  }
  return s;
}

// The pixel centre's barycentrics (at NDC xn, yn), clamped into the
// triangle -- a snapped pixel centre may lie a hair outside it -- and
// normalised, or a third each where they cannot be had.
void clamped_barycentrics(const FaceShade& s, double xn, double yn, double b[3]) {
  for (int k = 0; k < 3; ++k) b[k] = s.bary[3 * k] * xn + s.bary[3 * k + 1] * yn + s.bary[3 * k + 2];
  const double sum = b[0] + b[1] + b[2];
  if (sum != 0.0 && std::isfinite(sum)) {
    for (int k = 0; k < 3; ++k) b[k] = std::min(1.0, std::max(0.0, b[k] / sum));
    const double total = b[0] + b[1] + b[2];
    for (int k = 0; k < 3; ++k) b[k] /= total;
  } else {
    b[0] = b[1] = b[2] = 1.0 / 3.0;
  }
}

// Smooth shading's normal at barycentrics b of the face with corners idx:
// the corners' normals interpolated, normalised and turned to the viewer,
// or the flat normal where they cancel.
Vec3 smooth_normal(const ShadingInput& in, const FaceShade& s, const int32_t* idx, const double b[3]) {
  Vec3 ns{0, 0, 0};
  for (int k = 0; k < 3; ++k) ns = ns + b[k] * load3(in.vertex_normals + 3 * int64_t(idx[k]));
  return dot(ns, ns) > 0.0 ? s.side * normalized(ns) : s.normal;
}

// The scalar pass's colour of pixel (i, j) of face f (prepared as s, with
// barycentrics), into out[0..2]: for interpolated shading, smooth or with
// per-vertex colours.
void shade_pixel(const ShadingInput& in, const FaceShade& s, int32_t f, int i, int j, bool smooth,
                 uint8_t* out) {
  const double half_w = 0.5 * in.width, half_h = 0.5 * in.height;
  double b[3];
  clamped_barycentrics(s, (i + 0.5) / half_w - 1.0, 1.0 - (j + 0.5) / half_h, b);
  const int32_t* idx = in.mesh.faces + 3 * int64_t(f);
  const Vec3 n = smooth ? smooth_normal(in, s, idx, b) : s.normal;
  double albedo[3] = {0.0, 0.0, 0.0};
  for (int c = 0; c < 3; ++c) {
    switch (in.color_source) {
      case ColorSource::kUniform: albedo[c] = in.uniform_color[c]; break;
      case ColorSource::kPerFace: albedo[c] = in.colors[3 * int64_t(f) + c]; break;
      case ColorSource::kPerVertex:
        albedo[c] = b[0] * in.colors[3 * int64_t(idx[0]) + c] +
                    b[1] * in.colors[3 * int64_t(idx[1]) + c] +
                    b[2] * in.colors[3 * int64_t(idx[2]) + c];
        break;
    }
  }
  const double light = intensity(in, n, -1.0 * load3(in.light_dir));
  for (int c = 0; c < 3; ++c) out[c] = to_byte(albedo[c] * light);
}


#if defined(ZBUFFER_AVX512)
void shade_avx512(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image);
#elif defined(ZBUFFER_AVX2)
void shade_avx2(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image);
#endif

}  // namespace

void shade(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image) {
  const bool interpolated = in.vertex_normals || in.color_source == ColorSource::kPerVertex;
  if (in.pixels_beyond_faces && interpolated) {
    shade_scalar(in, triangle_id, image);
    return;
  }
#if defined(ZBUFFER_AVX512)
  shade_avx512(in, triangle_id, image);
#elif defined(ZBUFFER_AVX2)
  shade_avx2(in, triangle_id, image);
#else
  shade_scalar(in, triangle_id, image);
#endif
}

void shade_scalar(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image) {
  const bool smooth = in.vertex_normals != nullptr;
  const bool per_vertex = in.color_source == ColorSource::kPerVertex;
  const bool need_bary = smooth || per_vertex;

  std::unique_ptr<FaceShade[]> faces(new FaceShade[size_t(in.mesh.n_faces)]);
  std::vector<uint8_t> ready(size_t(in.mesh.n_faces), 0);

  auto prepare = [&](int32_t f) -> const FaceShade& {
    if (!ready[f]) {
      faces[f] = prepare_face(in, f, need_bary);
      ready[f] = 1;
    }
    return faces[f];
  };

  for (int j = 0; j < in.height; ++j) {
    for (int i = 0; i < in.width; ++i) {
      const size_t p = size_t(j) * size_t(in.width) + size_t(i);
      uint8_t* out = image + 3 * p;
      const int32_t f = triangle_id[size_t(j) * in.id_pitch() + size_t(i)];
      if (f < 0) {
        out[0] = in.background[0];
        out[1] = in.background[1];
        out[2] = in.background[2];
        continue;
      }
      const FaceShade& s = prepare(f);
      if (!need_bary) {
        out[0] = s.rgb[0];
        out[1] = s.rgb[1];
        out[2] = s.rgb[2];
        continue;
      }

      shade_pixel(in, s, f, i, j, smooth, out);
    }
  }
}

namespace {

#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)

// The Vector Passes
//
// 16 (AVX-512) or 8 (AVX2) pixels of a row per step, in float32 (shading
// need not be bit-exact; it agrees with the scalar pass and the numpy twin
// within one level). Per-face data sits in a table of rows (a colour each,
// and 16 or 32 floats for interpolation). Flat shading loads each pixel's
// colour (gathers, where a step shows background too); interpolated
// shading broadcasts a row's fields into the lanes of each run of one id
// among the step's pixels (16 neighbouring pixels show a few faces, and a
// gather per field costs about an element a cycle on Zen, as on Intel
// cores with the gather data sampling fix).

// Design decision: the per-face table is prepared before the pixel pass,
// for the faces that show up -- not lazily, face by face as the pixels
// meet them. Good: AVX-512 builds prepare 8 faces per instruction, AVX2
// builds 4 (and both prefetch the corners of the faces to come), and the
// pixel pass has no "seen yet?" test. Bad: where the mesh has more faces
// than a quarter of the pixels (1/64 for interpolated shading, whose rows
// cost more), finding the faces that show up takes a pass over the ids of
// its own (8 or 16 ids compared with their left neighbours per
// instruction, the ids that start a run packed into a short list, then
// looked up), and their rows are then numbered apart from the faces (a
// slot per face found, so that the table stays as small as the image's
// faces: a mesh of millions
// of faces would otherwise scatter its few visible rows over hundreds of
// megabytes of fresh pages). Found faces get rows in the order the image
// first shows them, so that the pixel pass reads the table almost in
// order (in face order it waited on a cache miss for most faces: 1.6x as
// long on bunny_69k at 1024 x 1024, smooth). That pass and the preparation
// go band by band (kBand rows): a band's new faces are found and prepared,
// then its pixels shaded, while its ids and the rows just written are
// still in the caches (smooth shading 0.97-0.98x the time of one pass over
// the whole image before the pixels on bunny_69k and armadillo_86k at
// 1024 x 1024, down to 0.85x while the machine was busy; benchmarks/
// README.md). With fewer faces every face
// is prepared, which costs less than finding out, and row = face. The
// tables live on from frame to frame (one per thread, up to kKeptRows
// rows), so that they are not allocated and faulted in anew each time.
struct FaceTable {
  // What a thread keeps after a pass: 4 MB of flat rows, 16 MB of
  // interpolation rows, 16 MB each of slot numbers, of the faces found and
  // of exact steps, 512 KB of "seen" bits, and 64 Ki exact faces' FaceShades.
  static constexpr size_t kKeptRows = size_t(1) << 20;
  static constexpr size_t kKeptRowFloats = size_t(1) << 22;
  static constexpr size_t kKeptSlots = size_t(1) << 22;
  // Room for n rows, with the fields the interpolated passes read (the
  // barycentrics' coefficients if bary, the normal map if map). Not zeroed
  // (Buffer): the passes read only the rows prepared.
  void resize(size_t n, bool bary, bool map) {
    if (rows_allocated < n) {
      rows_allocated = n;
      rgb.clear();  // (emptied first: nothing copied into the new arrays)
      rgb.resize(n);
      rows.clear();
    }
    row_floats = row_floats_for(bary, map);
    map_at = map_at_for(bary);
    fit_rows(bary || map);
  }
  // Room for rows [0, n), keeping the rows written (by_slot: rows are added
  // band by band). After resize, with the same fields.
  void grow(size_t n, bool bary, bool map) {
    if (rows_allocated >= n) return;
    rows_allocated = std::max(n, 2 * rows_allocated);
    rgb.resize(rows_allocated);
    fit_rows(bary || map);
  }
  // Interpolation rows for every row allocated.
  void fit_rows(bool interpolated) {
    const size_t floats = size_t(row_floats) * rows_allocated;
    if (interpolated && rows.size() < floats) rows.resize(floats);
  }
  // After a pass: give back the memory of arrays too large to keep.
  void trim() {
    if (exact.capacity() > kKeptRows / 16) std::vector<FaceShade>().swap(exact);
    if (exact_steps.size() > kKeptSlots) Buffer<uint32_t>().swap(exact_steps);
    if (rows_allocated > kKeptRows || rows.size() > kKeptRowFloats) {
      rows_allocated = 0;
      Buffer<int32_t>().swap(rgb);
      LineBuffer<float>().swap(rows);
    }
    if (slot.size() > kKeptSlots) Buffer<int32_t>().swap(slot);
    if (found.capacity() > kKeptSlots) Buffer<int32_t>().swap(found);
    if (seen.capacity() > kKeptSlots / 64) std::vector<uint64_t>().swap(seen);
  }
  // Row of face f: f itself, or slot[f] when by_slot.
  bool by_slot = false;
  Buffer<int32_t> slot;         // by_slot: the row of each face found (others unset)
  Buffer<int32_t> found;        // by_slot: the faces found, in image order (row r: found[r])
  std::vector<uint64_t> seen;   // by_slot: a bit per face, set where found
  int32_t row(int32_t f) const { return by_slot ? slot[size_t(f)] : f; }
  size_t rows_allocated = 0;
  Buffer<int32_t> rgb;   // flat colour of row r, 0x00BBGGRR
  // What interpolation reads, row_floats floats a row (at row_floats r):
  // one cache line a face (two for smooth shading with per-vertex
  // colours), so that a pass that meets a face loads one line, not one per
  // field (the pixels meet faces in image order, not in row order).
  static constexpr int kLine = 16;
  enum Field {
    kBary = 0,    // 9: coefficient c of barycentric k at 3 k + c (per-vertex colours)
    kNormal = 9,  // 3: the flat normal, facing the viewer
    kExact = 12,  // interpolated: int32 1 + index into `exact`, or 0 (13-15: unused)
  };
  static constexpr int row_floats_for(bool bary, bool map) {
    return bary && map ? 2 * kLine : kLine;
  }
  static constexpr int map_at_for(bool bary) { return bary ? kLine : 0; }
  int row_floats = kLine;
  int map_at = 0;  // smooth: FaceShade::normal_map from here (after the barycentrics if kept)
  LineBuffer<float> rows;  // (so that each row is one line, not parts of two)
  // Interpolated shading: the faces the vector passes leave to the scalar
  // pass's way (FaceShade::exact), as it prepares them. Row field kExact
  // holds 1 + the face's index here (int32 bits), else 0.
  std::vector<FaceShade> exact;
  // The steps of a row of a pass with lanes of such faces (y, x, lane
  // bits), shaded again after the row (finish_exact): in the loop over the
  // row they would crowd its registers (an inlined or called helper there:
  // 1.4-1.5x as slow).
  Buffer<uint32_t> exact_steps;
  const FaceShade* exact_face(const float* row) const {
    int32_t at;
    std::memcpy(&at, row + kExact, sizeof at);
    return at ? &exact[size_t(at) - 1] : nullptr;
  }
  // Face s left to the scalar way, for row r (after r's fields are written).
  void add_exact(size_t r, const FaceShade& s) {
    exact.push_back(s);
    const int32_t at = int32_t(exact.size());
    std::memcpy(rows.data() + size_t(row_floats) * r + kExact, &at, sizeof at);
  }
  // Room for a row's steps of `step` pixels (exact_steps).
  void reserve_steps(int width, int step) {
    const size_t most = 3 * ((size_t(width) + size_t(step) - 1) / size_t(step));
    if (exact_steps.size() < most) {
      Buffer<uint32_t>().swap(exact_steps);
      exact_steps.resize(most);
    }
  }
};

void store_row(FaceTable& table, size_t r, const FaceShade& s, bool bary, bool map) {
  table.rgb[r] = int32_t(s.rgb[0]) | (int32_t(s.rgb[1]) << 8) | (int32_t(s.rgb[2]) << 16);
  if (!bary && !map) return;
  float* row = table.rows.data() + size_t(table.row_floats) * r;
  std::fill(row, row + table.row_floats, 0.0f);
  if (bary)
    for (int c = 0; c < 9; ++c) row[FaceTable::kBary + c] = float(s.bary[c]);
  if (map)
    for (int c = 0; c < 9; ++c) row[table.map_at + c] = float(s.normal_map[c]);
  row[FaceTable::kNormal + 0] = float(s.normal.x);
  row[FaceTable::kNormal + 1] = float(s.normal.y);
  row[FaceTable::kNormal + 2] = float(s.normal.z);
  if (s.exact) table.add_exact(r, s);
}

// For the vector preparations: the faces of rows first + j, for the bits j
// of `lanes`, left to the scalar way, from their lanes of the FaceShade
// fields that way reads (fields: the barycentrics' 9 coefficients, the
// side, the normal's 3 components; the same values as prepare_face's).
template <int W>
void add_exact_lanes(FaceTable& table, size_t first, unsigned lanes, const double (&fields)[13][W]) {
  for (; lanes; lanes &= lanes - 1) {
    const int j = __builtin_ctz(lanes);
    FaceShade e{};
    for (int c = 0; c < 9; ++c) e.bary[c] = fields[c][j];
    e.side = fields[9][j];
    e.normal = {fields[10][j], fields[11][j], fields[12][j]};
    e.exact = true;
    table.add_exact(first + size_t(j), e);
  }
}

// The pixels of a pass's recorded steps (FaceTable::exact_steps: row y,
// from pixel x, lane bits) shaded again the scalar pass's way.
__attribute__((noinline)) void finish_exact(const ShadingInput& in, const FaceTable& table,
                                            const int32_t* triangle_id, uint8_t* image, size_t n_steps) {
  const bool smooth = in.vertex_normals != nullptr;
  for (size_t k = 0; k < n_steps; ++k) {
    const int y = int(table.exact_steps[3 * k]), x = int(table.exact_steps[3 * k + 1]);
    const size_t at = size_t(y) * size_t(in.width) + size_t(x);
    const int32_t* ids = triangle_id + size_t(y) * in.id_pitch() + size_t(x);
    for (unsigned lanes = table.exact_steps[3 * k + 2]; lanes; lanes &= lanes - 1) {
      const int j = __builtin_ctz(lanes);
      const int32_t face = ids[j];
      const FaceShade& s =
          *table.exact_face(table.rows.data() + size_t(table.row_floats) * size_t(table.row(face)));
      shade_pixel(in, s, face, x + j, y, smooth, image + 3 * (at + size_t(j)));
    }
  }
}

// prepare_face for V::kWidth faces f at once (lanes `live`; double_lanes.h:
// 8 in AVX-512 builds, 4 in AVX2 builds), in double: the same operations in
// the same order, so the same bits; into rows first .. first + kWidth - 1.
// corners[k][j] is the vertex at corner k of lane j's face, read by the
// caller: positions and vertex normals are loaded a vertex at a time and
// transposed (V::load_xyz), not gathered by coordinate: flat shading
// 0.87-0.92x the time, smooth 0.97-1.04x (benchmarks/results/
// ab-shading-loads*.md; simd.h's corner_pairs4 on the cost of gathers).
// Returns the lanes whose normal lies outside [kNormalLow, kNormalHigh]
// (face_normal_direction), left for prepare_face to prepare again (their
// rows are written, with normals of no use). One function per kind of
// row (bary: barycentric coefficients, map: smooth shading's normal map;
// neither: a flat colour), so that each keeps in registers what it needs.
template <class V, bool bary, bool map>
unsigned prepare_faces(const ShadingInput& in, FaceTable& table, typename V::Index f,
                       typename V::IndexMask live_index, const int32_t (*corners)[V::kWidth],
                       size_t first) {
  using D = typename V::D;
  using Mask = typename V::Mask;
  const D zero = V::set(0.0), one = V::set(1.0);
  const Mask live = V::widen(live_index);
  auto positive_finite = [](D v) {  // 0 < v < inf (not NaN)
    return V::gt(v, V::set(0.0)) & V::lt(v, V::set(std::numeric_limits<double>::infinity()));
  };
  const typename V::Index f3 = V::times3(f);
  D p[3][3];  // corner k, coordinate c
  for (int k = 0; k < 3; ++k) V::load_xyz(in.mesh.positions, corners[k], p[k]);
  auto dot = [](const D* a, const D* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  D e1[3], e2[3], ng[3], to_viewer[3];
  for (int c = 0; c < 3; ++c) {
    e1[c] = p[1][c] - p[0][c];
    e2[c] = p[2][c] - p[0][c];
  }
  for (int c = 0; c < 3; ++c) {
    const int a = (c + 1) % 3, b = (c + 2) % 3;
    ng[c] = e1[a] * e2[b] - e1[b] * e2[a];
    to_viewer[c] = V::set(in.viewer[c]) - V::set(in.viewer[3]) * p[0][c];
  }
  // The lanes to prepare again (prepare_face): their normal takes
  // face_normal_direction's robust way.
  const D largest_ng = V::max(V::abs(ng[2]), V::max(V::abs(ng[1]), V::abs(ng[0])));
  const unsigned redo = V::bits(V::andnot(V::ge(largest_ng, V::set(kNormalLow)) &
                                                V::le(largest_ng, V::set(kNormalHigh)),
                                            live));
  const Mask back = V::lt(dot(ng, to_viewer), zero);
  const D side = V::blend(back, one, V::set(-1.0));
  const D len = V::sqrt(dot(ng, ng));
  const Mask nonzero = V::gt(len, zero);
  const D inv = one / len;
  D normal[3];
  for (int c = 0; c < 3; ++c) normal[c] = side * V::blend(nonzero, zero, inv * ng[c]);
  // Flat shading: the final colour is all a face needs (a masked store).
  // (Interpolated shading lights each pixel and never reads it.)
  if constexpr (!bary && !map) {
    D to_light[3];
    for (int c = 0; c < 3; ++c) to_light[c] = V::set(-1.0 * in.light_dir[c]);
    const D light = V::set(in.ambient) + V::set(in.diffuse) * V::max(dot(normal, to_light), zero);
    auto byte = [&](int c) {
      const D albedo = in.color_source == ColorSource::kPerFace
                           ? V::gather(in.colors, V::add(f3, V::index(c)), live_index)
                           : V::set(double(in.uniform_color[c]));
      const D v = V::min(V::max(albedo * light, zero), one);
      return V::floor(v * V::set(255.0) + V::set(0.5));
    };
    V::store_rgb(table.rgb.data() + first, live_index, byte(0), byte(1), byte(2));
    return redo;
  }

  D coef[9], normal_map[9];
  const double* m = in.mvp;
  D cx[3], cy[3], cw[3];
  auto row = [&](const double* r, int k) {
    return V::set(r[0]) * p[k][0] + V::set(r[1]) * p[k][1] + V::set(r[2]) * p[k][2] + V::set(r[3]);
  };
  for (int k = 0; k < 3; ++k) {
    cx[k] = row(m, k);
    cy[k] = row(m + 4, k);
    cw[k] = row(m + 12, k);
  }
  D b[9], big = zero;
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, c = (k + 2) % 3;
    b[3 * k + 0] = cy[a] * cw[c] - cy[c] * cw[a];
    b[3 * k + 1] = cw[a] * cx[c] - cw[c] * cx[a];
    b[3 * k + 2] = cx[a] * cy[c] - cx[c] * cy[a];
  }
  for (const D& v : b) big = V::max(V::abs(v), big);
  const Mask scalable = positive_finite(big);
  const D inv_big = one / big;
  for (int c = 0; c < 9; ++c) coef[c] = V::blend(scalable, b[c], b[c] * inv_big);
  const D det = coef[0] * cx[0] + coef[1] * cy[0] + coef[2] * cw[0];
  // FaceShade::exact: not sums_are_close ...
  const D w = V::max(cw[2], V::max(cw[1], cw[0]));
  Mask exact = V::andnot(V::gt(cw[0], zero) & V::gt(cw[1], zero) & V::gt(cw[2], zero) &
                             V::ge(V::abs(det), V::set(kLeastSum) * w),
                         live);
  if constexpr (map) {
    D vn[3][3];  // corner k, component c
    for (int k = 0; k < 3; ++k) V::load_xyz(in.vertex_normals, corners[k], vn[k]);
    const Mask usable = scalable & positive_finite(V::abs(det));  // det finite and not 0
    const Mask opposite = V::lt(det, zero) ^ back;             // det and side of two signs
    const D sign = V::blend(opposite, one, V::set(-1.0));     // +1 where of one sign
    D largest = zero;
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < 3; ++j) {
        const D mapped = vn[0][c] * coef[j] + vn[1][c] * coef[3 + j] + vn[2][c] * coef[6 + j];
        const D mean = j < 2 ? zero : side * (vn[0][c] + vn[1][c] + vn[2][c]);
        normal_map[3 * c + j] = V::blend(usable, mean, sign * mapped);
        largest = V::max(V::abs(normal_map[3 * c + j]), largest);
      }
    }
    const Mask normalise = positive_finite(largest);
    const D inv_largest = one / largest;
    for (D& v : normal_map) v = V::blend(normalise, v, v * inv_largest);

    // ... or not map_is_close.
    const D half_w = V::set(0.5 * in.width), half_h = V::set(0.5 * in.height);
    const D least2 = V::set(kLeastCornerLength * kLeastCornerLength);
    Mask close = V::ge(largest, V::set(kLeastMapEntry));
    D x[3], y[3];
    for (int k = 0; k < 3; ++k) {
      x[k] = cx[k] * half_w;
      y[k] = cy[k] * half_h;
      D len2 = zero;
      for (int c = 0; c < 3; ++c) {
        const D v = normal_map[3 * c] * cx[k] + normal_map[3 * c + 1] * cy[k] +
                    normal_map[3 * c + 2] * cw[k];
        len2 = len2 + v * v;
      }
      close &= V::ge(len2, least2 * (cw[k] * cw[k]));
    }
    auto minor = [&](int a, int b) { return y[a] * cw[b] - y[b] * cw[a]; };
    const D area = x[0] * minor(1, 2) - x[1] * minor(0, 2) + x[2] * minor(0, 1);
    D edge2 = zero, spread2 = zero;
    for (int k = 0; k < 3; ++k) {
      const int a = (k + 1) % 3, mk = (k + 2) % 3;
      const D ex = x[a] * cw[k] - x[k] * cw[a];
      const D ey = y[a] * cw[k] - y[k] * cw[a];
      edge2 = V::max((ex * ex + ey * ey) * (cw[mk] * cw[mk]), edge2);
      D d2 = zero, along = zero;
      for (int c = 0; c < 3; ++c) {
        const D d = vn[a][c] - vn[k][c];
        d2 = d2 + d * d;
        along = along + vn[a][c] * vn[k][c];
      }
      spread2 = V::max(d2, spread2);
      close &= V::ge(along, zero);
    }
    const D spread_bound = V::set(kSpreadPerPixel * kSpreadPerPixel) * (area * area);
    close &= V::le(spread2 * edge2, spread_bound);
    exact |= V::andnot(close, live);
  }

  // Into the table's rows: the interpolated fields as rows of 16 or 32
  // floats (fields by lane, transposed a square at a time).
  typename V::F field[2 * FaceTable::kLine];
  for (auto& v : field) v = V::zero_float();
  if constexpr (bary)
    for (int c = 0; c < 9; ++c) field[FaceTable::kBary + c] = V::to_float(coef[c]);
  if constexpr (map)
    for (int c = 0; c < 9; ++c) field[table.map_at + c] = V::to_float(normal_map[c]);
  for (int c = 0; c < 3; ++c) field[FaceTable::kNormal + c] = V::to_float(normal[c]);
  V::store_rows(table.rows.data() + size_t(table.row_floats) * first, table.row_floats, field,
                V::bits(live));
  if (const unsigned exact_lanes = V::bits(exact) & ~redo) {
    double fields[13][V::kWidth];
    for (int c = 0; c < 9; ++c) V::store(fields[c], coef[c]);
    V::store(fields[9], side);
    for (int c = 0; c < 3; ++c) V::store(fields[10 + c], normal[c]);
    add_exact_lanes(table, first, exact_lanes, fields);
  }
  return redo;
}

// prepare_faces for the kind of rows a pass reads.
template <class V>
unsigned prepare_faces(const ShadingInput& in, FaceTable& table, typename V::Index f,
                       typename V::IndexMask live, const int32_t (*corners)[V::kWidth], bool bary,
                       bool map, size_t first) {
  if (map)
    return bary ? prepare_faces<V, true, true>(in, table, f, live, corners, first)
                : prepare_faces<V, false, true>(in, table, f, live, corners, first);
  return bary ? prepare_faces<V, true, false>(in, table, f, live, corners, first)
              : prepare_faces<V, false, false>(in, table, f, live, corners, first);
}

// Calls sight(face) for the id of every run of one id among the `count`
// ids at `ids` (and maybe again for a face sighted before), skipping -1:
// the runs' ids packed into a short list first (id_runs.h), then sighted (a
// loop over each 16 pixels' runs would mispredict its trip count).
template <class Sight>
void sight_runs(const int32_t* ids, size_t count, Sight&& sight) {
  constexpr size_t kChunk = 2048;
  alignas(64) int32_t runs[kChunk + 16];
  int32_t left = -1;
  for (size_t p = 0; p < count; p += kChunk) {
    const size_t m = std::min(kChunk, count - p);
    const size_t n = id_run_starts(ids + p, m, left, runs);
    for (size_t k = 0; k < n; ++k) sight(runs[k]);
    left = ids[p + m - 1];
  }
}

// Rows [first, count) of the table prepared: row r for the face list[r]
// (by_slot) or r.
void prepare_rows(const ShadingInput& in, FaceTable& table, size_t first, size_t count, bool bary,
                  bool map) {
  const Buffer<int32_t>& list = table.found;
  auto face_at = [&](size_t i) { return table.by_slot ? list[i] : int32_t(i); };
  // Rows row0 + j, for the bits j of `lanes`, prepared again the scalar
  // way (the vector preparations leave faces of extreme scale to it).
  auto prepare_again = [&](size_t row0, unsigned lanes) {
    for (; lanes; lanes &= lanes - 1) {
      const size_t r = row0 + size_t(__builtin_ctz(lanes));
      store_row(table, r, prepare_face(in, face_at(r), bary || map, map), bary, map);
    }
  };
  // The vertices of rows row0 .. row0 + width - 1 by corner (vertex 0 past
  // the last row).
  auto corner_vertices = [&](size_t row0, int width, auto& corners) {
    for (int j = 0; j < width; ++j) {
      const bool row = row0 + size_t(j) < count;
      const int32_t* idx = in.mesh.faces + 3 * size_t(row ? face_at(row0 + size_t(j)) : 0);
      for (int k = 0; k < 3; ++k) corners[k][j] = row ? idx[k] : 0;
    }
  };
  size_t i = first;
  // (int32 gather indices of per-face colours: 3 n_faces must fit)
  constexpr int64_t kMaxIndexed = int64_t(std::numeric_limits<int32_t>::max()) / 3;
  const bool indexed = in.mesh.n_faces <= kMaxIndexed;
#ifdef ZBUFFER_AVX512
  if (indexed) {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (; i < count; i += 8) {
      const __mmask8 live = __mmask8(_bzhi_u32(0xFF, uint32_t(std::min<size_t>(count - i, 8))));
      const __m256i f = table.by_slot ? _mm256_maskz_loadu_epi32(live, list.data() + i)
                                      : _mm256_add_epi32(_mm256_set1_epi32(int32_t(i)), lane);
      // The loads wait on memory (found faces come in image order, their
      // corners from anywhere): the corners of the faces two steps on are
      // fetched now, and the found faces' indices four steps on. (Written
      // out per instruction set: a shared lambda taking the step's width
      // made the smooth pass 1.3x slower.)
      auto prefetch = [](const void* p) { _mm_prefetch(static_cast<const char*>(p), _MM_HINT_T0); };
      if (table.by_slot && i + 40 <= count)
        for (size_t a = i + 32; a < i + 40; ++a) prefetch(in.mesh.faces + 3 * size_t(list[a]));
      if (i + 24 <= count)
        for (size_t a = i + 16; a < i + 24; ++a)
          for (int k = 0; k < 3; ++k) {
            const size_t v = size_t(in.mesh.faces[3 * size_t(face_at(a)) + size_t(k)]);
            prefetch(in.mesh.positions + 3 * v);
            if (map) prefetch(in.vertex_normals + 3 * v);
          }
      alignas(32) int32_t corners[3][8];
      corner_vertices(i, 8, corners);
      prepare_again(i, prepare_faces<lanes::Doubles8>(in, table, f, live, corners, bary, map, i));
    }
  }
#elif defined(ZBUFFER_AVX2)
  if (indexed) {
    const __m128i lane = _mm_setr_epi32(0, 1, 2, 3);
    for (; i < count; i += 4) {
      const __m128i live =
          _mm_cmpgt_epi32(_mm_set1_epi32(int32_t(std::min<size_t>(count - i, 4))), lane);
      const __m128i f = table.by_slot ? _mm_maskload_epi32(list.data() + i, live)
                                      : _mm_add_epi32(_mm_set1_epi32(int32_t(i)), lane);
      // (as above: the corners of the faces two steps on, and the found
      // faces' indices four steps on)
      auto prefetch = [](const void* p) { _mm_prefetch(static_cast<const char*>(p), _MM_HINT_T0); };
      if (table.by_slot && i + 20 <= count)
        for (size_t a = i + 16; a < i + 20; ++a) prefetch(in.mesh.faces + 3 * size_t(list[a]));
      if (i + 12 <= count)
        for (size_t a = i + 8; a < i + 12; ++a)
          for (int k = 0; k < 3; ++k) {
            const size_t v = size_t(in.mesh.faces[3 * size_t(face_at(a)) + size_t(k)]);
            prefetch(in.mesh.positions + 3 * v);
            if (map) prefetch(in.vertex_normals + 3 * v);
          }
      alignas(16) int32_t corners[3][4];
      corner_vertices(i, 4, corners);
      prepare_again(i, prepare_faces<lanes::Doubles4>(in, table, f, live, corners, bary, map, i));
    }
  }
#endif
  for (; i < count; ++i)
    store_row(table, i, prepare_face(in, face_at(i), bary || map, map), bary, map);
}

// Starts a pass's table. With few faces, every face is prepared now, row =
// face. Otherwise (by_slot) none yet: prepare_band finds the faces each band
// of rows shows and prepares those not found before, a slot each in the
// order of their first pixels.
void begin_table(const ShadingInput& in, FaceTable& table, bool bary, bool map) {
  const size_t n_faces = size_t(in.mesh.n_faces);
  const size_t n_pixels = size_t(in.width) * size_t(in.height);
  // (Interpolated shading prepares far more per face -- a row of 16 or 32
  // floats and FaceShade::exact's checks -- so finding the faces pays
  // sooner: from 1/64 of the pixels on; 1/8 was 2x slower on bunny_69k.)
  table.by_slot = n_faces > n_pixels / (bary || map ? 64 : 4);
  table.exact.clear();
  if (!table.by_slot) {
    table.resize(n_faces, bary, map);
    prepare_rows(in, table, 0, n_faces, bary, map);
    return;
  }
  table.seen.assign((n_faces + 63) / 64, 0);
  table.found.clear();
  if (table.slot.size() < n_faces) {
    table.slot.clear();
    table.slot.resize(n_faces);
  }
  table.resize(0, bary, map);
}

// by_slot: finds the faces rows [j0, j1) of triangle_id show (each run of
// one id looked up once) and prepares those not found before.
void prepare_band(const ShadingInput& in, const int32_t* triangle_id, FaceTable& table, bool bary,
                  bool map, int j0, int j1) {
  if (!table.by_slot) return;
  Buffer<int32_t>& list = table.found;
  std::vector<uint64_t>& seen = table.seen;
  const size_t first = list.size();
  // (room for a new face per pixel and one more write; cut below)
  list.resize(first + size_t(in.width) * size_t(j1 - j0) + 1);
  size_t found = first;
  // A face seen for the first time is the next row: list[found] is
  // written for every run of one id, and kept (found advances) only on
  // the face's first sight -- no branch on it.
  auto sight = [&](int32_t face) {
    uint64_t& word = seen[size_t(face) >> 6];
    const uint64_t bit = uint64_t(1) << (face & 63);
    list[found] = face;
    found += (word & bit) == 0;
    word |= bit;
  };
  for (int j = j0; j < j1; ++j)
    sight_runs(triangle_id + size_t(j) * in.id_pitch(), size_t(in.width), sight);
  list.resize(found);
  for (size_t i = first; i < found; ++i) table.slot[size_t(list[i])] = int32_t(i);
  table.grow(found, bary, map);
  prepare_rows(in, table, first, found, bary, map);
}

// Rows a band holds: the passes prepare the faces of a band of rows, then
// shade it.
constexpr int kBand = 16;

// The calling thread's table, prepared for one pass and trimmed after it.
struct PreparedTable {
  FaceTable& table;
  PreparedTable(const ShadingInput& in, const int32_t* triangle_id, bool bary, bool map)
      : table(local()), in_(in), ids_(triangle_id), bary_(bary), map_(map) {
    begin_table(in, table, bary, map);
  }
  // Before shading rows [j0, j1): the faces they show prepared.
  void band(int j0, int j1) { prepare_band(in_, ids_, table, bary_, map_, j0, j1); }
  ~PreparedTable() { table.trim(); }
  PreparedTable(const PreparedTable&) = delete;
  PreparedTable& operator=(const PreparedTable&) = delete;
  static FaceTable& local() {
    thread_local FaceTable t;
    return t;
  }

 private:
  const ShadingInput& in_;
  const int32_t* ids_;
  bool bary_, map_;
};

#endif

#ifdef ZBUFFER_AVX2
// Vertex colours as float32 structure of arrays (component c of vertex v
// at c * n + v), for the AVX2 pass's gathers.
std::vector<float> components(const float* values, size_t n) {
  std::vector<float> out(3 * n);
  for (size_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) out[c * n + v] = values[3 * v + c];
  return out;
}
#endif

#ifdef ZBUFFER_AVX512

// Pack 16 colours 0x00BBGGRR into 48 bytes R G B R G B ... and store them.
inline void store_rgb16(uint8_t* out, __m512i rgba, __mmask16 lanes) {
  // Within each 128-bit lane: the 12 colour bytes first, then padding.
  const __m512i bytes = _mm512_set4_epi32(-1, 0x0E0D0C0A, 0x09080605, 0x04020100);
  const __m512i packed = _mm512_shuffle_epi8(rgba, bytes);
  // Then the three useful dwords of each 128-bit lane next to each other.
  const __m512i dwords = _mm512_set_epi32(15, 15, 15, 15, 14, 13, 12, 10, 9, 8, 6, 5, 4, 2, 1, 0);
  const __m512i line = _mm512_permutexvar_epi32(dwords, packed);
  // 16 lanes: the 48 bytes as 32 + 16, unmasked. (A byte-masked store of
  // them, as below, made smooth shading 1.04-1.05x and flat shading
  // 1.08x as slow on the benchmark machine; one unmasked 64-byte store,
  // its last 16 bytes overwritten by the next step, 1.01-1.05x as slow as
  // these two: benchmarks/README.md.)
  if (lanes == 0xFFFF) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), _mm512_castsi512_si256(line));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 32), _mm512_extracti32x4_epi32(line, 2));
    return;
  }
  // Fewer: a byte mask of the first 3 * count bytes.
  const int count = 32 - __builtin_clz(uint32_t(lanes) | 1u);  // lanes are a prefix
  const __mmask64 keep = count >= 16 ? __mmask64(0xFFFFFFFFFFFFull) : ((__mmask64(1) << (3 * count)) - 1);
  _mm512_mask_storeu_epi8(out, keep, line);
}

inline __m512i to_bytes(__m512 c) {  // floor(clamp(c, 0, 1) * 255 + 0.5)
  const __m512 v = _mm512_min_ps(_mm512_max_ps(c, _mm512_setzero_ps()), _mm512_set1_ps(1.0f));
  return _mm512_cvtps_epi32(_mm512_roundscale_ps(
      _mm512_add_ps(_mm512_mul_ps(v, _mm512_set1_ps(255.0f)), _mm512_set1_ps(0.5f)),
      _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC));
}

// The barycentrics of 16 pixel centres (NDC xn, yn) from their faces'
// coefficients: normalised and clamped into the triangle as the scalar
// pass's clamped_barycentrics does, a third each where they cannot be had.
inline void clamped_barycentrics16(const __m512* coef, __m512 xn, __m512 yn, __m512 b[3]) {
  const __m512 one = _mm512_set1_ps(1.0f);
  for (int k = 0; k < 3; ++k)
    b[k] = _mm512_add_ps(
        _mm512_add_ps(_mm512_mul_ps(coef[3 * k], xn), _mm512_mul_ps(coef[3 * k + 1], yn)),
        coef[3 * k + 2]);
  const __m512 sum = _mm512_add_ps(_mm512_add_ps(b[0], b[1]), b[2]);
  constexpr int kNanOrInfOrZero = 0x01 | 0x80 | 0x08 | 0x10 | 0x02 | 0x04;
  const __mmask16 bad = _mm512_fpclass_ps_mask(sum, kNanOrInfOrZero);
  const __m512 inv = _mm512_div_ps(one, sum);
  for (int k = 0; k < 3; ++k)
    b[k] = _mm512_min_ps(_mm512_max_ps(_mm512_mul_ps(b[k], inv), _mm512_setzero_ps()), one);
  const __m512 inv_total = _mm512_div_ps(one, _mm512_add_ps(_mm512_add_ps(b[0], b[1]), b[2]));
  for (int k = 0; k < 3; ++k)
    b[k] = _mm512_mask_mov_ps(_mm512_mul_ps(b[k], inv_total), bad, _mm512_set1_ps(1.0f / 3.0f));
}

// One pass per kind of shading (smooth normals, per-vertex colours), so
// that each keeps in registers only the fields it reads.
template <bool smooth, bool per_vertex>
void shade_pass_avx512(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image) {
  constexpr bool interpolated = smooth || per_vertex;
  constexpr int kRowFloats = FaceTable::row_floats_for(per_vertex, smooth);
  constexpr int kMapAt = FaceTable::map_at_for(per_vertex);
  PreparedTable prepared(in, triangle_id, per_vertex, smooth);
  FaceTable& table = prepared.table;
  size_t n_exact_steps = 0;
  if (interpolated) table.reserve_steps(in.width, 16);  // (faces are found band by band)

  const float half_w = float(0.5 * in.width), half_h = float(0.5 * in.height);
  // x of each column's pixel centres in NDC (and 16 spare entries).
  std::vector<float> xn_row(size_t(in.width) + 16);
  for (size_t i = 0; i < xn_row.size(); ++i) xn_row[i] = (float(i) + 0.5f) / half_w - 1.0f;
  const __m512i zero = _mm512_setzero_si512();
  const int32_t bg = int32_t(in.background[0]) | (int32_t(in.background[1]) << 8) |
                     (int32_t(in.background[2]) << 16);
  const __m512i background = _mm512_set1_epi32(bg);
  const __m512 lx = _mm512_set1_ps(float(-in.light_dir[0]));
  const __m512 ly = _mm512_set1_ps(float(-in.light_dir[1]));
  const __m512 lz = _mm512_set1_ps(float(-in.light_dir[2]));
  const __m512 ambient = _mm512_set1_ps(float(in.ambient));
  const __m512 diffuse = _mm512_set1_ps(float(in.diffuse));
  const __m512 one = _mm512_set1_ps(1.0f);
  auto fields_of = [&](int32_t face) {
    return table.rows.data() + size_t(kRowFloats) * size_t(table.row(face));
  };
  // a x + b y + c, each lane with its own coefficients
  auto affine = [](const __m512* abc, __m512 x, __m512 y) {
    return _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(abc[0], x), _mm512_mul_ps(abc[1], y)), abc[2]);
  };

  for (int j = 0; j < in.height; ++j) {
    if (j % kBand == 0) prepared.band(j, std::min(j + kBand, in.height));
    const int32_t* ids = triangle_id + size_t(j) * in.id_pitch();
    uint8_t* row = image + 3 * size_t(j) * size_t(in.width);
    const __m512 yn = _mm512_set1_ps(1.0f - (float(j) + 0.5f) / half_h);
    for (int i = 0; i < in.width; i += 16) {
      const __mmask16 valid =
          in.width - i >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (in.width - i)) - 1);
      const __m512i f = _mm512_maskz_loadu_epi32(valid, ids + i);
      const __mmask16 drawn = _mm512_mask_cmpge_epi32_mask(valid, f, zero);
      __m512i rgba = background;
      if constexpr (!interpolated) {
        if (drawn == 0xFFFF) {
          // A step of faces only: each lane's colour by loads (simd.h's
          // corner_pairs4 on why not gathers).
          rgba = simd::ints16([&](int k) { return table.rgb[size_t(table.row(ids[i + k]))]; });
        } else if (drawn) {
          const __m512i row =
              table.by_slot ? _mm512_mask_i32gather_epi32(zero, drawn, f, table.slot.data(), 4) : f;
          rgba = _mm512_mask_i32gather_epi32(background, drawn, row, table.rgb.data(), 4);
        }
      } else if (drawn) {
        // Each lane's face data, run by run: 16 neighbouring pixels show
        // few faces (a triangle covers runs of pixels), and a masked
        // broadcast per run and field costs far less than a gather per
        // field (about one element a cycle on the benchmark machine).
        __m512 coef[9], normal_map[9], n[3], corner_c[3][3], albedo[3];
        auto zeros = [](auto& regs) {
          for (__m512& v : regs) v = _mm512_setzero_ps();
        };
        zeros(n);
        if constexpr (per_vertex) {
          zeros(coef);
          for (auto& corner : corner_c) zeros(corner);
        }
        if constexpr (smooth) zeros(normal_map);
        for (int c = 0; c < 3; ++c) albedo[c] = _mm512_set1_ps(in.uniform_color[c]);
        // Run by run (a run: neighbouring lanes of one id), its lanes
        // known from the bits alone -- no compare waits on the last face.
        // Faces left to the scalar way (FaceShade::exact). (16 bits: as an
        // unsigned, GCC 12 under the sanitizers stored the mask assigned
        // to it below as 16 of its 32 bits, the rest stale.)
        __mmask16 exact_lanes = 0;
        // Smooth shading of a step of faces only (uniform colour): each
        // lane's row in one load, the 16 rows transposed into fields.
        const bool whole_rows = smooth && !per_vertex && drawn == 0xFFFF &&
                                in.color_source != ColorSource::kPerFace;
        if constexpr (smooth && !per_vertex) {
          static_assert(kRowFloats == 16, "a row is one vector");
          if (whole_rows) {
            __m512 field[16];
            for (int k = 0; k < 16; ++k) field[k] = _mm512_loadu_ps(fields_of(ids[i + k]));
            simd::transpose16(field);
            for (int c = 0; c < 9; ++c) normal_map[c] = field[kMapAt + c];
            exact_lanes = _mm512_cmpneq_epi32_mask(_mm512_castps_si512(field[FaceTable::kExact]), zero);
          }
        }
        const unsigned change =
            unsigned(_mm512_cmpneq_epi32_mask(f, _mm512_alignr_epi32(f, f, 15))) | 0x10001u;
        for (unsigned starts = whole_rows ? 0u : change & drawn; starts; starts &= starts - 1) {
          const unsigned s = unsigned(__builtin_ctz(starts));
          const unsigned after = change & ~((2u << s) - 1);  // the next run's start, or bit 16
          const __mmask16 same = __mmask16(((after & (0u - after)) - (1u << s)) & drawn);
          const int32_t face = ids[i + s];
          auto put = [&](__m512& reg, float v) { reg = _mm512_mask_mov_ps(reg, same, _mm512_set1_ps(v)); };
          const float* fields = fields_of(face);
          // (Smooth shading looks the flat normal up below, for the rare
          // pixel whose interpolated normal vanishes.)
          if constexpr (smooth)
            for (int c = 0; c < 9; ++c) put(normal_map[c], fields[kMapAt + c]);
          else
            for (int c = 0; c < 3; ++c) put(n[c], fields[FaceTable::kNormal + c]);
          exact_lanes |= __mmask16(same & (0u - unsigned(table.exact_face(fields) != nullptr)));
          if constexpr (per_vertex) {
            for (int c = 0; c < 9; ++c) put(coef[c], fields[FaceTable::kBary + c]);
            const int32_t* idx = in.mesh.faces + 3 * int64_t(face);
            for (int k = 0; k < 3; ++k)
              for (int c = 0; c < 3; ++c)
                put(corner_c[k][c], in.colors[3 * size_t(idx[k]) + size_t(c)]);
          }
          if (in.color_source == ColorSource::kPerFace)
            for (int c = 0; c < 3; ++c) put(albedo[c], in.colors[3 * int64_t(face) + c]);
        }
        const __m512 xn = _mm512_loadu_ps(xn_row.data() + i);

        // Normal: flat, or interpolated (FaceShade::normal_map) and normalised.
        if constexpr (smooth) {
          __m512 ns[3];
          for (int c = 0; c < 3; ++c) ns[c] = affine(normal_map + 3 * c, xn, yn);
          const __m512 len2 = _mm512_add_ps(
              _mm512_add_ps(_mm512_mul_ps(ns[0], ns[0]), _mm512_mul_ps(ns[1], ns[1])),
              _mm512_mul_ps(ns[2], ns[2]));
          const __mmask16 usable = _mm512_cmp_ps_mask(len2, _mm512_setzero_ps(), _CMP_GT_OQ);
          const __m512 scale = _mm512_div_ps(one, _mm512_sqrt_ps(len2));
          for (int c = 0; c < 3; ++c) n[c] = _mm512_mul_ps(ns[c], scale);
          for (unsigned l = drawn & ~usable; l; l &= l - 1) {  // the flat normal there
            const int k = __builtin_ctz(l);
            const float* fields = fields_of(ids[i + k]);
            for (int c = 0; c < 3; ++c)
              n[c] = _mm512_mask_mov_ps(n[c], __mmask16(1u << k), _mm512_set1_ps(fields[FaceTable::kNormal + c]));
          }
        }
        if (exact_lanes) {  // shaded again after the row
          uint32_t* step = table.exact_steps.data() + 3 * n_exact_steps++;
          step[0] = uint32_t(j);
          step[1] = uint32_t(i);
          step[2] = exact_lanes;
        }
        const __m512 ndotl = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(n[0], lx), _mm512_mul_ps(n[1], ly)), _mm512_mul_ps(n[2], lz));
        const __m512 intensity =
            _mm512_add_ps(ambient, _mm512_mul_ps(diffuse, _mm512_max_ps(ndotl, _mm512_setzero_ps())));

        // Albedo: per-vertex colours by the barycentrics at the pixel
        // centres, normalised and clamped.
        if constexpr (per_vertex) {
          __m512 b[3];
          clamped_barycentrics16(coef, xn, yn, b);
          for (int c = 0; c < 3; ++c) {
            albedo[c] = _mm512_setzero_ps();
            for (int k = 0; k < 3; ++k)
              albedo[c] = _mm512_add_ps(albedo[c], _mm512_mul_ps(b[k], corner_c[k][c]));
          }
        }
        __m512i channel[3];
        for (int c = 0; c < 3; ++c) channel[c] = to_bytes(_mm512_mul_ps(albedo[c], intensity));
        const __m512i colour = _mm512_or_si512(
            channel[0], _mm512_or_si512(_mm512_slli_epi32(channel[1], 8),
                                        _mm512_slli_epi32(channel[2], 16)));
        rgba = _mm512_mask_mov_epi32(background, drawn, colour);
      }
      store_rgb16(row + 3 * size_t(i), rgba, valid);
    }
    if (n_exact_steps) {
      finish_exact(in, table, triangle_id, image, n_exact_steps);
      n_exact_steps = 0;
    }
  }
}

void shade_avx512(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image) {
  const bool smooth = in.vertex_normals != nullptr;
  const auto pass = in.color_source == ColorSource::kPerVertex
                        ? (smooth ? shade_pass_avx512<true, true> : shade_pass_avx512<false, true>)
                        : (smooth ? shade_pass_avx512<true, false> : shade_pass_avx512<false, false>);
  pass(in, triangle_id, image);
}

#endif

#ifdef ZBUFFER_AVX2

inline __m256i to_bytes8(__m256 c) {  // floor(clamp(c, 0, 1) * 255 + 0.5)
  const __m256 v = _mm256_min_ps(_mm256_max_ps(c, _mm256_setzero_ps()), _mm256_set1_ps(1.0f));
  return _mm256_cvtps_epi32(_mm256_floor_ps(
      _mm256_add_ps(_mm256_mul_ps(v, _mm256_set1_ps(255.0f)), _mm256_set1_ps(0.5f))));
}

// clamped_barycentrics16 for 8 pixels.
inline void clamped_barycentrics8(const __m256* coef, __m256 xn, __m256 yn, __m256 b[3]) {
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  for (int k = 0; k < 3; ++k)
    b[k] = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(coef[3 * k], xn), _mm256_mul_ps(coef[3 * k + 1], yn)),
        coef[3 * k + 2]);
  const __m256 sum = _mm256_add_ps(_mm256_add_ps(b[0], b[1]), b[2]);
  const __m256 abs_sum = _mm256_and_ps(sum, _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF)));
  const __m256 bad = _mm256_or_ps(
      _mm256_or_ps(_mm256_cmp_ps(sum, sum, _CMP_UNORD_Q),  // NaN
                   _mm256_cmp_ps(abs_sum, _mm256_set1_ps(std::numeric_limits<float>::infinity()),
                                 _CMP_EQ_OQ)),
      _mm256_cmp_ps(sum, zero, _CMP_EQ_OQ));
  const __m256 inv = _mm256_div_ps(one, sum);
  for (int k = 0; k < 3; ++k) b[k] = _mm256_min_ps(_mm256_max_ps(_mm256_mul_ps(b[k], inv), zero), one);
  const __m256 inv_total = _mm256_div_ps(one, _mm256_add_ps(_mm256_add_ps(b[0], b[1]), b[2]));
  for (int k = 0; k < 3; ++k)
    b[k] = _mm256_blendv_ps(_mm256_mul_ps(b[k], inv_total), _mm256_set1_ps(1.0f / 3.0f), bad);
}

// The AVX-512 pass above, 8 pixels per step; lane masks are vectors. One
// pass per kind of shading, so that each keeps in registers only the
// fields it reads (AVX2 has 16 of them).
template <bool smooth, bool per_vertex>
void shade_pass_avx2(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image) {
  constexpr bool interpolated = smooth || per_vertex;
  constexpr int kRowFloats = FaceTable::row_floats_for(per_vertex, smooth);
  constexpr int kMapAt = FaceTable::map_at_for(per_vertex);
  PreparedTable prepared(in, triangle_id, per_vertex, smooth);
  FaceTable& table = prepared.table;
  size_t n_exact_steps = 0;
  if (interpolated) table.reserve_steps(in.width, 8);
  const size_t nv = size_t(in.mesh.n_vertices);
  const std::vector<float> vc = per_vertex ? components(in.colors, nv) : std::vector<float>();

  const float half_w = float(0.5 * in.width), half_h = float(0.5 * in.height);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 lanes_f = _mm256_cvtepi32_ps(lane);
  const __m256i lane_bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  const __m256i zero = _mm256_setzero_si256();
  const __m256 zero_f = _mm256_setzero_ps();
  const int32_t bg = int32_t(in.background[0]) | (int32_t(in.background[1]) << 8) |
                     (int32_t(in.background[2]) << 16);
  const __m256i background = _mm256_set1_epi32(bg);
  const __m256 lx = _mm256_set1_ps(float(-in.light_dir[0]));
  const __m256 ly = _mm256_set1_ps(float(-in.light_dir[1]));
  const __m256 lz = _mm256_set1_ps(float(-in.light_dir[2]));
  const __m256 ambient = _mm256_set1_ps(float(in.ambient));
  const __m256 diffuse = _mm256_set1_ps(float(in.diffuse));
  const __m256 one = _mm256_set1_ps(1.0f);
  // Pack 8 colours 0x00BBGGRR into 24 bytes R G B R G B ...: 12 bytes per
  // 128-bit half, then both halves through a small buffer.
  const __m256i rgb_bytes = _mm256_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1,
                                             0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1);
  auto fields_of = [&](int32_t face) {
    return table.rows.data() + size_t(kRowFloats) * size_t(table.row(face));
  };

  for (int j = 0; j < in.height; ++j) {
    if (j % kBand == 0) prepared.band(j, std::min(j + kBand, in.height));
    const int32_t* ids = triangle_id + size_t(j) * in.id_pitch();
    uint8_t* row = image + 3 * size_t(j) * size_t(in.width);
    const __m256 yn = _mm256_set1_ps(1.0f - (float(j) + 0.5f) / half_h);
    for (int i = 0; i < in.width; i += 8) {
      const int count = std::min(8, in.width - i);
      const __m256i valid = _mm256_cmpgt_epi32(_mm256_set1_epi32(count), lane);
      const __m256i f = _mm256_maskload_epi32(ids + i, valid);
      const __m256i drawn = _mm256_and_si256(valid, _mm256_cmpgt_epi32(f, _mm256_set1_epi32(-1)));
      const __m256 drawn_f = _mm256_castsi256_ps(drawn);
      const unsigned drawn_bits = unsigned(_mm256_movemask_ps(drawn_f));
      __m256i rgba = background;
      if constexpr (!interpolated) {
        if (drawn_bits == 0xFF) {  // faces only: by loads, as in shade_pass_avx512
          rgba = simd::ints8([&](int k) { return table.rgb[size_t(table.row(ids[i + k]))]; });
        } else if (drawn_bits) {
          // Each lane's row of the table, and its colour.
          const __m256i r = table.by_slot
                                ? _mm256_mask_i32gather_epi32(zero, table.slot.data(), f, drawn, 4)
                                : f;
          rgba = _mm256_mask_i32gather_epi32(background, table.rgb.data(), r, drawn, 4);
        }
      } else if (drawn_bits) {
        auto gather = [&](const float* base, __m256i index, __m256 fallback) {
          return _mm256_mask_i32gather_ps(fallback, base, index, drawn_f, 4);
        };
        // Each lane's fields, run by run (neighbouring lanes of one id; as
        // in the AVX-512 pass): broadcast and blended into the run's lanes,
        // where a gather per field costs more (far more on Zen, and on
        // Intel cores with the gather data sampling fix). Smooth shading
        // leaves out the flat normal: it is looked up below for the rare
        // pixel whose interpolated normal vanishes.
        __m256 coef[9], normal_map[9], flat[3];
        unsigned exact_lanes = 0;  // faces left to the scalar way (FaceShade::exact)
        if constexpr (per_vertex)
          for (auto& v : coef) v = zero_f;
        if constexpr (smooth)
          for (auto& v : normal_map) v = zero_f;
        else
          for (auto& v : flat) v = zero_f;
        // Smooth shading of a step of faces only (uniform colour): each
        // lane's row in two loads, transposed into fields (as in the
        // AVX-512 pass).
        const bool whole_rows = smooth && !per_vertex && drawn_bits == 0xFFu &&
                                in.color_source != ColorSource::kPerFace;
        if constexpr (smooth && !per_vertex) {
          static_assert(kRowFloats == 16 && kMapAt == 0, "a row is two vectors, the map first");
          if (whole_rows) {
            __m256 low[8], high[8];  // fields 0-7 and 8-15
            for (int k = 0; k < 8; ++k) {
              const float* fields = fields_of(ids[i + k]);
              low[k] = _mm256_loadu_ps(fields);
              high[k] = _mm256_loadu_ps(fields + 8);
            }
            simd::transpose8(low);
            simd::transpose8(high);
            for (int c = 0; c < 9; ++c) normal_map[c] = c < 8 ? low[c] : high[c - 8];
            exact_lanes = 0xFFu & ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(
                                   _mm256_castps_si256(high[FaceTable::kExact - 8]), _mm256_setzero_si256()))));
          }
        }
        if (!whole_rows) {
          const __m256i before =
              _mm256_permutevar8x32_epi32(f, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6));
          const unsigned same_as_before =
              unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(f, before))));
          const unsigned change = (~same_as_before & 0xFFu) | 0x101u;
          for (unsigned starts = change & drawn_bits; starts; starts &= starts - 1) {
            const unsigned s = unsigned(__builtin_ctz(starts));
            const unsigned after = change & ~((2u << s) - 1);  // the next run's start, or bit 8
            const unsigned run = ((after & (0u - after)) - (1u << s)) & drawn_bits;
            const __m256 in_run = _mm256_castsi256_ps(_mm256_cmpeq_epi32(
                _mm256_and_si256(_mm256_set1_epi32(int32_t(run)), lane_bit), lane_bit));
            const float* fields = fields_of(ids[i + s]);
            auto put = [&](__m256& reg, float v) { reg = _mm256_blendv_ps(reg, _mm256_set1_ps(v), in_run); };
            if constexpr (per_vertex)
              for (int c = 0; c < 9; ++c) put(coef[c], fields[FaceTable::kBary + c]);
            if constexpr (smooth)
              for (int c = 0; c < 9; ++c) put(normal_map[c], fields[kMapAt + c]);
            else
              for (int c = 0; c < 3; ++c) put(flat[c], fields[FaceTable::kNormal + c]);
            exact_lanes |= run & (0u - unsigned(table.exact_face(fields) != nullptr));
          }
        }
        const __m256 xn = _mm256_sub_ps(
            _mm256_div_ps(_mm256_add_ps(_mm256_add_ps(_mm256_set1_ps(float(i)), lanes_f),
                                        _mm256_set1_ps(0.5f)),
                          _mm256_set1_ps(half_w)),
            one);
        // a x + b y + c, each lane with its own coefficients
        auto affine = [&](const __m256* abc) {
          return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(abc[0], xn), _mm256_mul_ps(abc[1], yn)),
                               abc[2]);
        };

        // Normal: flat, or interpolated (FaceShade::normal_map) and normalised.
        __m256 n[3];
        if constexpr (smooth) {
          __m256 ns[3];
          for (int c = 0; c < 3; ++c) ns[c] = affine(normal_map + 3 * c);
          const __m256 len2 = _mm256_add_ps(
              _mm256_add_ps(_mm256_mul_ps(ns[0], ns[0]), _mm256_mul_ps(ns[1], ns[1])),
              _mm256_mul_ps(ns[2], ns[2]));
          const __m256 usable = _mm256_cmp_ps(len2, zero_f, _CMP_GT_OQ);
          const __m256 scale = _mm256_div_ps(one, _mm256_sqrt_ps(len2));
          for (int c = 0; c < 3; ++c) n[c] = _mm256_mul_ps(ns[c], scale);
          const unsigned flat_lanes = unsigned(_mm256_movemask_ps(_mm256_andnot_ps(usable, drawn_f)));
          if (flat_lanes) {  // the flat normal where the interpolated one vanishes
            alignas(32) float lanes[3][8];
            for (int c = 0; c < 3; ++c) _mm256_store_ps(lanes[c], n[c]);
            for (unsigned l = flat_lanes; l; l &= l - 1) {
              const int k = __builtin_ctz(l);
              for (int c = 0; c < 3; ++c) lanes[c][k] = fields_of(ids[i + k])[FaceTable::kNormal + c];
            }
            for (int c = 0; c < 3; ++c) n[c] = _mm256_load_ps(lanes[c]);
          }
        } else {
          for (int c = 0; c < 3; ++c) n[c] = flat[c];
        }
        if (exact_lanes) {  // shaded again after the row
          uint32_t* step = table.exact_steps.data() + 3 * n_exact_steps++;
          step[0] = uint32_t(j);
          step[1] = uint32_t(i);
          step[2] = exact_lanes;
        }
        const __m256 ndotl = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(n[0], lx), _mm256_mul_ps(n[1], ly)), _mm256_mul_ps(n[2], lz));
        const __m256 intensity =
            _mm256_add_ps(ambient, _mm256_mul_ps(diffuse, _mm256_max_ps(ndotl, zero_f)));

        // Albedo: per-vertex colours by the barycentrics at the pixel
        // centres, normalised and clamped.
        __m256 b[3];
        __m256i vid[3];  // each lane's corners
        const __m256i f3 = _mm256_mullo_epi32(f, _mm256_set1_epi32(3));
        if constexpr (per_vertex) {
          clamped_barycentrics8(coef, xn, yn, b);
          for (int k = 0; k < 3; ++k)
            vid[k] = _mm256_mask_i32gather_epi32(zero, in.mesh.faces,
                                                 _mm256_add_epi32(f3, _mm256_set1_epi32(k)), drawn, 4);
        }
        __m256i channel[3];
        for (int c = 0; c < 3; ++c) {
          __m256 albedo;
          if constexpr (per_vertex) {
            const float* comp = vc.data() + size_t(c) * nv;
            albedo = zero_f;
            for (int k = 0; k < 3; ++k)
              albedo = _mm256_add_ps(albedo, _mm256_mul_ps(b[k], gather(comp, vid[k], zero_f)));
          } else if (in.color_source == ColorSource::kPerFace) {
            albedo = gather(in.colors, _mm256_add_epi32(f3, _mm256_set1_epi32(c)), zero_f);
          } else {
            albedo = _mm256_set1_ps(in.uniform_color[c]);
          }
          channel[c] = to_bytes8(_mm256_mul_ps(albedo, intensity));
        }
        const __m256i colour = _mm256_or_si256(
            channel[0], _mm256_or_si256(_mm256_slli_epi32(channel[1], 8),
                                        _mm256_slli_epi32(channel[2], 16)));
        rgba = _mm256_blendv_epi8(background, colour, drawn);
      }
      alignas(32) uint8_t packed[32];
      _mm256_store_si256(reinterpret_cast<__m256i*>(packed), _mm256_shuffle_epi8(rgba, rgb_bytes));
      uint8_t* out = row + 3 * size_t(i);
      if (count == 8) {  // (copies of a constant size: a few moves, no call)
        std::memcpy(out, packed, 12);
        std::memcpy(out + 12, packed + 16, 12);
      } else {
        const int low = std::min(count, 4);
        std::memcpy(out, packed, 3 * size_t(low));
        if (count > 4) std::memcpy(out + 12, packed + 16, 3 * size_t(count - 4));
      }
    }
    if (n_exact_steps) {
      finish_exact(in, table, triangle_id, image, n_exact_steps);
      n_exact_steps = 0;
    }
  }
}

void shade_avx2(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image) {
  // The gathers index faces' corners and colours with int32 (3 f + c).
  if (in.mesh.n_faces > std::numeric_limits<int32_t>::max() / 3) {
    shade_scalar(in, triangle_id, image);
    return;
  }
  const bool smooth = in.vertex_normals != nullptr;
  const auto pass = in.color_source == ColorSource::kPerVertex
                        ? (smooth ? shade_pass_avx2<true, true> : shade_pass_avx2<false, true>)
                        : (smooth ? shade_pass_avx2<true, false> : shade_pass_avx2<false, false>);
  pass(in, triangle_id, image);
}

#endif

}  // namespace


void vertex_normals(const MeshView& mesh, double* out) {
  const size_t n = size_t(mesh.n_vertices);
  std::fill_n(out, 3 * n, 0.0);
  const double* p = mesh.positions;
  // Coordinates whose largest magnitude lies outside [2^-200, 2^200] are
  // scaled by the power of two that brings it into [1, 2) (exact, and the
  // same for every face: the same weights), so that the sums and their
  // squares neither overflow nor underflow; others are taken as they are.
  // Each coordinate is scaled by scalbn, not multiplied by 2^e: for a mesh
  // wholly below 2^-1023 (subnormal), 2^e itself would overflow to inf
  // (every normal came out zero, and smooth shading flat).
  double big = 0.0;
  for (size_t k = 0; k < 3 * n; ++k)
    if (std::isfinite(p[k])) big = std::max(big, std::abs(p[k]));
  const int e = big > 0.0 && (big < 0x1p-200 || big > 0x1p200) ? -std::ilogb(big) : 0;
  for (int corner = 0; corner < 3; ++corner)
    for (int64_t f = 0; f < mesh.n_faces; ++f) {
      const int32_t* idx = mesh.faces + 3 * f;
      const double* a = p + 3 * size_t(idx[0]);
      const double* b = p + 3 * size_t(idx[1]);
      const double* c = p + 3 * size_t(idx[2]);
      auto at = [e](const double* q, int k) { return e == 0 ? q[k] : std::scalbn(q[k], e); };
      const double u[3] = {at(b, 0) - at(a, 0), at(b, 1) - at(a, 1), at(b, 2) - at(a, 2)};
      const double v[3] = {at(c, 0) - at(a, 0), at(c, 1) - at(a, 1), at(c, 2) - at(a, 2)};
      double* sum = out + 3 * size_t(idx[corner]);
      sum[0] += u[1] * v[2] - u[2] * v[1];
      sum[1] += u[2] * v[0] - u[0] * v[2];
      sum[2] += u[0] * v[1] - u[1] * v[0];
    }
  for (size_t i = 0; i < n; ++i) {
    double* s = out + 3 * i;
    const double length = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    if (length > 0.0)
      for (int c = 0; c < 3; ++c) s[c] /= length;
    else
      s[0] = s[1] = s[2] = 0.0;
  }
}

}  // namespace zbuffer
