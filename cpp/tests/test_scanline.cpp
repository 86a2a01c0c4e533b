// The scanline algorithm's tables and row walk: the vector paths (faces
// assembled and set up 16 at a time, the active polygon list drawn 16
// polygons at a time) against the scalar ones and the plain raster loop.
#include <stdexcept>
#include <string>
#include <vector>

#include "check.h"
#include "frame.h"
#include "zbuffer/algorithms.h"
#include "zbuffer/raster.h"
#include "zbuffer/scanline.h"

using namespace zbuffer;

namespace {



// A mesh of mostly small triangles, some large, some degenerate, some
// behind the near plane (clipped); with `grid`, vertices on pixel centres
// and row boundaries (horizontal edges, edges through centres); every face
// listed twice, so that spans starting at one column meet in one group of
// 16 polygons (exact ties, won by the smaller id).
struct TestMesh {
  std::vector<double> pos;
  std::vector<int32_t> faces;
  MeshView view() const {
    return {pos.data(), int64_t(pos.size() / 3), faces.data(), int64_t(faces.size() / 3)};
  }
};

TestMesh make_mesh(unsigned long long seed, bool grid, int w, int h) {
  Lcg next{seed};
  TestMesh m;
  const int n_vertices = 3000;
  for (int i = 0; i < n_vertices; ++i) {
    double cx = double(next(-1200, 1200)) / 1000.0, cy = double(next(-1200, 1200)) / 1000.0;
    if (grid) {  // multiples of half a pixel in window coordinates
      cx = 2.0 * (double(next(-4, 2 * w + 4)) * 0.5) / w - 1.0;
      cy = 1.0 - 2.0 * (double(next(-4, 2 * h + 4)) * 0.5) / h;
    }
    const double cz = grid ? double(next(-900, 900)) / 1000.0 : double(next(-3000, 900)) / 1000.0;
    m.pos.insert(m.pos.end(), {cx, cy, cz});
  }
  for (int f = 0; f < 1000; ++f) {
    const int32_t a = int32_t(next(0, n_vertices - 1));
    const int32_t b = f % 11 == 0 ? a : int32_t(next(0, n_vertices - 1));
    const int32_t c = f % 5 == 0 ? int32_t(next(0, n_vertices - 1)) : int32_t((a + 1) % n_vertices);
    m.faces.insert(m.faces.end(), {a, b, c});
  }
  // Shrink most triangles: move each face's later vertices near its first
  // (on the grid: by whole half pixels).
  for (size_t f = 0; f < m.faces.size(); f += 3)
    if (f % 4 != 0)
      for (int k = 1; k < 3; ++k) {
        double* p = &m.pos[3 * size_t(m.faces[f + k])];
        const double* q = &m.pos[3 * size_t(m.faces[f])];
        p[0] = q[0] + (grid ? double(next(-12, 12)) / w : double(next(-40, 40)) / 1000.0);
        p[1] = q[1] + (grid ? double(next(-12, 12)) / h : double(next(-40, 40)) / 1000.0);
        p[2] = q[2] + double(next(-40, 40)) / 1000.0;
      }
  const size_t n = m.faces.size();
  for (size_t i = 0; i < n; ++i) m.faces.push_back(m.faces[i]);  // every face twice
  return m;
}

// Faces through ScanlineTables::add_faces (the vector assembly and setup in
// AVX-512 builds) and through the scalar assemble_triangle + add_triangle
// give the same tables: the same pixels, the same counts of everything the
// order of insertion does not change, and the plain raster loop's pixels.
void test_vector_tables_equal_scalar_tables() {
  const int w = 97, h = 71;
  // Perspective looking down -z from z = 1, near 0.1, far 4; and an
  // orthographic view for the grid mesh (window x, y as placed).
  const double n = 0.1, fa = 4.0, e = 1.0;
  const double perspective[16] = {1.2, 0, 0, 0, 0, 1.5, 0, 0, 0, 0, -(fa + n) / (fa - n),
                                  -2 * fa * n / (fa - n) + (fa + n) / (fa - n) * e, 0, 0, -1, e};
  const double ortho[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (int grid = 0; grid < 2; ++grid) {
    const TestMesh tm = make_mesh(grid ? 77 : 4242, grid != 0, w, h);
    const MeshView mesh = tm.view();
    const double* mvp = grid ? ortho : perspective;
    const Viewport vp(w, h);
    ScreenVertices screen;
    transform_vertices(mesh, mvp, vp, screen);
    for (int cull = 0; cull < 2; ++cull) {
      Frame fast(w, h), slow(w, h), plain(w, h);
      RenderStats fs, ss, ps;
      ScanlineTables vec, scalar;
      vec.reset(w, h);
      vec.add_faces(mesh, mvp, vp, screen, 0, mesh.n_faces, cull != 0, fs);
      vec.render(fast.target, fs);
      scalar.reset(w, h);
      for (int64_t f = 0; f < mesh.n_faces; ++f)
        assemble_triangle(mesh, mvp, vp, screen, f, cull != 0, ss, [&](const ScreenTriangle& t) {
          ++ss.rasterized;
          scalar.add_triangle(t, ss);
          const TriangleSetup s = setup_triangle(t, w, h);
          if (s.x_min <= s.x_max && s.y_min <= s.y_max)
            rasterize_rect_scalar(s, s.x_min, s.y_min, s.x_max, s.y_max, plain.target, ps);
        });
      scalar.render(slow.target, ss);
      CHECK(same_pixels(fast, slow));
      CHECK(same_pixels(fast, plain));
      // A frame with more polygons than the vector lists take (the limit
      // lowered to 0 here) runs the scalar lists: the same pixels, the
      // same counts.
      {
        Frame limited(w, h);
        RenderStats ls;
        ScanlineTables tables;
        tables.limit_vector_lists(0);
        tables.reset(w, h);
        tables.add_faces(mesh, mvp, vp, screen, 0, mesh.n_faces, cull != 0, ls);
        tables.render(limited.target, ls);
        CHECK(same_pixels(fast, limited));
        CHECK(ls.spans_drawn == fs.spans_drawn && ls.pixels_covered == fs.pixels_covered &&
              ls.active_edges_sum == fs.active_edges_sum &&
              ls.active_polygons_sum == fs.active_polygons_sum);
      }
      CHECK(fs.rasterized == ss.rasterized && fs.clipped == ss.clipped &&
            fs.culled_frustum == ss.culled_frustum && fs.culled_backface == ss.culled_backface &&
            fs.culled_degenerate == ss.culled_degenerate && fs.clip_pieces == ss.clip_pieces);
      CHECK(fs.polygons_inserted == ss.polygons_inserted && fs.edges_inserted == ss.edges_inserted);
      CHECK(fs.active_polygons_sum == ss.active_polygons_sum &&
            fs.active_polygons_max == ss.active_polygons_max &&
            fs.active_edges_sum == ss.active_edges_sum && fs.active_edges_max == ss.active_edges_max);
      CHECK(fs.spans_drawn == ss.spans_drawn && fs.pixels_covered == ss.pixels_covered &&
            fs.pixels_tested == ss.pixels_tested && fs.pixels_covered == ps.pixels_covered);
      CHECK(fs.pixels_tested == fs.pixels_covered);  // exact spans
      CHECK(ss.culled_degenerate > 0 && ss.pixels_covered > 1000);
      CHECK(grid != 0 || ss.clipped > 0);
      CHECK(cull == 0 || ss.culled_backface > 0);
    }
  }
}

// Memory is bounded (scanline.h, "Memory"): a mesh of more faces than
// kMaxScanlineTriangles is refused before any of it is read, and a thread
// keeps its tables for the next frame only up to its limit.
void test_scanline_memory_is_bounded() {
  const Algorithm& scanline = *find_algorithm("scanline");
  const TestMesh m = make_mesh(7, false, 96, 64);
  RenderInput in;
  in.mesh = m.view();
  for (int k = 0; k < 4; ++k) in.mvp[5 * k] = 1.0;
  Frame frame(96, 64);
  RenderStats stats;
  render(scanline, in, frame.target, stats);
  const size_t held = scanline_tables_held();
  CHECK(held > 0 && held <= kKeptScanlineBytes);  // kept for the next frame

  RenderInput huge = in;  // its faces are never read: only its count
  huge.mesh.n_faces = kMaxScanlineTriangles + 1;
  bool refused = false;
  try {
    RenderStats s;
    render(scanline, huge, frame.target, s);
  } catch (const std::length_error& e) {
    refused = std::string(e.what()).find("at most 2**24 (16,777,216) triangles") != std::string::npos;
  }
  CHECK(refused);
  CHECK(scanline_tables_held() == held);

  limit_kept_scanline_bytes(held - 1);  // this frame's tables are over the limit: given back
  RenderStats again;
  render(scanline, in, frame.target, again);
  CHECK(scanline_tables_held() == 0 && again.rasterized == stats.rasterized);
  limit_kept_scanline_bytes(kKeptScanlineBytes);
  render(scanline, in, frame.target, again);
  CHECK(scanline_tables_held() == held);
}

}  // namespace

int main() {
  test_vector_tables_equal_scalar_tables();
  test_scanline_memory_is_bounded();
  return check_report("test_scanline");
}
