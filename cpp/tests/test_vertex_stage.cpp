// The vertex stage: snapping, outcodes, clipping and the triangle counters.
#include <cmath>
#include <cstring>
#include <vector>

#include "check.h"
#include "zbuffer/algorithms.h"
#include "zbuffer/vertex_stage.h"

using namespace zbuffer;

namespace {

// OpenGL perspective looking down -z from the origin.
void perspective(double fov_y_deg, double aspect, double n, double f, double* m) {
  const double t = 1.0 / std::tan(fov_y_deg * M_PI / 360.0);
  for (int k = 0; k < 16; ++k) m[k] = 0.0;
  m[0] = t / aspect;
  m[5] = t;
  m[10] = -(f + n) / (f - n);
  m[11] = -2.0 * f * n / (f - n);
  m[14] = -1.0;
}

bool counters_add_up(const RenderStats& s) {
  return s.triangles_in - s.culled_invalid - s.culled_frustum - s.clipped + s.clip_pieces ==
         s.culled_backface + s.culled_degenerate + s.culled_hidden + s.rasterized;
}

RenderStats render_faces(const std::vector<double>& pos, const std::vector<int32_t>& faces,
                         const double* mvp, int w, int h, std::vector<int32_t>& ids) {
  RenderInput in;
  in.mesh = {pos.data(), int64_t(pos.size() / 3), faces.data(), int64_t(faces.size() / 3)};
  for (int k = 0; k < 16; ++k) in.mvp[k] = mvp[k];
  std::vector<float> depth(size_t(w) * h);
  ids.assign(size_t(w) * h, 0);
  DepthTarget t{depth.data(), ids.data(), w, h};
  RenderStats stats;
  render(*find_algorithm("zbuffer"), in, t, stats);
  return stats;
}

// Window coordinates: NDC (0, 0) is the image centre, NDC y up is row 0 down.
void test_viewport_and_snap() {
  const Viewport vp(640, 480);
  const ScreenVertex c = to_screen({0.0, 0.0, 0.0, 1.0}, vp);
  CHECK(c.x_fx == 320 * 256 && c.y_fx == 240 * 256 && c.z == 0.5);
  const ScreenVertex top_left = to_screen({-1.0, 1.0, -1.0, 1.0}, vp);
  CHECK(top_left.x_fx == 0 && top_left.y_fx == 0 && top_left.z == 0.0);
  // Round half to even: with W = 512, x_ndc = 2^-17 - 1 lands exactly half a
  // sub-pixel step right of the edge (rounds down to 0), three halves rounds up to 2.
  const Viewport vp512(512, 512);
  CHECK(to_screen({std::ldexp(1.0, -17) - 1.0, 0.0, 0.0, 1.0}, vp512).x_fx == 0);
  CHECK(to_screen({3.0 * std::ldexp(1.0, -17) - 1.0, 0.0, 0.0, 1.0}, vp512).x_fx == 2);
}

void test_outcodes() {
  const Viewport vp(100, 100);
  CHECK(outcode({0, 0, 0, 1}, vp) == 0);
  CHECK(outcode({2, 0, 0, 1}, vp) == kOutRight);
  CHECK(outcode({0, 0, -2, 1}, vp) == kOutNear);
  CHECK((outcode({0, 0, 0, -1}, vp) & kOutNear) != 0);  // behind the eye
  CHECK(outcode({3000, 0, 0, 1}, vp) == (kOutRight | kOutGuardRight));
  CHECK(outcode({INFINITY, 0, 0, 1}, vp) == kOutInvalid);
}

// A triangle through the near plane is clipped, not dropped; one behind the
// camera is culled; one far to the side is culled.
void test_near_clipping() {
  double m[16];
  perspective(60.0, 1.0, 0.5, 10.0, m);
  const std::vector<double> pos = {
      -1, -1, 1,  1, -1, -3,  0, 1, -3,     // crosses the near plane (z=-0.5)
      -1, -1, 2,  1, -1, 2,   0, 1, 2,      // behind the camera
      50, 0, -3,  52, 0, -3,  51, 1, -3,    // far to the right
  };
  const std::vector<int32_t> faces = {0, 1, 2, 3, 4, 5, 6, 7, 8};
  std::vector<int32_t> ids;
  const RenderStats s = render_faces(pos, faces, m, 64, 64, ids);
  CHECK(s.triangles_in == 3);
  CHECK(s.clipped == 1);
  CHECK(s.clip_pieces >= 1);
  CHECK(s.culled_frustum == 2);
  CHECK(counters_add_up(s));
  int64_t drawn = 0;
  for (int32_t id : ids) {
    CHECK(id == -1 || id == 0);  // pieces keep the input face's id
    drawn += id == 0;
  }
  CHECK(drawn > 0);
}

// The camera inside a closed box sees the inside of every wall.
void test_camera_inside_box() {
  double m[16];
  perspective(90.0, 1.0, 0.1, 100.0, m);
  std::vector<double> pos;
  for (int k = 0; k < 8; ++k) {
    pos.push_back(k & 1 ? 1.0 : -1.0);
    pos.push_back(k & 2 ? 1.0 : -1.0);
    pos.push_back(k & 4 ? 1.0 : -1.0);
  }
  const std::vector<int32_t> faces = {0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
                                      2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3};
  std::vector<int32_t> ids;
  const RenderStats s = render_faces(pos, faces, m, 32, 32, ids);
  CHECK(counters_add_up(s));
  for (int32_t id : ids) CHECK(id >= 0);  // no hole anywhere
}

// The vector vertex stage (8 at a time) equals the scalar formulas, vertex by
// vertex, including vertices that need clipping or overflow.
void test_transform_vertices_matches_scalar_formulas() {
  double m[16];
  perspective(70.0, 1.3, 0.3, 50.0, m);
  m[3] = 0.25;  // some translation
  m[7] = -0.5;
  std::vector<double> pos;
  uint64_t seed = 99;
  auto next = [&seed]() {
    seed = seed * 6364136223846793005ull + 1442695040888963407ull;
    return double(int64_t(seed >> 11) % 2000001 - 1000000) / 1000000.0;
  };
  for (int i = 0; i < 1003; ++i) {
    pos.push_back(next() * 8);
    pos.push_back(next() * 8);
    pos.push_back(next() * 20 - 5);
  }
  pos[3 * 17] = 1.7e308;  // times m[0] > 1: overflows in the transform
  pos[3 * 18 + 2] = 0.0;  // at the eye plane
  MeshView mesh{pos.data(), int64_t(pos.size() / 3), nullptr, 0};
  const Viewport vp(333, 250);
  ScreenVertices out;
  transform_vertices(mesh, m, vp, out);
  bool same = true;
  int clipped = 0;
  for (int64_t i = 0; i < mesh.n_vertices; ++i) {
    const ClipVertex c = transform_point(m, &pos[3 * i]);
    const uint32_t oc = outcode(c, vp);
    ScreenVertex s{};
    if (!(oc & (kOutClip | kOutInvalid))) s = to_screen(c, vp);
    clipped += (oc & kOutClip) != 0;
    same &= out.outcode[i] == oc && out.xy[2 * i] == s.x_fx && out.xy[2 * i + 1] == s.y_fx &&
            std::memcmp(&out.z[i], &s.z, sizeof(double)) == 0;
  }
  CHECK(same);
  CHECK(out.outcode[17] == kOutInvalid);
  CHECK(clipped > 10);
  // any_outcode is the OR of the outcodes: 0 only when every vertex is inside.
  uint32_t any = 0;
  for (int64_t i = 0; i < mesh.n_vertices; ++i) any |= out.outcode[i];
  CHECK(out.any_outcode == any && (any & kOutInvalid));
  MeshView inside{pos.data(), 1, nullptr, 0};
  for (int64_t i = 0; i < mesh.n_vertices && out.outcode[i] != 0; ++i) inside.positions += 3;
  transform_vertices(inside, m, vp, out);
  CHECK(out.outcode[0] == 0 && out.any_outcode == 0);
}

}  // namespace

int main() {
  test_transform_vertices_matches_scalar_formulas();
  test_viewport_and_snap();
  test_outcodes();
  test_near_clipping();
  test_camera_inside_box();
  return check_report("test_vertex_stage");
}
