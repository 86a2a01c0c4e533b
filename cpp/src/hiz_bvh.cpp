// `hiz_bvh`: the hierarchical Z-buffer with a bounding volume hierarchy in
// place of the octree. Through the registry the BVH is built for the frame
// (frame_tree.h: the build is part of the frame time) and rendered once;
// zbuffer.Scene builds bvh.h's instead, once.
#include <chrono>

#include "zbuffer/algorithms.h"
#include "zbuffer/frame_tree.h"
#include "zbuffer/object_tree.h"

namespace zbuffer {

void render_hiz_bvh(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  const auto t0 = std::chrono::steady_clock::now();
  // Rebuilt every frame into the same memory: this thread's last tree.
  thread_local ObjectTree tree;
  build_bvh_for_frame(input.mesh, BvhParams{}, tree);
  stats.build_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  thread_local TreeFrame frame;
  render_object_tree(tree, input, target, stats, frame);
}

}  // namespace zbuffer
