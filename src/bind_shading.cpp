// Bindings for the shading pass (shading.h).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "array_checks.h"
#include "render_common.h"
#include "zbuffer/mesh_checks.h"
#include "zbuffer/shading.h"

namespace zbuffer_py {

namespace {

py::array_t<uint8_t> shade(py::handle ids_obj, py::handle positions_obj, py::handle faces_obj,
                           py::handle mvp_obj, py::handle viewer_obj,
                           py::handle light_dir_obj, double ambient, double diffuse,
                           py::handle background_obj, py::handle uniform_color_obj,
                           const std::string& color_source, py::handle colors_obj,
                           py::handle normals_obj, py::handle out_obj,
                           bool pixels_beyond_faces, int64_t ids_below) {
  int pitch = 0;
  auto ids = require_rows<int32_t>(ids_obj, "triangle_id", {-1, -1}, pitch);
  auto positions = require_array<double>(positions_obj, "positions", {-1, 3});
  auto faces = require_array<int32_t>(faces_obj, "faces", {-1, 3});
  auto viewer = require_array<double>(viewer_obj, "viewer", {4});
  auto light = require_array<double>(light_dir_obj, "light_dir", {3});
  auto background = require_array<uint8_t>(background_obj, "background", {3});
  auto uniform = require_array<float>(uniform_color_obj, "uniform_color", {3});

  check_image_size(ids.shape(1), ids.shape(0), /*allow_empty=*/true);
  zbuffer::ShadingInput in;
  in.height = int(ids.shape(0));
  in.width = int(ids.shape(1));
  in.pitch = pitch;
  in.mesh = {positions.data(), positions.shape(0), faces.data(), faces.shape(0)};

  // Every id must name a face and every face index a vertex: the pass reads
  // them without further checks. (Ids a render has just written are below
  // its triangles_in: if that is at most the faces here, the pass over
  // them, ~0.1 ms at 1024 x 1024, is skipped.)
  bool bad = false;
  if (ids_below < 0 || ids_below > in.mesh.n_faces)
    zbuffer::for_each_run(size_t(in.width), size_t(in.height), in.id_pitch(),
                          [&](size_t at, size_t n) {
                            bad = bad || zbuffer::find_bad_triangle_id(ids.data() + at, int64_t(n),
                                                                       in.mesh.n_faces) >= 0;
                          });
  if (bad)
    throw py::value_error("triangle_id holds ids outside [-1, " +
                          std::to_string(in.mesh.n_faces) + ")");
  check_face_indices(in.mesh);

  py::array_t<float> colors;
  if (color_source == "uniform") {
    in.color_source = zbuffer::ColorSource::kUniform;
  } else if (color_source == "vertex" || color_source == "face") {
    const bool per_vertex = color_source == "vertex";
    colors = require_array<float>(colors_obj, "colors",
                                  {per_vertex ? in.mesh.n_vertices : in.mesh.n_faces, 3});
    in.color_source = per_vertex ? zbuffer::ColorSource::kPerVertex
                                 : zbuffer::ColorSource::kPerFace;
    in.colors = colors.data();
  } else {
    throw py::value_error("color_source must be \"uniform\", \"vertex\" or \"face\", got \"" +
                          color_source + "\"");
  }
  py::array_t<double> normals;
  if (!normals_obj.is_none()) {
    normals = require_array<double>(normals_obj, "vertex_normals", {in.mesh.n_vertices, 3});
    in.vertex_normals = normals.data();
  }
  read_mvp(mvp_obj, in.mvp);
  for (int k = 0; k < 4; ++k) in.viewer[k] = viewer.data()[k];
  for (int k = 0; k < 3; ++k) {
    in.light_dir[k] = light.data()[k];
    in.background[k] = background.data()[k];
    in.uniform_color[k] = uniform.data()[k];
  }
  in.ambient = ambient;
  in.diffuse = diffuse;
  in.pixels_beyond_faces = pixels_beyond_faces;

  const std::vector<py::ssize_t> shape = {in.height, in.width, 3};
  py::array_t<uint8_t> image;
  if (out_obj.is_none()) {
    image = py::array_t<uint8_t>(shape);
  } else {  // the caller's image, written in place
    image = require_output<uint8_t>(out_obj, "out", shape);
    require_apart({image, "out"}, {{ids, "triangle_id"}, {positions, "positions"},
                                   {faces, "faces"}, {colors, "colors"},
                                   {normals, "vertex_normals"}});
  }
  uint8_t* out = image.mutable_data();
  {
    py::gil_scoped_release release;
    zbuffer::shade(in, ids.data(), out);
  }
  return image;
}

py::array_t<double> vertex_normals(py::handle positions_obj, py::handle faces_obj) {
  auto positions = require_array<double>(positions_obj, "positions", {-1, 3});
  auto faces = require_array<int32_t>(faces_obj, "faces", {-1, 3});
  const zbuffer::MeshView mesh{positions.data(), positions.shape(0), faces.data(), faces.shape(0)};
  check_face_indices(mesh);
  py::array_t<double> normals({positions.shape(0), py::ssize_t(3)});
  double* out = normals.mutable_data();
  {
    py::gil_scoped_release release;
    zbuffer::vertex_normals(mesh, out);
  }
  return normals;
}

}  // namespace

void bind_shading(py::module_& m) {
  m.def("vertex_normals", &vertex_normals, py::arg("positions"), py::arg("faces"),
        "(N, 3) float64 area-weighted unit vertex normals (zero for unused vertices);\n"
        "the same bits as zbuffer.reference.vertex_normals.");
  m.def("shade", &shade, py::arg("triangle_id"), py::arg("positions"), py::arg("faces"),
        py::arg("mvp"), py::arg("viewer"), py::arg("light_dir"), py::arg("ambient"),
        py::arg("diffuse"), py::arg("background"), py::arg("uniform_color"),
        py::arg("color_source") = "uniform", py::arg("colors") = py::none(),
        py::arg("vertex_normals") = py::none(), py::arg("out") = py::none(),
        py::arg("pixels_beyond_faces") = false, py::arg("ids_below") = -1,
        "Lambert-shade a visibility result (triangle_id (H, W) int32, C-contiguous or with\n"
        "padded rows); returns an (H, W, 3) uint8 image (out, if given: C-contiguous,\n"
        "writeable, sharing no memory with the inputs). With\n"
        "pixels_beyond_faces (polygons drawn natively: a pixel carries its polygon's\n"
        "first triangle, which it may lie outside), interpolated shading runs the\n"
        "scalar pass, the one whose clamping holds for such pixels. ids_below:\n"
        "every id in triangle_id is -1 or below it (triangle_id was just written by\n"
        "a render whose stats['triangles_in'] it is); when it is at most len(faces),\n"
        "the ids are not checked again. -1: they are.");
}

}  // namespace zbuffer_py
