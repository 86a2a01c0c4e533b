// Lambert shading of a visibility result. See shading.h for the model.
#include "zbuffer/shading.h"

#include <algorithm>
#include <cmath>

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

// m * (x, y, z, 1), dehomogenised.
inline Vec3 unproject(const double* m, double x, double y, double z) {
  const double r[4] = {m[0] * x + m[1] * y + m[2] * z + m[3],
                       m[4] * x + m[5] * y + m[6] * z + m[7],
                       m[8] * x + m[9] * y + m[10] * z + m[11],
                       m[12] * x + m[13] * y + m[14] * z + m[15]};
  return {r[0] / r[3], r[1] / r[3], r[2] / r[3]};
}

inline uint8_t to_byte(double c) {
  return uint8_t(std::floor(std::min(1.0, std::max(0.0, c)) * 255.0 + 0.5));
}

}  // namespace

void shade(const ShadingInput& in, const int32_t* triangle_id, uint8_t* image) {
  const bool smooth = in.vertex_normals != nullptr;
  const bool need_bary = smooth || in.color_source == ColorSource::kPerVertex;
  const Vec3 to_light = -1.0 * load3(in.light_dir);
  const Vec3 viewer = load3(in.viewer);
  const double half_w = 0.5 * in.width, half_h = 0.5 * in.height;

  int32_t cached_id = -1;  // flat shading: neighbours share a face's colour
  uint8_t cached_rgb[3] = {0, 0, 0};

  for (int j = 0; j < in.height; ++j) {
    for (int i = 0; i < in.width; ++i) {
      const size_t p = size_t(j) * size_t(in.width) + size_t(i);
      uint8_t* out = image + 3 * p;
      const int32_t f = triangle_id[p];
      if (f < 0) {
        out[0] = in.background[0];
        out[1] = in.background[1];
        out[2] = in.background[2];
        continue;
      }
      if (!need_bary && f == cached_id) {
        out[0] = cached_rgb[0];
        out[1] = cached_rgb[1];
        out[2] = cached_rgb[2];
        continue;
      }

      // Face geometry and which side the viewer sees.
      const int32_t* idx = in.mesh.faces + 3 * int64_t(f);
      const Vec3 p0 = load3(in.mesh.positions + 3 * int64_t(idx[0]));
      const Vec3 e1 = load3(in.mesh.positions + 3 * int64_t(idx[1])) - p0;
      const Vec3 e2 = load3(in.mesh.positions + 3 * int64_t(idx[2])) - p0;
      const Vec3 ng = cross(e1, e2);
      const Vec3 to_viewer = viewer - in.viewer[3] * p0;
      const double side = dot(ng, to_viewer) < 0.0 ? -1.0 : 1.0;

      // Barycentrics of the view ray through the pixel centre (Moller-Trumbore),
      // clamped into the triangle: a snapped pixel centre may lie a hair outside.
      double b1 = 1.0 / 3.0, b2 = 1.0 / 3.0;
      if (need_bary) {
        const double xn = (i + 0.5) / half_w - 1.0;
        const double yn = 1.0 - (j + 0.5) / half_h;
        const Vec3 origin = unproject(in.inv_mvp, xn, yn, -1.0);
        const Vec3 dir = unproject(in.inv_mvp, xn, yn, 1.0) - origin;
        const Vec3 pvec = cross(dir, e2);
        const double det = dot(e1, pvec);
        if (det != 0.0 && std::isfinite(det)) {
          const double inv_det = 1.0 / det;
          const Vec3 tvec = origin - p0;
          b1 = dot(tvec, pvec) * inv_det;
          b2 = dot(dir, cross(tvec, e1)) * inv_det;
          b1 = std::min(1.0, std::max(0.0, b1));
          b2 = std::min(1.0, std::max(0.0, b2));
          if (b1 + b2 > 1.0) {
            const double s = 1.0 / (b1 + b2);
            b1 *= s;
            b2 *= s;
          }
        }
      }
      const double b0 = 1.0 - b1 - b2;

      // Normal, facing the viewer.
      Vec3 n = ng;
      if (smooth) {
        const Vec3 n0 = load3(in.vertex_normals + 3 * int64_t(idx[0]));
        const Vec3 n1 = load3(in.vertex_normals + 3 * int64_t(idx[1]));
        const Vec3 n2 = load3(in.vertex_normals + 3 * int64_t(idx[2]));
        const Vec3 ns = b0 * n0 + b1 * n1 + b2 * n2;
        if (dot(ns, ns) > 0.0) n = ns;
      }
      n = side * normalized(n);

      // Lambert.
      const double intensity =
          in.ambient + in.diffuse * std::max(0.0, dot(n, to_light));
      double albedo[3] = {0.0, 0.0, 0.0};
      for (int c = 0; c < 3; ++c) {
        switch (in.color_source) {
          case ColorSource::kUniform: albedo[c] = in.uniform_color[c]; break;
          case ColorSource::kPerFace: albedo[c] = in.colors[3 * int64_t(f) + c]; break;
          case ColorSource::kPerVertex:
            albedo[c] = b0 * in.colors[3 * int64_t(idx[0]) + c] +
                        b1 * in.colors[3 * int64_t(idx[1]) + c] +
                        b2 * in.colors[3 * int64_t(idx[2]) + c];
            break;
        }
      }
      for (int c = 0; c < 3; ++c) out[c] = to_byte(albedo[c] * intensity);
      cached_id = f;
      cached_rgb[0] = out[0];
      cached_rgb[1] = out[1];
      cached_rgb[2] = out[2];
    }
  }
}

}  // namespace zbuffer
