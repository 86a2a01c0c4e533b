// `hiz_octree`: the hierarchical Z-buffer with its object-space octree
// (Greene, Kass and Miller 1993, section 4). Through the registry the octree
// is built for the frame (frame_tree.h: the build is part of the frame
// time) and rendered once; zbuffer.Scene builds octree.h's instead, once.
#include "zbuffer/algorithms.h"
#include "zbuffer/frame_tree.h"
#include "zbuffer/object_tree.h"

namespace zbuffer {

void render_hiz_octree(const RenderInput& input, DepthTarget& target, RenderStats& stats) {
  render_built_per_frame(input, target, stats, [](const MeshView& mesh, ObjectTree& tree) {
    OctreeParams params;
    params.leaf_size = frame_leaf_size(mesh.n_faces);
    build_octree_for_frame(mesh, params, tree);
  });
}

}  // namespace zbuffer
