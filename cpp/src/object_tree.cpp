// Clusters of object-space trees, and the front-to-back traversal that
// renders them against a Z-pyramid.
#include "zbuffer/object_tree.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "zbuffer/algorithms.h"
#include "zbuffer/triangle_batch.h"
#include "zbuffer/vertex_stage.h"
#include "zbuffer/zpyramid.h"
#include "id_runs.h"
#include "setup16.h"
#include "simd.h"
#include "timing.h"

namespace zbuffer {

int64_t ObjectTree::memory_bytes() const {
  return int64_t(nodes.size() * sizeof(TreeNode) + clusters.size() * sizeof(TriangleCluster) +
                 positions.size() * sizeof(double) + faces.size() * sizeof(int32_t) +
                 ids.size() * sizeof(int32_t) + source.size() * sizeof(int32_t) +
                 order.size() * sizeof(int32_t) + face_bucket.size() * sizeof(int32_t) +
                 cluster_of_id.size() * sizeof(int32_t));
}

void ObjectTree::clear() {
  nodes.clear();
  clusters.clear();
  positions.clear();
  faces.clear();
  ids.clear();
  source.clear();
  cluster_of_id.clear();
  n_input_faces = 0;
  mesh_positions = nullptr;
  mesh_vertices = 0;
  mesh_faces = mesh_ids = nullptr;
  order.clear();
  // (face_bucket is kept: the next per-frame build writes it whole.)
}

// Cluster Construction

namespace {
constexpr int64_t kFetchAhead = 8;
std::vector<uint64_t>& vertex_scratch() {
  thread_local std::vector<uint64_t> v;
  return v;
}
std::vector<int32_t>& face_scratch() {
  thread_local std::vector<int32_t> v;
  return v;
}
// A vertex's slot: the last cluster that used it (high half; all ones:
// none) and its index among that cluster's vertices.
constexpr uint64_t kNoSlot = ~uint64_t(0);
}  // namespace

ClusterBuilder::ClusterBuilder(const MeshView& mesh, ObjectTree& tree)
    : mesh_(mesh), tree_(tree), vertex_slot_(vertex_scratch()), face_mark_(face_scratch()) {
  vertex_slot_.assign(size_t(mesh.n_vertices), kNoSlot);
  tree_.n_input_faces = mesh.n_faces;
  if (tree_.shared) face_mark_.assign(size_t(mesh.n_faces), -1);
}

void ClusterBuilder::reserve(int64_t references) {
  // Room for every reference's three vertices (no cluster can copy more);
  // only the pages written are ever mapped, and those of a large tree in
  // huge pages (a fresh tree faults in hundreds of MB: 20% of a Scene build
  // of 11.7 million triangles in 4 KiB pages).
  // Faces index the tree's vertex copies, at most three per reference.
  constexpr int64_t kMostReferences = (int64_t(std::numeric_limits<int32_t>::max()) - 1) / 3;
  if (references > kMostReferences)
    throw std::length_error("a tree of " + std::to_string(references) +
                            " triangle references is too large: at most " +
                            std::to_string(kMostReferences));
  const size_t n = size_t(references);
  reserve_huge(tree_.faces, 3 * n);
  reserve_huge(tree_.ids, n);
  reserve_huge(tree_.positions, 9 * n + 1);  // (+1: add_cluster's slack)
  if (tree_.shared) reserve_huge(tree_.source, n);
}

void ClusterBuilder::add_cluster(int32_t node, const int32_t* face, int64_t n) {
  const int32_t c = int32_t(tree_.clusters.size());
  TriangleCluster cluster;
  cluster.node = node;
  cluster.face_begin = int64_t(tree_.ids.size());
  cluster.vertex_begin = int64_t(tree_.positions.size() / 3);
  // Room for n faces and 3 n vertices, written through pointers, then cut
  // to what was written (buffer.h).
  const size_t f0 = tree_.ids.size(), p0 = tree_.positions.size();
  tree_.ids.resize(f0 + size_t(n));
  tree_.faces.resize(3 * (f0 + size_t(n)));
  tree_.positions.resize(p0 + 9 * size_t(n) + 1);
  if (tree_.shared) tree_.source.resize(f0 + size_t(n));
  int32_t* out_ids = tree_.ids.data() + f0;
  int32_t* out_faces = tree_.faces.data() + 3 * f0;
  int32_t* out_source = tree_.shared ? tree_.source.data() + f0 : nullptr;
  double* out_positions = tree_.positions.data() + p0;
  uint64_t* const slot = vertex_slot_.data();
  int32_t* const face_mark = face_mark_.data();
  double lo[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  std::numeric_limits<double>::infinity()};
  double hi[3] = {-lo[0], -lo[1], -lo[2]};
  const int32_t* const mesh_faces = mesh_.faces;
  const double* const mesh_positions = mesh_.positions;
  const uint32_t cluster_mark = uint32_t(c);
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  const __m256i xyz_lanes = _mm256_set_epi64x(0, -1, -1, -1);
  __m256d lo4 = _mm256_set1_pd(lo[0]), hi4 = _mm256_set1_pd(hi[0]);
#endif
  int32_t local = 0;  // the cluster's vertices so far
  const int32_t vertex_base = int32_t(cluster.vertex_begin);  // (reserve: below 2^31)
  int64_t kept = 0;
  for (int64_t r = 0; r < n; ++r) {
    const int32_t f = face[r];
    // The faces come in tree order, scattered over the mesh: fetch ahead.
    if (r + 2 * kFetchAhead < n) prefetch(mesh_faces + 3 * int64_t(face[r + 2 * kFetchAhead]));
    if (r + kFetchAhead < n) {
      const int32_t* ahead = mesh_faces + 3 * int64_t(face[r + kFetchAhead]);
      for (int k = 0; k < 3; ++k) {
        prefetch(slot + ahead[k]);
        prefetch(mesh_positions + 3 * int64_t(ahead[k]));
      }
    }
    if (out_source) {  // the same face reached through two cells of one leaf
      if (face_mark[f] == c) continue;
      face_mark[f] = c;
      out_source[kept] = f;
    }
    // A vertex's first use in this cluster copies it to the next local
    // index. Without branches: each corner is copied to that index and
    // bounded, and the index moves on only at a first use (a vertex is used
    // by about six faces, so a branch on it mispredicted a third of the time).
    const int32_t* idx = mesh_faces + 3 * int64_t(f);
    for (int k = 0; k < 3; ++k) {
      const int32_t v = idx[k];
      const uint64_t was = slot[v];
      const bool first = uint32_t(was >> 32) != cluster_mark;
      const int32_t at = first ? local : int32_t(uint32_t(was));
      slot[v] = uint64_t(cluster_mark) << 32 | uint32_t(at);
      const double* p = mesh_positions + 3 * int64_t(v);
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
      // (x, y, z, 0); min and max keep the bound where p is NaN, as
      // std::min and std::max do below.
      // (Stored whole: the fourth lane lands where the next copy goes, or
      // in the double of slack past the room for 3 n vertices.)
      const __m256d xyz = _mm256_maskload_pd(p, xyz_lanes);
      _mm256_storeu_pd(out_positions + 3 * int64_t(local), xyz);
      lo4 = _mm256_min_pd(xyz, lo4);
      hi4 = _mm256_max_pd(xyz, hi4);
#else
      for (int a = 0; a < 3; ++a) {
        out_positions[3 * int64_t(local) + a] = p[a];
        lo[a] = std::min(lo[a], p[a]);
        hi[a] = std::max(hi[a], p[a]);
      }
#endif
      local += first;
      out_faces[3 * kept + k] = vertex_base + at;
    }
    out_ids[kept] = mesh_.id(f);
    ++kept;
  }
#if defined(ZBUFFER_AVX512) || defined(ZBUFFER_AVX2)
  alignas(32) double lo_out[4], hi_out[4];
  _mm256_store_pd(lo_out, lo4);
  _mm256_store_pd(hi_out, hi4);
  for (int a = 0; a < 3; ++a) {
    lo[a] = lo_out[a];
    hi[a] = hi_out[a];
  }
#endif
  tree_.ids.resize(f0 + size_t(kept));
  tree_.faces.resize(3 * (f0 + size_t(kept)));
  tree_.positions.resize(p0 + 3 * size_t(local));
  if (tree_.shared) tree_.source.resize(f0 + size_t(kept));
  cluster.face_end = int64_t(tree_.ids.size());
  cluster.vertex_end = int64_t(tree_.positions.size() / 3);
  tree_.clusters.push_back(cluster);
  TreeNode& t = tree_.nodes[size_t(node)];
  t.cluster = c;
  for (int a = 0; a < 3; ++a) {
    t.lo[a] = lo[a];
    t.hi[a] = hi[a];
  }
}

void ClusterBuilder::finish() {
  // id -> cluster, when ids are the face indices (then temporal coherence
  // can map the pixels of a frame back to clusters).
  if (mesh_.face_ids) return;
  reserve_huge(tree_.cluster_of_id, size_t(mesh_.n_faces));
  tree_.cluster_of_id.assign(size_t(mesh_.n_faces), -1);
  for (size_t c = 0; c < tree_.clusters.size(); ++c) {
    const TriangleCluster& cl = tree_.clusters[c];
    for (int64_t r = cl.face_begin; r < cl.face_end; ++r) {
      int32_t& slot = tree_.cluster_of_id[size_t(tree_.ids[size_t(r)])];
      if (slot < 0) slot = int32_t(c);
    }
  }
}

void merge_child_bounds(ObjectTree& tree, int32_t i) {
  TreeNode& node = tree.nodes[size_t(i)];
  if (node.cluster < 0) {
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = std::numeric_limits<double>::infinity();
      node.hi[a] = -std::numeric_limits<double>::infinity();
    }
  }
  for (int32_t k = 0; k < node.n_children; ++k) {
    const TreeNode& child = tree.nodes[size_t(node.first_child + k)];
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = std::min(node.lo[a], child.lo[a]);
      node.hi[a] = std::max(node.hi[a], child.hi[a]);
    }
  }
}

int32_t add_children(ObjectTree& tree, int32_t parent, int n) {
  const int32_t first = int32_t(tree.nodes.size());
  tree.nodes.resize(tree.nodes.size() + size_t(n));
  tree.nodes[size_t(parent)].first_child = first;
  tree.nodes[size_t(parent)].n_children = n;
  return first;
}

// Node Test

namespace {

// A node's box as the pyramid sees it: a pixel rectangle that contains every
// pixel any of its triangles can cover, and a depth no pixel of theirs can be
// nearer than.
struct ProjectedNode {
  int32_t node;
  int x0, y0, x1, y1;
  float z_near;
  bool testable;  // false: the box reaches the near plane, never cull it
};

// Margins for rounding. A triangle's vertices are transformed by the same
// double formulas as the box corners (transform_point, to_screen), so the
// two differ from the exact values by rounding only. Each clip coordinate
// is a sum of four products, within 4u (u = 2^-53) times the sum of their
// magnitudes S of the exact value; a coordinate divided by w is then within
// about 4u (S_c + |c / w| S_w) / w, for a corner and for a vertex alike.
// kRoundingScale (2^-49 = 16u) covers both with room for the divide and
// the viewport's operations; it is applied with the largest magnitudes and
// smallest w over the box. Large world coordinates seen from close by make
// S / w large (the matrix's translation cancels most of the products):
// such a scene needs more than a fixed margin. kDepthMargin adds what the
// depth of a pixel loses to float32 (its clamp to the triangle's nearest
// vertex depth rounded to float).
constexpr double kRoundingScale = 1.0 / double(int64_t(1) << 49);
constexpr double kDepthMargin = 1e-7;

// The largest float <= v.
float float_at_or_below(double v) {
  float f = float(v);
  if (double(f) > v) f = std::nextafter(f, -std::numeric_limits<float>::infinity());
  return f;
}

// How far beyond a plane of the view volume (x + w < 0, w - x < 0, ... in
// clip space) all of a box's corners must lie for none of its triangles'
// vertices to be computed inside it: a corner's computed x + w and a
// vertex's are each within 8u (S_x + S_w) of the exact values (u = 2^-53;
// S: the row's largest sum of product magnitudes, `mag`), and the exact
// values of a point in the box are a convex combination of its corners'.
// kRoundingScale (16u) covers both. Without it, a mesh tiny beside its
// distance from the origin (size 10 at 1e15) lost a triangle that the
// reference drew: its box's corners, rounded, fell just outside a plane.
// Margins per axis; infinite (never outside) where the magnitudes overflow.
void plane_margins(const double* mag, double* margin) {
  for (int a = 0; a < 3; ++a) {
    margin[a] = kRoundingScale * (mag[a] + mag[3]);
    if (!(margin[a] <= std::numeric_limits<double>::max()))
      margin[a] = std::numeric_limits<double>::infinity();
  }
}

// Projects node `i`'s box. Returns false if it lies outside the view volume
// (wholly beyond one of its planes, or off the image).
bool project_node(const TreeNode& node, int32_t i, const double* mvp, const Viewport& vp,
                  ProjectedNode& out) {
  bool near = false;
  double x_lo = std::numeric_limits<double>::infinity(), x_hi = -x_lo;
  double y_lo = x_lo, y_hi = -x_lo, z_lo = x_lo;
  // For the rounding margins: per clip row the largest sum of the products'
  // magnitudes over the corners, the smallest w, the largest |x/w|, |y/w|,
  // |z/w|.
  double mag[4] = {0, 0, 0, 0}, w_min = x_lo, ndc_max[3] = {0, 0, 0};
#ifdef ZBUFFER_AVX512
  // The 8 corners in the 8 lanes: lane k takes hi on axis a where bit a of k
  // is set. The same formulas as below, one instruction per operation.
  const __m512d x = _mm512_mask_blend_pd(0xAA, _mm512_set1_pd(node.lo[0]), _mm512_set1_pd(node.hi[0]));
  const __m512d y = _mm512_mask_blend_pd(0xCC, _mm512_set1_pd(node.lo[1]), _mm512_set1_pd(node.hi[1]));
  const __m512d z = _mm512_mask_blend_pd(0xF0, _mm512_set1_pd(node.lo[2]), _mm512_set1_pd(node.hi[2]));
  __m512d clip[4];
  simd::transform8(mvp, x, y, z, clip);
  const __m512d cx = clip[0], cy = clip[1], cz = clip[2], cw = clip[3];
  const __mmask8 invalid = simd::nonfinite8(clip);
  // Magnitudes of each row's products, for the rounding margins.
  const __m512d ax = _mm512_abs_pd(x), ay = _mm512_abs_pd(y), az = _mm512_abs_pd(z);
  auto magnitude = [&](int r) {
    const double* m = mvp + 4 * r;
    return _mm512_reduce_max_pd(_mm512_add_pd(
        _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(_mm512_set1_pd(std::abs(m[0])), ax),
                                    _mm512_mul_pd(_mm512_set1_pd(std::abs(m[1])), ay)),
                      _mm512_mul_pd(_mm512_set1_pd(std::abs(m[2])), az)),
        _mm512_set1_pd(std::abs(m[3]))));
  };
  for (int r = 0; r < 4; ++r) mag[r] = magnitude(r);
  auto below = [&](__m512d v, double margin = 0.0) {
    return __mmask8(_mm512_cmp_pd_mask(v, _mm512_set1_pd(-margin), _CMP_LT_OQ) & ~invalid);
  };
  // Wholly outside one plane of the view volume, by more than rounding
  // could move a corner and a vertex (plane_margins; an invalid corner is
  // outside none, as outcode() has it).
  double margin[3];
  plane_margins(mag, margin);
  if (below(_mm512_add_pd(cx, cw), margin[0]) == 0xFF ||
      below(_mm512_sub_pd(cw, cx), margin[0]) == 0xFF ||
      below(_mm512_add_pd(cy, cw), margin[1]) == 0xFF ||
      below(_mm512_sub_pd(cw, cy), margin[1]) == 0xFF ||
      below(_mm512_add_pd(cz, cw), margin[2]) == 0xFF ||
      below(_mm512_sub_pd(cw, cz), margin[2]) == 0xFF)
    return false;
  near = (invalid | below(_mm512_add_pd(cz, cw)) |
          _mm512_cmp_pd_mask(cw, _mm512_set1_pd(kMinClipW), _CMP_NGE_UQ)) != 0;
  if (!near) {
    const __m512d one = _mm512_set1_pd(1.0);
    const __m512d inv_w = _mm512_div_pd(one, cw);
    const __m512d xn = _mm512_mul_pd(cx, inv_w), yn = _mm512_mul_pd(cy, inv_w),
                  zn = _mm512_mul_pd(cz, inv_w);
    const __m512d xw = _mm512_mul_pd(_mm512_add_pd(xn, one), _mm512_set1_pd(vp.half_w));
    const __m512d yw = _mm512_mul_pd(_mm512_sub_pd(one, yn), _mm512_set1_pd(vp.half_h));
    const __m512d zw = _mm512_add_pd(_mm512_mul_pd(zn, _mm512_set1_pd(0.5)), _mm512_set1_pd(0.5));
    x_lo = _mm512_reduce_min_pd(xw);
    x_hi = _mm512_reduce_max_pd(xw);
    y_lo = _mm512_reduce_min_pd(yw);
    y_hi = _mm512_reduce_max_pd(yw);
    z_lo = _mm512_reduce_min_pd(zw);
    w_min = _mm512_reduce_min_pd(cw);
    ndc_max[0] = _mm512_reduce_max_pd(_mm512_abs_pd(xn));
    ndc_max[1] = _mm512_reduce_max_pd(_mm512_abs_pd(yn));
    ndc_max[2] = _mm512_reduce_max_pd(_mm512_abs_pd(zn));
  }
#else
  ClipVertex clip[8];
  for (int corner = 0; corner < 8; ++corner) {
    const double p[3] = {(corner & 1) ? node.hi[0] : node.lo[0],
                         (corner & 2) ? node.hi[1] : node.lo[1],
                         (corner & 4) ? node.hi[2] : node.lo[2]};
    clip[corner] = transform_point(mvp, p);
    for (int r = 0; r < 4; ++r) {
      const double* m = mvp + 4 * r;
      mag[r] = std::max(mag[r], std::abs(m[0]) * std::abs(p[0]) + std::abs(m[1]) * std::abs(p[1]) +
                                    std::abs(m[2]) * std::abs(p[2]) + std::abs(m[3]));
    }
  }
  // Wholly outside one plane (as above: by more than the margins; an
  // invalid corner is outside none).
  double margin[3];
  plane_margins(mag, margin);
  uint32_t all_out = 0x3F;  // bit 2a: below -w on axis a, bit 2a + 1: above w
  uint32_t oc[8];
  for (int corner = 0; corner < 8; ++corner) {
    const ClipVertex& c = clip[corner];
    oc[corner] = outcode(c, vp);
    if (oc[corner] & kOutInvalid) all_out = 0;
    const double v[3] = {c.x, c.y, c.z};
    for (int a = 0; a < 3; ++a) {
      if (!(v[a] + c.w < -margin[a])) all_out &= ~(1u << (2 * a));
      if (!(c.w - v[a] < -margin[a])) all_out &= ~(2u << (2 * a));
    }
  }
  if (all_out) return false;
  for (int corner = 0; corner < 8; ++corner) {
    const ClipVertex& c = clip[corner];
    if (oc[corner] & (kOutNear | kOutInvalid)) {  // at, behind or too close to the eye
      near = true;
      continue;
    }
    // The perspective divide and viewport, as to_screen does them.
    const double inv_w = 1.0 / c.w;
    const double xw = (c.x * inv_w + 1.0) * vp.half_w;
    const double yw = (1.0 - c.y * inv_w) * vp.half_h;
    const double zw = (c.z * inv_w) * 0.5 + 0.5;
    x_lo = std::min(x_lo, xw);
    x_hi = std::max(x_hi, xw);
    y_lo = std::min(y_lo, yw);
    y_hi = std::max(y_hi, yw);
    z_lo = std::min(z_lo, zw);
    w_min = std::min(w_min, c.w);
    ndc_max[0] = std::max(ndc_max[0], std::abs(c.x * inv_w));
    ndc_max[1] = std::max(ndc_max[1], std::abs(c.y * inv_w));
    ndc_max[2] = std::max(ndc_max[2], std::abs(c.z * inv_w));
  }
#endif
  // The rounding margins (see kRoundingScale), in NDC; w is at least what
  // the corners' computed w says less its own error.
  double err[3] = {0, 0, 0};
  if (!near) {
    const double w_low = w_min - kRoundingScale * mag[3];
    if (w_low > 0.0 && std::isfinite(mag[0] + mag[1] + mag[2] + mag[3])) {
      for (int a = 0; a < 3; ++a) err[a] = kRoundingScale * (mag[a] + ndc_max[a] * mag[3]) / w_low;
    } else {
      near = true;  // too close to the eye to bound: never culled
    }
  }
  out.node = i;
  if (near) {  // the projection of the box is unbounded: keep it whole
    out.x0 = 0;
    out.y0 = 0;
    out.x1 = vp.width - 1;
    out.y1 = vp.height - 1;
    out.z_near = -std::numeric_limits<float>::infinity();
    out.testable = false;
    return true;
  }
  // In front of the eye the box projects into the bounding rectangle of its
  // corners; a pixel whose centre (i + 0.5) is covered lies within half a
  // pixel of it, and snapping moves vertices by 1/512 pixel: one pixel of
  // margin each side. Clamped in double before converting to int.
  auto pixel = [](double v, double limit) {
    return int(std::floor(std::max(-1.0, std::min(limit, v))));
  };
  const double x_pad = 1.0 + err[0] * vp.half_w, y_pad = 1.0 + err[1] * vp.half_h;
  out.x0 = std::max(0, pixel(x_lo - x_pad, vp.width));
  out.x1 = std::min(vp.width - 1, pixel(x_hi + x_pad, vp.width));
  out.y0 = std::max(0, pixel(y_lo - y_pad, vp.height));
  out.y1 = std::min(vp.height - 1, pixel(y_hi + y_pad, vp.height));
  if (out.x0 > out.x1 || out.y0 > out.y1) return false;  // off the image
  out.z_near = float_at_or_below(z_lo - kDepthMargin - 0.5 * err[2]);
  out.testable = true;
  return true;
}

// The level a node's rectangle is tested at: the finest kept level where
// it spans at most 16 cells a side (ZPyramid::max_over stops at two, which
// for the small boxes of leaves reads up to four times the area). A finer
// test hides more nodes; its reads (up to 16 x 16 cells, a row 16 or 8 at
// a time: ZPyramid::max_over_cells) cost far less than drawing a cluster.
// Against four cells a side (benchmarks/ab.py, spot grid in perspective,
// N = 20 and 40): per-frame trees 0.94-0.96x, trees built once 0.89-0.90x,
// bunny_69k 0.97-0.99x; 32 cells a side gained no more.
int node_level(const ZPyramid& pyramid, const ProjectedNode& r) {
  if (pyramid.levels() <= pyramid.first_level())  // a tiny image: no coarse levels
    return pyramid.query_level(r.x0, r.y0, r.x1, r.y1);
  int k = pyramid.first_level();
  while (k + 1 < pyramid.levels() &&
         (((r.x1 >> k) - (r.x0 >> k)) > 15 || ((r.y1 >> k) - (r.y0 >> k)) > 15))
    ++k;
  return k;
}

// The farthest depth the pyramid holds over a node's rectangle: the maximum
// of the cells covering it at node_level.
float farthest_under(const ZPyramid& pyramid, const ProjectedNode& r) {
  return pyramid.max_over_cells(node_level(pyramid, r), r.x0, r.y0, r.x1, r.y1);
}

// The faces and ids of an indexed tree's cluster `cl`, gathered from the
// mesh's arrays by the tree's order into `faces` and `ids`.
void gather_rows(const ObjectTree& tree, const TriangleCluster& cl, std::vector<int32_t>& faces,
                 std::vector<int32_t>& ids) {
  const size_t n = size_t(cl.face_end - cl.face_begin);
  faces.resize(3 * n);
  ids.resize(n);
  const int32_t* order = tree.order.data() + cl.face_begin;
  size_t k = 0;
#ifdef ZBUFFER_AVX512
  // 16 rows at a time: three gathers of corners, one of ids, and the
  // corners interleaved back into rows (simd::interleave16) -- where 3 x the
  // face index fits the gathers' int32 lanes.
  const bool gatherable = tree.n_input_faces <= std::numeric_limits<int32_t>::max() / 3;
  for (; gatherable && k < n; k += 16) {
    const __mmask16 live = n - k >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << (n - k)) - 1u);
    if (k + 64 < n) {  // mostly runs of consecutive faces: fetch ahead along them
      const int64_t ahead = order[k + 64];
      for (int line = 0; line < 3; ++line) prefetch(tree.mesh_faces + 3 * ahead + 16 * line);
      if (tree.mesh_ids) prefetch(tree.mesh_ids + ahead);
    }
    const __m512i f = _mm512_maskz_loadu_epi32(live, order + k);
    const __m512i f3 = _mm512_mullo_epi32(f, _mm512_set1_epi32(3));
    __m512i corner[3];
    for (int j = 0; j < 3; ++j)
      corner[j] = _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), live,
                                              _mm512_add_epi32(f3, _mm512_set1_epi32(j)),
                                              tree.mesh_faces, 4);
    const __m512i id = tree.mesh_ids ? _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), live, f,
                                                                    tree.mesh_ids, 4)
                                     : f;
    simd::interleave16(corner, int(std::min<size_t>(16, n - k)), &faces[3 * k]);
    _mm512_mask_storeu_epi32(&ids[k], live, id);
  }
#endif
  for (; k < n; ++k) {
    const int32_t f = order[k];
    std::memcpy(&faces[3 * k], tree.mesh_faces + 3 * int64_t(f), 3 * sizeof(int32_t));
    ids[k] = tree.mesh_ids ? tree.mesh_ids[f] : f;
  }
}

// Design decision: an indexed tree's vertices go through the vertex stage
// when the first cluster drawn that uses them does, in blocks of 256, rather
// than all of them up front as the plain Z-buffer does. Good: a frame whose
// tree culls most of the mesh transforms little more than what it draws
// (the 5 x 5 x 80 spot grid in perspective: a quarter of the blocks; per
// frame octree 0.84x, BVH 0.81x). Bad: a cluster whose vertices are spread
// over the mesh (a coarse node's own faces; a leaf whose faces reuse
// vertices numbered long before) looks up each face's three blocks (three
// gathers per 16 faces), and blocks done one by one stream less well than
// one pass: drawing everything so was 3-8% slower. Hence the limits: meshes
// under 2^18 vertices are transformed up front, and past half of the blocks
// the rest are done at once and the lookups stop (N = 20: octree, which
// reaches 90% of the blocks, 1.02x; BVH 0.99x; orthographic 1.00-1.02x).
// And where the frame before, of the same vertices, drew at least
// TreeFrame::kUpFrontShare of the tree's faces (those not culled in nodes),
// they all go through the vertex stage up front: frames of a mesh from one
// camera, or from nearby ones, draw about the same share, and drawing most
// of the mesh, the lookups cost more than the blocks they spare (spot grid
// in perspective, N = 10 and 20, octree 97% and 82% drawn, 0.96-0.98x the
// lazy frame's time; orthographic, all drawn, 0.97-0.98x; BVH N = 10, 76%,
// 0.96x -- but with a share of 0.4, the octree at N = 40, 49% drawn, 1.03x).
// The first frame of a mesh, and those after one that drew less, go as
// needed.
// A Scene tree's vertices (its clusters' own copies, a run each) follow the
// same choice, up front or as needed -- but as needed, a cluster at a time,
// exactly its run, as before the choice existed: blocks of 256 over runs
// of a few hundred would transform the copies of clusters not drawn (the
// perspective grid 4-5% slower). Up front, single meshes are 2-5% faster
// than a cluster at a time (benchmarks/README.md).
// The screen vertices do not depend on when (or in which block) they are
// computed, and the outcodes' OR, which lets assembly skip reading outcodes
// when it is 0, only grows by vertices not used before: the output is the
// same bits.
class LazyVertices {
 public:
  static constexpr int kShift = 8;  // 256 vertices a block

  LazyVertices(const double* positions, int64_t n_vertices, bool up_front, const double* mvp,
               const Viewport& vp, ScreenVertices& out, std::vector<uint32_t>& done)
      : mvp_(mvp), vp_(vp), out_(out), done_(done) {
    mesh_.positions = positions;
    mesh_.n_vertices = n_vertices;
    out_.resize(size_t(n_vertices));
    out_.any_outcode = 0;
    n_blocks_ = (n_vertices >> kShift) + 1;
    done_.assign(size_t(n_blocks_), 0);
    if (up_front) transform_rest();
  }

  // A Scene tree's cluster, drawn at most once a frame: its own vertex
  // copies, begin .. end - 1, which no other cluster uses, transformed
  // exactly (no blocks to keep track of), and the outcodes' OR made theirs
  // alone, so that the cluster's faces skip reading outcodes where its own
  // vertices allow (as when each cluster had its screen vertices to itself).
  // Up front, the OR stays every vertex's.
  void need_own(int64_t begin, int64_t end) {
    if (all_) return;
    out_.any_outcode = transform_vertex_range(mesh_, mvp_, vp_, begin, end, out_);
  }

  // Every vertex of the n faces (vertex indices, 3 a face) transformed.
  void need(const int32_t* faces, int64_t n) {
    if (all_ || n == 0) return;
    // A cluster whose vertices lie within a few blocks (a leaf of a mesh in
    // visiting order, its vertices numbered by first use) gets those blocks
    // whole; only one spread over the mesh (a coarse node's own faces)
    // looks up each face's.
    int32_t lo = faces[0], hi = faces[0];
    int64_t i = 0;
#ifdef ZBUFFER_AVX512
    __m512i vlo = _mm512_set1_epi32(lo), vhi = vlo;
    for (; i + 16 <= 3 * n; i += 16) {
      const __m512i v = _mm512_loadu_si512(faces + i);
      vlo = _mm512_min_epi32(vlo, v);
      vhi = _mm512_max_epi32(vhi, v);
    }
    lo = _mm512_reduce_min_epi32(vlo);
    hi = _mm512_reduce_max_epi32(vhi);
#endif
    for (; i < 3 * n; ++i) {
      lo = std::min(lo, faces[i]);
      hi = std::max(hi, faces[i]);
    }
    const int32_t first = lo >> kShift, last = hi >> kShift;
    if (int64_t(last - first) < std::max<int64_t>(4, n / 32)) {
      // Runs of blocks not done yet, each through the vertex stage at once.
      for (int32_t b = first; b <= last;) {
        if (done_[size_t(b)]) {
          ++b;
          continue;
        }
        int32_t e = b;
        for (; e <= last && !done_[size_t(e)]; ++e) done_[size_t(e)] = 1;
        transform_blocks(b, e);
        b = e;
      }
      return;
    }
    int64_t k = 0;
#ifdef ZBUFFER_AVX512
    for (; k < n; k += 16) {
      const int count = int(std::min<int64_t>(16, n - k));
      const __mmask16 live = count == 16 ? __mmask16(0xFFFF) : __mmask16((1u << count) - 1u);
      __m512i corner[3];
      simd::deinterleave16(faces + 3 * k, count, corner);
      for (int j = 0; j < 3; ++j) {
        const __m512i block = _mm512_srli_epi32(corner[j], kShift);
        const __m512i done = _mm512_mask_i32gather_epi32(_mm512_set1_epi32(1), live, block,
                                                         done_.data(), 4);
        __mmask16 todo = _mm512_cmpeq_epi32_mask(done, _mm512_setzero_si512());
        if (!todo) continue;
        alignas(64) int32_t b[16];
        _mm512_store_si512(b, block);
        for (; todo; todo &= __mmask16(todo - 1)) need_block(b[__builtin_ctz(todo)]);
      }
    }
#endif
    for (; k < n; ++k)
      for (int j = 0; j < 3; ++j) need_block(faces[3 * k + j] >> kShift);
  }

 private:
  void need_block(int32_t b) {
    if (done_[size_t(b)]) return;
    done_[size_t(b)] = 1;
    transform_blocks(b, b + 1);
  }
  // Blocks b .. e - 1 (marked done) through the vertex stage; past half of
  // them, the rest too.
  void transform_blocks(int32_t b, int32_t e) {
    const int64_t begin = int64_t(b) << kShift;
    const int64_t end = std::min(mesh_.n_vertices, int64_t(e) << kShift);
    out_.any_outcode |= transform_vertex_range(mesh_, mvp_, vp_, begin, end, out_);
    blocks_done_ += e - b;
    if (2 * blocks_done_ > n_blocks_) transform_rest();
  }
  // Every block not done yet, and no more lookups.
  void transform_rest() {
    all_ = true;
    for (int64_t b = 0; b < n_blocks_;) {
      if (done_[size_t(b)]) {
        ++b;
        continue;
      }
      int64_t e = b;
      for (; e < n_blocks_ && !done_[size_t(e)]; ++e) done_[size_t(e)] = 1;
      const int64_t begin = b << kShift, end = std::min(mesh_.n_vertices, e << kShift);
      out_.any_outcode |= transform_vertex_range(mesh_, mvp_, vp_, begin, end, out_);
      b = e;
    }
  }

  MeshView mesh_;
  const double* mvp_;
  const Viewport& vp_;
  ScreenVertices& out_;
  std::vector<uint32_t>& done_;
  int64_t n_blocks_ = 0, blocks_done_ = 0;
  bool all_ = false;  // every vertex done: need() has nothing to look up
};

}  // namespace

// Traversal

void render_object_tree(const ObjectTree& tree, const RenderInput& input, DepthTarget& target,
                        RenderStats& stats, TreeFrame& frame, bool temporal) {
  const auto start = Clock::now();
  if (temporal && tree.cluster_of_id.empty() && tree.n_input_faces > 0)
    throw std::invalid_argument("temporal coherence needs a tree whose ids are the face indices");
  const Viewport vp(target.width, target.height);

  // Frame state: one more frame; stamps are reset only when the counter wraps
  // (or the state was sized for another tree).
  const size_t stamped_faces = tree.shared ? size_t(tree.n_input_faces) : 0;
  if (frame.node_fate.size() != tree.nodes.size() ||
      frame.cluster_stamp.size() != tree.clusters.size() ||
      frame.face_stamp.size() != stamped_faces ||
      frame.frame == std::numeric_limits<uint32_t>::max()) {
    frame.frame = 0;
    frame.cluster_stamp.assign(tree.clusters.size(), 0);
    frame.visible_stamp.assign(tree.clusters.size(), 0);
    frame.reached_rank.assign(tree.clusters.size(), 0);
    frame.face_stamp.assign(stamped_faces, 0);
    frame.node_fate.assign(tree.nodes.size(), kNodeNotReached);
    frame.visible_clusters.clear();
    frame.has_visible = false;
  } else {
    std::fill(frame.node_fate.begin(), frame.node_fate.end(), kNodeNotReached);
  }
  const uint32_t now = ++frame.frame;

  // The pyramid is kept from 4 x 4 cells up (hiz: 8 x 8) for a tree of at
  // least as many triangles as the image has pixels: behind the nodes a traversal keeps,
  // many small triangles are hidden, and finer cells prove more of them so
  // (a third more culled on the orthographic grid of benchmarks/bench_hiz.py,
  // for a little more upkeep). A smaller mesh's triangles cover pixels
  // enough for 8 x 8 cells, which cost less to keep and to test against:
  // single meshes 1-3% faster (benchmarks/README.md).
  const int fine = tree.n_input_faces < int64_t(target.width) * target.height ? 3 : 2;
  ZPyramid pyramid(target.depth, target.width, target.height, fine, /*cleared=*/true, target.pitch);
  pyramid.record_culls(input.culls);
  TriangleBatch batch(target, stats, &pyramid);
  // Lazy upkeep (triangle_batch.h): on a single unoccluded mesh the pyramid
  // is brought up to date every few flushes, and the node tests see it a
  // little late (per-frame trees 0.97-0.99x, built once 0.98-1.02x,
  // benchmarks/README.md); where triangles are culled, after every flush.
  batch.set_lazy_upkeep(true);
  // Per-thread scratch, looked up once here: each use of a thread_local in
  // the lambdas below would call __tls_get_addr again (a shared library's
  // thread-locals; perf: its share of a per-frame octree frame went from
  // 2.1% to 1.4%).
  thread_local ScreenVertices tls_screen;
  thread_local std::vector<int32_t> tls_kept_faces, tls_kept_ids;
  thread_local std::vector<uint32_t> tls_blocks_done;
  ScreenVertices& screen = tls_screen;
  std::vector<int32_t>& kept_faces = tls_kept_faces;
  std::vector<int32_t>& kept_ids = tls_kept_ids;
  int64_t reached = 0;         // faces handed to the batch (each once)
  double draw_ms = 0.0;        // vertex stage, cluster drawing and batch flushes
  // The vertices the clusters' faces index (an indexed tree's: the mesh's;
  // a Scene tree's: its copies): through the vertex stage as clusters need
  // them, or all up front where that is cheaper (LazyVertices).
  const auto lazy_start = Clock::now();
  const double* positions = tree.mesh_positions ? tree.mesh_positions : tree.positions.data();
  const int64_t n_vertices =
      tree.mesh_positions ? tree.mesh_vertices : int64_t(tree.positions.size() / 3);
  frame.vertices_up_front = n_vertices > 0 && (n_vertices < frame.lazy_vertices_from ||
                                               (frame.drawn_positions == positions &&
                                                frame.drawn_vertices == n_vertices &&
                                                frame.drawn_share >= TreeFrame::kUpFrontShare));
  LazyVertices lazy(positions, n_vertices, frame.vertices_up_front, input.mvp, vp, screen,
                    tls_blocks_done);
  {
    const double ms = ms_between(lazy_start, Clock::now());
    stats.vertex_ms += ms;
    draw_ms += ms;
  }

  // Drawing a cluster: its own vertices through the vertex stage, its faces
  // into the batch (which culls and draws them as `hiz` does).
  auto draw_cluster = [&](int32_t c) {
    if (frame.cluster_stamp[size_t(c)] == now) return;  // drawn already this frame
    frame.cluster_stamp[size_t(c)] = now;
    const TriangleCluster& cl = tree.clusters[size_t(c)];
    MeshView mesh;  // the faces index all the vertices (the mesh's, or the tree's copies)
    mesh.positions = positions;
    mesh.n_vertices = n_vertices;
    mesh.faces = tree.face_rows() + 3 * cl.face_begin;
    mesh.face_ids = tree.id_rows() + cl.face_begin;
    mesh.n_faces = cl.face_end - cl.face_begin;
    // The faces drawn: rows begin .. end - 1 of `mesh`, with `bucket` only
    // those of the cluster's buckets.
    int64_t begin = 0;
    const int32_t* bucket = nullptr;
    if (cl.range_end > cl.range_begin) {
      // Faces of the mesh among a few others (TriangleCluster::range_begin):
      // drawn from the mesh's arrays, the others skipped.
      mesh.faces = tree.mesh_faces;
      mesh.face_ids = tree.mesh_ids;
      mesh.n_faces = cl.range_end;
      begin = cl.range_begin;
      bucket = tree.face_bucket.data();
    } else if (!tree.order.empty()) {
      // An indexed tree's rows name faces of the mesh: gather them.
      gather_rows(tree, cl, kept_faces, kept_ids);
      mesh.faces = kept_faces.data();
      mesh.face_ids = kept_ids.data();
    } else if (tree.shared) {
      // Greene's rule put some faces in several clusters: keep those not
      // drawn yet this frame.
      kept_faces.clear();
      kept_ids.clear();
      for (int64_t r = cl.face_begin; r < cl.face_end; ++r) {
        uint32_t& stamp = frame.face_stamp[size_t(tree.source[size_t(r)])];
        if (stamp == now) continue;
        stamp = now;
        kept_faces.insert(kept_faces.end(), &tree.faces[3 * size_t(r)], &tree.faces[3 * size_t(r)] + 3);
        kept_ids.push_back(tree.ids[size_t(r)]);
      }
      mesh.faces = kept_faces.data();
      mesh.face_ids = kept_ids.data();
      mesh.n_faces = int64_t(kept_ids.size());
    }
    const int64_t end = mesh.n_faces;
    reached += bucket ? cl.face_end - cl.face_begin : end;
    if (end == begin) return;
    const auto t0 = Clock::now();
    if (tree.mesh_positions)
      lazy.need(mesh.faces + 3 * begin, end - begin);
    else
      lazy.need_own(cl.vertex_begin, cl.vertex_end);
    const auto t1 = Clock::now();
    batch.add_faces_in_buckets(mesh, input.mvp, vp, screen, begin, end, input.cull_backfaces,
                               bucket, cl.bucket_begin, cl.bucket_end);
    const auto t2 = Clock::now();
    stats.vertex_ms += ms_between(t0, t1);
    stats.raster_ms += ms_between(t1, t2);
    draw_ms += ms_between(t0, t2);
  };
  auto flush = [&](TriangleBatch::Upkeep upkeep = TriangleBatch::Upkeep::kAsSet) {
    const auto t0 = Clock::now();
    batch.flush(upkeep);
    const double ms = ms_between(t0, Clock::now());
    stats.raster_ms += ms;
    draw_ms += ms;
  };

  // Temporal coherence: what was visible last frame first, so that the
  // pyramid the traversal starts from is already close to the final one --
  // in the order the last frame's traversal reached those clusters (front to
  // back for a camera close to this one), with the pyramid brought up to
  // date as they go. Not projected or tested against the pyramid first:
  // a cluster that has left the view or become hidden since is drawn all the
  // same (its triangles are culled one by one), which cost less than
  // projecting and testing them all (they were ordered by the nearest depth
  // of their projected boxes before: temporal frames of the 5 x 5 x 20 spot
  // grid's orbit 1.10-1.13x the time of plain ones, now 1.07-1.08x).
  constexpr int kFlushAt = 256;  // see the traversal below
  if (temporal && frame.has_visible) {
    std::vector<int32_t>& visible = frame.visible_clusters;
    std::sort(visible.begin(), visible.end(), [&](int32_t a, int32_t b) {
      return frame.reached_rank[size_t(a)] < frame.reached_rank[size_t(b)];
    });
    for (int32_t c : visible) {
      if (batch.pending() >= kFlushAt) flush();
      draw_cluster(c);
    }
    // The traversal starts from the pyramid these clusters made: all of it,
    // whatever updates the lazy upkeep put off.
    flush(TriangleBatch::Upkeep::kNow);
  }

  // Front to back, depth first: children are pushed farthest first, so the
  // nearest is visited next. Before a node is tested, the batch is flushed
  // if it holds enough triangles (kFlushAt) to be worth bringing the pyramid
  // up to date (which the lazy upkeep above may put off while nothing is
  // culled).
  std::vector<ProjectedNode> stack;
  uint32_t rank = 0;  // of the clusters reached (TreeFrame::reached_rank)
  ProjectedNode root;
  if (!tree.nodes.empty()) {
    if (project_node(tree.nodes[0], 0, input.mvp, vp, root)) {
      stack.push_back(root);
    } else {
      frame.node_fate[0] = kNodeOutside;
      ++stats.nodes_outside;
    }
  }
  while (!stack.empty()) {
    const ProjectedNode item = stack.back();
    stack.pop_back();
    if (item.testable) {
      if (batch.pending() >= kFlushAt) flush();
      if (item.z_near > farthest_under(pyramid, item)) {
        frame.node_fate[size_t(item.node)] = kNodeHidden;  // and its whole subtree
        ++stats.nodes_hidden;
        if (pyramid.recording_culls())
          pyramid.count_culled(node_level(pyramid, item), item.x0, item.y0, item.x1, item.y1,
                               tree.nodes[size_t(item.node)].n_triangles);
        continue;
      }
    }
    ++stats.nodes_visited;
    const TreeNode& node = tree.nodes[size_t(item.node)];
    frame.node_fate[size_t(item.node)] = kNodeVisited;
    if (node.cluster >= 0) {
      frame.reached_rank[size_t(node.cluster)] = rank++;
      draw_cluster(node.cluster);
      frame.node_fate[size_t(item.node)] = kNodeDrawn;
    }
    // Visit near child first: order the children by their nearest depth.
    ProjectedNode kids[8];
    int n = 0;
    for (int32_t k = 0; k < node.n_children; ++k) {
      const int32_t child = node.first_child + k;
      ProjectedNode p;
      if (!project_node(tree.nodes[size_t(child)], child, input.mvp, vp, p)) {
        frame.node_fate[size_t(child)] = kNodeOutside;
        ++stats.nodes_outside;
        continue;
      }
      int j = n++;
      for (; j > 0 && kids[j - 1].z_near < p.z_near; --j) kids[j] = kids[j - 1];
      kids[j] = p;  // kids sorted farthest first
    }
    for (int k = 0; k < n; ++k) stack.push_back(kids[k]);
  }
  flush(TriangleBatch::Upkeep::kNone);
  stats.culled_in_nodes += tree.n_input_faces - reached;
  stats.depth_storage_bytes = pyramid.storage_bytes();
  frame.drawn_positions = positions;
  frame.drawn_vertices = n_vertices;
  frame.drawn_share = tree.n_input_faces > 0 ? double(reached) / double(tree.n_input_faces) : 0.0;

  // Temporal coherence: record the clusters with a pixel in this frame.
  // Rows 1/128 of the image apart (every row of a small image) are enough:
  // the set only decides what is drawn first next frame (anything missed is
  // found by the traversal), and what a cluster shows of itself is seldom
  // so thin. (Every other row at 1024 x 1024 made temporal frames ~5%
  // slower: the scan's lookups of cluster_of_id miss the caches.) A row's
  // ids are looked up once per run of one id (id_runs.h, as the shading
  // pass's face scan finds them): 0.33 ms of a 1024 x 1024 temporal frame
  // of the 5 x 5 x 20 spot grid's orbit.
  if (temporal) {
    const int stride = std::max(1, target.height / 128);
    frame.visible_clusters.clear();
    const int32_t* cluster_of_id = tree.cluster_of_id.data();
    uint32_t* seen = frame.visible_stamp.data();
    std::vector<int32_t>& visible = frame.visible_clusters;
    thread_local std::vector<int32_t> tls_runs;
    std::vector<int32_t>& runs = tls_runs;
    if (runs.size() < size_t(target.width) + 16) runs.resize(size_t(target.width) + 16);
    for (int y = 0; y < target.height; y += stride) {
      const int32_t* row = target.triangle_id + size_t(y) * target.row_pitch();
      const size_t n = id_run_starts(row, size_t(target.width), -1, runs.data());
      for (size_t k = 0; k < n; ++k) {
        const int32_t c = cluster_of_id[runs[k]];
        if (seen[c] == now) continue;
        seen[c] = now;
        visible.push_back(c);
      }
    }
    frame.has_visible = true;
  } else {
    frame.has_visible = false;
  }
  stats.traversal_ms += ms_between(start, Clock::now()) - draw_ms;
}

void render_tree_frame(const ObjectTree& tree, const RenderInput& input, DepthTarget& target,
                       RenderStats& stats, TreeFrame& frame, bool temporal) {
  const auto start = Clock::now();
  stats.triangles_in += tree.n_input_faces;
  draw_cleared(target, /*allow_scratch=*/true, [&](DepthTarget& drawn) {
    render_object_tree(tree, input, drawn, stats, frame, temporal);
  });
  stats.total_ms += ms_between(start, Clock::now());
}

void render_built_per_frame(const RenderInput& input, DepthTarget& target, RenderStats& stats,
                            void (*build)(const MeshView& mesh, ObjectTree& tree)) {
  const auto t0 = Clock::now();
  thread_local ObjectTree tree;
  build(input.mesh, tree);
  stats.build_ms += ms_between(t0, Clock::now());
  thread_local TreeFrame frame;
  render_object_tree(tree, input, target, stats, frame);
}

}  // namespace zbuffer
