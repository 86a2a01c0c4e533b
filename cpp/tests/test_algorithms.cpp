// Every registered algorithm produces the plain Z-buffer's bits, on random
// scenes with heavy occlusion (so that hierarchical culling really happens).
#include <cmath>
#include <map>
#include <cstring>
#include <string>
#include <vector>

#include "check.h"
#include "zbuffer/algorithms.h"

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
    for (const Algorithm& algo : algorithms()) {
      std::vector<float> depth(size_t(w) * h);
      std::vector<int32_t> ids(size_t(w) * h);
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
      if (std::string(algo.name) != "zbuffer") CHECK(stats.culled_hidden > 0);
      nodes_hidden[algo.name] += stats.nodes_hidden;
    }
  }
  // The object-space algorithms cull whole nodes on these scenes.
  CHECK(nodes_hidden["hiz_octree"] > 0);
  CHECK(nodes_hidden["hiz_bvh"] > 0);
}

}  // namespace

int main() {
  test_every_algorithm_equals_the_plain_zbuffer();
  return check_report("test_algorithms");
}
