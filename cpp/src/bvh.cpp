// Linear BVH construction: Morton codes of centroids, one radix sort, then
// nodes split where the codes' highest differing bit changes.
#include "zbuffer/bvh.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "morton.h"

namespace zbuffer {

namespace {

class BvhBuilder {
 public:
  BvhBuilder(const MeshView& mesh, const BvhParams& params, ObjectTree& tree)
      : mesh_(mesh), params_(params), tree_(tree), clusters_(mesh, tree) {}

  void build() {
    // Centroids on the vertex grid (cubic cells, so that the nodes of a long
    // scene are not stretched along it: a node long in the viewing direction
    // has its nearest depth far in front of most of its triangles, and culls
    // late), sorted along the Z-order curve.
    thread_local VertexGrid grid;
    grid.build(mesh_);
    std::vector<uint64_t>& words = thread_scratch<uint64_t>();
    sorted_centroid_codes(grid, mesh_, words);
    unpack_words(words, codes_, faces_);
    clusters_.reserve(int64_t(codes_.size()));
    tree_.nodes.emplace_back();
    build_node(0, 0, int64_t(codes_.size()), 0);
    clusters_.finish();
  }

 private:
  // Node `index` holds the sorted faces [b, e).
  void build_node(int32_t index, int64_t b, int64_t e, int depth) {
    tree_.nodes[size_t(index)].depth = depth;
    tree_.nodes[size_t(index)].n_triangles = e - b;
    if (e - b <= params_.leaf_size) {
      clusters_.add_cluster(index, faces_.data() + b, e - b);
      return;
    }
    // Split where the highest bit in which the codes differ turns to 1 (all
    // codes of the range share the bits above it); equal codes: the middle.
    const uint32_t differ = codes_[size_t(b)] ^ codes_[size_t(e - 1)];
    int64_t mid = b + (e - b) / 2;
    if (differ) {
      const uint32_t bit = 1u << (31 - __builtin_clz(differ));
      mid = std::partition_point(codes_.begin() + b, codes_.begin() + e,
                                 [bit](uint32_t c) { return !(c & bit); }) -
            codes_.begin();
    }
    const int32_t first = add_children(tree_, index, 2);
    build_node(first, b, mid, depth + 1);
    build_node(first + 1, mid, e, depth + 1);
    merge_child_bounds(tree_, index);
  }

  const MeshView& mesh_;
  const BvhParams& params_;
  ObjectTree& tree_;
  ClusterBuilder clusters_;
  std::vector<uint32_t>& codes_ = thread_scratch<uint32_t>();  // sorted centroid codes
  std::vector<int32_t>& faces_ = thread_scratch<int32_t>();    // and their faces
};

}  // namespace

void build_bvh(const MeshView& mesh, const BvhParams& params, ObjectTree& tree) {
  if (params.leaf_size < 1)
    throw std::invalid_argument("leaf_size must be >= 1, got " + std::to_string(params.leaf_size));
  tree.clear();
  tree.shared = false;
  if (mesh.n_faces == 0) return;
  BvhBuilder(mesh, params, tree).build();
}

ObjectTree build_bvh(const MeshView& mesh, const BvhParams& params) {
  ObjectTree tree;
  build_bvh(mesh, params, tree);
  return tree;
}

}  // namespace zbuffer
