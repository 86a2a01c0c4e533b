// The bounding volume hierarchy of `hiz_bvh`: a binary tree over a mesh's
// triangles, rendered front to back by render_object_tree (object_tree.h)
// with the same node test as the octree.
#pragma once

#include "zbuffer/object_tree.h"
#include "zbuffer/types.h"

namespace zbuffer {

struct BvhParams {
  // A node with at most this many triangles is a leaf.
  int leaf_size = 1024;  // measured: spot grid and single meshes (benchmarks/README.md)
};

// Design decision: a linear BVH (Lauterbach et al. 2009; Karras 2012):
// triangles sorted by the Morton code of their centroid, each node split
// where the highest differing bit of its codes changes -- a spatial median
// split -- and at the middle when all codes are equal. Not the surface area
// heuristic: SAH trees are tighter and pay off for ray tracing, where every
// ray descends to leaves, but a Z-pyramid test culls whole subtrees and
// draws clusters of dozens of triangles, and SAH costs many times more to
// build, which matters when the tree is built per frame (`zbuffer.render`).
// Good: linear time after one radix sort, the same machinery as the octree.
// Bad: boxes are looser than SAH's where triangles are long and thin.
ObjectTree build_bvh(const MeshView& mesh, const BvhParams& params);
// The same into `tree`, reusing its memory (a tree rebuilt every frame).
void build_bvh(const MeshView& mesh, const BvhParams& params, ObjectTree& tree);

}  // namespace zbuffer
