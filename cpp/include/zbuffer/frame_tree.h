// Trees built for one frame: the octree and BVH that `zbuffer.render`
// builds in every call of `hiz_octree` and `hiz_bvh` (the registry path),
// where the build is part of the frame time.
#pragma once

#include "zbuffer/bvh.h"
#include "zbuffer/object_tree.h"
#include "zbuffer/octree.h"
#include "zbuffer/types.h"

namespace zbuffer {

// Design decision: one counting sort instead of a radix sort and a
// recursive split. Every face gets a bucket -- for the octree, the node of a
// complete octree of depth T that encloses it (numbered in pre-order, so a
// subtree is a contiguous run of buckets and a node's own faces come first);
// for the BVH, the top 3T bits of its centroid's Morton code -- one pass
// counts them and bounds each bucket's faces on the vertex grid, a second
// scatters the faces into bucket order, and the nodes are read off the
// bucket counts. The tree is `indexed` (object_tree.h): its clusters are
// runs of the mesh's faces over the mesh's own vertices. T grows
// with the mesh (about leaf_size triangles per cell a closed surface
// crosses), up to 6. Good: two passes over the faces, nothing sorted, no vertex
// copied -- and when the faces already come in bucket order with their ids
// (the BVH of a mesh in spatial order: Mesh.prepare's order is the same
// Morton code), no second pass: the clusters are runs of the caller's own
// arrays (9-13% off the per-frame BVH on the spot grid). Bad: leaves can
// only be as fine as depth T (a dense cell is one large leaf), and bounds
// are those of grid cells, up to two cells looser than the triangles'.
// The face pass (each face's bucket and box) and the copy into bucket order
// run 16 faces per instruction in AVX-512 builds; `vector = false` runs the
// scalar loops instead (tests hold the two to the same tree).
void build_octree_for_frame(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree,
                            bool vector = true);
void build_bvh_for_frame(const MeshView& mesh, const BvhParams& params, ObjectTree& tree,
                         bool vector = true);

// The depth T used for a mesh of `faces` faces and the given leaf size.
int frame_tree_depth(int64_t faces, int leaf_size);

// The leaf size the registry's per-frame trees aim at: smaller than a
// Scene's (512), as measured. A tree built every frame pays for its depth
// within the frame: the depth this gives (one level deeper than 512 from
// about 1,500 to 1.57M faces) is up to 8% faster on small single meshes
// (spot, dragon_20k) and equal on the spot grid from N = 20 up, where T is
// capped at 6 either way (benchmarks/README.md).
constexpr int kFrameLeafSize = 128;

}  // namespace zbuffer
