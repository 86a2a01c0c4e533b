// zbuffer._core: the compiled core. The public API is the Python package
// (python/zbuffer); this module is private and may change.
#include <pybind11/pybind11.h>

#include "zbuffer/conventions.h"
#include "zbuffer/raster.h"
#include "zbuffer/vertex_stage.h"

namespace py = pybind11;

namespace zbuffer_py {
void bind_readers(py::module_& m);
void bind_object_tree(py::module_& m);
void bind_render(py::module_& m);
void bind_shading(py::module_& m);
}  // namespace zbuffer_py

PYBIND11_MODULE(_core, m) {
  m.doc() = "zbuffer's compiled core (private; use the zbuffer package)";
  m.attr("SUBPIXEL_BITS") = zbuffer::kSubpixelBits;
  m.attr("MAX_IMAGE_SIDE") = zbuffer::kMaxImageSide;
  m.attr("MAX_IMAGE_PIXELS") = zbuffer::kMaxImagePixels;
  m.attr("GUARD_BAND_PX") = zbuffer::kGuardBandPx;
  m.attr("MIN_CLIP_W") = zbuffer::kMinClipW;
  m.attr("MAX_CLIP_VERTICES") = zbuffer::kMaxClipVertices;
  m.attr("RASTER_BACKEND") = zbuffer::raster_backend();
  zbuffer_py::bind_render(m);
  zbuffer_py::bind_object_tree(m);
  zbuffer_py::bind_shading(m);
  zbuffer_py::bind_readers(m);
}
