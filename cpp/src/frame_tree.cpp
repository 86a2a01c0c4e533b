// Per-frame octree and BVH: a counting sort into buckets, nodes read off
// the bucket counts (frame_tree.h).
#include "zbuffer/frame_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "morton.h"
#include "setup8.h"  // (AVX2 builds: bits8)
#include "simd.h"

namespace zbuffer {

namespace {

constexpr int kMaxFrameDepth = 6;

// Faces in buckets: bucket of each face, faces per bucket (then the first
// face of each bucket), and each bucket's box on the vertex grid.
// Consecutive faces mostly fall in the same bucket (meshes list neighbours
// together), so a run of them is counted and bounded in registers and
// written once: updating the same counter and box in memory face after face
// would chain every face to the previous one's store.
struct Buckets {
  int32_t* of_face = nullptr;  // the tree's face_bucket (reset)
  std::vector<int64_t> start;  // n_buckets + 1: bucket b's count at b + 1, its first face
                               // at b after scatter()
  std::vector<uint16_t> box;   // 6 per bucket: lo xyz, hi xyz (grid cells)
  // The first and last face of each bucket (first > last: none).
  std::vector<int64_t> first_face, last_face;

  void reset(size_t n_buckets, size_t n_faces, std::vector<int32_t>& face_bucket) {
    face_bucket.resize(n_faces);
    of_face = face_bucket.data();
    start.assign(n_buckets + 1, 0);
    first_face.assign(n_buckets, std::numeric_limits<int64_t>::max());
    last_face.assign(n_buckets, -1);
    box.resize(6 * n_buckets);
    for (size_t b = 0; b < n_buckets; ++b) {
      std::fill_n(&box[6 * b], 3, uint16_t(VertexGrid::kMask));
      std::fill_n(&box[6 * b + 3], 3, uint16_t(0));
    }
    run_ = -1;
    last_ = -1;
    in_order_ = true;
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
    clear_lanes();
#endif
  }
  void add(int64_t f, int32_t b, const uint32_t* lo, const uint32_t* hi) {
    of_face[size_t(f)] = b;
    in_order_ &= b >= last_;
    last_ = b;
    add_run(b, 1, f, f, lo, hi);
  }
#ifdef ZBUFFER_AVX512
  // add() for faces f .. f + 15, buckets b and grid boxes lo/hi by axis.
  // Those in the current run's bucket -- most of them: a bucket holds
  // hundreds of consecutive faces -- go into the run's lane-wise bounds,
  // reduced once when the run ends; the others straight into their buckets,
  // a bucket at a time, a face alone without a reduction (an octree's faces
  // that belong to a coarser node -- wider than a cell under the loose
  // rule, straddling a cell border under the simpler one -- or the first
  // faces of the next run). A step with no face in the run ends it; the next
  // is lane 15's bucket. Counts and boxes do not depend on the order faces
  // come in. (Ending the run for every other bucket present, six masked
  // reductions each, was a third of the octree's build.)
  void add16(int64_t f, __m512i b, const __m512i* lo, const __m512i* hi) {
    _mm512_storeu_si512(&of_face[size_t(f)], b);
    // In order while no face's bucket is below the one before it.
    const __m512i before = _mm512_alignr_epi32(b, _mm512_set1_epi32(last_), 15);
    in_order_ &= _mm512_cmplt_epi32_mask(b, before) == 0;
    const int32_t last = _mm_extract_epi32(_mm512_extracti32x4_epi32(b, 3), 3);
    last_ = last;
    __mmask16 in_run = run_ >= 0 ? _mm512_cmpeq_epi32_mask(b, _mm512_set1_epi32(run_)) : 0;
    if (!in_run) {
      end_run();
      in_run = _mm512_cmpeq_epi32_mask(b, _mm512_set1_epi32(last));
      run_ = last;
      run_count_ = 0;
      run_first_ = f + __builtin_ctz(in_run);
      for (int a = 0; a < 3; ++a) {
        run_lo_[a] = ~uint32_t(0);
        run_hi_[a] = 0;
      }
    }
    for (int a = 0; a < 3; ++a) {
      const __m512i run_lo = _mm512_loadu_si512(lane_lo_[a]), run_hi = _mm512_loadu_si512(lane_hi_[a]);
      _mm512_storeu_si512(lane_lo_[a], _mm512_mask_min_epu32(run_lo, in_run, run_lo, lo[a]));
      _mm512_storeu_si512(lane_hi_[a], _mm512_mask_max_epu32(run_hi, in_run, run_hi, hi[a]));
    }
    run_count_ += __builtin_popcount(in_run);
    run_last_ = f + 31 - __builtin_clz(in_run);
    __mmask16 left = __mmask16(~in_run);
    if (!left) return;
    alignas(64) int32_t bs[16];
    alignas(64) uint32_t l[3][16], h[3][16];
    _mm512_store_si512(bs, b);
    for (int a = 0; a < 3; ++a) {
      _mm512_store_si512(l[a], lo[a]);
      _mm512_store_si512(h[a], hi[a]);
    }
    while (left) {
      const int k = __builtin_ctz(left);
      const __mmask16 same = _mm512_mask_cmpeq_epi32_mask(left, b, _mm512_set1_epi32(bs[k]));
      left &= __mmask16(~same);
      const bool one = (same & (same - 1)) == 0;  // a face alone: no reduction
      uint32_t fl[3], fh[3];
      for (int a = 0; a < 3; ++a) {
        fl[a] = one ? l[a][k] : _mm512_mask_reduce_min_epu32(same, lo[a]);
        fh[a] = one ? h[a][k] : _mm512_mask_reduce_max_epu32(same, hi[a]);
      }
      add_to_bucket(bs[k], __builtin_popcount(same), f + k, f + 31 - __builtin_clz(same), fl, fh);
    }
  }
#elif defined(ZBUFFER_AVX2)
  // add16 for faces f .. f + 7 (AVX2 builds): the same runs and buckets.
  void add8(int64_t f, __m256i b, const __m256i* lo, const __m256i* hi) {
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(&of_face[size_t(f)]), b);
    // In order while no face's bucket is below the one before it.
    const __m256i before = _mm256_blend_epi32(
        _mm256_permutevar8x32_epi32(b, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6)),
        _mm256_set1_epi32(last_), 0x01);
    in_order_ &= _mm256_testz_si256(_mm256_cmpgt_epi32(before, b), _mm256_set1_epi32(-1)) != 0;
    const int32_t last = _mm256_extract_epi32(b, 7);
    last_ = last;
    __m256i in_run = _mm256_cmpeq_epi32(b, _mm256_set1_epi32(run_));  // (run_ -1: no bucket)
    if (_mm256_testz_si256(in_run, in_run)) {
      end_run();
      in_run = _mm256_cmpeq_epi32(b, _mm256_set1_epi32(last));
      run_ = last;
      run_count_ = 0;
      run_first_ = f + __builtin_ctz(simd::bits8(in_run));
      for (int a = 0; a < 3; ++a) {
        run_lo_[a] = ~uint32_t(0);
        run_hi_[a] = 0;
      }
    }
    const __m256i out_of_run = _mm256_xor_si256(in_run, _mm256_set1_epi32(-1));
    for (int a = 0; a < 3; ++a) {
      __m256i* run_lo = reinterpret_cast<__m256i*>(lane_lo_[a]);
      __m256i* run_hi = reinterpret_cast<__m256i*>(lane_hi_[a]);
      // Lanes out of the run: lo all ones, hi zero, which change nothing.
      const __m256i face_lo = _mm256_or_si256(lo[a], out_of_run);
      const __m256i face_hi = _mm256_and_si256(hi[a], in_run);
      _mm256_storeu_si256(run_lo, _mm256_min_epu32(_mm256_loadu_si256(run_lo), face_lo));
      _mm256_storeu_si256(run_hi, _mm256_max_epu32(_mm256_loadu_si256(run_hi), face_hi));
    }
    const unsigned run_bits = simd::bits8(in_run);
    run_count_ += __builtin_popcount(run_bits);
    run_last_ = f + 31 - __builtin_clz(run_bits);
    unsigned left = ~run_bits & 0xFFu;
    if (!left) return;
    alignas(32) int32_t bs[8];
    alignas(32) uint32_t l[3][8], h[3][8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(bs), b);
    for (int a = 0; a < 3; ++a) {
      _mm256_store_si256(reinterpret_cast<__m256i*>(l[a]), lo[a]);
      _mm256_store_si256(reinterpret_cast<__m256i*>(h[a]), hi[a]);
    }
    while (left) {
      const int k = __builtin_ctz(left);
      const unsigned same = left & simd::bits8(_mm256_cmpeq_epi32(b, _mm256_set1_epi32(bs[k])));
      left &= ~same;
      uint32_t fl[3] = {~uint32_t(0), ~uint32_t(0), ~uint32_t(0)}, fh[3] = {0, 0, 0};
      for (unsigned m = same; m; m &= m - 1)
        for (int a = 0; a < 3; ++a) {
          fl[a] = std::min(fl[a], l[a][__builtin_ctz(m)]);
          fh[a] = std::max(fh[a], h[a][__builtin_ctz(m)]);
        }
      add_to_bucket(bs[k], __builtin_popcount(same), f + k, f + 31 - __builtin_clz(same), fl, fh);
    }
  }
#endif
  // Counts to starts, and the faces' indices in bucket order (the tree's
  // order) -- unless they came in that order, with ids: then the tree's rows
  // are the mesh's own. `vector`: the AVX-512 loop below, which writes the
  // same rows in the same order as the scalar one (tests hold it to that).
  void scatter(const MeshView& mesh, ObjectTree& tree, bool vector) {
    end_run();
    for (size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
    if (in_order_ && mesh.face_ids) {
      tree.faces.clear();
      tree.ids.clear();
      tree.mesh_faces = mesh.faces;
      tree.mesh_ids = mesh.face_ids;
      return;
    }
    thread_local std::vector<int64_t> next;
    next.assign(start.begin(), start.end() - 1);
    tree.mesh_faces = mesh.faces;
    tree.mesh_ids = mesh.face_ids;
    tree.order.resize(size_t(mesh.n_faces));
    int32_t* order = tree.order.data();
    int64_t f = 0;
#ifdef ZBUFFER_AVX512
    // 16 faces at a time: those in the bucket of the first go to consecutive
    // places at once (compressed, in order), the others one by one. The
    // octree's faces come mostly in runs (Mesh.prepare's order is that of
    // the depth-T cells) broken by single faces that belong to a coarser
    // node (under the loose rule, only faces wider than a cell: a mesh of
    // narrow ones comes in bucket order and is not listed at all).
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    for (; vector && f + 16 <= mesh.n_faces; f += 16) {
      const __m512i bucket = _mm512_loadu_si512(&of_face[size_t(f)]);
      const int32_t b = of_face[size_t(f)];
      const __mmask16 same = _mm512_cmpeq_epi32_mask(bucket, _mm512_set1_epi32(b));
      const int64_t to = next[size_t(b)];
      const int n_same = __builtin_popcount(same);
      _mm512_mask_storeu_epi32(order + to, __mmask16((1u << n_same) - 1u),
                               _mm512_maskz_compress_epi32(same, _mm512_add_epi32(_mm512_set1_epi32(int32_t(f)), lane)));
      next[size_t(b)] = to + n_same;
      for (__mmask16 other = __mmask16(~same); other; other &= __mmask16(other - 1)) {
        const int64_t g = f + __builtin_ctz(other);
        order[next[size_t(of_face[size_t(g)])]++] = int32_t(g);
      }
    }
#endif
    (void)vector;
    for (; f < mesh.n_faces; ++f) order[next[size_t(of_face[size_t(f)])]++] = int32_t(f);
  }
  // Grid box of buckets [b, e) into lo/hi (empty buckets do not widen it).
  void unite(size_t b, size_t e, uint32_t* lo, uint32_t* hi) const {
    for (size_t k = b; k < e; ++k) {
      if (start[k + 1] == start[k]) continue;
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min<uint32_t>(lo[a], box[6 * k + a]);
        hi[a] = std::max<uint32_t>(hi[a], box[6 * k + 3 + a]);
      }
    }
  }
  // The first and last face of buckets [b, e) (first > last: none).
  void face_span(size_t b, size_t e, int64_t& first, int64_t& last) const {
    first = std::numeric_limits<int64_t>::max();
    last = -1;
    for (size_t k = b; k < e; ++k) {
      first = std::min(first, first_face[k]);
      last = std::max(last, last_face[k]);
    }
  }

 private:
  // `count` more faces in bucket b, the first `first` and the last `last`,
  // with the grid box lo .. hi.
  void add_run(int32_t b, int64_t count, int64_t first, int64_t last, const uint32_t* lo,
               const uint32_t* hi) {
    if (b != run_) {
      end_run();
      run_ = b;
      run_count_ = 0;
      run_first_ = first;
      for (int a = 0; a < 3; ++a) {
        run_lo_[a] = lo[a];
        run_hi_[a] = hi[a];
      }
    }
    run_count_ += count;
    run_last_ = last;
    for (int a = 0; a < 3; ++a) {
      run_lo_[a] = std::min(run_lo_[a], lo[a]);
      run_hi_[a] = std::max(run_hi_[a], hi[a]);
    }
  }
  void end_run() {
    if (run_ < 0) return;
#ifdef ZBUFFER_AVX512
    for (int a = 0; a < 3; ++a) {
      run_lo_[a] = std::min(run_lo_[a], _mm512_reduce_min_epu32(_mm512_loadu_si512(lane_lo_[a])));
      run_hi_[a] = std::max(run_hi_[a], _mm512_reduce_max_epu32(_mm512_loadu_si512(lane_hi_[a])));
    }
    clear_lanes();
#elif defined(ZBUFFER_AVX2)
    for (int a = 0; a < 3; ++a) {
      run_lo_[a] = std::min(run_lo_[a], *std::min_element(lane_lo_[a], lane_lo_[a] + 8));
      run_hi_[a] = std::max(run_hi_[a], *std::max_element(lane_hi_[a], lane_hi_[a] + 8));
    }
    clear_lanes();
#endif
    add_to_bucket(run_, run_count_, run_first_, run_last_, run_lo_, run_hi_);
    run_ = -1;
  }
  // `count` faces, from `first` to `last`, with the grid box lo .. hi, into
  // bucket b's count, face span and box.
  void add_to_bucket(int32_t b, int64_t count, int64_t first, int64_t last, const uint32_t* lo,
                     const uint32_t* hi) {
    start[size_t(b) + 1] += count;
    first_face[size_t(b)] = std::min(first_face[size_t(b)], first);
    last_face[size_t(b)] = std::max(last_face[size_t(b)], last);
    uint16_t* bx = &box[6 * size_t(b)];
    for (int a = 0; a < 3; ++a) {
      bx[a] = std::min<uint16_t>(bx[a], uint16_t(lo[a]));
      bx[3 + a] = std::max<uint16_t>(bx[3 + a], uint16_t(hi[a]));
    }
  }
  int32_t run_ = -1;
  int32_t last_ = -1;      // the bucket of the latest face
  bool in_order_ = true;   // the faces so far came in bucket order
  int64_t run_count_ = 0;
  int64_t run_first_ = 0, run_last_ = 0;  // the run's first and last face
  uint32_t run_lo_[3] = {}, run_hi_[3] = {};
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  // More of the run's bounds, lane by lane (add16; add8: the first 8),
  // folded in by end_run.
  // (Plain arrays, moved by unaligned loads and stores: a thread_local in a
  // shared library need not get a vector's alignment.)
  uint32_t lane_lo_[3][16], lane_hi_[3][16];
  void clear_lanes() {
    for (int a = 0; a < 3; ++a) {
      std::fill_n(lane_lo_[a], 16, ~uint32_t(0));
      std::fill_n(lane_hi_[a], 16, uint32_t(0));
    }
  }
#endif
};

Buckets& buckets() {
  thread_local Buckets b;
  return b;
}

void set_bounds(TreeNode& node, const VertexGrid& grid, const uint32_t* lo, const uint32_t* hi) {
  for (int a = 0; a < 3; ++a) {
    node.lo[a] = grid.world_lo(lo[a], a);
    node.hi[a] = grid.world_hi(hi[a], a);
  }
}

int32_t add_cluster(ObjectTree& tree, int32_t node, int64_t b, int64_t e) {
  const int32_t c = int32_t(tree.clusters.size());
  TriangleCluster cluster;
  cluster.face_begin = b;
  cluster.face_end = e;
  cluster.node = node;
  tree.clusters.push_back(cluster);
  tree.nodes[size_t(node)].cluster = c;
  return c;
}

// Cluster c of an indexed tree holds the faces of buckets [lo, hi): where
// they lie among few others in the mesh's order, it is set to be drawn from
// there (TriangleCluster::range_begin) instead of by gathering its rows. A mesh in
// spatial order (Mesh.prepare: the Morton order on the trees' grid) lists a
// cell's faces together, interleaved with the few that belong to a coarser
// node (wider than a cell, or straddling its border: octree.h's rules);
// those are skipped, at most kRangeSlack - 1 of the cluster's size.
constexpr int64_t kRangeSlack = 2;
void set_mesh_range(ObjectTree& tree, int32_t c, const Buckets& buckets, size_t lo, size_t hi) {
  if (tree.order.empty()) return;  // its rows are runs of the mesh's arrays already
  TriangleCluster& cl = tree.clusters[size_t(c)];
  int64_t first, last;
  buckets.face_span(lo, hi, first, last);
  if (last < first || last - first + 1 > kRangeSlack * (cl.face_end - cl.face_begin)) return;
  cl.range_begin = int32_t(first);  // (face indices fit `order`'s int32)
  cl.range_end = int32_t(last + 1);
  cl.bucket_begin = int32_t(lo);
  cl.bucket_end = int32_t(hi);
}

void begin(const MeshView& mesh, ObjectTree& tree) {
  tree.clear();
  tree.shared = false;
  tree.n_input_faces = mesh.n_faces;
  tree.mesh_positions = mesh.positions;
  tree.mesh_vertices = mesh.n_vertices;
}

// Octree

class FrameOctree {
 public:
  FrameOctree(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree,
              const VertexGrid& grid)
      : mesh_(mesh), params_(params), tree_(tree), grid_(grid), b_(buckets()),
        cells_(std::min(frame_tree_depth(mesh.n_faces, params.leaf_size), params.max_depth),
               params.rule == OctreeRule::kLoose) {}

  void build(bool vector) {
    b_.reset(size_t(cells_.subtree(0)), size_t(mesh_.n_faces), tree_.face_bucket);
    int64_t f = 0;
#ifdef ZBUFFER_AVX512
    if (vector)
      for (; f + 16 <= mesh_.n_faces; f += 16) {
        __m512i c[3], lo[3], hi[3];
        face_cells16(grid_, mesh_.faces + 3 * f, c, lo, hi);
        b_.add16(f, cells_.holder16(c, lo, hi), lo, hi);
      }
#elif defined(ZBUFFER_AVX2)
    if (vector)
      for (; f + 8 <= mesh_.n_faces; f += 8) {
        __m256i c[3], lo[3], hi[3];
        face_cells8(grid_, mesh_.faces + 3 * f, c, lo, hi);
        b_.add8(f, cells_.holder8(c, lo, hi), lo, hi);
      }
#endif
    (void)vector;
    for (; f < mesh_.n_faces; ++f) {
      uint32_t lo[3], hi[3];
      const int64_t cell = cells_.holder(grid_, mesh_.faces + 3 * f, lo, hi);
      b_.add(f, int32_t(cell), lo, hi);
    }
    b_.scatter(mesh_, tree_, vector);
    tree_.nodes.emplace_back();
    build_node(0, 0, 0);
  }

 private:
  // Node `i` of the tree is bucket `index` at `level`.
  void build_node(int32_t i, int64_t index, int level) {
    const int64_t end_index = index + cells_.subtree(level);
    const int64_t b = b_.start[size_t(index)], e = b_.start[size_t(end_index)];
    tree_.nodes[size_t(i)].depth = level;
    tree_.nodes[size_t(i)].n_triangles = e - b;
    uint32_t lo[3] = {VertexGrid::kMask, VertexGrid::kMask, VertexGrid::kMask}, hi[3] = {0, 0, 0};
    if (e - b <= params_.leaf_size || level == cells_.depth()) {  // a leaf: the whole subtree
      b_.unite(size_t(index), size_t(end_index), lo, hi);
      set_bounds(tree_.nodes[size_t(i)], grid_, lo, hi);
      set_mesh_range(tree_, add_cluster(tree_, i, b, e), b_, size_t(index), size_t(end_index));
      return;
    }
    const int64_t own_end = b_.start[size_t(index) + 1];
    if (own_end > b)
      set_mesh_range(tree_, add_cluster(tree_, i, b, own_end), b_, size_t(index),
                     size_t(index) + 1);
    b_.unite(size_t(index), size_t(index) + 1, lo, hi);
    int64_t child_index[8];
    int n = 0;
    for (int c = 0; c < 8; ++c) {
      const int64_t k = index + 1 + c * cells_.subtree(level + 1);
      if (b_.start[size_t(k + cells_.subtree(level + 1))] > b_.start[size_t(k)]) child_index[n++] = k;
    }
    const int32_t first = add_children(tree_, i, n);
    for (int k = 0; k < n; ++k) build_node(first + k, child_index[k], level + 1);
    if (own_end > b) set_bounds(tree_.nodes[size_t(i)], grid_, lo, hi);
    merge_child_bounds(tree_, i);
  }

  const MeshView& mesh_;
  const OctreeParams& params_;
  ObjectTree& tree_;
  const VertexGrid& grid_;
  Buckets& b_;
  OctreeCells cells_;  // depth T
};

// BVH

class FrameBvh {
 public:
  FrameBvh(const MeshView& mesh, const BvhParams& params, ObjectTree& tree, const VertexGrid& grid)
      : mesh_(mesh), params_(params), tree_(tree), grid_(grid), b_(buckets()) {
    bits_ = 3 * frame_tree_depth(mesh.n_faces, params.leaf_size);
  }

  void build(bool vector) {
    b_.reset(size_t(1) << bits_, size_t(mesh_.n_faces), tree_.face_bucket);
    int64_t f = 0;
#ifdef ZBUFFER_AVX512
    if (vector) {
      for (; f + 16 <= mesh_.n_faces; f += 16) {
        __m512i c[3], lo[3], hi[3];
        face_cells16(grid_, mesh_.faces + 3 * f, c, lo, hi);
        const __m512i code = centroid_codes16(c);
        b_.add16(f, _mm512_srli_epi32(code, unsigned(30 - bits_)), lo, hi);
      }
    }
#elif defined(ZBUFFER_AVX2)
    if (vector) {
      for (; f + 8 <= mesh_.n_faces; f += 8) {
        __m256i c[3], lo[3], hi[3];
        face_cells8(grid_, mesh_.faces + 3 * f, c, lo, hi);
        b_.add8(f, _mm256_srli_epi32(centroid_codes8(c), 30 - bits_), lo, hi);
      }
    }
#endif
    (void)vector;
    for (; f < mesh_.n_faces; ++f) {
      uint32_t lo[3], hi[3];
      face_cells(grid_, mesh_.faces + 3 * f, lo, hi);
      b_.add(f, int32_t(grid_.centroid_code(mesh_.faces + 3 * f) >> (30 - bits_)), lo, hi);
    }
    b_.scatter(mesh_, tree_, vector);
    used_.clear();
    for (size_t k = 0; k + 1 < b_.start.size(); ++k)
      if (b_.start[k + 1] > b_.start[k]) used_.push_back(uint32_t(k));
    tree_.nodes.emplace_back();
    build_node(0, 0, used_.size(), 0);
  }

 private:
  // Node `i` holds the used buckets [u0, u1).
  void build_node(int32_t i, size_t u0, size_t u1, int depth) {
    const int64_t b = b_.start[used_[u0]], e = b_.start[size_t(used_[u1 - 1]) + 1];
    tree_.nodes[size_t(i)].depth = depth;
    tree_.nodes[size_t(i)].n_triangles = e - b;
    if (e - b <= params_.leaf_size || u1 - u0 == 1) {
      uint32_t lo[3] = {VertexGrid::kMask, VertexGrid::kMask, VertexGrid::kMask}, hi[3] = {0, 0, 0};
      b_.unite(used_[u0], size_t(used_[u1 - 1]) + 1, lo, hi);
      set_bounds(tree_.nodes[size_t(i)], grid_, lo, hi);
      add_cluster(tree_, i, b, e);
      return;
    }
    // Split where the highest differing bit of the bucket codes turns to 1.
    const uint32_t bit = 1u << (31 - __builtin_clz(used_[u0] ^ used_[u1 - 1]));
    const size_t mid = size_t(std::partition_point(used_.begin() + long(u0), used_.begin() + long(u1),
                                                   [bit](uint32_t k) { return !(k & bit); }) -
                              used_.begin());
    const int32_t first = add_children(tree_, i, 2);
    build_node(first, u0, mid, depth + 1);
    build_node(first + 1, mid, u1, depth + 1);
    merge_child_bounds(tree_, i);
  }

  const MeshView& mesh_;
  const BvhParams& params_;
  ObjectTree& tree_;
  const VertexGrid& grid_;
  Buckets& b_;
  int bits_ = 3;
  std::vector<uint32_t> used_;
};

}  // namespace

int frame_tree_depth(int64_t faces, int leaf_size) {
  // A closed surface in its bounding cube crosses about 3 x 4^T cells of a
  // depth-T grid (a sphere: pi x 4^T): aim for leaf_size triangles in each.
  // (Counting 4^T cells instead, one level deeper on meshes under ~1.5M
  // faces, made per-frame trees 3-16% slower on single meshes: bucket
  // bookkeeping and clusters of a few faces.)
  const double cells = double(faces) / (3.0 * double(std::max(1, leaf_size)));
  const int depth = cells > 1.0 ? int(std::ceil(std::log(cells) / std::log(4.0))) : 1;
  return std::max(1, std::min(kMaxFrameDepth, depth));
}

void build_octree_for_frame(const MeshView& mesh, const OctreeParams& params, ObjectTree& tree,
                            bool vector) {
  if (params.rule == OctreeRule::kGreene)
    throw std::invalid_argument("a per-frame octree takes the loose or the simpler rule, not Greene's");
  begin(mesh, tree);
  if (mesh.n_faces == 0) return;
  thread_local VertexGrid grid;
  grid.build(mesh, vector);
  FrameOctree(mesh, params, tree, grid).build(vector);
}

void build_bvh_for_frame(const MeshView& mesh, const BvhParams& params, ObjectTree& tree,
                         bool vector) {
  begin(mesh, tree);
  if (mesh.n_faces == 0) return;
  thread_local VertexGrid grid;
  grid.build(mesh, vector);
  FrameBvh(mesh, params, tree, grid).build(vector);
}

}  // namespace zbuffer
