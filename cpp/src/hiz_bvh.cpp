// `hiz_bvh`: the hierarchical Z-buffer with a bounding volume hierarchy in
// place of the octree. Through the registry the BVH is built for the frame
// (frame_tree.h: the build is part of the frame time) and rendered once;
// zbuffer.Scene builds bvh.h's instead, once.
#include "zbuffer/algorithms.h"
#include "zbuffer/frame_tree.h"
#include "zbuffer/object_tree.h"

namespace zbuffer {

void render_hiz_bvh(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  render_built_per_frame(input, target, stats, [](const MeshView& mesh, ObjectTree& tree) {
    BvhParams params;
    params.leaf_size = frame_leaf_size(mesh.n_faces);
    build_bvh_for_frame(mesh, params, tree);
  });
}

}  // namespace zbuffer
