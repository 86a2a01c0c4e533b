// What the render bindings share: argument checks, the stats dict and the
// output planes.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <vector>

#include "array_checks.h"
#include "zbuffer/types.h"

namespace zbuffer_py {

// A check that reads arrays and touches no Python object, run without the
// GIL when it reads more than kScanWithoutGil values: on the 5 x 5 x 80 spot
// grid (35 M indices, 18 M coordinates) a render's checks take about 9 ms,
// in which other Python threads may go on (the render reads the same arrays
// without the GIL after them). Smaller ones keep it: releasing and taking
// it back would cost more than they do.
constexpr int64_t kScanWithoutGil = int64_t(1) << 16;
template <class Scan>
int64_t scan_arrays(int64_t values, Scan scan) {
  if (values <= kScanWithoutGil) return scan();
  py::gil_scoped_release release;
  return scan();
}

// Raises ValueError unless 1 <= width, height (0 too with allow_empty) and
// the image is not too large (conventions.h: kMaxImageSide, kMaxImagePixels).
void check_image_size(int64_t width, int64_t height, bool allow_empty = false);

// Raises ValueError naming the first face index outside [0, n_vertices).
// Called with the GIL; scans of large meshes release it meanwhile.
void check_face_indices(const zbuffer::MeshView& mesh);

// Checks the mesh arrays and returns a view of them (called with the GIL,
// released meanwhile for large meshes, as check_face_indices does).
zbuffer::MeshView mesh_view(const py::array_t<double>& positions,
                            const py::array_t<int32_t>& faces);

// The mvp as 16 finite doubles (ValueError otherwise).
void read_mvp(py::handle mvp_obj, double* out);

// Every counter and time of a render, by name.
py::dict stats_dict(const zbuffer::RenderStats& s);

// A render's cull counts (record_culls): the result's (h, w) int64 arrays,
// one per pyramid level, and the CullMap that counts into them.
struct CullRecording {
  py::list levels;
  std::unique_ptr<zbuffer::CullMap> map;
};

// With record_culls, a CullRecording for a width x height render, its map
// attached to `input` (null otherwise). Made with the GIL held.
std::unique_ptr<CullRecording> attach_cull_map(bool record_culls, int width, int height,
                                               zbuffer::RenderInput& input);

// What a render binding returns: (depth, triangle_id, stats), and with cull
// counts a fourth item, their arrays.
py::tuple render_result(py::array_t<float> depth, py::array_t<int32_t> ids,
                        const zbuffer::RenderStats& stats, const CullRecording* culls);

// The (H, W) depth and id planes a render writes, and the pixels from one
// row's start to the next's in both (DepthTarget.pitch).
struct Planes {
  py::array_t<float> depth;
  py::array_t<int32_t> ids;
  int pitch = 0;

  zbuffer::DepthTarget target(int width, int height) {
    return {depth.mutable_data(), ids.mutable_data(), width, height, pitch};
  }
};

// New planes, in one block: rows padded to zbuffer::padded_pitch(width).
Planes allocate_planes(int width, int height);

// The planes a render writes: the caller's (out_depth float32 and out_ids
// int32, both (height, width), with contiguous rows the same number of
// pixels apart (require_rows), writeable, apart from each other and from
// every array in `inputs`), or, when both are None, new ones
// (allocate_planes). ValueError/TypeError naming what is wrong otherwise.
Planes output_planes(py::handle out_depth, py::handle out_ids, int width, int height,
                     const std::vector<NamedArray>& inputs);

}  // namespace zbuffer_py
