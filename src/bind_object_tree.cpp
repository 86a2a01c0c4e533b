// Bindings for the object-space trees (object_tree.h, octree.h, bvh.h):
// built once, rendered from any camera, inspected for display.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <chrono>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include "array_checks.h"
#include "render_common.h"
#include "zbuffer/bvh.h"
#include "zbuffer/object_tree.h"
#include "zbuffer/octree.h"
#include "zbuffer/zpyramid.h"

namespace zbuffer_py {

namespace {

// A built tree with the state of its last frame. Renders of one tree are
// serialised (its frame state is shared); different trees render in
// parallel.
struct Tree {
  std::string kind;
  zbuffer::ObjectTree tree;
  zbuffer::TreeFrame frame;
  double build_ms = 0.0;
  std::mutex mutex;
};

template <class Build>
std::unique_ptr<Tree> build(const std::string& kind, py::handle positions_obj,
                            py::handle faces_obj, Build&& build_tree) {
  auto positions = require_array<double>(positions_obj, "positions", {-1, 3});
  auto faces = require_array<int32_t>(faces_obj, "faces", {-1, 3});
  const zbuffer::MeshView mesh = mesh_view(positions, faces);
  auto out = std::make_unique<Tree>();
  out->kind = kind;
  bool out_of_memory = false;
  {
    py::gil_scoped_release release;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      out->tree = build_tree(mesh);
    } catch (const std::bad_alloc&) {
      out_of_memory = true;  // (a MemoryError, raised with the GIL held)
    }
    out->build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  if (out_of_memory) {  // (pybind11 has no memory_error class: set the exception, then raise it)
    PyErr_SetString(PyExc_MemoryError, ("not enough memory to build the " + kind).c_str());
    throw py::error_already_set();
  }
  return out;
}

py::tuple render(Tree& self, py::handle mvp_obj, int width, int height, bool cull_backfaces,
                 bool temporal, bool record_culls, py::handle out_depth_obj,
                 py::handle out_ids_obj) {
  check_image_size(width, height);
  zbuffer::RenderInput input;
  read_mvp(mvp_obj, input.mvp);
  input.cull_backfaces = cull_backfaces;
  // (Temporal coherence needs cluster_of_id: the trees built here have it.)
  // (The tree holds its own copies of the mesh: no input array to keep apart.)
  Planes planes = output_planes(out_depth_obj, out_ids_obj, width, height, {});
  zbuffer::DepthTarget target = planes.target(width, height);
  zbuffer::RenderStats stats;
  const auto culls = attach_cull_map(record_culls, width, height, input);
  {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(self.mutex);
    zbuffer::render_tree_frame(self.tree, input, target, stats, self.frame, temporal);
  }
  return render_result(planes.depth, planes.ids, stats, culls.get());
}

py::dict nodes(Tree& self) {
  // Waiting for another thread's render of this tree without the GIL, so
  // that other Python threads run meanwhile (that render takes the GIL back
  // only after it lets go of the tree).
  std::unique_lock<std::mutex> lock(self.mutex, std::defer_lock);
  {
    py::gil_scoped_release release;
    lock.lock();
  }
  const auto& nodes = self.tree.nodes;
  const py::ssize_t n = py::ssize_t(nodes.size());
  py::array_t<double> lo({n, py::ssize_t(3)}), hi({n, py::ssize_t(3)});
  py::array_t<int32_t> depth(n), parent(n), first_child(n), n_children(n);
  py::array_t<int64_t> n_triangles(n), own_triangles(n);
  py::array_t<uint8_t> fate(n);
  auto l = lo.mutable_unchecked<2>(), h = hi.mutable_unchecked<2>();
  auto d = depth.mutable_unchecked<1>(), p = parent.mutable_unchecked<1>();
  auto fc = first_child.mutable_unchecked<1>(), nc = n_children.mutable_unchecked<1>();
  auto nt = n_triangles.mutable_unchecked<1>(), ot = own_triangles.mutable_unchecked<1>();
  auto f = fate.mutable_unchecked<1>();
  const bool rendered = self.frame.node_fate.size() == nodes.size();
  {
    // Filled without the GIL (plain memory of this call's own arrays): a
    // tree of millions of nodes takes a second or more.
    py::gil_scoped_release release;
    for (py::ssize_t i = 0; i < n; ++i) p(i) = -1;
    for (py::ssize_t i = 0; i < n; ++i) {
      const zbuffer::TreeNode& node = nodes[size_t(i)];
      for (int a = 0; a < 3; ++a) {
        l(i, a) = node.lo[a];
        h(i, a) = node.hi[a];
      }
      d(i) = node.depth;
      fc(i) = node.first_child;
      nc(i) = node.n_children;
      nt(i) = node.n_triangles;
      ot(i) = 0;
      if (node.cluster >= 0) {
        const auto& cl = self.tree.clusters[size_t(node.cluster)];
        ot(i) = cl.face_end - cl.face_begin;
      }
      f(i) = rendered ? self.frame.node_fate[size_t(i)] : uint8_t(zbuffer::kNodeNotReached);
      for (int32_t k = 0; k < node.n_children; ++k) p(node.first_child + k) = int32_t(i);
    }
  }
  py::dict out;
  out["lo"] = lo;
  out["hi"] = hi;
  out["depth"] = depth;
  out["parent"] = parent;
  out["first_child"] = first_child;
  out["n_children"] = n_children;
  out["n_triangles"] = n_triangles;
  out["own_triangles"] = own_triangles;
  out["fate"] = fate;
  return out;
}

}  // namespace

void bind_object_tree(py::module_& m) {
  py::class_<Tree>(m, "ObjectTree", "A built octree or BVH with the state of its last frame.")
      .def_property_readonly("kind", [](const Tree& t) { return t.kind; })
      .def_property_readonly("build_ms", [](const Tree& t) { return t.build_ms; })
      .def_property_readonly("n_nodes", [](const Tree& t) { return int64_t(t.tree.nodes.size()); })
      .def_property_readonly("n_clusters",
                             [](const Tree& t) { return int64_t(t.tree.clusters.size()); })
      .def_property_readonly("n_references", [](const Tree& t) { return int64_t(t.tree.ids.size()); })
      .def_property_readonly("n_faces", [](const Tree& t) { return t.tree.n_input_faces; })
      .def_property_readonly("memory_bytes", [](const Tree& t) { return t.tree.memory_bytes(); })
      .def("render", &render, py::arg("mvp"), py::arg("width"), py::arg("height"),
           py::arg("cull_backfaces") = false, py::arg("temporal") = false,
           py::arg("record_culls") = false, py::arg("out_depth") = py::none(),
           py::arg("out_ids") = py::none(),
           "Render one frame: (depth, triangle_id, stats), and with record_culls the\n"
           "triangles culled by tests that read each pyramid cell, per level. With\n"
           "out_depth and out_ids, into those arrays (as _core.render).")
      .def("nodes", &nodes,
           "The nodes as arrays: lo, hi (K, 3) float64; depth, parent, first_child,\n"
           "n_children (K,) int32; n_triangles, own_triangles (K,) int64; fate (K,) uint8\n"
           "(0 not reached, 1 outside, 2 hidden, 3 visited, 4 drawn) in the last frame.");
  m.def(
      "build_octree",
      [](py::handle positions, py::handle faces, int leaf_size, int max_depth,
         const std::string& rule) {
        zbuffer::OctreeParams params;
        params.leaf_size = leaf_size;
        params.max_depth = max_depth;
        if (!zbuffer::parse_octree_rule(rule, params.rule))
          throw py::value_error(
              "unknown octree rule \"" + rule + "\"; valid rules are \"" +
              zbuffer::octree_rule_name(zbuffer::OctreeRule::kLoose) + "\", \"" +
              zbuffer::octree_rule_name(zbuffer::OctreeRule::kSmallest) + "\", \"" +
              zbuffer::octree_rule_name(zbuffer::OctreeRule::kGreene) + "\"");
        // (leaf_size and max_depth: build_octree's std::invalid_argument, a ValueError)
        return build("octree", positions, faces,
                     [&](const zbuffer::MeshView& mesh) { return zbuffer::build_octree(mesh, params); });
      },
      py::arg("positions"), py::arg("faces"), py::arg("leaf_size") = zbuffer::OctreeParams{}.leaf_size,
      py::arg("max_depth") = zbuffer::OctreeParams{}.max_depth, py::arg("rule") = zbuffer::octree_rule_name(zbuffer::OctreeParams{}.rule),
      "Build the octree of `hiz_octree` over (N, 3) float64 positions and (M, 3) int32 faces.");
  m.def(
      "build_bvh",
      [](py::handle positions, py::handle faces, int leaf_size) {
        zbuffer::BvhParams params;  // (leaf_size: build_bvh's std::invalid_argument)
        params.leaf_size = leaf_size;
        return build("bvh", positions, faces,
                     [&](const zbuffer::MeshView& mesh) { return zbuffer::build_bvh(mesh, params); });
      },
      py::arg("positions"), py::arg("faces"), py::arg("leaf_size") = zbuffer::BvhParams{}.leaf_size,
      "Build the BVH of `hiz_bvh` over (N, 3) float64 positions and (M, 3) int32 faces.");
  m.attr("MAX_OCTREE_DEPTH") = zbuffer::kMaxOctreeDepth;
  m.attr("DEFAULT_OCTREE_LEAF_SIZE") = zbuffer::OctreeParams{}.leaf_size;
  m.attr("DEFAULT_OCTREE_MAX_DEPTH") = zbuffer::OctreeParams{}.max_depth;
  m.attr("DEFAULT_BVH_LEAF_SIZE") = zbuffer::BvhParams{}.leaf_size;
}

}  // namespace zbuffer_py
