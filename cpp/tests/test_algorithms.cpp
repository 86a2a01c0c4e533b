// Every registered algorithm produces the plain Z-buffer's bits, on random
// scenes with heavy occlusion (so that hierarchical culling really happens).
#include <algorithm>
#include <cmath>
#include <map>
#include <cstring>
#include <string>
#include <vector>

#include "check.h"
#include "spatial.h"
#include "zbuffer/algorithms.h"
#include "zbuffer/mesh_order.h"
#include "zbuffer/triangle_batch.h"
#include "zbuffer/zpyramid.h"

using namespace zbuffer;

namespace {


void test_every_algorithm_equals_the_plain_zbuffer() {
  std::map<std::string, int64_t> nodes_hidden;
  for (int scene = 0; scene < 6; ++scene) {
    Lcg next{uint64_t(100 + scene)};
    std::vector<double> pos;
    std::vector<int32_t> faces;
    // A few big occluders near the camera, then many small triangles
    // behind and around them; sizes and depths vary by scene.
    const int n_big = 4 + scene, n_small = 3000;
    for (int t = 0; t < n_big + n_small; ++t) {
      const bool big = t < n_big;
      const double cx = next.uniform(-1.5, 1.5), cy = next.uniform(-1.5, 1.5);
      const double cz = big ? next.uniform(-1.5, -1.0) : next.uniform(-4.0, -1.2);
      const double r = big ? next.uniform(0.5, 1.5) : next.uniform(0.01, 0.2);
      // Occluders are counter-clockwise seen from the camera (front faces,
      // kept by back-face culling); the small ones are oriented at random.
      const double corner[3][2] = {{-1, -1}, {1, -1}, {0, 1}};
      for (int k = 0; k < 3; ++k) {
        pos.push_back(cx + (big ? r * corner[k][0] : next.uniform(-r, r)));
        pos.push_back(cy + (big ? r * corner[k][1] : next.uniform(-r, r)));
        pos.push_back(cz + next.uniform(-0.1, 0.1));
        faces.push_back(int32_t(faces.size()));
      }
    }
    // Perspective from the origin looking down -z, near 0.5, far 10.
    const double n = 0.5, f = 10.0, s = 1.0 / std::tan(0.6);
    const double mvp[16] = {s, 0, 0, 0, 0, s * 1.2, 0, 0, 0, 0, -(f + n) / (f - n),
                            -2 * f * n / (f - n), 0, 0, -1, 0};
    RenderInput input;
    input.mesh = {pos.data(), int64_t(pos.size() / 3), faces.data(), int64_t(faces.size() / 3)};
    for (int k = 0; k < 16; ++k) input.mvp[k] = mvp[k];
    input.cull_backfaces = scene % 2 == 1;
    const int w = 120 + 13 * scene, h = 96 + 7 * scene;
    std::vector<float> ref_depth(size_t(w) * h);
    std::vector<int32_t> ref_ids(size_t(w) * h);
    DepthTarget ref{ref_depth.data(), ref_ids.data(), w, h};
    RenderStats ref_stats;
    render(*find_algorithm("zbuffer"), input, ref, ref_stats);
    // The batch's occlusion test at every finest pyramid level it supports
    // (hiz keeps 8 x 8 cells, the trees of at least as many triangles as pixels 4 x 4;
    // 2 x 2 works too), eager and
    // lazy upkeep, small and full batches: the same bits, and culling.
    for (int first : {1, 2, 3})
      for (int capacity : {64, TriangleBatch::kCapacity}) {
        std::vector<float> depth(size_t(w) * h);
        std::vector<int32_t> ids(size_t(w) * h);
        DepthTarget target{depth.data(), ids.data(), w, h};
        clear_target(target);
        ZPyramid pyramid(depth.data(), w, h, first, /*cleared=*/true);
        RenderStats stats;
        render_faces_batched(input, target, stats, &pyramid, capacity, /*lazy_upkeep=*/first == 2);
        CHECK(std::memcmp(depth.data(), ref_depth.data(), depth.size() * sizeof(float)) == 0);
        CHECK(ids == ref_ids);
        CHECK(stats.culled_hidden > 0);
        CHECK(stats.rasterized + stats.culled_hidden == ref_stats.rasterized);
      }
    // Faces in spatial order, visited cell by cell nearest first (the
    // image-space algorithms with a pyramid): the same bits, the same ids.
    {
      const SpatialMesh spatial(input.mesh);
      RenderInput cells = input;
      cells.mesh = spatial.view();
      cells.cells = spatial.cells();
      CHECK(cells.cells.n > 8 && spatial.cell_start.back() == int32_t(spatial.order.size()));
      std::vector<int32_t> visit;
      near_to_far(cells.cells, mvp, visit);
      CHECK(int64_t(visit.size()) == cells.cells.n);
      auto clip_z = [&](int32_t k) {
        const double* c = spatial.cell_centre.data() + 3 * k;
        return mvp[8] * c[0] + mvp[9] * c[1] + mvp[10] * c[2] + mvp[11];
      };
      for (size_t k = 1; k < visit.size(); ++k) CHECK(clip_z(visit[k - 1]) <= clip_z(visit[k]));
      for (const char* name : {"zbuffer", "hiz"}) {
        std::vector<float> depth(size_t(w) * h);
        std::vector<int32_t> ids(size_t(w) * h);
        DepthTarget target{depth.data(), ids.data(), w, h};
        RenderStats stats;
        render(*find_algorithm(name), cells, target, stats);
        CHECK(std::memcmp(depth.data(), ref_depth.data(), depth.size() * sizeof(float)) == 0);
        CHECK(ids == ref_ids);
      }
    }
    for (const Algorithm& algo : algorithms()) {
      // Stale values in the planes: render() clears them.
      std::vector<float> depth(size_t(w) * h, 0.25f);
      std::vector<int32_t> ids(size_t(w) * h, 12345);
      DepthTarget target{depth.data(), ids.data(), w, h};
      RenderStats stats;
      render(algo, input, target, stats);
      CHECK(std::memcmp(depth.data(), ref_depth.data(), depth.size() * sizeof(float)) == 0);
      CHECK(ids == ref_ids);
      // The counters add up, and the triangles drawn or culled one by one
      // are those the plain Z-buffer drew, minus any in culled tree nodes.
      CHECK(stats.triangles_in - stats.culled_in_nodes - stats.culled_invalid -
                stats.culled_frustum - stats.clipped + stats.clip_pieces ==
            stats.culled_backface + stats.culled_degenerate + stats.culled_hidden +
                stats.rasterized);
      if (stats.culled_in_nodes == 0)
        CHECK(stats.rasterized + stats.culled_hidden == ref_stats.rasterized);
      else
        CHECK(stats.rasterized + stats.culled_hidden <= ref_stats.rasterized);
      // (The scanline culls nothing: it draws every triangle's exact spans.)
      if (std::string(algo.name) != "zbuffer" && std::string(algo.name) != "scanline")
        CHECK(stats.culled_hidden > 0);
      nodes_hidden[algo.name] += stats.nodes_hidden;
      // Into planes with padded rows (rows `pitch` pixels apart, the last
      // one ending the allocation): the same pixels, the padding untouched.
      {
        const int pitch = w + 3 + 5 * scene;
        const size_t n = size_t(h - 1) * pitch + size_t(w);
        std::vector<float> pdepth(n, -7.0f);
        std::vector<int32_t> pids(n, -7);
        DepthTarget padded{pdepth.data(), pids.data(), w, h, pitch};
        RenderStats pstats;
        render(algo, input, padded, pstats);
        bool rows_same = true, padding_kept = true;
        for (int y = 0; y < h; ++y) {
          const size_t at = size_t(y) * pitch, ref_at = size_t(y) * w;
          rows_same &= std::memcmp(pdepth.data() + at, ref_depth.data() + ref_at, w * sizeof(float)) == 0 &&
                       std::equal(pids.begin() + at, pids.begin() + at + w, ref_ids.begin() + ref_at);
          for (size_t p = at + w; p < std::min(n, at + pitch); ++p)
            padding_kept &= pdepth[p] == -7.0f && pids[p] == -7;
        }
        CHECK(rows_same);
        CHECK(padding_kept);
        CHECK(pstats.pixels_written == stats.pixels_written && pstats.rasterized == stats.rasterized);
      }
      if (std::string(algo.name) == "scanline") {
        // Spans are exact: every pixel tested is covered, and the pixels
        // covered are the reference's.
        CHECK(stats.pixels_tested == stats.pixels_covered);
        CHECK(stats.pixels_covered == ref_stats.pixels_covered);
        CHECK(stats.polygons_inserted > 0 && stats.polygons_inserted <= stats.rasterized);
        CHECK(stats.edges_inserted >= 2 * stats.polygons_inserted);
        CHECK(stats.scanline_rows == h && stats.active_polygons_max > 0);
        CHECK(stats.active_polygons_sum <= stats.active_polygons_max * h);
        CHECK(stats.depth_storage_bytes == int64_t(w) * int64_t(sizeof(float)));
      } else {
        CHECK(stats.depth_storage_bytes >= int64_t(w) * h * int64_t(sizeof(float)));
      }
    }
  }
  // The object-space algorithms cull whole nodes on these scenes.
  CHECK(nodes_hidden["hiz_octree"] > 0);
  CHECK(nodes_hidden["hiz_bvh"] > 0);
}

// Polygon faces drawn natively by the scanline cover what their
// triangulations cover (planar, simple): a grid of quads at constant depths
// (so depth is exact either way) and L-shaped hexagons, whose fan from
// corner 0 would overdraw. A polygon's pixels carry its first triangle's id.
void test_scanline_polygons_cover_their_triangulation() {
  std::vector<double> pos;
  std::vector<int32_t> faces, indices;
  std::vector<int64_t> offsets = {0};
  std::vector<int32_t> first_of;  // first triangle of each polygon
  auto vertex = [&](double x, double y, double z) {
    pos.insert(pos.end(), {x, y, z});
    return int32_t(pos.size() / 3 - 1);
  };
  Lcg next{99};
  for (int q = 0; q < 36; ++q) {  // quads, some wound each way
    const double x0 = -0.9 + 0.3 * (q % 6) + next.uniform(-0.05, 0.05);
    const double y0 = -0.9 + 0.3 * (q / 6) + next.uniform(-0.05, 0.05);
    const double z = next.uniform(-0.5, 0.5);
    int32_t v[4] = {vertex(x0, y0, z), vertex(x0 + 0.31, y0, z), vertex(x0 + 0.33, y0 + 0.29, z),
                    vertex(x0 - 0.02, y0 + 0.3, z)};
    if (q % 3 == 0) std::swap(v[1], v[3]);
    first_of.push_back(int32_t(faces.size() / 3));
    faces.insert(faces.end(), {v[0], v[1], v[2], v[0], v[2], v[3]});
    indices.insert(indices.end(), v, v + 4);
    offsets.push_back(int64_t(indices.size()));
  }
  for (int l = 0; l < 3; ++l) {  // L-shaped hexagons, corner 0 at (4, 0)
    const double s = 0.1 + 0.05 * l, x0 = -0.8 + 0.55 * l, y0 = -0.3 - 0.1 * l, z = -0.8;
    const double c[6][2] = {{4, 0}, {4, 2}, {2, 2}, {2, 4}, {0, 4}, {0, 0}};
    int32_t v[6];
    for (int k = 0; k < 6; ++k) v[k] = vertex(x0 + s * c[k][0], y0 + s * c[k][1], z);
    first_of.push_back(int32_t(faces.size() / 3));
    // An exact triangulation: (4,0)(4,2)(2,2), (4,0)(2,2)(0,0), (2,2)(2,4)(0,4), (2,2)(0,4)(0,0)
    faces.insert(faces.end(), {v[0], v[1], v[2], v[0], v[2], v[5], v[2], v[3], v[4], v[2], v[4], v[5]});
    indices.insert(indices.end(), v, v + 6);
    offsets.push_back(int64_t(indices.size()));
  }
  RenderInput input;
  input.mesh = {pos.data(), int64_t(pos.size() / 3), faces.data(), int64_t(faces.size() / 3)};
  const double ortho[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (int k = 0; k < 16; ++k) input.mvp[k] = ortho[k];
  const int w = 157, h = 131;
  std::vector<float> d0(size_t(w) * h), d1(size_t(w) * h);
  std::vector<int32_t> i0(size_t(w) * h), i1(size_t(w) * h);
  DepthTarget tri{d0.data(), i0.data(), w, h}, poly{d1.data(), i1.data(), w, h};
  RenderStats st, sp;
  render(*find_algorithm("zbuffer"), input, tri, st);
  input.polygons = {offsets.data(), indices.data(), int64_t(offsets.size() - 1)};
  render(*find_algorithm("scanline"), input, poly, sp);
  // The polygon each triangle id belongs to.
  std::vector<int32_t> owner(faces.size() / 3);
  for (size_t p = 0; p < first_of.size(); ++p)
    for (int64_t t = first_of[p]; t < (p + 1 < first_of.size() ? first_of[p + 1] : int64_t(owner.size())); ++t)
      owner[size_t(t)] = int32_t(p);
  bool same = true, first_ids = true;
  for (size_t p = 0; p < d0.size(); ++p) {
    same &= (i0[p] < 0) == (i1[p] < 0);
    if (i0[p] >= 0 && i1[p] >= 0) {
      same &= owner[size_t(i0[p])] == owner[size_t(i1[p])] && d0[p] == d1[p];
      first_ids &= i1[p] == first_of[size_t(owner[size_t(i1[p])])];
    }
  }
  CHECK(same);
  CHECK(first_ids);
  CHECK(sp.pixels_covered == st.pixels_covered && sp.pixels_tested == sp.pixels_covered);
  CHECK(sp.rasterized == st.rasterized && st.rasterized == int64_t(faces.size() / 3));
  CHECK(sp.polygons_inserted == int64_t(first_of.size()));
}

// Planes whose rows share L1 cache sets (algorithms.h): only at widths that
// are multiples of 1024, with the id plane less than 512 bytes from the
// depth plane modulo 4 KiB. There the ids go to a scratch plane 2 KiB off
// the depth plane, large enough for them, and finish() copies them over.
void test_ids_are_placed_apart_from_depth() {
  alignas(4096) static float block[4 * 1024 * 2 + 4 * 1024];
  auto target = [&](int width, size_t ids_at) {
    return DepthTarget{block, reinterpret_cast<int32_t*>(reinterpret_cast<char*>(block) + ids_at),
                       width, 2};
  };
  CHECK(planes_share_cache_sets(target(1024, 8192)));
  CHECK(planes_share_cache_sets(target(2048, 16384 + 508)));
  CHECK(planes_share_cache_sets(target(1024, 8192 + 4096 - 4)));
  CHECK(!planes_share_cache_sets(target(1024, 8192 + 512)));
  CHECK(!planes_share_cache_sets(target(1024, 8192 + 2048)));
  CHECK(!planes_share_cache_sets(target(1000, 8192)));
  CHECK(!planes_share_cache_sets(target(512, 8192)));
  // id_plane_address: the first address from `from` on, 2 KiB past the
  // depth plane modulo 4 KiB.
  for (uintptr_t depth : {uintptr_t(0x10000), uintptr_t(0x10040), uintptr_t(0x10ffc)})
    for (uintptr_t from = depth; from < depth + 3 * 4096; from += 4) {
      const uintptr_t at = id_plane_address(depth, from);
      CHECK(at >= from && at < from + 4096 && (at - depth) % 4096 == 2048);
    }
  for (int width : {1024, 2048}) {
    const DepthTarget t = target(width, size_t(width) * 2 * sizeof(float));
    const PlacedIds kept(t, /*allow_scratch=*/false);
    CHECK(!kept.scratch() && kept.plane() == t.triangle_id);
    const PlacedIds placed(t, /*allow_scratch=*/true);
    CHECK(placed.scratch());
    const uintptr_t apart =
        (reinterpret_cast<uintptr_t>(placed.plane()) - reinterpret_cast<uintptr_t>(t.depth)) % 4096;
    CHECK(apart == 2048);
    for (int i = 0; i < 2 * width; ++i) placed.plane()[i] = i;  // (ASan: in bounds)
    placed.finish();
    for (int i = 0; i < 2 * width; ++i) CHECK(t.triangle_id[i] == i);
  }
  // The scratch is kept after images of up to 2^24 pixels, freed after
  // larger ones (planes at one offset modulo 4 KiB: it is used).
  for (const int height : {16384, 16385}) {
    const size_t n = size_t(1024) * size_t(height);
    std::vector<float> planes(2 * n + 1024);
    float* depth = planes.data() + (1024 - reinterpret_cast<uintptr_t>(planes.data()) / 4 % 1024);
    const DepthTarget t{depth, reinterpret_cast<int32_t*>(depth + n), 1024, height};
    const PlacedIds placed(t, /*allow_scratch=*/true);
    CHECK(placed.scratch() && PlacedIds::thread_scratch_size() >= n);
    placed.finish();
    CHECK((PlacedIds::thread_scratch_size() > 0) == (n <= (size_t(1) << 24)));
  }
}

}  // namespace

int main() {
  test_ids_are_placed_apart_from_depth();
  test_scanline_polygons_cover_their_triangulation();
  test_every_algorithm_equals_the_plain_zbuffer();
  return check_report("test_algorithms");
}
