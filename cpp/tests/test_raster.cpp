// The raster core on hand-built screen triangles: fill rule, ties, depth.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include "check.h"
#include "frame.h"
#include "zbuffer/raster.h"
#include "zbuffer/triangle_batch.h"
#include "zbuffer/zpyramid.h"

using namespace zbuffer;

namespace {


ScreenVertex sv(int32_t x_fx, int32_t y_fx, double z) { return {x_fx, y_fx, 0u, z}; }


// A random screen triangle around (cx, cy) within r sub-pixels.
ScreenTriangle random_triangle(Lcg& next, int64_t cx, int64_t cy, int64_t r, int32_t id,
                               RenderStats& stats, bool& ok) {
  ScreenVertex v[3];
  for (auto& p : v)
    p = sv(int32_t(cx + next(-r, r)), int32_t(cy + next(-r, r)), double(next(0, 64)) / 64.0);
  ScreenTriangle tri;
  ok = make_triangle(v[0], v[1], v[2], id, false, tri, stats);
  return tri;
}


// Hand a triangle through the same assembly the algorithms use.
void draw(Frame& fr, ScreenVertex a, ScreenVertex b, ScreenVertex c, int32_t id,
          RenderStats& stats) {
  ScreenTriangle t;
  if (make_triangle(a, b, c, id, false, t, stats))
    rasterize_triangle(t, fr.target, stats);
}

// A square cut into a grid of triangles with vertices at awkward sub-pixel
// positions, some exactly on pixel centres: every pixel centre strictly
// inside is covered exactly once, whatever the diagonals do.
void test_tessellated_square_covered_once() {
  Frame fr(64, 64);
  RenderStats stats;
  const int n = 7;
  const int32_t x0 = 3 * 256 + 128, x1 = 60 * 256 + 31;  // x0 on a pixel centre
  std::vector<int32_t> g(n + 1);
  for (int k = 0; k <= n; ++k) g[k] = x0 + int32_t((int64_t(x1 - x0) * k) / n) + (k % 3 == 1 ? 128 : 0);
  g[n] = x1;
  int id = 0;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      ScreenVertex a = sv(g[c], g[r], 0.5), b = sv(g[c + 1], g[r], 0.5),
                   d = sv(g[c], g[r + 1], 0.5), e = sv(g[c + 1], g[r + 1], 0.5);
      draw(fr, a, b, e, id++, stats);
      draw(fr, a, e, d, id++, stats);
    }
  // Pixel centres covered by the square [x0, x1) x [x0, x1) under top-left:
  // left/top edges included, right/bottom excluded.
  int64_t expected = 0;
  for (int j = 0; j < fr.h; ++j)
    for (int i = 0; i < fr.w; ++i) {
      const int64_t px = pixel_centre_fx(i), py = pixel_centre_fx(j);
      const bool inside = px >= x0 && px < x1 && py >= x0 && py < x1;
      expected += inside;
      CHECK(inside == (fr.ids[size_t(j) * fr.w + i] >= 0));
    }
  CHECK(stats.pixels_covered == expected);
  CHECK(stats.pixels_written == expected);
}

// Identical triangles: the smaller id wins whatever the drawing order.
void test_tie_goes_to_smaller_id() {
  for (int order = 0; order < 2; ++order) {
    Frame fr(16, 16);
    RenderStats stats;
    const int32_t first = order == 0 ? 3 : 9, second = order == 0 ? 9 : 3;
    draw(fr, sv(0, 0, 0.25), sv(4000, 0, 0.5), sv(0, 4000, 0.75), first, stats);
    draw(fr, sv(0, 0, 0.25), sv(4000, 0, 0.5), sv(0, 4000, 0.75), second, stats);
    CHECK(fr.ids[0] == 3);
    CHECK(fr.ids[17] == 3);
  }
}

// The depth write on (depth, id) keys keeps what depth_write keeps, write by
// write: depths in [0, 1] (0 and 1 included, many exact ties), ids from 0
// up to 2^31 - 1, from an empty pixel.
void test_key_depth_write_equals_depth_write() {
  Lcg next{2024};
  const float depths[] = {0.0f, 1.0f, 0.5f, 0.25f, 1e-30f, 0.9999999f};
  for (int run = 0; run < 200; ++run) {
    float depth = std::numeric_limits<float>::infinity();
    int32_t id = -1;
    uint64_t key = kEmptyDepthKey;
    CHECK(key == depth_key(depth, id));
    for (int w = 0; w < 50; ++w) {
      const float z = next(0, 3) == 0 ? float(next.uniform(0.0, 1.0))
                                      : depths[next(0, int(sizeof depths / sizeof *depths) - 1)];
      const int32_t zid = next(0, 4) == 0 ? int32_t(2147483647 - next(0, 3)) : int32_t(next(0, 20));
      const bool won = depth_write(&depth, &id, 0, z, zid);
      CHECK(depth_write_key(&key, 0, depth_key(z, zid)) == won);
      CHECK(key == depth_key(depth, id));
    }
  }
}

// Depth follows the written formula and stays in the triangle's range.
void test_depth_formula_and_clamp() {
  Frame fr(32, 32);
  RenderStats stats;
  draw(fr, sv(0, 0, 0.1), sv(32 * 256, 0, 0.9), sv(0, 32 * 256, 0.3), 0, stats);
  bool in_range = true, nonconstant = false;
  for (size_t p = 0; p < fr.depth.size(); ++p) {
    if (fr.ids[p] < 0) continue;
    in_range &= fr.depth[p] >= float(0.1) && fr.depth[p] <= float(0.9);
    nonconstant |= fr.depth[p] != fr.depth[0];
  }
  CHECK(in_range);
  CHECK(nonconstant);
  // Pixel (0, 0): both edge values at the centre (128, 128) are 8192 * 128.
  const double inv_area = 1.0 / (8192.0 * 8192.0);
  const float a1 = float((0.9 - 0.1) * inv_area), a2 = float((0.3 - 0.1) * inv_area);
  const float w = 8192.0f * 128.0f;
  const float z = float(0.1) + (w * a1 + w * a2);
  CHECK(fr.depth[0] == z);
}

// A triangle far outside the image touches nothing; one straddling the
// border is cut to the image.
void test_box_clamped_to_image() {
  Frame fr(8, 8);
  RenderStats stats;
  draw(fr, sv(-100000, -100000, 0.5), sv(-90000, -100000, 0.5), sv(-100000, -90000, 0.5), 0, stats);
  CHECK(stats.pixels_tested == 0);
  draw(fr, sv(-4000, -4000, 0.5), sv(8000, -4000, 0.5), sv(-4000, 8000, 0.5), 1, stats);
  CHECK(fr.ids[0] == 1);
  CHECK(stats.pixels_tested <= 64);
}

// The build's loop (vector or scalar) equals the scalar loop bit for bit on
// random triangles, including sub-rectangles of their boxes.
void test_fast_loop_equals_scalar_loop() {
  Frame fast(70, 45), slow(70, 45);
  RenderStats fs, ss;
  Lcg next{12345};
  for (int t = 0; t < 3000; ++t) {
    bool ok;
    const ScreenTriangle tri = random_triangle(next, next(-2000, 72 * 256), next(-2000, 47 * 256),
                                               t % 3 == 0 ? 6000 : 800, t % 500, fs, ok);
    if (!ok) continue;
    const TriangleSetup s = setup_triangle(tri, 70, 45);
    if (s.x_min > s.x_max || s.y_min > s.y_max) continue;
    if (t % 2) {  // the whole-triangle entry point, against the scalar loop
      rasterize_triangle(tri, fast.target, fs);
      rasterize_rect_scalar(s, s.x_min, s.y_min, s.x_max, s.y_max, slow.target, ss);
      continue;
    }
    // A sub-rectangle too, as tiled algorithms use.
    const int xa = int(next(s.x_min, s.x_max)), ya = int(next(s.y_min, s.y_max));
    rasterize_rect(s, s.x_min, s.y_min, xa, s.y_max, fast.target, fs);
    rasterize_rect_scalar(s, s.x_min, s.y_min, xa, s.y_max, slow.target, ss);
    if (xa < s.x_max) {
      rasterize_rect(s, xa + 1, s.y_min, s.x_max, ya, fast.target, fs);
      rasterize_rect_scalar(s, xa + 1, s.y_min, s.x_max, ya, slow.target, ss);
      if (ya < s.y_max) {
        rasterize_rect(s, xa + 1, ya + 1, s.x_max, s.y_max, fast.target, fs);
        rasterize_rect_scalar(s, xa + 1, ya + 1, s.x_max, s.y_max, slow.target, ss);
      }
    }
  }
  CHECK(same_pixels(fast, slow));
  CHECK(fs.pixels_covered == ss.pixels_covered);
  CHECK(fs.pixels_written == ss.pixels_written);
  CHECK(ss.pixels_covered > 10000);
  std::printf("test_raster: rasterize_rect backend is %s\n", raster_backend());
}

// TriangleSpans gives, on every row, exactly the run of pixel centres that
// the coverage test admits (checked pixel by pixel over the box), and
// rectangles wide enough to be drawn by spans give the scalar loop's bits:
// vertices snapped to pixel centres and rows of centres (ties with edges),
// horizontal and vertical edges, slivers, and huge triangles (int64 edge
// values, far past the image), whole boxes and random sub-rectangles.
void test_spans_equal_coverage_and_scalar_loop() {
  const int w = 101, h = 67;
  Frame fast(w, h), slow(w, h);
  RenderStats fs, ss;
  Lcg next{97531};
  int64_t checked_rows = 0;
  for (int t = 0; t < 4000; ++t) {
    const int64_t r = t % 4 == 0 ? (int64_t(1) << 23) : t % 4 == 1 ? 40 * 256 : 12 * 256;
    const int64_t cx = next(-1000, 103 * 256), cy = next(-1000, 69 * 256);
    ScreenVertex v[3];
    for (auto& p : v) {
      int64_t x = cx + next(-r, r), y = cy + next(-r, r);
      if (next(0, 2) == 0) x = (x & ~int64_t(255)) + 128;  // on a column of centres
      if (next(0, 2) == 0) y = (y & ~int64_t(255)) + 128;  // on a row of centres
      p = sv(int32_t(x), int32_t(y), double(next(0, 64)) / 64.0);
    }
    if (t % 7 == 0) v[1].y_fx = v[0].y_fx;  // a horizontal edge
    if (t % 11 == 0) v[2].x_fx = v[1].x_fx;  // a vertical edge
    ScreenTriangle tri;
    if (!make_triangle(v[0], v[1], v[2], t, false, tri, fs)) continue;
    const TriangleSetup s = setup_triangle(tri, w, h);
    if (s.x_min > s.x_max || s.y_min > s.y_max) continue;

    TriangleSpans spans(s, s.y_min);
    for (int y = s.y_min; y <= s.y_max; ++y, ++checked_rows) {
      int lo, hi, first = s.x_max + 1, last = s.x_min - 1;
      spans.span(s.x_min, s.x_max, lo, hi);
      for (int x = s.x_min; x <= s.x_max; ++x) {
        bool in = true;
        for (int k = 0; k < 3; ++k)
          in &= s.w_origin[k] + int64_t(x - s.x_min) * s.step_x[k] +
                    int64_t(y - s.y_min) * s.step_y[k] >= 0;
        if (in) {
          first = std::min(first, x);
          last = x;
        }
      }
      CHECK(lo > hi ? first > last : (lo == first && hi == last));
      for (int x = first; x <= last; ++x) {  // one run: no gap inside it
        bool in = true;
        for (int k = 0; k < 3; ++k)
          in &= s.w_origin[k] + int64_t(x - s.x_min) * s.step_x[k] +
                    int64_t(y - s.y_min) * s.step_y[k] >= 0;
        CHECK(in);
      }
      spans.next_row();
    }

    const int xa = int(next(s.x_min, s.x_max)), ya = int(next(s.y_min, s.y_max));
    if (t % 2) {
      rasterize_rect(s, s.x_min, s.y_min, s.x_max, s.y_max, fast.target, fs);
    } else {
      rasterize_rect(s, s.x_min, s.y_min, xa, ya, fast.target, fs);
      if (xa < s.x_max) rasterize_rect(s, xa + 1, s.y_min, s.x_max, s.y_max, fast.target, fs);
      if (ya < s.y_max) rasterize_rect(s, s.x_min, ya + 1, xa, s.y_max, fast.target, fs);
    }
    rasterize_rect_scalar(s, s.x_min, s.y_min, s.x_max, s.y_max, slow.target, ss);
  }
  CHECK(same_pixels(fast, slow));
  CHECK(fs.pixels_covered == ss.pixels_covered && fs.pixels_written == ss.pixels_written);
  CHECK(fs.pixels_tested < ss.pixels_tested);  // spans test only covered pixels
  CHECK(ss.pixels_covered > 100000 && checked_rows > 50000);
}

// A huge triangle (edge values beyond 2^30) is drawn by exact spans even in
// a narrow image, in every build alike: only its covered pixels are tested.
void test_huge_triangle_tested_by_spans_in_every_build() {
  Frame fr(50, 50);
  RenderStats stats;
  // Its long edge crosses the image's diagonal.
  ScreenTriangle tri;
  CHECK(make_triangle(sv(-(1 << 22), -(1 << 22), 0.5), sv((1 << 22) + 50 * 256, (1 << 22) + 50 * 256, 0.5),
                      sv(-(1 << 22), (1 << 22), 0.5), 0, false, tri, stats));
  rasterize_triangle(tri, fr.target, stats);
  CHECK(stats.pixels_covered > 0 && stats.pixels_covered < 2500);
  CHECK(stats.pixels_tested == stats.pixels_covered);
}

// A hierarchical batch draws a large triangle by runs of the 8 x 8 tiles
// its pyramid does not show to be nearer already: behind two near stripes,
// large far triangles are drawn in several runs a row of tiles (each run
// from a copy of the triangle's spans), with the scalar loop's bits.
void test_large_triangles_drawn_by_runs_of_tiles() {
  const int w = 200, h = 150;
  Frame fast(w, h), slow(w, h);
  RenderStats fs, ss;
  ZPyramid pyramid(fast.depth.data(), w, h, 1, /*cleared=*/true);
  TriangleBatch batch(fast.target, fs, &pyramid, 16);
  auto add = [&](ScreenVertex a, ScreenVertex b, ScreenVertex c, int32_t id) {
    ScreenTriangle t;
    if (!make_triangle(a, b, c, id, false, t, fs)) return;
    batch.add(t);
    const TriangleSetup s = setup_triangle(t, w, h);
    if (s.x_min <= s.x_max && s.y_min <= s.y_max)
      rasterize_rect_scalar(s, s.x_min, s.y_min, s.x_max, s.y_max, slow.target, ss);
  };
  // Two near stripes, full height, drawn and brought into the pyramid first.
  int32_t id = 0;
  for (int x0 : {24, 104}) {
    const int32_t l = x0 * 256, r = (x0 + 40) * 256, b = (h + 1) * 256;
    add(sv(l, -256, 0.1), sv(r, -256, 0.1), sv(r, b, 0.1), id++);
    add(sv(l, -256, 0.1), sv(r, b, 0.1), sv(l, b, 0.1), id++);
  }
  batch.flush();
  // Large far triangles across them.
  Lcg next{31337};
  for (int t = 0; t < 40; ++t) {
    ScreenVertex v[3];
    for (auto& p : v)
      p = sv(int32_t(next(-40 * 256, (w + 40) * 256)), int32_t(next(-40 * 256, (h + 40) * 256)),
             0.3 + double(next(0, 60)) / 100.0);
    add(v[0], v[1], v[2], id++);
  }
  batch.flush();
  CHECK(same_pixels(fast, slow));
  CHECK(fs.pixels_covered <= ss.pixels_covered && fs.pixels_covered > 10000);
  CHECK(fs.tiles_skipped > 100);
}

// Spans (the scanline algorithm's primitive) written into a one-row buffer
// give the bits of the scalar rectangle loop, row by row, for any sub-range
// of a row: small triangles (int32 lanes) and huge ones (int64 lanes).
void test_span_equals_scalar_rect() {
  const int w = 75, h = 40;
  Frame slow(w, h), fast(w, h), scalar(w, h);
  RenderStats ss, fs, cs;
  Lcg next{2468};
  for (int t = 0; t < 3000; ++t) {
    bool ok;
    const int64_t r = t % 5 == 0 ? (int64_t(1) << 22) : 900;  // huge: edge values > 2^30
    const ScreenTriangle tri = random_triangle(next, next(-2000, 77 * 256), next(-2000, 42 * 256),
                                               r, t % 700, ss, ok);
    if (!ok) continue;
    const TriangleSetup s = setup_triangle(tri, w, h);
    if (s.x_min > s.x_max || s.y_min > s.y_max) continue;
    rasterize_rect_scalar(s, s.x_min, s.y_min, s.x_max, s.y_max, slow.target, ss);
    for (int y = s.y_min; y <= s.y_max; ++y) {
      // The whole box row, or a random part of it split in two.
      const int xa = int(next(s.x_min, s.x_max));
      float* d = fast.depth.data() + size_t(y) * w;
      int32_t* i = fast.ids.data() + size_t(y) * w;
      if (t % 2) {
        rasterize_span(s, y, s.x_min, s.x_max, d, i, fs);
      } else {
        rasterize_span(s, y, s.x_min, xa, d, i, fs);
        if (xa < s.x_max) rasterize_span(s, y, xa + 1, s.x_max, d, i, fs);
      }
      rasterize_span_scalar(s, y, s.x_min, s.x_max, scalar.depth.data() + size_t(y) * w,
                            scalar.ids.data() + size_t(y) * w, cs);
    }
  }
  CHECK(same_pixels(fast, slow));
  CHECK(same_pixels(scalar, slow));
  CHECK(fs.pixels_covered == ss.pixels_covered && cs.pixels_covered == ss.pixels_covered);
  CHECK(fs.pixels_tested == ss.pixels_tested && cs.pixels_tested == ss.pixels_tested);
  CHECK(ss.pixels_covered > 10000);
}

// A batch (vector setup, groups by box shape, any order) draws the same bits
// as triangles drawn one by one with the scalar loop.
void test_batch_equals_scalar_loop() {
  Frame fast(90, 61), slow(90, 61);
  RenderStats fs, ss;
  Lcg next{777};
  TriangleBatch batch(fast.target, fs);
  for (int t = 0; t < 5000; ++t) {
    bool ok;
    const ScreenTriangle tri =
        random_triangle(next, next(-3000, 92 * 256), next(-3000, 63 * 256),
                        t % 7 == 0 ? 9000 : t % 3 == 0 ? 1500 : 600, t % 700, fs, ok);
    if (!ok) continue;
    batch.add(tri);
    const TriangleSetup s = setup_triangle(tri, 90, 61);
    if (s.x_min <= s.x_max && s.y_min <= s.y_max)
      rasterize_rect_scalar(s, s.x_min, s.y_min, s.x_max, s.y_max, slow.target, ss);
  }
  batch.flush();
  CHECK(same_pixels(fast, slow));
  CHECK(fs.pixels_covered == ss.pixels_covered);
  CHECK(ss.pixels_covered > 10000);
}

// Faces through the batch's vector assembly and setup (16 at a time) draw
// the same bits as the scalar assembly and scalar loop, and count the same
// triangles, with clipping, culling and degenerate faces mixed in.
void test_batch_faces_equal_scalar_assembly() {
  const int w = 83, h = 67;
  Lcg next{4242};
  std::vector<double> pos;
  for (int i = 0; i < 3000; ++i) {
    const double cx = double(next(-1200, 1200)) / 1000.0, cy = double(next(-1200, 1200)) / 1000.0;
    const double cz = double(next(-3000, 900)) / 1000.0;  // some behind the near plane
    pos.insert(pos.end(), {cx, cy, cz});
  }
  std::vector<int32_t> faces;
  for (int f = 0; f < 1000; ++f) {
    const int32_t a = int32_t(next(0, 2999));
    // Mostly small triangles (neighbouring vertices), some big, some degenerate.
    const int32_t b = f % 11 == 0 ? a : int32_t(next(0, 2999));
    const int32_t c = f % 5 == 0 ? int32_t(next(0, 2999)) : int32_t((a + 1) % 3000);
    faces.insert(faces.end(), {a, b, c});
  }
  // Shrink most triangles: move each face's later vertices near its first.
  for (size_t f = 0; f < faces.size(); f += 3)
    if (f % 4 != 0)
      for (int k = 1; k < 3; ++k)
        for (int c = 0; c < 3; ++c)
          pos[3 * size_t(faces[f + k]) + c] =
              pos[3 * size_t(faces[f]) + c] + double(next(-40, 40)) / 1000.0;
  const MeshView mesh{pos.data(), int64_t(pos.size() / 3), faces.data(),
                      int64_t(faces.size() / 3)};
  // Perspective looking down -z from z = 1, near 0.1, far 4.
  const double n = 0.1, fa = 4.0, e = 1.0;
  const double mvp[16] = {1.2, 0, 0, 0, 0, 1.5, 0, 0, 0, 0, -(fa + n) / (fa - n),
                          -2 * fa * n / (fa - n) + (fa + n) / (fa - n) * e, 0, 0, -1, e};
  const Viewport vp(w, h);
  ScreenVertices screen;
  transform_vertices(mesh, mvp, vp, screen);
  for (int cull = 0; cull < 2; ++cull) {
    Frame fast(w, h), slow(w, h);
    RenderStats fs, ss;
    TriangleBatch batch(fast.target, fs);
    batch.add_faces(mesh, mvp, vp, screen, 0, mesh.n_faces, cull != 0);
    batch.flush();
    for (int64_t f = 0; f < mesh.n_faces; ++f)
      assemble_triangle(mesh, mvp, vp, screen, f, cull != 0, ss, [&](const ScreenTriangle& t) {
        ++ss.rasterized;
        const TriangleSetup s = setup_triangle(t, w, h);
        if (s.x_min <= s.x_max && s.y_min <= s.y_max)
          rasterize_rect_scalar(s, s.x_min, s.y_min, s.x_max, s.y_max, slow.target, ss);
      });
    CHECK(same_pixels(fast, slow));
    CHECK(fs.rasterized == ss.rasterized && fs.clipped == ss.clipped &&
          fs.culled_frustum == ss.culled_frustum && fs.culled_backface == ss.culled_backface &&
          fs.culled_degenerate == ss.culled_degenerate && fs.clip_pieces == ss.clip_pieces);
    // Rectangles 64 pixels or more across, or with edge values of 2^30 or
    // more, are walked by exact spans: only their covered pixels are tested.
    CHECK(fs.pixels_covered == ss.pixels_covered);
    CHECK(fs.pixels_tested >= fs.pixels_covered && fs.pixels_tested < ss.pixels_tested);
    CHECK(ss.clipped > 0 && ss.culled_degenerate > 0 && ss.pixels_covered > 1000);
    CHECK(cull == 0 || ss.culled_backface > 0);
  }
}

}  // namespace

// The vector test of small faces against the pyramid (cull_small16 in
// AVX-512 builds, cull_small8 in AVX2 ones, as faces are added) culls the
// faces that the scalar test (cull_small, as add() takes triangles one by
// one) culls: behind a flushed wall of random depths, a few hundred small
// faces at random depths -- under a batch, so that both meet the same
// pyramid -- at each finest kept level, boxes of 1 to 15 pixels (1 to 3
// cells a side). The counts must agree (images would: a face left unculled
// is drawn and hidden anyway), and some faces must be culled and some not.
void test_small_face_culling_vector_equals_scalar() {
  const int w = 150, h = 110;  // (not multiples of the blocks or cells)
  Lcg next{9001};
  std::vector<double> pos;
  std::vector<int32_t> faces;
  auto vertex = [&](double x, double y, double z) {
    pos.insert(pos.end(), {x, y, z});
    return int32_t(pos.size() / 3 - 1);
  };
  // The wall: 10 x 10 quads over the whole image, each at its own depth.
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 10; ++i) {
      const double x0 = -1.0 + 0.2 * i, y0 = -1.0 + 0.2 * j, z = next.uniform(-0.4, 0.2);
      const int32_t a = vertex(x0, y0, z), b = vertex(x0 + 0.2, y0, z),
                    c = vertex(x0 + 0.2, y0 + 0.2, z), d = vertex(x0, y0 + 0.2, z);
      faces.insert(faces.end(), {a, b, c, a, c, d});
    }
  const int64_t n_wall = int64_t(faces.size() / 3);
  const int n_test = 400;
  for (int t = 0; t < n_test; ++t) {
    const double x = next.uniform(-1.0, 0.9), y = next.uniform(-1.0, 0.9);
    const double dx = 2.0 * double(next(1, 15)) / w, dy = 2.0 * double(next(1, 15)) / h;
    const double z = next.uniform(-0.5, 0.5);
    const int32_t a = vertex(x, y, z), b = vertex(x + dx, y + 0.3 * dy, z + 0.01),
                  c = vertex(x + 0.4 * dx, y + dy, z + 0.02);
    faces.insert(faces.end(), {a, b, c});
  }
  const MeshView mesh{pos.data(), int64_t(pos.size() / 3), faces.data(), int64_t(faces.size() / 3)};
  const double mvp[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const Viewport vp(w, h);
  ScreenVertices screen;
  transform_vertices(mesh, mvp, vp, screen);
  for (int first : {1, 2, 3}) {
    Frame vec(w, h), one(w, h);
    ZPyramid pv(vec.depth.data(), w, h, first, /*cleared=*/true);
    ZPyramid po(one.depth.data(), w, h, first, /*cleared=*/true);
    RenderStats sv_stats, so_stats;
    TriangleBatch bv(vec.target, sv_stats, &pv), bo(one.target, so_stats, &po);
    for (TriangleBatch* b : {&bv, &bo}) {
      b->add_faces(mesh, mvp, vp, screen, 0, n_wall, false);
      b->flush(TriangleBatch::Upkeep::kNow);
    }
    const int64_t before_v = sv_stats.culled_hidden, before_o = so_stats.culled_hidden;
    bv.add_faces(mesh, mvp, vp, screen, n_wall, mesh.n_faces, false);
    for (int64_t f = n_wall; f < mesh.n_faces; ++f)
      assemble_triangle(mesh, mvp, vp, screen, f, false, so_stats, [&](const ScreenTriangle& t) {
        ++so_stats.rasterized;
        bo.add(t);
      });
    const int64_t culled_v = sv_stats.culled_hidden - before_v;
    const int64_t culled_o = so_stats.culled_hidden - before_o;
    CHECK(culled_v == culled_o);
    // (A scalar build batches no face: it tests them all when it draws.)
    if (std::strcmp(raster_backend(), "scalar") != 0)
      CHECK(culled_o > n_test / 10 && culled_o < n_test - n_test / 10);
    bv.flush();
    bo.flush();
    CHECK(same_pixels(vec, one));
  }
}

int main() {
  test_spans_equal_coverage_and_scalar_loop();
  test_small_face_culling_vector_equals_scalar();
  test_huge_triangle_tested_by_spans_in_every_build();
  test_large_triangles_drawn_by_runs_of_tiles();
  test_span_equals_scalar_rect();
  test_batch_faces_equal_scalar_assembly();
  test_batch_equals_scalar_loop();
  test_fast_loop_equals_scalar_loop();
  test_tessellated_square_covered_once();
  test_tie_goes_to_smaller_id();
  test_key_depth_write_equals_depth_write();
  test_depth_formula_and_clamp();
  test_box_clamped_to_image();
  return check_report("test_raster");
}
