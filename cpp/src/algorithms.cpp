// The registry and the common render entry point.
#include "zbuffer/algorithms.h"

#include <algorithm>
#include <chrono>
#include <limits>

namespace zbuffer {

const std::vector<Algorithm>& algorithms() {
  static const std::vector<Algorithm> registry = {
      {"zbuffer", "plain Z-buffer: every triangle, every pixel of its box", &render_zbuffer},
      {"hiz", "hierarchical Z-buffer: triangles and 8x8 tiles tested against a Z-pyramid",
       &render_hiz, /*polygons=*/false, /*pyramid=*/true},
      {"scanline",
       "scanline Z-buffer: sorted polygon and edge tables, active lists, one row of depth",
       &render_scanline, /*polygons=*/true},
      {"hiz_octree", "hierarchical Z-buffer over an object-space octree, front to back",
       &render_hiz_octree, /*polygons=*/false, /*pyramid=*/true},
      {"hiz_bvh", "hierarchical Z-buffer over a bounding volume hierarchy, nearest child first",
       &render_hiz_bvh, /*polygons=*/false, /*pyramid=*/true},
  };
  return registry;
}

const Algorithm* find_algorithm(const std::string& name) {
  for (const Algorithm& a : algorithms())
    if (name == a.name) return &a;
  return nullptr;
}

std::string algorithm_names() {
  std::string names;
  for (const Algorithm& a : algorithms()) {
    if (!names.empty()) names += ", ";
    names += '"';
    names += a.name;
    names += '"';
  }
  return names;
}

void clear_target(DepthTarget& target) {
  const size_t n = size_t(target.width) * size_t(target.height);
  std::fill_n(target.depth, n, std::numeric_limits<float>::infinity());
  std::fill_n(target.triangle_id, n, int32_t(-1));
}

void render(const Algorithm& algorithm, const RenderInput& input,
            DepthTarget& target, RenderStats& stats) {
  const auto start = std::chrono::steady_clock::now();
  clear_target(target);
  stats.triangles_in += input.mesh.n_faces;
  algorithm.render(input, target, stats);
  // Algorithms that keep less (or more) than the W x H depth buffer say so.
  if (stats.depth_storage_bytes == 0)
    stats.depth_storage_bytes = int64_t(target.width) * target.height * int64_t(sizeof(float));
  const auto stop = std::chrono::steady_clock::now();
  stats.total_ms += std::chrono::duration<double, std::milli>(stop - start).count();
}

}  // namespace zbuffer
