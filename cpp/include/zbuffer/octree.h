// The octree of the hierarchical Z-buffer (Greene, Kass and Miller 1993,
// section 4): a world-space octree over a mesh's triangles, built once per
// scene and rendered front to back by render_object_tree (object_tree.h).
#pragma once

#include <string>

#include "zbuffer/object_tree.h"
#include "zbuffer/types.h"

namespace zbuffer {

// Which node a triangle goes to: the rules differ on triangles that
// straddle the boundary between two children.
enum class OctreeRule {
  // The simpler rule: the triangle stays in the smallest node that encloses
  // it. Each triangle has one home, but one crossing a split plane near the
  // root is drawn whenever the root is visited, however small it is.
  kSmallest,
  // Greene's rule: a triangle is put in the cells of the deepest level at
  // which it spans at most two cells a side -- every one of the (at most 8)
  // cells it overlaps there -- and drawn at most once per frame.
  kGreene,
  // The loose octree's rule (Ulrich, "Loose octrees", Game Programming Gems,
  // 2000): a triangle goes to the cell of its centroid (on the vertex grid:
  // the mean of its corners' cells, rounded down) at the deepest level
  // whose cells are at least as wide as the triangle's box. Each triangle
  // has one home, and only a large one a coarse home, however it lies
  // across the split planes; a cell's triangles may reach out of it (by
  // less than its width), which node bounds -- those of their triangles --
  // take in.
  kLoose,
};

// "smallest", "greene" or "loose"; parse returns false for an unknown name.
const char* octree_rule_name(OctreeRule rule);
bool parse_octree_rule(const std::string& name, OctreeRule& rule);

struct OctreeParams {
  // A node whose subtree holds at most this many distinct faces is a leaf
  // (Greene's rule may reference a face from several of its cells).
  int leaf_size = 1024;  // measured: spot grid and single meshes (benchmarks/README.md)
  // Depth of the finest cells (the root is depth 0): cells of the root cube
  // divided 2^max_depth times a side. 1 .. kMaxOctreeDepth.
  int max_depth = 10;
  // The loose rule: on the spot grid and single meshes, per frame 8-15%
  // faster than the simpler rule, built once up to 10% (benchmarks/README.md).
  OctreeRule rule = OctreeRule::kLoose;
};

constexpr int kMaxOctreeDepth = 10;  // cells are numbered below 2^31 (1024 a side)

// Design decision: the octree is built from a sort, not by inserting
// triangles one by one. Each triangle reference gets a key -- the number of
// its cell in the pre-order of the complete octree of depth max_depth -- and
// one radix sort puts every node's own references first and its subtree
// right after them; the nodes are then read off the sorted keys. Node bounds are
// the bounds of the node's triangles, not its cube, so a node that holds one
// small triangle in a large cell culls like the triangle. Good: linear-time
// build (no pointer chasing, no per-node allocation), tight bounds. Bad: a
// depth limit of 10 (1024 cells a side), and the nodes of a cell's subtree
// must all be built at once.
ObjectTree build_octree(const MeshView& mesh, const OctreeParams& params);
// The same into `tree`, reusing its memory (a tree rebuilt every frame).
void build_octree(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree);

}  // namespace zbuffer
