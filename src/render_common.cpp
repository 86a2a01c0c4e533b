// Shared by the render bindings (render_common.h).
#include "render_common.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "zbuffer/conventions.h"
#include "zbuffer/mesh_checks.h"
#include "zbuffer/zpyramid.h"

namespace zbuffer_py {

void check_image_size(int64_t width, int64_t height, bool allow_empty) {
  if (width < 0 || height < 0 || (!allow_empty && (width == 0 || height == 0)))
    throw py::value_error("width and height must be positive, got " +
                          std::to_string(width) + "x" + std::to_string(height));
  if (width > zbuffer::kMaxImageSide || height > zbuffer::kMaxImageSide ||
      width * height > zbuffer::kMaxImagePixels)
    throw py::value_error("image " + std::to_string(width) + "x" + std::to_string(height) +
                          " is too large: at most " + std::to_string(zbuffer::kMaxImageSide) +
                          " pixels a side and " + std::to_string(zbuffer::kMaxImagePixels) +
                          " pixels in all");
}

void check_face_indices(const zbuffer::MeshView& mesh) {
  int32_t index = 0;  // read in the scan: after it, another thread may have changed it
  const int64_t bad = scan_arrays(3 * mesh.n_faces, [&] {
    const int64_t at = zbuffer::find_bad_face_index(mesh);
    if (at >= 0) index = mesh.faces[at];
    return at;
  });
  if (bad >= 0)
    throw py::value_error("face " + std::to_string(bad / 3) + " has vertex index " +
                          std::to_string(index) + ", outside [0, " +
                          std::to_string(mesh.n_vertices) + ")");
}

// Checks the mesh arrays and returns a view of them (called with the GIL).
zbuffer::MeshView mesh_view(const py::array_t<double>& positions,
                            const py::array_t<int32_t>& faces) {
  zbuffer::MeshView mesh;
  mesh.positions = positions.data();
  mesh.n_vertices = positions.shape(0);
  mesh.faces = faces.data();
  mesh.n_faces = faces.shape(0);
  if (mesh.n_vertices > std::numeric_limits<int32_t>::max())
    throw py::value_error("too many vertices: at most 2**31 - 1");
  if (mesh.n_faces > std::numeric_limits<int32_t>::max())
    throw py::value_error("too many faces: at most 2**31 - 1");
  check_face_indices(mesh);
  const int64_t nonfinite =
      scan_arrays(3 * mesh.n_vertices, [&] { return zbuffer::find_nonfinite_vertex(mesh); });
  if (nonfinite >= 0)
    throw py::value_error("vertex " + std::to_string(nonfinite) +
                          " has a NaN or infinite coordinate");
  return mesh;
}

py::dict stats_dict(const zbuffer::RenderStats& s) {
  py::dict d;
  d["triangles_in"] = s.triangles_in;
  d["culled_in_nodes"] = s.culled_in_nodes;
  d["culled_invalid"] = s.culled_invalid;
  d["culled_frustum"] = s.culled_frustum;
  d["clipped"] = s.clipped;
  d["clipped_away"] = s.clipped_away;
  d["clip_pieces"] = s.clip_pieces;
  d["culled_backface"] = s.culled_backface;
  d["culled_degenerate"] = s.culled_degenerate;
  d["culled_hidden"] = s.culled_hidden;
  d["rasterized"] = s.rasterized;
  d["pixels_tested"] = s.pixels_tested;
  d["pixels_covered"] = s.pixels_covered;
  d["pixels_written"] = s.pixels_written;
  d["tiles_skipped"] = s.tiles_skipped;
  d["pyramid_cells_updated"] = s.pyramid_cells_updated;
  d["polygons_inserted"] = s.polygons_inserted;
  d["edges_inserted"] = s.edges_inserted;
  d["scanline_rows"] = s.scanline_rows;
  d["active_polygons_max"] = s.active_polygons_max;
  d["active_polygons_mean"] =
      s.scanline_rows ? double(s.active_polygons_sum) / double(s.scanline_rows) : 0.0;
  d["active_edges_max"] = s.active_edges_max;
  d["active_edges_mean"] =
      s.scanline_rows ? double(s.active_edges_sum) / double(s.scanline_rows) : 0.0;
  d["spans_drawn"] = s.spans_drawn;
  d["depth_storage_bytes"] = s.depth_storage_bytes;
  d["nodes_visited"] = s.nodes_visited;
  d["nodes_hidden"] = s.nodes_hidden;
  d["nodes_outside"] = s.nodes_outside;
  d["build_ms"] = s.build_ms;
  d["traversal_ms"] = s.traversal_ms;
  d["vertex_ms"] = s.vertex_ms;
  d["raster_ms"] = s.raster_ms;
  d["pyramid_ms"] = s.pyramid_ms;
  d["render_ms"] = s.total_ms;  // the C++ call; Python adds total_ms
  return d;
}

std::unique_ptr<CullRecording> attach_cull_map(bool record_culls, int width, int height,
                                               zbuffer::RenderInput& input) {
  if (!record_culls) return nullptr;
  auto recording = std::make_unique<CullRecording>();
  // The result's own arrays: no copy. Zeroed by numpy.zeros, whose large
  // arrays are fresh pages the system gives zeroed as they are first
  // touched: the cells no test counts in (levels no test reads, most of
  // level 0 among them) never become resident. (Zeroed here, every page was
  // written: 2.4 GB more at the largest image, against the 64 MB its counts
  // touch.)
  const py::object zeros = py::module_::import("numpy").attr("zeros");
  recording->map = std::make_unique<zbuffer::CullMap>(width, height, [&](int w, int h) {
    auto level = py::array_t<int64_t>(zeros(py::make_tuple(h, w), "int64"));
    recording->levels.append(level);
    return level.mutable_data();
  });
  input.culls = recording->map.get();
  return recording;
}

py::tuple render_result(py::array_t<float> depth, py::array_t<int32_t> ids,
                        const zbuffer::RenderStats& stats, const CullRecording* culls) {
  if (!culls) return py::make_tuple(depth, ids, stats_dict(stats));
  return py::make_tuple(depth, ids, stats_dict(stats), culls->levels);
}

// Both planes in one block, their rows padded at widths where rows would
// otherwise lie 4 KiB apart (zbuffer::padded_pitch), and their start
// addresses 2 KiB apart modulo 4 KiB: at widths that are a multiple of 1024
// pixels every row of both planes would otherwise fall in the same L1 cache
// set, and a triangle's rows would evict each other.
Planes allocate_planes(int width, int height) {
  const int pitch = zbuffer::padded_pitch(width);
  const size_t n = size_t(pitch) * size_t(height);
  py::array_t<uint8_t> block(py::ssize_t(2 * 4 * n + 4096 + 64));
  uint8_t* base = block.mutable_data();
  const size_t depth_at = (64 - reinterpret_cast<uintptr_t>(base) % 64) % 64;
  const uintptr_t depth_addr = reinterpret_cast<uintptr_t>(base) + depth_at;
  const uintptr_t ids_addr = zbuffer::id_plane_address(depth_addr, depth_addr + 4 * n);
  const std::vector<py::ssize_t> shape = {height, width};
  const std::vector<py::ssize_t> strides = {py::ssize_t(4) * pitch, 4};
  py::array_t<float> depth(shape, strides, reinterpret_cast<float*>(depth_addr), block);
  py::array_t<int32_t> ids(shape, strides, reinterpret_cast<int32_t*>(ids_addr), block);
  return {depth, ids, pitch};
}

Planes output_planes(py::handle out_depth, py::handle out_ids, int width, int height,
                     const std::vector<NamedArray>& inputs) {
  if (out_depth.is_none() && out_ids.is_none()) return allocate_planes(width, height);
  if (out_depth.is_none() || out_ids.is_none())
    throw py::value_error("give both out_depth and out_ids, or neither");
  const std::vector<py::ssize_t> shape = {height, width};
  int depth_pitch = 0, ids_pitch = 0;
  auto depth = require_output_rows<float>(out_depth, "out_depth", shape, depth_pitch);
  auto ids = require_output_rows<int32_t>(out_ids, "out_ids", shape, ids_pitch);
  if (depth_pitch != ids_pitch && height > 1)
    throw py::value_error("out_depth and out_ids must have their rows the same number of pixels "
                          "apart, got " + std::to_string(depth_pitch) + " and " +
                          std::to_string(ids_pitch));
  std::vector<NamedArray> others = inputs;
  others.push_back({ids, "out_ids"});
  require_apart({depth, "out_depth"}, others);
  require_apart({ids, "out_ids"}, inputs);
  return {depth, ids, height > 1 ? depth_pitch : width};
}

void read_mvp(py::handle mvp_obj, double* out) {
  auto mvp = require_array<double>(mvp_obj, "mvp", {4, 4});
  for (int k = 0; k < 16; ++k) {
    out[k] = mvp.data()[k];
    if (!std::isfinite(out[k]))
      throw py::value_error("the camera matrix has a NaN or infinite entry");
  }
}

}  // namespace zbuffer_py
