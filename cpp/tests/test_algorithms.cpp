// Every registered algorithm produces the plain Z-buffer's bits, on random
// scenes with heavy occlusion (so that hierarchical culling really happens).
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "check.h"
#include "zbuffer/algorithms.h"

using namespace zbuffer;

namespace {


void test_every_algorithm_equals_the_plain_zbuffer() {
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
    for (const Algorithm& algo : algorithms()) {
      std::vector<float> depth(size_t(w) * h);
      std::vector<int32_t> ids(size_t(w) * h);
      DepthTarget target{depth.data(), ids.data(), w, h};
      RenderStats stats;
      render(algo, input, target, stats);
      CHECK(std::memcmp(depth.data(), ref_depth.data(), depth.size() * sizeof(float)) == 0);
      CHECK(ids == ref_ids);
      CHECK(stats.rasterized + stats.culled_hidden == ref_stats.rasterized);
      if (std::string(algo.name) == "hiz") CHECK(stats.culled_hidden > 0);
      if (std::string(algo.name) == "scanline") {
        // Spans are exact: every pixel tested is covered, and the pixels
        // covered are the plain Z-buffer's (which tests whole boxes).
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
}

}  // namespace

int main() {
  test_every_algorithm_equals_the_plain_zbuffer();
  return check_report("test_algorithms");
}
