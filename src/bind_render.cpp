// Bindings for the registry and the render entry point (algorithms.h), the
// Z-pyramid's levels of a depth plane (zpyramid.h) and the mesh orders
// (mesh_order.h).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <limits>
#include <string>
#include <vector>

#include "array_checks.h"
#include "render_common.h"
#include "zbuffer/algorithms.h"
#include "zbuffer/mesh_checks.h"
#include "zbuffer/mesh_order.h"
#include "zbuffer/scanline.h"
#include "zbuffer/zpyramid.h"

namespace zbuffer_py {

namespace {

// The number of runs an array of run boundaries describes: its n + 1
// entries must run from 0 to `end` (ValueError naming `what` and `end_name`
// otherwise). Whether the runs are well formed is the caller's to check.
template <class T>
int64_t run_count(const py::array_t<T>& start, int64_t end, const std::string& what,
                  const std::string& end_name) {
  const int64_t n = start.shape(0) - 1;
  if (n < 0) throw py::value_error(what + " must not be empty");
  if (start.data()[0] != 0 || start.data()[n] != end)
    throw py::value_error(what + " must run from 0 to " + end_name);
  return n;
}

// Checks polygon faces (GIL held): offsets rising from 0 to the number of
// indices, at least 3 corners each, indices in range, and as many triangles in the
// triangulation as the polygons have (size - 2 each).
zbuffer::PolygonView polygon_view(const py::array_t<int64_t>& offsets,
                                  const py::array_t<int32_t>& indices,
                                  const zbuffer::MeshView& mesh) {
  zbuffer::PolygonView polys;
  polys.offsets = offsets.data();
  polys.indices = indices.data();
  polys.n_polygons =
      run_count(offsets, indices.shape(0), "polygon_offsets", "len(polygon_indices)");
  int64_t triangles = 0;
  for (int64_t p = 0; p < polys.n_polygons; ++p) {
    // (offsets[p] lies in [0, len(indices)]: checked as offsets[p - 1]'s
    // successor, or offsets[0] == 0)
    if (polys.offsets[p + 1] < polys.offsets[p] || polys.offsets[p + 1] > indices.shape(0))
      throw py::value_error("polygon_offsets[" + std::to_string(p + 1) + "] = " +
                            std::to_string(polys.offsets[p + 1]) + " is outside [" +
                            std::to_string(polys.offsets[p]) + ", len(polygon_indices) = " +
                            std::to_string(indices.shape(0)) + "]");
    const int64_t n = polys.offsets[p + 1] - polys.offsets[p];
    if (n < 3)
      throw py::value_error("polygon " + std::to_string(p) + " has " + std::to_string(n) +
                            " corners; at least 3 are needed");
    triangles += n - 2;
  }
  if (triangles != mesh.n_faces)
    throw py::value_error("the polygons have " + std::to_string(triangles) +
                          " triangles (size - 2 each), but faces has " +
                          std::to_string(mesh.n_faces) + " rows");
  for (int64_t k = 0; k < indices.shape(0); ++k)
    if (polys.indices[k] < 0 || polys.indices[k] >= mesh.n_vertices)
      throw py::value_error("polygon_indices[" + std::to_string(k) + "] = " +
                            std::to_string(polys.indices[k]) + " is outside [0, " +
                            std::to_string(mesh.n_vertices) + ")");
  return polys;
}

// Checks face cells (GIL held): runs from 0 to the number of faces, none
// empty, with finite centres.
zbuffer::FaceCells face_cells(const py::array_t<int32_t>& start, const py::array_t<double>& centre,
                              const zbuffer::MeshView& mesh) {
  zbuffer::FaceCells cells;
  cells.start = start.data();
  cells.centre = centre.data();
  cells.n = run_count(start, mesh.n_faces, "cell_start", "the number of faces");
  if (centre.shape(0) != cells.n)
    throw py::value_error("cell_centre must have one row per cell (" + std::to_string(cells.n) +
                          "), got " + std::to_string(centre.shape(0)));
  for (int64_t k = 0; k < cells.n; ++k)
    if (cells.start[k + 1] <= cells.start[k])
      throw py::value_error("cell_start must increase, got " + std::to_string(cells.start[k]) +
                            " then " + std::to_string(cells.start[k + 1]) + " at " +
                            std::to_string(k));
  for (int64_t k = 0; k < 3 * cells.n; ++k)
    if (!std::isfinite(cells.centre[k])) throw py::value_error("cell_centre must be finite");
  return cells;
}

py::tuple render(py::handle positions_obj, py::handle faces_obj, py::handle mvp_obj,
                 int width, int height, const std::string& algo, bool cull_backfaces,
                 py::handle face_ids_obj, py::handle polygon_offsets_obj,
                 py::handle polygon_indices_obj, bool record_culls, py::handle cell_start_obj,
                 py::handle cell_centre_obj, py::handle out_depth_obj, py::handle out_ids_obj) {
  const zbuffer::Algorithm* algorithm = zbuffer::find_algorithm(algo);
  if (!algorithm)
    throw py::value_error("unknown algorithm \"" + algo + "\"; valid names are " +
                          zbuffer::algorithm_names());
  check_image_size(width, height);
  if (record_culls && !algorithm->pyramid)
    throw py::value_error("record_culls: algorithm \"" + algo + "\" has no Z-pyramid to cull "
                          "with; the hiz algorithms have one");
  auto positions = require_array<double>(positions_obj, "positions", {-1, 3});
  auto faces = require_array<int32_t>(faces_obj, "faces", {-1, 3});

  zbuffer::RenderInput input;
  input.mesh = mesh_view(positions, faces);
  py::array_t<int32_t> face_ids;
  if (!face_ids_obj.is_none()) {
    face_ids = require_array<int32_t>(face_ids_obj, "face_ids", {input.mesh.n_faces});
    input.mesh.face_ids = face_ids.data();
    int32_t id = 0;  // (read in the scan, as check_face_indices does)
    const int64_t bad = scan_arrays(input.mesh.n_faces, [&] {
      const int64_t at = zbuffer::find_negative_id(input.mesh);
      if (at >= 0) id = input.mesh.face_ids[at];
      return at;
    });
    if (bad >= 0)
      throw py::value_error("face_ids must be >= 0, got " + std::to_string(id) + " at " +
                            std::to_string(bad));
  }
  py::array_t<int32_t> cell_start;
  py::array_t<double> cell_centre;
  if (!cell_start_obj.is_none() || !cell_centre_obj.is_none()) {
    if (cell_start_obj.is_none() || cell_centre_obj.is_none())
      throw py::value_error("give both cell_start and cell_centre, or neither");
    cell_start = require_array<int32_t>(cell_start_obj, "cell_start", {-1});
    cell_centre = require_array<double>(cell_centre_obj, "cell_centre", {-1, 3});
    input.cells = face_cells(cell_start, cell_centre, input.mesh);
  }
  py::array_t<int64_t> polygon_offsets;
  py::array_t<int32_t> polygon_indices;
  if (!polygon_offsets_obj.is_none() || !polygon_indices_obj.is_none()) {
    if (polygon_offsets_obj.is_none() || polygon_indices_obj.is_none())
      throw py::value_error("give both polygon_offsets and polygon_indices, or neither");
    if (!algorithm->polygons)
      throw py::value_error("algorithm \"" + algo + "\" draws triangles only; pass polygons "
                            "to an algorithm that draws them (\"scanline\")");
    polygon_offsets = require_array<int64_t>(polygon_offsets_obj, "polygon_offsets", {-1});
    polygon_indices = require_array<int32_t>(polygon_indices_obj, "polygon_indices", {-1});
    input.polygons = polygon_view(polygon_offsets, polygon_indices, input.mesh);
  }
  read_mvp(mvp_obj, input.mvp);
  input.cull_backfaces = cull_backfaces;

  // Outputs are the user's arrays: written in place, handed over uncopied
  // (new ones, or those the caller passed to be rendered into).
  Planes planes = output_planes(
      out_depth_obj, out_ids_obj, width, height,
      {{positions, "positions"}, {faces, "faces"}, {face_ids, "face_ids"},
       {cell_start, "cell_start"}, {cell_centre, "cell_centre"},
       {polygon_offsets, "polygon_offsets"}, {polygon_indices, "polygon_indices"}});
  zbuffer::DepthTarget target = planes.target(width, height);
  zbuffer::RenderStats stats;
  const auto culls = attach_cull_map(record_culls, width, height, input);
  {
    py::gil_scoped_release release;
    zbuffer::render(*algorithm, input, target, stats);
  }
  return render_result(planes.depth, planes.ids, stats, culls.get());
}

// Names of the registered algorithms with `flag` set.
py::list algorithms_with(bool zbuffer::Algorithm::*flag) {
  py::list out;
  for (const zbuffer::Algorithm& a : zbuffer::algorithms())
    if (a.*flag) out.append(a.name);
  return out;
}

}  // namespace

void bind_render(py::module_& m) {
  m.attr("MAX_SCANLINE_TRIANGLES") = zbuffer::kMaxScanlineTriangles;
  m.def("check_scanline_faces", &zbuffer::check_scanline_faces, py::arg("n_faces"),
        "ValueError for more faces than algo='scanline' draws (MAX_SCANLINE_TRIANGLES).");
  m.def(
      "algorithms",
      [] {
        py::list out;
        for (const zbuffer::Algorithm& a : zbuffer::algorithms())
          out.append(py::make_tuple(a.name, a.summary));
        return out;
      },
      "List of (name, summary) of the registered depth algorithms.");
  m.def("render", &render, py::arg("positions"), py::arg("faces"), py::arg("mvp"),
        py::arg("width"), py::arg("height"), py::arg("algo") = "zbuffer",
        py::arg("cull_backfaces") = false, py::arg("face_ids") = py::none(),
        py::arg("polygon_offsets") = py::none(), py::arg("polygon_indices") = py::none(),
        py::arg("record_culls") = false, py::arg("cell_start") = py::none(),
        py::arg("cell_centre") = py::none(), py::arg("out_depth") = py::none(),
        py::arg("out_ids") = py::none(),
        "Render depth and triangle ids; returns (depth, triangle_id, stats), and with\n"
        "record_culls (algorithms with a Z-pyramid) a fourth item: per pyramid level an\n"
        "int64 array of the triangles culled by tests that read each cell. With face_ids,\n"
        "face f is reported as face_ids[f] (faces passed in another order). With polygons\n"
        "(int64 offsets, int32 indices; faces = their triangulation in polygon order), an\n"
        "algorithm that draws polygons draws them natively, each with its first triangle's id.\n"
        "With cells (spatial_order's cell_start and cell_centre for these faces), the\n"
        "image-space algorithms visit the faces cell by cell, nearest cell first.\n"
        "With out_depth and out_ids (float32 and int32 (height, width), rows contiguous and\n"
        "the same number of pixels apart in both (C-contiguous or padded), writeable,\n"
        "sharing no memory with each other or the inputs), renders into them and returns\n"
        "them instead of new arrays; new ones have padded rows at widths that are multiples\n"
        "of 512 from 1024 up.");
  m.def(
      "polygon_algorithms", [] { return algorithms_with(&zbuffer::Algorithm::polygons); },
      "Names of the algorithms that draw polygon faces natively.");
  m.def(
      "pyramid_algorithms", [] { return algorithms_with(&zbuffer::Algorithm::pyramid); },
      "Names of the algorithms with a Z-pyramid (record_culls works with them).");
  m.def(
      "pyramid_levels",
      [](py::handle depth_obj) {
        int pitch = 0;
        auto depth = require_rows<float>(depth_obj, "depth", {-1, -1}, pitch);
        if (depth.size() == 0) throw py::value_error("depth must not be empty");
        check_image_size(depth.shape(1), depth.shape(0));
        const int h = int(depth.shape(0)), w = int(depth.shape(1));
        py::list levels;
        levels.append(depth);
        std::unique_ptr<zbuffer::ZPyramid> pyramid;
        {
          py::gil_scoped_release release;
          pyramid = std::make_unique<zbuffer::ZPyramid>(depth.data(), w, h, 1, false, pitch);
        }
        for (int k = 1; k < pyramid->levels(); ++k) {
          py::array_t<float> level({py::ssize_t(pyramid->height(k)), py::ssize_t(pyramid->width(k))});
          std::copy_n(pyramid->level(k), size_t(pyramid->width(k)) * pyramid->height(k),
                      level.mutable_data());
          levels.append(level);
        }
        return levels;
      },
      py::arg("depth"),
      "Z-pyramid of an (H, W) float32 depth map: [depth, level 1, ...], each cell the max\n"
      "of its 2x2 children (a list of float32 arrays down to 1x1).");
  m.def(
      "spatial_order",
      [](py::handle positions_obj, py::handle faces_obj) {
        auto positions = require_array<double>(positions_obj, "positions", {-1, 3});
        auto faces = require_array<int32_t>(faces_obj, "faces", {-1, 3});
        const zbuffer::MeshView mesh = mesh_view(positions, faces);
        py::array_t<int32_t> order(py::ssize_t(mesh.n_faces));
        int32_t* out = order.mutable_data();
        std::vector<int32_t> start;
        std::vector<double> centre;
        {
          py::gil_scoped_release release;
          zbuffer::spatial_order(mesh, out, start, centre);
        }
        py::array_t<int32_t> cell_start(py::ssize_t(start.size()));
        std::copy(start.begin(), start.end(), cell_start.mutable_data());
        py::array_t<double> cell_centre({py::ssize_t(centre.size() / 3), py::ssize_t(3)});
        std::copy(centre.begin(), centre.end(), cell_centre.mutable_data());
        return py::make_tuple(order, cell_start, cell_centre);
      },
      py::arg("positions"), py::arg("faces"),
      "(order, cell_start, cell_centre): a permutation of the faces along a Z-order curve\n"
      "of their centroids (int32), and the runs of faces[order] that share a cell of the\n"
      "curve's coarse 8 x 8 x 8 grid: cell k holds cell_start[k] .. cell_start[k+1] - 1,\n"
      "centred at cell_centre[k] (only nonempty cells).");
  m.def(
      "first_use_order",
      [](py::handle faces_obj, int64_t n_vertices) {
        auto faces = require_array<int32_t>(faces_obj, "faces", {-1, 3});
        if (n_vertices < 0 || n_vertices > std::numeric_limits<int32_t>::max())
          throw py::value_error("n_vertices must be in 0 .. 2**31 - 1, got " +
                                std::to_string(n_vertices));
        zbuffer::MeshView mesh;
        mesh.faces = faces.data();
        mesh.n_faces = faces.shape(0);
        mesh.n_vertices = n_vertices;
        check_face_indices(mesh);
        py::array_t<int32_t> renumbered({py::ssize_t(mesh.n_faces), py::ssize_t(3)});
        py::array_t<int32_t> old_of_new(py::ssize_t(mesh.n_vertices));
        int32_t* out = renumbered.mutable_data();
        int32_t* order = old_of_new.mutable_data();
        {
          py::gil_scoped_release release;
          zbuffer::first_use_order(mesh.faces, mesh.n_faces, mesh.n_vertices, out, order);
        }
        return py::make_tuple(renumbered, old_of_new);
      },
      py::arg("faces"), py::arg("n_vertices"),
      "(faces, vertex_order): the vertices renumbered in the order the faces first use\n"
      "them (then the unused ones, in their order): faces as int32 indices into\n"
      "positions[vertex_order] for any (n_vertices, 3) positions: the same triangles.");
}

}  // namespace zbuffer_py
