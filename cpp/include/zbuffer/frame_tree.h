// Trees built for one frame: the octree and BVH that `zbuffer.render`
// builds in every call of `hiz_octree` and `hiz_bvh` (the registry path),
// where the build is part of the frame time.
#pragma once

#include <algorithm>
#include <cstdint>

#include "zbuffer/bvh.h"
#include "zbuffer/object_tree.h"
#include "zbuffer/octree.h"
#include "zbuffer/types.h"

namespace zbuffer {

// Design decision: one counting sort instead of a radix sort and a
// recursive split. Every face gets a bucket -- for the octree, the node of a
// complete octree of depth T that holds it by params.rule (numbered in
// pre-order, so a subtree is a contiguous run of buckets and a node's own
// faces come first);
// for the BVH, the top 3T bits of its centroid's Morton code -- one pass
// counts them and bounds each bucket's faces on the vertex grid, a second
// lists the faces' indices in bucket order (the tree's `order`), and the
// nodes are read off the bucket counts. The tree is `indexed`
// (object_tree.h): its clusters are runs of that list, over the mesh's own
// faces and vertices; drawing a cluster gathers its faces (or, for most of
// an octree's, reads them where they lie in the mesh: below). T grows with the
// mesh (about leaf_size triangles per cell a closed surface crosses), up to
// 6. Good: two passes over the faces, nothing sorted, 4 bytes written per
// face -- and when the faces already come in bucket order with their ids
// (the BVH of a mesh in spatial order: Mesh.prepare's order is the same
// Morton code; so is, under the loose rule, the octree of one whose faces
// are all narrower than a depth-T cell), no second pass: the clusters are
// runs of the caller's own arrays (9-13% off the per-frame BVH on the spot
// grid). Listing indices
// instead of copying the faces and ids (16 bytes a face) took 5-13% off the
// per-frame octree from the 5 x 5 x 20 spot grid up (memory traffic: the
// copy was a third of the build; N = 10 and single meshes within noise),
// though gathering the faces of the clusters drawn gives back part of it.
// So an octree's cluster whose faces lie in a stretch of the mesh's own
// order at most twice its size -- a cell of a mesh in spatial order, among
// the few faces of coarser nodes -- is drawn from that
// stretch, the faces of other buckets masked off by a compare per 16 (8 in
// AVX2 builds): on the spot grids 2-4% less per frame (benchmarks/ab.py;
// 0-2% in AVX2 builds), single meshes within noise. The tree keeps each
// face's bucket, and the build counts each bucket's first and last face.
// Bad: leaves can only be as fine as depth T (a dense cell is one large
// leaf), and bounds are those of grid cells, up to two cells looser than the
// triangles'.
// The face pass (each face's bucket and box) runs 16 faces per instruction
// in AVX-512 builds and 8 in AVX2 ones, the listing in bucket order 16 in
// AVX-512 builds (one by one otherwise); `vector = false` runs the
// scalar loops instead (tests hold the two to the same tree). The octree
// reads params' leaf_size, max_depth and rule, the loose or the simpler one
// (a face has one bucket: Greene's rule, which gives it several cells, is
// refused with std::invalid_argument).
void build_octree_for_frame(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree,
                            bool vector = true);
void build_bvh_for_frame(const MeshView& mesh, const BvhParams& params, ObjectTree& tree,
                         bool vector = true);

// The depth T used for a mesh of `faces` faces and the given leaf size.
int frame_tree_depth(int64_t faces, int leaf_size);

// The leaf size the registry's per-frame trees (octree and BVH) aim at, by
// mesh size: 128 triangles up to 20,480 faces, then faces / 160 (the depth
// stays at 3), up to 8192 (from 1,310,720 faces on). A tree built every
// frame pays for its depth within the frame: one level shallower (fewer,
// fuller clusters) wins on large meshes, loses on small ones that need the
// level; on the orthographic grid, where nodes are seldom hidden whole,
// shallow trees win most. The measurements behind each bound:
// benchmarks/README.md, "Leaf size of the per-frame trees by mesh size" and
// "The per-frame BVH's leaves".
inline int frame_leaf_size(int64_t faces) {
  return int(std::min<int64_t>(8192, std::max<int64_t>(128, faces / 160)));
}

}  // namespace zbuffer
