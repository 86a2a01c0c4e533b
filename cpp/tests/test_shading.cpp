// The shading pass: the vector pass agrees with the scalar one.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "../src/id_runs.h"
#include "check.h"
#include "zbuffer/algorithms.h"
#include "zbuffer/shading.h"

using namespace zbuffer;

namespace {

// A UV sphere of radius 1 at the origin, with unit vertex normals.
void sphere(int rings, int sectors, std::vector<double>& pos, std::vector<int32_t>& faces,
            std::vector<double>& normals) {
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s < sectors; ++s) {
      const double theta = M_PI * r / rings, phi = 2 * M_PI * s / sectors;
      const double p[3] = {std::sin(theta) * std::cos(phi), std::cos(theta),
                           std::sin(theta) * std::sin(phi)};
      for (double c : p) {
        pos.push_back(c);
        normals.push_back(c);
      }
    }
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < sectors; ++s) {
      const int a = r * sectors + s, b = r * sectors + (s + 1) % sectors;
      const int c = a + sectors, d = b + sectors;
      faces.insert(faces.end(), {a, c, d, a, d, b});
    }
}

// The ids the plain Z-buffer draws of `mesh` at w x h.
std::vector<int32_t> visible_ids(const MeshView& mesh, const double mvp[16], int w, int h) {
  RenderInput input;
  input.mesh = mesh;
  for (int k = 0; k < 16; ++k) input.mvp[k] = mvp[k];
  std::vector<float> depth(size_t(w) * h);
  std::vector<int32_t> ids(size_t(w) * h);
  DepthTarget target{depth.data(), ids.data(), w, h};
  RenderStats stats;
  render(*find_algorithm("zbuffer"), input, target, stats);
  CHECK(stats.pixels_written > 1000);
  return ids;
}

// A unit light direction.
void set_light(ShadingInput& in, double x, double y, double z) {
  const double len = std::sqrt(x * x + y * y + z * z);
  in.light_dir[0] = x / len;
  in.light_dir[1] = y / len;
  in.light_dir[2] = z / len;
}

// The largest difference of a channel between the vector pass and the
// scalar pass, shading ids.
int worst_difference(const ShadingInput& in, const std::vector<int32_t>& ids) {
  std::vector<uint8_t> fast(ids.size() * 3), slow(ids.size() * 3);
  shade(in, ids.data(), fast.data());
  shade_scalar(in, ids.data(), slow.data());
  int worst = 0;
  for (size_t k = 0; k < fast.size(); ++k) worst = std::max(worst, std::abs(int(fast[k]) - int(slow[k])));
  return worst;
}

struct Eye {
  double x, y, z, near, far;
};

// The vector pass prepares every face of a mesh with few faces for its
// image (at most a quarter of the pixels, 1/64 for interpolated shading),
// else only the faces it finds in the image: the sphere's 2,304 faces at
// 77 x 61 (found, either shading), 160 x 121 (all for flat, found for
// interpolated) and 400 x 400 (all). Flat colours from uniform or per-face
// colours are the same bytes; interpolated ones within one level.
// With zero_band, the vertex normals of rings 10-12 are zero (as where the
// faces around a vertex cancel out): smooth shading falls back to the flat
// normal on the faces between them.
// With a `scale` (a power of two), the sphere is that much larger and the
// camera with it (the same clip coordinates, bits and all): the images are
// returned, for the caller to hold to those at scale 1.
std::vector<std::vector<uint8_t>> test_vector_pass_matches_scalar_pass(
    int w, int h, Eye eye = {0, 0, 3, 1, 6}, bool zero_band = false, double scale = 1.0) {
  std::vector<std::vector<uint8_t>> images;
  std::vector<double> pos, normals;
  std::vector<int32_t> faces;
  sphere(24, 48, pos, faces, normals);
  if (zero_band) std::fill(normals.begin() + 10 * 48 * 3, normals.begin() + 13 * 48 * 3, 0.0);
  for (double& c : pos) c *= scale;
  const int n_faces = int(faces.size() / 3), n_vertices = int(pos.size() / 3);
  // Perspective camera at the eye looking down -z, 45 degrees, square
  // pixels in NDC: the projection times a translation by -eye.
  const double f = 1.0 / std::tan(M_PI / 8), n = eye.near, fa = eye.far;
  const double a = -(fa + n) / (fa - n), b = -2 * fa * n / (fa - n);
  const double mvp[16] = {f / scale, 0,         0,          -f * eye.x,
                          0,         f / scale, 0,          -f * eye.y,
                          0,         0,         a / scale,  b - a * eye.z,
                          0,         0,         -1 / scale, eye.z};
  const MeshView mesh{pos.data(), n_vertices, faces.data(), n_faces};
  const std::vector<int32_t> ids = visible_ids(mesh, mvp, w, h);

  std::vector<float> colors_v(size_t(n_vertices) * 3), colors_f(size_t(n_faces) * 3);
  for (size_t k = 0; k < colors_v.size(); ++k) colors_v[k] = float((k * 37) % 101) / 100.0f;
  for (size_t k = 0; k < colors_f.size(); ++k) colors_f[k] = float((k * 53) % 97) / 96.0f;
  for (int smooth = 0; smooth < 2; ++smooth)
    for (int source = 0; source < 3; ++source) {
      ShadingInput in;
      in.mesh = mesh;
      in.width = w;
      in.height = h;
      for (int k = 0; k < 16; ++k) in.mvp[k] = mvp[k];
      in.viewer[0] = eye.x * scale;
      in.viewer[1] = eye.y * scale;
      in.viewer[2] = eye.z * scale;
      in.viewer[3] = 1;
      set_light(in, 0.3, -0.5, -0.8);
      in.vertex_normals = smooth ? normals.data() : nullptr;
      in.color_source = ColorSource(source);
      in.colors = source == 1 ? colors_v.data() : source == 2 ? colors_f.data() : nullptr;
      CHECK(worst_difference(in, ids) <= (smooth == 0 && source != 1 ? 0 : 1));
      images.emplace_back(ids.size() * 3);
      shade(in, ids.data(), images.back().data());
    }
  return images;
}

// Coordinates near 1e-100 and 1e100: the face normals' squares would
// underflow and overflow (normals lost, ambient light only), so such faces
// are prepared from edges scaled by powers of two -- the same images as at
// scale 1, in the vector and the scalar pass alike.
void test_extreme_scales() {
  for (const double scale : {0x1p-330, 0x1p330})
    for (const int w : {77, 400}) {
      const auto one = test_vector_pass_matches_scalar_pass(w, w, {0, 0, 3, 1, 6});
      const auto far = test_vector_pass_matches_scalar_pass(w, w, {0, 0, 3, 1, 6}, false, scale);
      CHECK(one.size() == far.size());
      for (size_t k = 0; k < one.size() && k < far.size(); ++k) CHECK(one[k] == far[k]);
    }
}

// Faces that float32 gets wrong unless they are left to the scalar way
// (shading.cpp, FaceShade::exact): needles -- a long edge and a third
// corner a hair off it -- with random corner normals and colours (a covered
// pixel centre may lie outside such a triangle by more than its width,
// where the smooth normal map extrapolates, and at large sizes the
// barycentrics cancel in float32), and faces whose corners' normals are
// 120 degrees apart (they cancel inside the face). The vector pass must
// give the scalar pass's result within a level, smooth and with per-vertex
// colours, at two sizes.
void test_hard_faces_match_scalar_pass() {
  Lcg rng{20261125};
  std::vector<double> pos, normals;
  std::vector<float> colours;
  std::vector<int32_t> faces;
  auto corner = [&](double x, double y, double z, double nx, double ny, double nz) {
    const double len = std::sqrt(nx * nx + ny * ny + nz * nz);
    pos.insert(pos.end(), {x, y, z});
    normals.insert(normals.end(), {nx / len, ny / len, nz / len});
    for (int c = 0; c < 3; ++c) colours.push_back(float(rng.uniform(0.0, 1.0)));
    faces.push_back(int32_t(faces.size()));
  };
  for (int t = 0; t < 600; ++t) {
    const double x = rng.uniform(-0.9, 0.9), y = rng.uniform(-0.9, 0.9), z = rng.uniform(-0.5, 0.5);
    const double angle = rng.uniform(0.0, 2 * M_PI), length = rng.uniform(0.05, 0.4);
    const double dx = std::cos(angle), dy = std::sin(angle);
    const double off = rng.uniform(1e-5, 4e-3) * (rng(0, 1) ? 1.0 : -1.0);  // 0.001-0.4 px at 200 px
    const double along = rng.uniform(0.1, 0.9) * length;
    const double p[3][3] = {{x, y, z},
                            {x + length * dx, y + length * dy, z + rng.uniform(-0.1, 0.1)},
                            {x + along * dx - off * dy, y + along * dy + off * dx, z}};
    for (int k = 0; k < 3; ++k)
      corner(p[k][0], p[k][1], p[k][2], rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.2, 1));
  }
  for (int t = 0; t < 40; ++t) {
    const double x = rng.uniform(-0.9, 0.9), y = rng.uniform(-0.9, 0.9), r = rng.uniform(0.02, 0.1);
    const double spin = rng.uniform(0.0, 2 * M_PI), axial = rng.uniform(1e-4, 1e-2);
    for (int k = 0; k < 3; ++k) {
      const double a = spin + 2 * M_PI * k / 3;
      corner(x + r * std::cos(a), y + r * std::sin(a), 0.6, std::cos(a), std::sin(a), axial);
    }
  }
  const int n_faces = int(faces.size() / 3);
  const double mvp[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1};  // orthographic
  for (const int w : {200, 1600}) {
    const int h = w * 17 / 20;
    const MeshView mesh{pos.data(), int64_t(pos.size() / 3), faces.data(), n_faces};
    const std::vector<int32_t> ids = visible_ids(mesh, mvp, w, h);
    for (int mode = 0; mode < 3; ++mode) {  // smooth; smooth, per-vertex colours; per-vertex colours
      ShadingInput in;
      in.mesh = mesh;
      in.width = w;
      in.height = h;
      for (int k = 0; k < 16; ++k) in.mvp[k] = mvp[k];
      in.vertex_normals = mode < 2 ? normals.data() : nullptr;
      in.color_source = mode > 0 ? ColorSource::kPerVertex : ColorSource::kUniform;
      in.colors = mode > 0 ? colours.data() : nullptr;
      set_light(in, 0.2, 0.3, -0.9);
      const int worst = worst_difference(in, ids);
      CHECK(worst <= 1);
      if (worst > 1) std::printf("hard faces: %d x %d, mode %d: %d levels off\n", w, h, mode, worst);
    }
  }
}

// Area-weighted vertex normals: a closed sphere's lie along its radii (all
// one way: the faces' winding, inwards for this sphere) and have unit
// length; an unused vertex and a vertex only on a degenerate face get zero.
void test_vertex_normals() {
  std::vector<double> pos, exact;
  std::vector<int32_t> faces;
  sphere(24, 48, pos, faces, exact);
  const int64_t used = int64_t(pos.size() / 3);
  for (double c : {5.0, 5.0, 5.0, 7.0, 7.0, 7.0}) pos.push_back(c);  // two more vertices
  for (int k = 0; k < 3; ++k) faces.push_back(int32_t(used + 1));  // a degenerate face
  const MeshView mesh{pos.data(), int64_t(pos.size() / 3), faces.data(), int64_t(faces.size() / 3)};
  std::vector<double> normals(pos.size(), -1.0);
  vertex_normals(mesh, normals.data());
  double lowest = 1.0, highest = -1.0;
  for (int64_t v = 0; v < used; ++v) {
    const double* n = &normals[size_t(3 * v)];
    const double* e = &exact[size_t(3 * v)];
    CHECK(std::abs(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] - 1.0) < 1e-12);
    const double along = n[0] * e[0] + n[1] * e[1] + n[2] * e[2];
    lowest = std::min(lowest, along);
    highest = std::max(highest, along);
  }
  // (The poles: one face each, a few degrees off the axis.)
  CHECK((lowest > 0.99 && highest <= 1.0 + 1e-12) || (highest < -0.99 && lowest >= -1.0 - 1e-12));
  for (int64_t v = used; v < used + 2; ++v)
    for (int c = 0; c < 3; ++c) CHECK(normals[size_t(3 * v + c)] == 0.0);
}

}  // namespace

// id_run_starts (the face scan's and temporal coherence's) against its
// definition: rows of runs of random ids, -1 among them, every length from
// 0 to 70 (the vector loops' tails), with and without the id before the
// first continuing its run.
void test_id_run_starts() {
  Lcg rng{7};
  for (size_t count = 0; count <= 70; ++count)
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<int32_t> ids(count);
      int32_t id = -1;
      for (int32_t& x : ids) {
        if (rng(0, 9) < 4) id = rng(0, 9) < 3 ? -1 : int32_t(rng(0, 8));
        x = id;
      }
      const int32_t left = trial % 2 && count ? ids[0] : int32_t(trial % 3) - 1;
      std::vector<int32_t> expected, got(count + 16);
      int32_t previous = left;
      for (int32_t x : ids) {
        if (x != previous && x >= 0) expected.push_back(x);
        previous = x;
      }
      const size_t n = id_run_starts(ids.data(), count, left, got.data());
      got.resize(n);
      CHECK(got == expected);
    }
}

int main() {
  test_id_run_starts();
  test_vertex_normals();
  test_hard_faces_match_scalar_pass();
  test_vector_pass_matches_scalar_pass(77, 61);
  test_vector_pass_matches_scalar_pass(160, 121);
  test_vector_pass_matches_scalar_pass(400, 400);
  test_vector_pass_matches_scalar_pass(77, 61);  // tables kept from the frames before
  // From inside the sphere: every face seen from behind, and faces reaching
  // behind the camera (corners with w < 0), near and far.
  test_vector_pass_matches_scalar_pass(160, 121, {0.1, 0.2, 0.3, 0.05, 3.0});
  test_vector_pass_matches_scalar_pass(400, 400, {-0.2, 0.1, 0.0, 0.01, 3.0});
  test_vector_pass_matches_scalar_pass(77, 61, {0, 0, 3, 1, 6}, true);
  test_vector_pass_matches_scalar_pass(400, 400, {0, 0, 3, 1, 6}, true);
  test_extreme_scales();
  return check_report("test_shading");
}
