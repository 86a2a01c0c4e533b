// Bindings for the OBJ reader's fast path (obj_reader.h).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string_view>
#include <utility>
#include <vector>

#include "zbuffer/obj_reader.h"

namespace py = pybind11;

namespace zbuffer_py {

namespace {

// The vector as a numpy array of the given shape that owns it (no copy).
template <class T>
py::array_t<T> owning_array(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* held = new std::vector<T>(std::move(values));
  py::capsule owner(held, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, held->data(), owner);
}

py::object read_obj_records(const py::bytes& text) {
  char* data = nullptr;
  py::ssize_t size = 0;
  if (PyBytes_AsStringAndSize(text.ptr(), &data, &size) != 0) throw py::error_already_set();
  zbuffer::ObjRecords records;
  bool ok = false;
  {
    py::gil_scoped_release release;  // (the bytes object is immutable and held)
    ok = zbuffer::read_obj_records(std::string_view(data, size_t(size)), records);
  }
  if (!ok) return py::none();
  const auto n = py::ssize_t(records.positions.size() / 3);
  const auto n_colors = py::ssize_t(records.colors.size() / 3);
  const auto n_faces = py::ssize_t(records.sizes.size());
  const auto n_corners = py::ssize_t(records.indices.size());
  py::object colors = py::none();
  if (n_colors) colors = owning_array(std::move(records.colors), {n_colors, 3});
  return py::make_tuple(owning_array(std::move(records.positions), {n, 3}), colors,
                        owning_array(std::move(records.sizes), {n_faces}),
                        owning_array(std::move(records.indices), {n_corners}));
}

}  // namespace

void bind_obj(py::module_& m) {
  m.def("read_obj_records", &read_obj_records, py::arg("text"),
        "The v and f records of an OBJ file's bytes: (positions (n, 3) float64, colours "
        "(n, 3) float64 as written or None, polygon sizes int64, indices int64, 0-based), or "
        "None when the file holds anything outside the common subset this reader takes, "
        "errors included (obj_reader.h): then python/zbuffer/obj.py reads it.");
}

}  // namespace zbuffer_py
