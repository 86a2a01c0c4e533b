// Octree construction: keys, one radix sort, nodes read off the sorted keys.
#include "zbuffer/octree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "morton.h"

namespace zbuffer {

const char* octree_rule_name(OctreeRule rule) {
  return rule == OctreeRule::kGreene ? "greene" : "smallest";
}

bool parse_octree_rule(const std::string& name, OctreeRule& rule) {
  if (name == "smallest") rule = OctreeRule::kSmallest;
  else if (name == "greene") rule = OctreeRule::kGreene;
  else return false;
  return true;
}

namespace {

// A reference's key: the Morton code of its cell's first finest cell, then
// its level in 5 bits. Sorted, a cell's own references come first (lowest
// level at the same code) and its subtree follows, children in Morton order.
constexpr int kLevelBits = 5;
inline uint64_t make_key(uint32_t x, uint32_t y, uint32_t z, int level) {
  return (uint64_t(morton_30(x, y, z)) << kLevelBits) | uint64_t(level);
}
inline int level_of(uint64_t key) { return int(key & ((1u << kLevelBits) - 1)); }

class OctreeBuilder {
 public:
  OctreeBuilder(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree)
      : mesh_(mesh), params_(params), tree_(tree), clusters_(mesh, tree) {}

  void build() {
    make_keys();
    radix_sort(keys_, faces_, 3 * params_.max_depth + kLevelBits);
    clusters_.reserve(int64_t(keys_.size()));
    tree_.nodes.emplace_back();
    build_node(0, 0, int64_t(keys_.size()), 0);
    clusters_.finish();
  }

 private:
  // Keys
  void make_keys() {
    const int64_t n = mesh_.n_faces;
    const int depth = params_.max_depth;
    // Cells of the finest level: the vertex grid's 1024 a side, coarsened.
    thread_local VertexGrid grid;
    grid.build(mesh_);
    const int coarsen = VertexGrid::kBits - depth;

    const bool greene = params_.rule == OctreeRule::kGreene;
    keys_.clear();
    faces_.clear();
    keys_.reserve(size_t(n) * (greene ? 2 : 1));
    faces_.reserve(keys_.capacity());
    for (int64_t f = 0; f < n; ++f) {
      const int32_t* idx = mesh_.faces + 3 * f;
      const uint32_t c0 = grid.cell[size_t(idx[0])], c1 = grid.cell[size_t(idx[1])],
                     c2 = grid.cell[size_t(idx[2])];
      uint32_t q_lo[3], q_hi[3];
      for (int a = 0; a < 3; ++a) {
        const uint32_t v0 = VertexGrid::axis(c0, a), v1 = VertexGrid::axis(c1, a),
                       v2 = VertexGrid::axis(c2, a);
        q_lo[a] = std::min({v0, v1, v2}) >> coarsen;
        q_hi[a] = std::max({v0, v1, v2}) >> coarsen;
      }
      if (!greene) {
        // The smallest enclosing cell: the level where the box's corner
        // cells stop sharing their high bits.
        const uint32_t differ = (q_lo[0] ^ q_hi[0]) | (q_lo[1] ^ q_hi[1]) | (q_lo[2] ^ q_hi[2]);
        const int s = differ ? 32 - __builtin_clz(differ) : 0;  // bits below the common prefix
        add(q_lo[0] >> s << s, q_lo[1] >> s << s, q_lo[2] >> s << s, depth - s, int32_t(f));
        continue;
      }
      // Greene's rule: the deepest level where the box spans at most two
      // cells a side, and every cell it overlaps there.
      int s = 0;
      while (s < depth && ((q_hi[0] >> s) - (q_lo[0] >> s) > 1 || (q_hi[1] >> s) - (q_lo[1] >> s) > 1 ||
                           (q_hi[2] >> s) - (q_lo[2] >> s) > 1))
        ++s;
      if (s == depth) {  // only the root holds it (it spans the whole cube)
        add(0, 0, 0, 0, int32_t(f));
        continue;
      }
      for (uint32_t z = q_lo[2] >> s; z <= q_hi[2] >> s; ++z)
        for (uint32_t y = q_lo[1] >> s; y <= q_hi[1] >> s; ++y)
          for (uint32_t x = q_lo[0] >> s; x <= q_hi[0] >> s; ++x)
            add(x << s, y << s, z << s, depth - s, int32_t(f));
    }
  }

  void add(uint32_t x, uint32_t y, uint32_t z, int level, int32_t face) {
    keys_.push_back(make_key(x, y, z, level));
    faces_.push_back(face);
  }

  // Nodes
  // Node `index` holds the references [b, e), all inside its cell at `level`.
  // It is a leaf if they name at most leaf_size faces (under Greene's rule a
  // face may be referenced from several of its cells; a leaf keeps it once).
  // Its n_triangles is set once its clusters are: the references its
  // subtree's clusters hold.
  void build_node(int32_t index, int64_t b, int64_t e, int level) {
    tree_.nodes[size_t(index)].depth = level;
    if (distinct_faces(index, b, e) <= params_.leaf_size || level == params_.max_depth) {
      clusters_.add_cluster(index, faces_.data() + b, e - b);  // a leaf: the whole subtree
      tree_.nodes[size_t(index)].n_triangles = own_references(index);
      return;
    }
    int64_t own_end = b;
    while (own_end < e && level_of(keys_[size_t(own_end)]) == level) ++own_end;
    if (own_end > b) clusters_.add_cluster(index, faces_.data() + b, own_end - b);

    // Children: runs of equal 3-bit child codes, in Morton order.
    const int shift = kLevelBits + 3 * (params_.max_depth - level - 1);
    int64_t start[9];
    int n = 0;
    for (int64_t r = own_end; r < e;) {
      const uint64_t code = (keys_[size_t(r)] >> shift) & 7;
      start[n++] = r;
      r = std::partition_point(keys_.begin() + r, keys_.begin() + e,
                               [&](uint64_t k) { return ((k >> shift) & 7) == code; }) -
          keys_.begin();
    }
    start[n] = e;
    const int32_t first = add_children(tree_, index, n);
    int64_t references = own_references(index);
    for (int k = 0; k < n; ++k) {
      build_node(first + k, start[k], start[k + 1], level + 1);
      references += tree_.nodes[size_t(first + k)].n_triangles;
    }
    tree_.nodes[size_t(index)].n_triangles = references;
    merge_child_bounds(tree_, index);
  }

  // How many faces references [b, e) name: e - b, or under Greene's rule
  // (where one face may have several) the distinct ones, marked with the
  // node's index.
  int64_t distinct_faces(int32_t index, int64_t b, int64_t e) {
    if (!tree_.shared) return e - b;
    if (mark_.size() != size_t(mesh_.n_faces)) mark_.assign(size_t(mesh_.n_faces), -1);
    int64_t n = 0;
    for (int64_t r = b; r < e; ++r) {
      int32_t& m = mark_[size_t(faces_[size_t(r)])];
      n += m != index;
      m = index;
    }
    return n;
  }

  // The references of node `index`'s own cluster (0 without one).
  int64_t own_references(int32_t index) const {
    const int32_t c = tree_.nodes[size_t(index)].cluster;
    if (c < 0) return 0;
    const TriangleCluster& cl = tree_.clusters[size_t(c)];
    return cl.face_end - cl.face_begin;
  }

  const MeshView& mesh_;
  const OctreeParams& params_;
  ObjectTree& tree_;
  ClusterBuilder clusters_;
  // Scratch, kept per thread from build to build (no page faults anew).
  std::vector<uint64_t>& keys_ = scratch_keys();
  std::vector<int32_t>& faces_ = scratch_faces();
  std::vector<int32_t> mark_;  // Greene's rule: per face, the last node that counted it
  static std::vector<uint64_t>& scratch_keys() {
    thread_local std::vector<uint64_t> v;
    return v;
  }
  static std::vector<int32_t>& scratch_faces() {
    thread_local std::vector<int32_t> v;
    return v;
  }
};

}  // namespace

void build_octree(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree) {
  if (params.leaf_size < 1)
    throw std::invalid_argument("leaf_size must be >= 1, got " + std::to_string(params.leaf_size));
  if (params.max_depth < 1 || params.max_depth > kMaxOctreeDepth)
    throw std::invalid_argument("max_depth must be in 1 .. " + std::to_string(kMaxOctreeDepth) +
                                ", got " + std::to_string(params.max_depth));
  tree.clear();
  tree.shared = params.rule == OctreeRule::kGreene;
  if (mesh.n_faces == 0) return;
  OctreeBuilder(mesh, params, tree).build();
}

ObjectTree build_octree(const MeshView& mesh, const OctreeParams& params) {
  ObjectTree tree;
  build_octree(mesh, params, tree);
  return tree;
}

}  // namespace zbuffer
