// The registry and the common render entry point.
#include "zbuffer/algorithms.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <limits>

#include "zbuffer/buffer.h"

namespace zbuffer {

const std::vector<Algorithm>& algorithms() {
  static const std::vector<Algorithm> registry = {
      {"zbuffer",
       "plain Z-buffer: every triangle, every pixel of its box (exact spans for large ones)",
       &render_zbuffer},
      {"hiz", "hierarchical Z-buffer: triangles and 8x8 tiles tested against a Z-pyramid",
       &render_hiz, /*polygons=*/false, /*pyramid=*/true},
      {"scanline",
       "scanline Z-buffer: sorted polygon and edge tables, active lists, one row of depth",
       &render_scanline, /*polygons=*/true, /*pyramid=*/false, /*row_by_row=*/true},
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
  for_each_run(size_t(target.width), size_t(target.height), target.row_pitch(),
               [&](size_t at, size_t n) {
                 std::fill_n(target.depth + at, n, std::numeric_limits<float>::infinity());
                 std::fill_n(target.triangle_id + at, n, int32_t(-1));
               });
}

bool planes_share_cache_sets(const DepthTarget& target) {
  constexpr uintptr_t kPage = 4096, kNear = 512;
  // (Padded rows, whose pitch is never a multiple of 1024, have their own
  // remedy: types.h, padded_pitch.)
  if (target.row_pitch() != size_t(target.width) || target.width % 1024 != 0) return false;
  const uintptr_t apart = (reinterpret_cast<uintptr_t>(target.triangle_id) -
                           reinterpret_cast<uintptr_t>(target.depth)) % kPage;
  return apart < kNear || apart > kPage - kNear;
}

namespace {
// PlacedIds' scratch plane: kept for the next frame after images of up to
// 2^24 pixels (4096 x 4096), freed after larger ones.
thread_local Buffer<int32_t> id_scratch;
constexpr size_t kKeptPixels = size_t(1) << 24;
}  // namespace

PlacedIds::PlacedIds(const DepthTarget& target, bool allow_scratch)
    : ids_(target.triangle_id), plane_(target.triangle_id),
      pixels_(size_t(target.width) * size_t(target.height)) {
  if (!allow_scratch || pixels_ == 0 || !planes_share_cache_sets(target)) return;
  Buffer<int32_t>& scratch = id_scratch;
  constexpr size_t kSlack = 4096 / sizeof(int32_t);  // ids, room for the placement below
  if (scratch.size() < pixels_ + kSlack) scratch.resize(pixels_ + kSlack);
  // (Both planes are 4-byte aligned: the placed plane is too.)
  plane_ = reinterpret_cast<int32_t*>(id_plane_address(
      reinterpret_cast<uintptr_t>(target.depth), reinterpret_cast<uintptr_t>(scratch.data())));
}

void PlacedIds::finish() const {
  if (!scratch()) return;
  std::memcpy(ids_, plane_, pixels_ * sizeof(int32_t));
  if (pixels_ > kKeptPixels) Buffer<int32_t>().swap(id_scratch);
}

size_t PlacedIds::thread_scratch_size() { return id_scratch.size(); }

void render(const Algorithm& algorithm, const RenderInput& input,
            DepthTarget& target, RenderStats& stats) {
  const auto start = std::chrono::steady_clock::now();
  stats.triangles_in += input.mesh.n_faces;
  draw_cleared(target, !algorithm.row_by_row,
               [&](DepthTarget& drawn) { algorithm.render(input, drawn, stats); });
  // Algorithms that keep less (or more) than the W x H depth buffer say so.
  if (stats.depth_storage_bytes == 0)
    stats.depth_storage_bytes = int64_t(target.width) * target.height * int64_t(sizeof(float));
  const auto stop = std::chrono::steady_clock::now();
  stats.total_ms += std::chrono::duration<double, std::milli>(stop - start).count();
}

}  // namespace zbuffer
