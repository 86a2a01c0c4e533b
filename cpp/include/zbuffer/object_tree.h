// Object-space trees for the hierarchical Z-buffer, and the one traversal
// that renders them.
//
// The octree (octree.h) and the bounding volume hierarchy (bvh.h) differ in
// how they split space; once built, both are the same thing: nodes with
// bounds and children, some of which own a cluster of triangles. One
// traversal (render_object_tree) visits the nodes front to back, culls every
// node whose projected box the Z-pyramid proves hidden -- its whole subtree
// with it -- and hands the clusters of the others to a TriangleBatch, which
// culls and draws triangles exactly as `hiz` does. Culling is strict and
// conservative, so the output is the plain Z-buffer's, bit for bit.
#pragma once

#include <cstdint>
#include <vector>

#include "zbuffer/buffer.h"
#include "zbuffer/types.h"

namespace zbuffer {

// A node: the bounds of every triangle in its subtree (world space), its
// children, and the cluster of triangles it owns itself (if any).
struct TreeNode {
  double lo[3], hi[3];
  int32_t first_child = -1;  // children are first_child .. first_child + n_children - 1
  int32_t n_children = 0;
  int32_t cluster = -1;      // index into ObjectTree::clusters, or -1
  int32_t depth = 0;         // 0 for the root
  int64_t n_triangles = 0;   // triangle references its subtree's clusters hold
};

// The triangles one node owns, drawn as one unit.
struct TriangleCluster {
  int64_t face_begin = 0, face_end = 0;      // rows of ObjectTree::faces and ids
  int64_t vertex_begin = 0, vertex_end = 0;  // rows of ObjectTree::positions (0, 0 if indexed)
  int32_t node = -1;
  // A per-frame octree's cluster may also be drawn from the mesh's own
  // arrays: the faces range_begin .. range_end - 1 whose
  // ObjectTree::face_bucket is in bucket_begin .. bucket_end - 1 are exactly
  // its rows (empty range: not so; its rows are gathered). int32, as an
  // indexed tree's `order` is.
  int32_t range_begin = 0, range_end = 0;
  int32_t bucket_begin = 0, bucket_end = 0;
};

// Design decision: a tree built to last (zbuffer.Scene) is self-contained.
// Every cluster gets its own copy of its vertices, a run of `positions`
// that its faces index, so that drawing a cluster transforms exactly the
// vertices it uses (vertex_stage.h: 8 at a time with AVX-512, 4 with AVX2)
// and never touches the rest of the mesh -- or, for a tree of fewer copies
// than TreeFrame::lazy_vertices_from (every single mesh measured) and where
// the frame before drew most of the tree, every copy up front in one pass,
// as an indexed tree does (object_tree.cpp, LazyVertices).
// Good: a large tree's render time depends on what is visible, not on the
// size of the mesh, and the tree outlives the arrays it was built from. Bad: vertices on
// cluster borders are stored (and transformed) more than once -- identical
// bits each time, so the output does not change -- the tree holds about
// 40 bytes per triangle, and a thread that renders it keeps screen vertices
// for all its copies (20 bytes each, reused by its next frames).
//
// A tree built for one frame (frame_tree.h) is `indexed` instead: it runs
// over the mesh's own arrays, and the traversal transforms the mesh's
// vertices as the clusters it draws need them (object_tree.cpp,
// LazyVertices; small meshes all up front). Its clusters are runs of
// `order`, the mesh's face index of each row, so that building writes 4
// bytes a face -- or, when the faces came in the tree's order with their ids
// (a BVH of a mesh in spatial order), runs of the mesh's face and id arrays
// themselves, and building writes nothing per face.
struct ObjectTree {
  std::vector<TreeNode> nodes;           // nodes[0] is the root (empty mesh: none)
  std::vector<TriangleCluster> clusters;
  // (Buffers: grown without zeroing, then written once; buffer.h.)
  Buffer<double> positions;              // (vertices, 3) each cluster's copies, a run each
  Buffer<int32_t> faces;                 // (references, 3) rows of positions, in the cluster's run
  Buffer<int32_t> ids;                   // (references,) triangle id reported
  Buffer<int32_t> source;                // (references,) input face index (shared only)
  int64_t n_input_faces = 0;
  // True when one face may be referenced by several clusters (Greene's rule
  // for the octree); the traversal then draws each face at most once.
  bool shared = false;
  // Non-null for an indexed tree: the mesh positions its faces index (the
  // caller keeps them alive while rendering); `positions` is then empty.
  const double* mesh_positions = nullptr;
  int64_t mesh_vertices = 0;
  // Non-null for an indexed tree: the mesh's face and id arrays (no ids:
  // a face's id is its index). `faces` and `ids` are then empty.
  const int32_t* mesh_faces = nullptr;
  const int32_t* mesh_ids = nullptr;
  // An indexed tree's rows: the mesh's face index of each; empty when the
  // rows are the mesh's own (the faces came in cluster order, with ids).
  Buffer<int32_t> order;
  // A per-frame tree's bucket of each mesh face (frame_tree.h), written by
  // every per-frame build; the octree's clusters drawn as ranges of the mesh
  // read it (TriangleCluster::range_begin). Other trees leave it empty.
  std::vector<int32_t> face_bucket;

  // Row r of the clusters: its three vertex indices, and its id.
  const int32_t* face(int64_t r) const {
    if (!mesh_faces) return faces.data() + 3 * r;
    return mesh_faces + 3 * int64_t(order.empty() ? r : order[size_t(r)]);
  }
  int32_t id(int64_t r) const {
    if (!mesh_faces) return ids[size_t(r)];
    if (order.empty()) return mesh_ids[r];
    const int32_t f = order[size_t(r)];
    return mesh_ids ? mesh_ids[f] : f;
  }
  // The rows of a tree that are runs of arrays (all but an indexed tree with
  // an order): faces (3 per row) and ids.
  const int32_t* face_rows() const { return mesh_faces ? mesh_faces : faces.data(); }
  const int32_t* id_rows() const { return mesh_faces ? mesh_ids : ids.data(); }
  // id -> cluster (the first one holding it), if ids are the face indices
  // 0 .. n_input_faces - 1; empty otherwise. Temporal coherence needs it.
  Buffer<int32_t> cluster_of_id;

  // Bytes held by the tree (not the caller's arrays an indexed tree runs
  // over: mesh_positions, mesh_faces, mesh_ids).
  int64_t memory_bytes() const;

  // Empty the tree, keeping its memory for the next build.
  void clear();
};

// Builds the clusters and node bounds of a tree whose structure is decided.
// Octree and BVH builders sort face references so that every node's own
// references and its subtree are contiguous, then call add_cluster for each
// node that owns triangles.
class ClusterBuilder {
 public:
  ClusterBuilder(const MeshView& mesh, ObjectTree& tree);
  // Room for `references` face references in all (the sum of add_cluster's
  // n over the build), so that the tree's arrays never move while clusters
  // are added; called once, before the first add_cluster.
  void reserve(int64_t references);
  // Make node `node` own faces face[0 .. n) (input indices); sets its
  // cluster and bounds. In a shared tree (Greene's rule), duplicate faces
  // within one cluster are dropped.
  void add_cluster(int32_t node, const int32_t* face, int64_t n);
  // Finish: cluster_of_id.
  void finish();

 private:
  const MeshView& mesh_;
  ObjectTree& tree_;
  // Per input vertex and (shared trees) per input face: scratch kept per
  // thread from build to build.
  std::vector<uint64_t>& vertex_slot_;  // the last cluster to use it, its index there
  std::vector<int32_t>& face_mark_;
};

// Bounds of node `i` from its cluster and its children (children first).
void merge_child_bounds(ObjectTree& tree, int32_t i);

// Appends n (empty) children to node `parent` and returns the index of the
// first. Invalidates references into tree.nodes.
int32_t add_children(ObjectTree& tree, int32_t parent, int n);

// What happened to a node in the last render.
enum NodeFate : uint8_t {
  kNodeNotReached = 0,  // an ancestor was culled (or the tree was not rendered)
  kNodeOutside = 1,     // outside the view volume
  kNodeHidden = 2,      // its projected box is behind the Z-pyramid
  kNodeVisited = 3,     // tested and kept; owns no triangles
  kNodeDrawn = 4,       // tested and kept; its triangles were handed on
};

// The per-frame state of one tree: reused across frames so that nothing of
// the size of the mesh is cleared per frame.
// Design decision: stamps (the number of the frame that last touched a face
// or cluster) instead of flags. Good: a new frame costs one increment, not a
// pass over every face. Bad: 4 bytes per face (shared trees) and 12 per
// cluster.
struct TreeFrame {
  uint32_t frame = 0;
  std::vector<uint32_t> face_stamp;     // shared trees: frame a face was last drawn in
  std::vector<uint32_t> cluster_stamp;  // frame a cluster was last drawn in
  std::vector<uint32_t> visible_stamp;  // frame a cluster was last found visible
  std::vector<uint8_t> node_fate;       // NodeFate of each node in the last frame
  std::vector<int32_t> visible_clusters;  // clusters with a pixel on the last frame's sampled rows
  std::vector<uint32_t> reached_rank;   // the order the last traversal reached clusters in
  bool has_visible = false;             // visible_clusters belongs to the tree's last frame
  // A tree over at least this many vertices (an indexed tree's: the mesh's;
  // a Scene tree's: its copies) has them transformed as the clusters drawn
  // need them (object_tree.cpp: LazyVertices), a smaller one all up front --
  // and so has a larger one when the frame before, over the same vertices,
  // drew most of the tree's faces. Tests lower it.
  int64_t lazy_vertices_from = int64_t(1) << 18;
  static constexpr double kUpFrontShare = 0.6;
  // The tree's vertices in the last frame, and the share of the
  // tree's faces that frame drew (handed to the batch, not culled in nodes).
  // Only a guess for the next frame: a new array at the address of a freed
  // one is taken for it, which changes the frame's speed, never its bits.
  const double* drawn_positions = nullptr;
  int64_t drawn_vertices = 0;
  double drawn_share = 0.0;
  bool vertices_up_front = false;  // the last frame transformed every vertex first
};

// Renders one frame of the tree into the cleared target (depth +inf, ids -1)
// and adds to stats: nodes visited, hidden and outside, triangles in culled
// nodes (culled_in_nodes), and everything the TriangleBatch counts.
//
// With `temporal` (Greene, Kass and Miller, section 6), the clusters that
// had a visible pixel in the frame before are drawn first, and the pyramid
// they produce is what the traversal starts with; the clusters visible now
// are recorded for the next frame. Needs tree.cluster_of_id.
void render_object_tree(const ObjectTree& tree, const RenderInput& input, DepthTarget& target,
                        RenderStats& stats, TreeFrame& frame, bool temporal = false);

// What render() (algorithms.h) does around an algorithm, for a tree built
// beforehand: clear the target, count the tree's faces in triangles_in,
// render, time the whole call. input.mesh is not used.
void render_tree_frame(const ObjectTree& tree, const RenderInput& input, DepthTarget& target,
                       RenderStats& stats, TreeFrame& frame, bool temporal = false);

// A registry algorithm's body: build a tree of input.mesh with `build` (into
// this thread's tree of the last frame, reusing its memory), count the time
// in build_ms, render it.
void render_built_per_frame(const RenderInput& input, DepthTarget& target, RenderStats& stats,
                            void (*build)(const MeshView& mesh, ObjectTree& tree));

}  // namespace zbuffer
