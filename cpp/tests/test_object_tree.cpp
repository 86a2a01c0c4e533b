// Octree and BVH structure: every face is in the tree, node bounds contain
// their triangles and their children, and Greene's rule draws a face that
// several cells share at most once per frame.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <vector>

#include "../src/morton.h"
#include "check.h"
#include "spatial.h"
#include "zbuffer/algorithms.h"
#include "zbuffer/bvh.h"
#include "zbuffer/frame_tree.h"
#include "zbuffer/object_tree.h"
#include "zbuffer/octree.h"

using namespace zbuffer;

namespace {

struct Soup {
  std::vector<double> pos;
  std::vector<int32_t> faces;
  MeshView view() const {
    return {pos.data(), int64_t(pos.size() / 3), faces.data(), int64_t(faces.size() / 3)};
  }
};

// Triangles of mixed sizes (a few spanning most of the box) in [-1, 1]^3.
Soup random_soup(uint64_t seed, int n) {
  Lcg next{seed};
  Soup s;
  for (int t = 0; t < n; ++t) {
    const double r = t % 50 == 0 ? 1.0 : next.uniform(0.001, 0.1);
    const double c[3] = {next.uniform(-1, 1), next.uniform(-1, 1), next.uniform(-1, 1)};
    for (int k = 0; k < 3; ++k) {
      for (int a = 0; a < 3; ++a) s.pos.push_back(std::clamp(c[a] + next.uniform(-r, r), -1.0, 1.0));
      s.faces.push_back(int32_t(s.faces.size()));
    }
  }
  return s;
}

// A wavy sheet of (n - 1)^2 quads in [-1, 1]^3, two triangles each, listed
// row by row: neighbouring faces follow each other, as in real meshes.
Soup wavy_sheet(int n) {
  Soup s;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = 2.0 * i / (n - 1) - 1.0, y = 2.0 * j / (n - 1) - 1.0;
      s.pos.insert(s.pos.end(), {x, y, 0.5 * std::sin(3 * x) * std::cos(2 * y)});
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int32_t v = j * n + i;
      s.faces.insert(s.faces.end(), {v, v + 1, v + n, v + 1, v + n + 1, v + n});
    }
  return s;
}

bool inside(const double* p, const TreeNode& n) {
  for (int a = 0; a < 3; ++a)
    if (p[a] < n.lo[a] || p[a] > n.hi[a]) return false;
  return true;
}

void check_structure(const ObjectTree& tree, const Soup& soup, bool each_once) {
  const MeshView mesh = soup.view();
  CHECK(tree.n_input_faces == mesh.n_faces);
  std::vector<int> seen(size_t(mesh.n_faces), 0);
  for (size_t i = 0; i < tree.nodes.size(); ++i) {
    const TreeNode& node = tree.nodes[i];
    // Children lie inside their parent, one level deeper.
    for (int32_t k = 0; k < node.n_children; ++k) {
      const TreeNode& child = tree.nodes[size_t(node.first_child + k)];
      CHECK(child.depth == node.depth + 1);
      for (int a = 0; a < 3; ++a) CHECK(child.lo[a] >= node.lo[a] && child.hi[a] <= node.hi[a]);
    }
    if (node.cluster < 0) continue;
    const TriangleCluster& cl = tree.clusters[size_t(node.cluster)];
    CHECK(cl.node == int32_t(i));
    for (int64_t r = cl.face_begin; r < cl.face_end; ++r) {
      const int32_t id = tree.ids[size_t(r)];
      ++seen[size_t(id)];
      for (int k = 0; k < 3; ++k) {
        // The face indexes the cluster's own copy of the vertex, which is the
        // input vertex, and the node contains it.
        const int32_t v = tree.faces[3 * size_t(r) + k];
        CHECK(v >= cl.vertex_begin && v < cl.vertex_end);
        const double* copy = &tree.positions[3 * size_t(v)];
        const double* input = &soup.pos[3 * size_t(soup.faces[3 * size_t(id) + k])];
        CHECK(std::memcmp(copy, input, 3 * sizeof(double)) == 0);
        CHECK(inside(copy, node));
      }
    }
  }
  for (int count : seen) CHECK(each_once ? count == 1 : count >= 1);
}

void test_structures() {
  for (int scene = 0; scene < 4; ++scene) {
    const Soup soup = random_soup(7 + scene, 2000 + 500 * scene);
    for (int leaf : {1, 8, 64, 1000}) {
      OctreeParams p;
      p.leaf_size = leaf;
      p.max_depth = 3 + scene * 2;
      check_structure(build_octree(soup.view(), p), soup, true);
      p.rule = OctreeRule::kLoose;
      check_structure(build_octree(soup.view(), p), soup, true);
      p.rule = OctreeRule::kGreene;
      const ObjectTree greene = build_octree(soup.view(), p);
      check_structure(greene, soup, false);
      if (leaf == 8) CHECK(greene.ids.size() > size_t(soup.faces.size() / 3));  // shared faces exist
      BvhParams b;
      b.leaf_size = leaf;
      const ObjectTree bvh = build_bvh(soup.view(), b);
      check_structure(bvh, soup, true);
      for (const TreeNode& n : bvh.nodes)
        CHECK(n.n_children == 2 || (n.n_children == 0 && n.n_triangles <= leaf));
    }
  }
}

// The radix sort orders words by the bits asked for alone, stably (ties,
// and words equal in those bits, keep their order), and keeps them whole;
// the sorted centroid codes (16 faces at a time in AVX-512 builds, 8 in AVX2) are the
// faces' VertexGrid::centroid_code, stably sorted; Morton codes by bit
// deposit equal those by spreading bits.
void test_radix_sort_and_morton_codes() {
  Lcg next{5};
  for (int bits : {1, 7, 22, 30, 31}) {
    for (size_t n : {size_t(0), size_t(1), size_t(2), size_t(1000), size_t(70000)}) {
      std::vector<uint64_t> words(n);
      for (size_t i = 0; i < n; ++i) {
        words[i] = next.bits();
        if (i % 3 == 0 && i > 0) words[i] = words[i - 1] ^ (uint64_t(1) << 63) ^ 1;  // ties
      }
      const uint64_t mask = ((uint64_t(1) << bits) - 1) << 32;
      std::vector<uint64_t> want = words;
      std::stable_sort(want.begin(), want.end(),
                       [mask](uint64_t a, uint64_t b) { return (a & mask) < (b & mask); });
      radix_sort_bits(words, 32, bits);
      CHECK(words == want);
    }
  }
  for (int faces : {5, 16, 1000, 1037}) {
    const Soup soup = random_soup(uint64_t(faces), faces);
    const MeshView mesh = soup.view();
    VertexGrid grid;
    grid.build(mesh);
    std::vector<uint64_t> words, want;
    sorted_centroid_codes(grid, mesh, words);
    for (int64_t f = 0; f < mesh.n_faces; ++f)
      want.push_back(uint64_t(grid.centroid_code(mesh.faces + 3 * f)) << 32 | uint64_t(f));
    std::stable_sort(want.begin(), want.end(), [](uint64_t a, uint64_t b) { return a >> 32 < b >> 32; });
    CHECK(words == want);
  }
  auto spread = [](uint32_t x, uint32_t y, uint32_t z) {
    return spread_bits_10(x) | (spread_bits_10(y) << 1) | (spread_bits_10(z) << 2);
  };
  for (uint32_t v : {0u, 1u, 511u, 512u, 1023u})
    CHECK(morton_30(v, 0, 0) == spread(v, 0, 0) && morton_30(0, v, 0) == spread(0, v, 0) &&
          morton_30(0, 0, v) == spread(0, 0, v) && morton_30(v, v, v) == spread(v, v, v));
  for (int t = 0; t < 10000; ++t) {
    const uint32_t x = uint32_t(next(0, 1023)), y = uint32_t(next(0, 1023)), z = uint32_t(next(0, 1023));
    CHECK(morton_30(x, y, z) == spread(x, y, z));
  }
}

// The octree's clusters (smallest enclosing cell) hold the faces in the
// order of (the Morton code of their cell's first finest cell, its level),
// ties in face order -- pre-order, computed here that other way and sorted
// by std::stable_sort: the build's pre-order cell numbers must come to the
// same order, also where a coarse cell's faces tie in code with the finest
// cell it starts at.
void test_octree_reference_order() {
  for (int scene = 0; scene < 3; ++scene) {
    const Soup soup = scene < 2 ? random_soup(31 + scene, 3000) : wavy_sheet(40);
    const MeshView mesh = soup.view();
    for (int depth : {4, 10}) {
      OctreeParams p;
      p.max_depth = depth;
      p.leaf_size = 16;
      p.rule = OctreeRule::kSmallest;
      const ObjectTree tree = build_octree(mesh, p);
      VertexGrid grid;
      grid.build(mesh);
      const int coarsen = VertexGrid::kBits - depth;
      std::vector<std::pair<uint64_t, int32_t>> want;
      bool mixed = false;  // a tie in code between levels: the case this test is about
      for (int64_t f = 0; f < mesh.n_faces; ++f) {
        uint32_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
          lo[a] = ~0u;
          hi[a] = 0;
          for (int k = 0; k < 3; ++k) {
            const uint32_t c = VertexGrid::axis(grid.cell[size_t(soup.faces[3 * size_t(f) + k])], a) >> coarsen;
            lo[a] = std::min(lo[a], c);
            hi[a] = std::max(hi[a], c);
          }
        }
        int s = 0;
        while ((lo[0] >> s) != (hi[0] >> s) || (lo[1] >> s) != (hi[1] >> s) || (lo[2] >> s) != (hi[2] >> s)) ++s;
        const uint64_t code = morton_30(lo[0] >> s << s, lo[1] >> s << s, lo[2] >> s << s);
        want.emplace_back(code << 5 | uint64_t(depth - s), int32_t(f));
      }
      std::stable_sort(want.begin(), want.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
      for (size_t i = 1; i < want.size(); ++i)
        mixed |= want[i].first >> 5 == want[i - 1].first >> 5 && want[i].first != want[i - 1].first;
      if (scene == 0 && depth == 10) CHECK(mixed);
      CHECK(tree.ids.size() == want.size());
      for (size_t i = 0; i < want.size() && i < tree.ids.size(); ++i) CHECK(tree.ids[i] == want[i].second);
    }
  }
}

// The cell holding each face (OctreeCells, 16 faces at a time in AVX-512
// builds, the rest one by one), against the rules' definitions checked
// level by level: the simpler rule's is the deepest cell whose span holds
// the face's whole grid box, the loose rule's the deepest level whose cells
// are at least as wide as the box, at the face's centroid cell.
void test_octree_cells_hold_faces_by_their_rule() {
  for (int scene = 0; scene < 2; ++scene) {
    const Soup soup = scene == 0 ? random_soup(41, 3005) : wavy_sheet(33);
    const MeshView mesh = soup.view();
    VertexGrid grid;
    grid.build(mesh);
    for (int depth : {1, 3, 6, 10})
      for (bool loose : {false, true}) {
        const OctreeCells cells(depth, loose);
        std::vector<uint64_t> words;
        face_words(grid, mesh, cells, words);
        int levels_seen = 0;  // a bit per level some face went to
        for (int64_t f = 0; f < mesh.n_faces; ++f) {
          uint32_t lo[3], hi[3], q[3];
          face_cells(grid, mesh.faces + 3 * f, lo, hi);
          grid.centroid_cell(mesh.faces + 3 * f, q);
          int level = depth;
          for (;; --level) {
            const int shift = VertexGrid::kBits - level;
            bool fits = true;
            for (int a = 0; a < 3; ++a)
              fits &= loose ? hi[a] - lo[a] < (1u << shift) : lo[a] >> shift == hi[a] >> shift;
            if (fits) break;
          }
          levels_seen |= 1 << level;
          const int shift = VertexGrid::kBits - level;
          const uint32_t* at = loose ? q : lo;
          const uint32_t want = uint32_t(cells.number(at[0] >> shift, at[1] >> shift, at[2] >> shift, level));
          CHECK(uint32_t(words[size_t(f)] >> 32) == want);  // (16 or 8 at a time where it can)
          CHECK(cells.one(grid, mesh.faces + 3 * f) == want);  // one at a time
          CHECK(uint32_t(words[size_t(f)]) == uint32_t(f));
        }
        if (scene == 0 && depth >= 3) CHECK(__builtin_popcount(levels_seen) >= 2);  // not all at one level
      }
  }
}

// A Scene's trees (their own vertex copies) drawn with those vertices
// transformed all up front and as the clusters drawn need them -- frames
// from cameras that draw most of the tree, a zoomed few clusters, another
// corner zoomed (whose blocks hold the camera before's vertices, which must
// not be read) -- give the plain Z-buffer's bits.
void test_scene_trees_vertices_up_front_and_as_needed() {
  const Soup soup = random_soup(77, 4000);
  RenderInput input;
  input.mesh = soup.view();
  const double n = 0.5, f = 10.0, a = -(f + n) / (f - n), b = -2 * f * n / (f - n);
  const double mvp[16] = {1.5, 0, 0, 0, 0, 1.5, 0, 0, 0, 0, a, b - 3 * a, 0, 0, -1, 3};
  std::copy(mvp, mvp + 16, input.mvp);
  RenderInput zoom = input, zoom_aside = input, other = input;
  zoom.mvp[0] *= 8;
  zoom.mvp[5] *= 8;
  zoom_aside.mvp[0] *= 10;
  zoom_aside.mvp[5] *= 10;
  zoom_aside.mvp[3] = 1.5;
  zoom_aside.mvp[7] = -1.5;
  other.mvp[0] = 1.2;
  // From inside the soup (the eye at z = 0): the near plane cuts through
  // it, so some clusters' vertices have outcodes and others none.
  RenderInput inside = input;
  inside.mvp[11] = b;
  inside.mvp[15] = 0;
  const int w = 96, h = 80;
  for (int kind = 0; kind < 4; ++kind) {  // octree (loose, simpler, Greene's rule), BVH
    ObjectTree tree;
    if (kind < 3) {
      OctreeParams p;
      p.leaf_size = 16;
      p.rule = kind == 0 ? OctreeRule::kLoose : kind == 1 ? OctreeRule::kSmallest : OctreeRule::kGreene;
      tree = build_octree(soup.view(), p);
    } else {
      BvhParams p;
      p.leaf_size = 16;
      tree = build_bvh(soup.view(), p);
    }
    CHECK(!tree.mesh_positions && !tree.positions.empty());
    for (int64_t lazy_from : {int64_t(1) << 18, int64_t(0)}) {
      TreeFrame frame;
      frame.lazy_vertices_from = lazy_from;
      bool saw_up_front = false, saw_lazy = false;
      bool saw_clipped = false;
      for (const RenderInput* in :
           {&other, &zoom, &zoom_aside, &input, &input, &zoom, &inside, &other, &inside}) {
        std::vector<float> want_depth(size_t(w) * h, std::numeric_limits<float>::infinity());
        std::vector<int32_t> want_ids(size_t(w) * h, -1);
        DepthTarget want{want_depth.data(), want_ids.data(), w, h};
        RenderStats want_stats;
        render(*find_algorithm("zbuffer"), *in, want, want_stats);
        std::vector<float> depth(want_depth.size(), std::numeric_limits<float>::infinity());
        std::vector<int32_t> ids(want_ids.size(), -1);
        DepthTarget target{depth.data(), ids.data(), w, h};
        RenderStats stats;
        stats.triangles_in = soup.view().n_faces;
        render_object_tree(tree, *in, target, stats, frame);
        (frame.vertices_up_front ? saw_up_front : saw_lazy) = true;
        saw_clipped |= stats.clipped > 0 && !frame.vertices_up_front;
        CHECK(std::memcmp(depth.data(), want_depth.data(), depth.size() * sizeof(float)) == 0);
        CHECK(ids == want_ids);
      }
      CHECK(saw_up_front);
      CHECK(saw_lazy == (lazy_from == 0));
      CHECK(saw_clipped == (lazy_from == 0));
    }
  }
}

void test_greene_draws_each_face_once() {
  // Tiny triangles facing the camera, most of them visible: every face
  // reached is handed on exactly once, although Greene's rule puts many of
  // them in several cells.
  Soup soup;
  Lcg next{99};
  for (int t = 0; t < 3000; ++t) {
    const double x = next.uniform(-1, 1), y = next.uniform(-1, 1), z = next.uniform(-3, -2);
    const double d = 0.004;
    const double v[3][3] = {{x, y, z}, {x + d, y, z}, {x, y + d, z}};
    for (int k = 0; k < 3; ++k) {
      for (int a = 0; a < 3; ++a) soup.pos.push_back(v[k][a]);
      soup.faces.push_back(int32_t(soup.faces.size()));
    }
  }
  OctreeParams p;
  p.leaf_size = 4;
  p.rule = OctreeRule::kGreene;
  const ObjectTree tree = build_octree(soup.view(), p);
  CHECK(tree.ids.size() > size_t(3000));
  RenderInput input;
  input.mesh = soup.view();
  const double mvp[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, -1.2, -2.2, 0, 0, -1, 0};
  std::copy(mvp, mvp + 16, input.mvp);
  const int w = 400, h = 400;
  std::vector<float> depth(size_t(w) * h, std::numeric_limits<float>::infinity());
  std::vector<int32_t> ids(size_t(w) * h, -1);
  DepthTarget target{depth.data(), ids.data(), w, h};
  TreeFrame frame;
  for (int round = 0; round < 3; ++round) {  // stamps carry over between frames
    std::fill(depth.begin(), depth.end(), std::numeric_limits<float>::infinity());
    std::fill(ids.begin(), ids.end(), -1);
    RenderStats stats;
    stats.triangles_in = 3000;
    render_object_tree(tree, input, target, stats, frame, round > 0);
    // Every face handed on once: those reached are exactly those drawn,
    // culled one by one, or degenerate (a face handed on twice would be
    // counted twice on the right).
    CHECK(stats.culled_frustum == 0 && stats.clipped == 0);
    CHECK(stats.triangles_in - stats.culled_in_nodes ==
          stats.rasterized + stats.culled_hidden + stats.culled_degenerate);
    CHECK(stats.rasterized > 2500);
  }
  // One frame state for two shared trees of as many nodes and clusters (a
  // root leaf each) over different numbers of faces: the face stamps are
  // sized for the second (indexed past their end before; ASan builds caught it).
  p.leaf_size = 1 << 20;
  Soup fewer = soup;
  fewer.pos.resize(fewer.pos.size() / 2 - fewer.pos.size() / 2 % 9);
  fewer.faces.resize(fewer.pos.size() / 3);
  const ObjectTree small = build_octree(fewer.view(), p), large = build_octree(soup.view(), p);
  CHECK(small.nodes.size() == 1 && large.nodes.size() == 1 && small.shared && large.shared);
  TreeFrame shared_frame;
  for (const ObjectTree* t : {&small, &large}) {
    std::fill(depth.begin(), depth.end(), std::numeric_limits<float>::infinity());
    std::fill(ids.begin(), ids.end(), -1);
    RenderStats stats;
    render_object_tree(*t, input, target, stats, shared_frame);
    CHECK(shared_frame.face_stamp.size() == size_t(t->n_input_faces));
    CHECK(stats.rasterized + stats.culled_hidden + stats.culled_degenerate == t->n_input_faces);
  }
}

// Per-frame trees: indexed clusters over the mesh's own vertices, each face
// once, bounds containing their triangles, and the plain Z-buffer's bits --
// also for faces passed in spatial order with their ids, where the BVH's
// clusters are runs of the caller's own arrays.
void test_frame_trees() {
  for (int scene = 0; scene < 6; ++scene) {
    const Soup soup = random_soup(31 + scene / 2, 3000 + 1000 * (scene / 2));
    const SpatialMesh spatial(soup.view());
    const bool ordered = scene % 2 == 1;
    const MeshView mesh = ordered ? spatial.view() : soup.view();
    RenderInput input;
    input.mesh = mesh;
    // Perspective from z = 3 looking down -z at the soup in [-1, 1]^3.
    const double n = 0.5, f = 10.0, a = -(f + n) / (f - n), b = -2 * f * n / (f - n);
    const double mvp[16] = {1.5, 0, 0, 0, 0, 1.5, 0, 0, 0, 0, a, b - 3 * a, 0, 0, -1, 3};
    std::copy(mvp, mvp + 16, input.mvp);
    const int w = 96, h = 80;
    std::vector<float> ref_depth(size_t(w) * h);
    std::vector<int32_t> ref_ids(size_t(w) * h);
    DepthTarget ref{ref_depth.data(), ref_ids.data(), w, h};
    RenderStats ref_stats;
    render(*find_algorithm("zbuffer"), input, ref, ref_stats);
    CHECK(ref_stats.pixels_written > w * h / 2);  // the soup fills the view
    for (int leaf : {1, 4, 64}) {
      int up_front_seen = 0;  // trees whose frames drew every vertex up front
      for (int kind = 0; kind < 3; ++kind) {  // octree (simpler rule, loose rule), BVH
        ObjectTree tree;
        if (kind < 2) {
          OctreeParams p;
          p.leaf_size = leaf;
          p.rule = kind == 0 ? OctreeRule::kSmallest : OctreeRule::kLoose;
          build_octree_for_frame(mesh, p, tree);
        } else {
          BvhParams p;
          p.leaf_size = leaf;
          build_bvh_for_frame(mesh, p, tree);
        }
        CHECK(tree.mesh_positions == mesh.positions && tree.positions.empty());
        if (ordered && kind == 2)  // the BVH's buckets follow the spatial order
          CHECK(tree.order.empty());
        if (!ordered) CHECK(tree.order.size() == size_t(mesh.n_faces));
        CHECK(tree.mesh_faces == mesh.faces && tree.faces.empty() && tree.ids.empty());
        std::vector<int> seen(size_t(mesh.n_faces), 0);
        for (size_t i = 0; i < tree.nodes.size(); ++i) {
          const TreeNode& node = tree.nodes[i];
          for (int32_t k = 0; k < node.n_children; ++k) {
            const TreeNode& child = tree.nodes[size_t(node.first_child + k)];
            for (int a = 0; a < 3; ++a) CHECK(child.lo[a] >= node.lo[a] && child.hi[a] <= node.hi[a]);
          }
          if (node.cluster < 0) continue;
          const TriangleCluster& cl = tree.clusters[size_t(node.cluster)];
          for (int64_t r = cl.face_begin; r < cl.face_end; ++r) {
            const int32_t id = tree.id(r);
            ++seen[size_t(id)];
            for (int k = 0; k < 3; ++k) {  // the face's corners (renumbered in spatial order)
              const double* p = mesh.positions + 3 * int64_t(tree.face(r)[k]);
              CHECK(std::memcmp(p, &soup.pos[3 * size_t(soup.faces[3 * size_t(id) + k])],
                                3 * sizeof(double)) == 0);
              CHECK(inside(p, node));
            }
          }
        }
        for (int count : seen) CHECK(count == 1);
        // A cluster drawn from the mesh's arrays (TriangleCluster::range_begin)
        // holds exactly the faces of its range in its buckets; the octree of
        // a mesh in spatial order draws most of its faces so.
        int64_t ranged = 0;
        for (const TriangleCluster& cl : tree.clusters) {
          if (cl.range_end <= cl.range_begin) continue;
          CHECK(kind < 2 && !tree.order.empty());
          CHECK(cl.range_begin >= 0 && cl.range_end <= mesh.n_faces);
          CHECK(tree.face_bucket.size() == size_t(mesh.n_faces));
          std::vector<int32_t> rows(tree.order.data() + cl.face_begin,
                                    tree.order.data() + cl.face_end);
          std::vector<int32_t> in_buckets;
          for (int64_t f = cl.range_begin; f < cl.range_end; ++f) {
            const int32_t b = tree.face_bucket[size_t(f)];
            if (b >= cl.bucket_begin && b < cl.bucket_end) in_buckets.push_back(int32_t(f));
          }
          std::sort(rows.begin(), rows.end());
          CHECK(rows == in_buckets);
          ranged += cl.face_end - cl.face_begin;
        }
        if (ordered && kind < 2 && leaf == 64 && !tree.order.empty()) CHECK(ranged > mesh.n_faces / 2);
        // Vertices all up front, and as clusters need them -- after a frame
        // from another camera with every vertex transformed, so that no
        // vertex left over from before is right by luck.
        for (int64_t lazy_from : {int64_t(1) << 18, int64_t(0)}) {
          std::vector<float> depth(size_t(w) * h, std::numeric_limits<float>::infinity());
          std::vector<int32_t> ids(size_t(w) * h, -1);
          DepthTarget target{depth.data(), ids.data(), w, h};
          RenderInput other = input;
          other.mvp[0] = 1.2;
          RenderStats stats;
          TreeFrame other_frame;
          render_object_tree(tree, other, target, stats, other_frame);
          std::fill(depth.begin(), depth.end(), std::numeric_limits<float>::infinity());
          std::fill(ids.begin(), ids.end(), -1);
          stats = RenderStats();
          TreeFrame frame;
          frame.lazy_vertices_from = lazy_from;
          render_object_tree(tree, input, target, stats, frame);
          CHECK(std::memcmp(depth.data(), ref_depth.data(), depth.size() * sizeof(float)) == 0);
          CHECK(ids == ref_ids);
          CHECK(stats.nodes_hidden > 0 || leaf == 64);
          if (lazy_from != 0) continue;
          // Frames after it: every vertex up front where the frame before,
          // of the same vertices, drew at least kUpFrontShare of the faces
          // (a view zoomed on the middle draws few), else as needed -- the
          // same bits either way.
          RenderInput zoom = input, zoom_aside = input;
          zoom.mvp[0] *= 8;
          zoom.mvp[5] *= 8;
          zoom_aside.mvp[0] *= 10;  // another corner of the soup, zoomed
          zoom_aside.mvp[5] *= 10;
          zoom_aside.mvp[3] = 1.5;
          zoom_aside.mvp[7] = -1.5;
          // (zoom_aside after zoom: a lazy frame that draws little, after a
          // frame from another camera -- its blocks not drawn keep that
          // camera's vertices, and must not be read.)
          bool saw_up_front = false, saw_lazy = false, saw_lazy_few = false;
          for (const RenderInput* in : {&zoom, &zoom_aside, &other, &zoom, &input, &other}) {
            std::vector<float> want_depth(depth.size(), std::numeric_limits<float>::infinity());
            std::vector<int32_t> want_ids(ids.size(), -1);
            DepthTarget want{want_depth.data(), want_ids.data(), w, h};
            RenderStats want_stats;
            render(*find_algorithm("zbuffer"), *in, want, want_stats);
            const bool up_front = frame.drawn_positions == mesh.positions &&
                                  frame.drawn_share >= TreeFrame::kUpFrontShare;
            std::fill(depth.begin(), depth.end(), std::numeric_limits<float>::infinity());
            std::fill(ids.begin(), ids.end(), -1);
            stats = RenderStats();
            stats.triangles_in = mesh.n_faces;
            render_object_tree(tree, *in, target, stats, frame);
            CHECK(frame.vertices_up_front == up_front);
            CHECK(frame.drawn_share ==
                  double(mesh.n_faces - stats.culled_in_nodes) / double(mesh.n_faces));
            (up_front ? saw_up_front : saw_lazy) = true;
            saw_lazy_few |= !up_front && frame.drawn_share < 0.5 && stats.rasterized > 0;
            CHECK(std::memcmp(depth.data(), want_depth.data(), depth.size() * sizeof(float)) == 0);
            CHECK(ids == want_ids);
          }
          // (The loose octree of some soups culls more than 1 - kUpFrontShare
          // of the faces in nodes in every frame: the other trees draw them
          // up front.)
          CHECK(saw_lazy && saw_lazy_few);
          up_front_seen += saw_up_front;
        }
      }
      CHECK(up_front_seen >= 2);  // (of the three kinds: the loose octree may cull too much)
    }
  }
}

// Per-frame trees' bounds contain their triangles also where the vertex
// grid's cube, set from the vertices' bounds, rounds short of its far end
// (lo + (hi - lo) < hi: x from -3 to 0.3), for every number of vertices
// past the last group of 8 (the scalar tail of the grid's pass), and after
// a grid built for other positions (no cell left over from them).
void test_frame_tree_bounds_when_the_cube_rounds() {
  for (int n = 3; n <= 20; ++n) {
    Soup soup;
    for (int v = 0; v < n; ++v) {
      const double t = double(v) / double(n - 1);
      soup.pos.insert(soup.pos.end(), {v == 0 ? -3.0 : 0.3, v == 0 ? 0.0 : t, 0.1 * t});
    }
    CHECK(soup.pos[0] + (0.3 - soup.pos[0]) < 0.3);  // the case this test is about
    for (int v = 1; v + 1 < n; ++v) soup.faces.insert(soup.faces.end(), {0, v, v + 1});
    for (int kind = 0; kind < 3; ++kind) {  // octree (simpler rule, loose rule), BVH
      ObjectTree warm, tree;
      Soup other = random_soup(7, 5);  // a grid built for other positions first
      if (kind < 2) {
        OctreeParams p;
        p.rule = kind == 0 ? OctreeRule::kSmallest : OctreeRule::kLoose;
        build_octree_for_frame(other.view(), p, warm);
        build_octree_for_frame(soup.view(), p, tree);
      } else {
        build_bvh_for_frame(other.view(), BvhParams(), warm);
        build_bvh_for_frame(soup.view(), BvhParams(), tree);
      }
      for (const TreeNode& node : tree.nodes) {
        if (node.cluster < 0) continue;
        const TriangleCluster& cl = tree.clusters[size_t(node.cluster)];
        for (int64_t r = cl.face_begin; r < cl.face_end; ++r)
          for (int k = 0; k < 3; ++k)
            CHECK(inside(soup.view().positions + 3 * int64_t(tree.face(r)[k]), node));
      }
    }
  }
}

// A per-frame octree gives each face one bucket: Greene's rule, which gives
// it several cells, is refused.
void test_frame_octree_refuses_greene_rule() {
  const Soup soup = random_soup(3, 50);
  OctreeParams p;
  p.rule = OctreeRule::kGreene;
  ObjectTree tree;
  bool threw = false;
  try {
    build_octree_for_frame(soup.view(), p, tree);
  } catch (const std::invalid_argument&) {
    threw = true;
  }
  CHECK(threw);
}

// The per-frame builders' vector face pass (AVX-512 and AVX2 builds) and
// scatter (AVX-512) give the very tree of the scalar ones: same nodes,
// bounds, clusters and face order -- and the same decision whether the
// faces came in bucket order. Faces are passed as they are, in spatial
// order with their ids (the per-frame BVH's buckets are then in order: no
// copy), and in spatial order with the last face moved to place 15 (the
// last lane of a step of 16 or 8) or 17 (the second lane of the next), or
// the first face moved to the end (out of order: copied).
void test_frame_tree_vector_pass_equals_scalar() {
  const Soup soups[] = {random_soup(7, 5001), wavy_sheet(90), wavy_sheet(17)};
  for (const Soup& soup : soups)
    for (int variant = 0; variant < 5; ++variant) {
      SpatialMesh spatial(soup.view());
      std::vector<int32_t>& order = spatial.order;
      if (variant == 2) std::rotate(order.begin() + 15, order.end() - 1, order.end());
      if (variant == 3) std::rotate(order.begin() + 17, order.end() - 1, order.end());
      if (variant == 4) std::rotate(order.begin(), order.begin() + 1, order.end());
      spatial.relist();
      const MeshView mesh = variant > 0 ? spatial.view() : soup.view();
      const size_t n = size_t(mesh.n_faces);
      for (int leaf : {1, 8, 128})
        for (int kind = 0; kind < 3; ++kind) {  // octree (simpler rule, loose rule), BVH
          ObjectTree fast, slow;
          if (kind < 2) {
            OctreeParams p;
            p.leaf_size = leaf;
            p.rule = kind == 0 ? OctreeRule::kSmallest : OctreeRule::kLoose;
            build_octree_for_frame(mesh, p, fast, /*vector=*/true);
            build_octree_for_frame(mesh, p, slow, /*vector=*/false);
          } else {
            BvhParams p;
            p.leaf_size = leaf;
            build_bvh_for_frame(mesh, p, fast, /*vector=*/true);
            build_bvh_for_frame(mesh, p, slow, /*vector=*/false);
          }
          CHECK(fast.nodes.size() == slow.nodes.size() && fast.clusters.size() == slow.clusters.size());
          CHECK(fast.nodes.size() > 1);
          for (size_t i = 0; i < std::min(fast.nodes.size(), slow.nodes.size()); ++i) {
            const TreeNode &a = fast.nodes[i], &b = slow.nodes[i];
            CHECK(a.first_child == b.first_child && a.n_children == b.n_children &&
                  a.cluster == b.cluster && a.depth == b.depth && a.n_triangles == b.n_triangles);
            CHECK(std::memcmp(a.lo, b.lo, sizeof a.lo) == 0 && std::memcmp(a.hi, b.hi, sizeof a.hi) == 0);
          }
          for (size_t c = 0; c < std::min(fast.clusters.size(), slow.clusters.size()); ++c) {
            const TriangleCluster &a = fast.clusters[c], &b = slow.clusters[c];
            CHECK(a.face_begin == b.face_begin && a.face_end == b.face_end && a.node == b.node);
            CHECK(a.range_begin == b.range_begin && a.range_end == b.range_end &&
                  a.bucket_begin == b.bucket_begin && a.bucket_end == b.bucket_end);
          }
          CHECK(fast.order == slow.order && fast.mesh_faces == mesh.faces && slow.mesh_faces == mesh.faces);
          CHECK(fast.face_bucket == slow.face_bucket && fast.face_bucket.size() == n);
          // In spatial order, the BVH's buckets come in order; out of order,
          // or without ids, the tree lists the faces in its order.
          if (kind == 2 && variant == 1) CHECK(fast.order.empty());
          // So are the loose octree's of a sheet of faces narrower than its cells.
          if (kind == 1 && variant == 1 && &soup == &soups[1] && leaf == 128) CHECK(fast.order.empty());
          if (variant == 0 || variant >= 2) CHECK(fast.order.size() == n);
          // Either way the clusters' rows are the faces they name.
          std::vector<int> seen(n, 0);
          for (const TriangleCluster& cl : fast.clusters)
            for (int64_t r = cl.face_begin; r < cl.face_end; ++r) {
              const int32_t id = fast.id(r);
              ++seen[size_t(id)];
              for (int k = 0; k < 3; ++k)
                CHECK(std::memcmp(mesh.positions + 3 * int64_t(fast.face(r)[k]),
                                  &soup.pos[3 * size_t(soup.faces[3 * size_t(id) + k])],
                                  3 * sizeof(double)) == 0);
            }
          for (int count : seen) CHECK(count == 1);
        }
    }
}

// A vertex grid built again for the same positions array (per-frame trees,
// frame after frame) reuses the bounds it knew only if they are still the
// bounds: whatever changed in the array, the grid equals one built afresh.
void test_vertex_grid_rebuilt_equals_fresh() {
  const Soup original = random_soup(11, 3001);
  Soup soup = original;
  const MeshView mesh = soup.view();  // points into soup.pos, edited below
  auto same = [](const VertexGrid& a, const VertexGrid& b) {
    return a.cell == b.cell && std::memcmp(a.origin, b.origin, sizeof a.origin) == 0 &&
           a.cell_size == b.cell_size;
  };
  // The vector loops (AVX-512: 8 vertices a step, AVX2: 4) give the scalar
  // loop's grid, on this mesh and on a few vertices fewer (the rest of a step).
  for (int64_t drop : {0, 1, 2, 3, 5, 7}) {
    MeshView part = mesh;
    part.n_vertices -= drop;
    VertexGrid vector_grid, scalar_grid;
    vector_grid.build(part, true);
    scalar_grid.build(part, false);
    CHECK(same(vector_grid, scalar_grid));
  }
  // Also with non-finite coordinates (the bindings refuse them; the core
  // takes them, and a NaN or -inf gets cell 0 in every loop), in vector
  // steps and in the rest of a step.
  const double kOdd[] = {std::numeric_limits<double>::quiet_NaN(),
                         -std::numeric_limits<double>::infinity(),
                         std::numeric_limits<double>::infinity()};
  for (double value : kOdd)
    for (int64_t v : {int64_t(0), int64_t(3), int64_t(35), int64_t(soup.pos.size() / 3 - 1)}) {
      Soup odd = original;
      odd.pos[3 * size_t(v) + size_t(v % 3)] = value;
      VertexGrid vector_grid, scalar_grid;
      vector_grid.build(odd.view(), true);
      scalar_grid.build(odd.view(), false);
      CHECK(same(vector_grid, scalar_grid));
    }
  for (bool vector : {true, false}) {
    VertexGrid kept;
    kept.build(mesh, vector);
    // Edits: none; an inner vertex moved (same bounds); a vertex moved out
    // of the bounds; the vertices below x = -0.5 moved up to it (bounds
    // that shrank).
    for (int edit = 0; edit < 4; ++edit) {
      if (edit == 1) soup.pos[3 * 100] = 0.25;
      if (edit == 2) soup.pos[3 * 200 + 1] = 3.0;
      if (edit == 3)
        for (size_t v = 0; v < soup.pos.size() / 3; ++v) soup.pos[3 * v] = std::max(soup.pos[3 * v], -0.5);
      kept.build(mesh, vector);
      VertexGrid fresh;
      fresh.build(mesh, vector);
      CHECK(same(kept, fresh));
      kept.build(mesh, vector);  // and once more, unchanged
      CHECK(same(kept, fresh));
    }
    std::copy(original.pos.begin(), original.pos.end(), soup.pos.begin());
  }
}

}  // namespace

int main() {
  test_frame_tree_bounds_when_the_cube_rounds();
  test_vertex_grid_rebuilt_equals_fresh();
  test_frame_tree_vector_pass_equals_scalar();
  test_structures();
  test_radix_sort_and_morton_codes();
  test_octree_reference_order();
  test_frame_trees();
  test_octree_cells_hold_faces_by_their_rule();
  test_scene_trees_vertices_up_front_and_as_needed();
  test_frame_octree_refuses_greene_rule();
  test_greene_draws_each_face_once();
  return check_report("test_object_tree");
}
