// What the render bindings share: argument checks, the stats dict and the
// output planes.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <utility>

#include "array_checks.h"
#include "zbuffer/types.h"

namespace zbuffer_py {

// Raises ValueError unless 1 <= width, height and the image is not too large.
void check_image_size(int width, int height);

// Checks the mesh arrays and returns a view of them (GIL held).
zbuffer::MeshView mesh_view(const py::array_t<double>& positions,
                            const py::array_t<int32_t>& faces);

// The mvp as 16 finite doubles (ValueError otherwise).
void read_mvp(py::handle mvp_obj, double* out);

// Every counter and time of a render, by name.
py::dict stats_dict(const zbuffer::RenderStats& s);

// A CullMap's levels as a list of (h, w) int64 arrays.
py::list cull_levels(const zbuffer::CullMap& map);

// The depth and id planes, as two C-contiguous (H, W) arrays in one block.
std::pair<py::array_t<float>, py::array_t<int32_t>> allocate_planes(int width, int height);

}  // namespace zbuffer_py
