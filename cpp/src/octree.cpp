// Octree construction: keys, one radix sort, nodes read off the sorted keys.
#include "zbuffer/octree.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "morton.h"

namespace zbuffer {

const char* octree_rule_name(OctreeRule rule) {
  switch (rule) {
    case OctreeRule::kSmallest: return "smallest";
    case OctreeRule::kGreene: return "greene";
    case OctreeRule::kLoose: return "loose";
  }
  return "?";
}

bool parse_octree_rule(const std::string& name, OctreeRule& rule) {
  if (name == "smallest") rule = OctreeRule::kSmallest;
  else if (name == "greene") rule = OctreeRule::kGreene;
  else if (name == "loose") rule = OctreeRule::kLoose;
  else return false;
  return true;
}

namespace {

static_assert(kMaxOctreeDepth <= OctreeCells::kMaxDepth, "cell numbers must fit 31 bits");

// Design decision: a reference's key is the pre-order number of its cell in
// the complete octree of depth max_depth (OctreeCells), not the cell's
// Morton code and level. Sorted, a cell's own references come first and
// each child's subtree follows, in Morton order, as with (code, level)
// keys -- but a number fits 31 bits, so a reference sorts as one 64-bit
// word (number above face) and a node's children are the runs of numbers
// of their subtrees. Good: the radix sort moves 8 bytes per reference
// instead of 12 (a 35-bit key and a face) for any number of faces, and the
// keys of 16 faces are computed at once in AVX-512 builds, 8 in AVX2 ones (with branch-free
// cluster copies, object_tree.cpp, the Scene octree of the 5 x 5 x 20 spot
// grid builds in about 0.77x the time). Bad: a number is a sum over the
// cell's octal digits, not a bit pattern.
class OctreeBuilder {
 public:
  OctreeBuilder(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree)
      : mesh_(mesh), params_(params), tree_(tree), clusters_(mesh, tree),
        cells_(params.max_depth, params.rule == OctreeRule::kLoose) {}

  void build() {
    make_keys();
    radix_sort_bits(words_, 32, cells_.bits());
    unpack_words(words_, keys_, faces_);
    clusters_.reserve(int64_t(keys_.size()));
    tree_.nodes.emplace_back();
    build_node(0, 0, int64_t(keys_.size()), 0, 0);
    clusters_.finish();
  }

 private:
  // Keys: words_ gets (number of the cell << 32 | face) for each reference.
  void make_keys() {
    const int64_t n = mesh_.n_faces;
    // Cells of the finest level: the vertex grid's 1024 a side, coarsened.
    thread_local VertexGrid grid;
    grid.build(mesh_);
    words_.clear();
    if (params_.rule != OctreeRule::kGreene) {
      // One reference per face: the cell that holds it.
      face_words(grid, mesh_, cells_, words_);
      return;
    }
    // Greene's rule: the deepest level where the box spans at most two
    // cells a side, and every cell it overlaps there.
    const int depth = params_.max_depth;
    const int coarsen = VertexGrid::kBits - depth;
    words_.reserve(size_t(n) * 2);
    for (int64_t f = 0; f < n; ++f) {
      uint32_t lo[3], hi[3];
      face_cells(grid, mesh_.faces + 3 * f, lo, hi);
      uint32_t q_lo[3], q_hi[3];
      for (int a = 0; a < 3; ++a) {
        q_lo[a] = lo[a] >> coarsen;
        q_hi[a] = hi[a] >> coarsen;
      }
      int s = 0;
      while (s < depth && ((q_hi[0] >> s) - (q_lo[0] >> s) > 1 || (q_hi[1] >> s) - (q_lo[1] >> s) > 1 ||
                           (q_hi[2] >> s) - (q_lo[2] >> s) > 1))
        ++s;
      if (s == depth) {  // only the root holds it (it spans the whole cube)
        words_.push_back(uint32_t(f));
        continue;
      }
      for (uint32_t z = q_lo[2] >> s; z <= q_hi[2] >> s; ++z)
        for (uint32_t y = q_lo[1] >> s; y <= q_hi[1] >> s; ++y)
          for (uint32_t x = q_lo[0] >> s; x <= q_hi[0] >> s; ++x)
            words_.push_back(uint64_t(cells_.number(x, y, z, depth - s)) << 32 | uint32_t(f));
    }
  }

  // Nodes
  // Node `index` is cell number `cell` at `level` and holds the references
  // [b, e), those of the cell's subtree. It is a leaf if they name at most
  // leaf_size faces (under Greene's rule a face may be referenced from
  // several of its cells; a leaf keeps it once). Its n_triangles is set
  // once its clusters are: the references its subtree's clusters hold.
  void build_node(int32_t index, int64_t b, int64_t e, int level, uint32_t cell) {
    tree_.nodes[size_t(index)].depth = level;
    if (distinct_faces(index, b, e) <= params_.leaf_size || level == params_.max_depth) {
      clusters_.add_cluster(index, faces_.data() + b, e - b);  // a leaf: the whole subtree
      tree_.nodes[size_t(index)].n_triangles = own_references(index);
      return;
    }
    const auto key = [this](int64_t r) { return keys_.begin() + r; };
    const int64_t own_end = std::upper_bound(key(b), key(e), cell) - keys_.begin();
    if (own_end > b) clusters_.add_cluster(index, faces_.data() + b, own_end - b);

    // Children: the nonempty runs of the eight subtrees, in Morton order.
    const uint32_t subtree = uint32_t(cells_.subtree(level + 1));
    int64_t start[9];
    uint32_t child_cell[8];
    int n = 0;
    for (int64_t r = own_end; r < e;) {
      const uint32_t first = cell + 1 + (keys_[size_t(r)] - cell - 1) / subtree * subtree;
      start[n] = r;
      child_cell[n++] = first;
      r = std::lower_bound(key(r), key(e), first + subtree) - keys_.begin();
    }
    start[n] = e;
    const int32_t first = add_children(tree_, index, n);
    int64_t references = own_references(index);
    for (int k = 0; k < n; ++k) {
      build_node(first + k, start[k], start[k + 1], level + 1, child_cell[k]);
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
  const OctreeCells cells_;
  std::vector<uint64_t>& words_ = thread_scratch<uint64_t>();  // cell number << 32 | face, sorted
  std::vector<uint32_t>& keys_ = thread_scratch<uint32_t>();   // then each reference's cell number
  std::vector<int32_t>& faces_ = thread_scratch<int32_t>();    // and its face
  std::vector<int32_t> mark_;  // Greene's rule: per face, the last node that counted it
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
