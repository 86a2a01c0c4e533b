// Bindings for the fast paths of the text mesh readers (obj_reader.h, off_reader.h,
// ply_reader.h).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string_view>
#include <utility>
#include <vector>

#include "zbuffer/obj_reader.h"
#include "zbuffer/off_reader.h"
#include "zbuffer/ply_reader.h"

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

// read(text, records) on the bytes' contents, without the GIL.
template <class Records, class Read>
bool read_records(const py::bytes& text, Records& records, Read read) {
  char* data = nullptr;
  py::ssize_t size = 0;
  if (PyBytes_AsStringAndSize(text.ptr(), &data, &size) != 0) throw py::error_already_set();
  py::gil_scoped_release release;  // (the bytes object is immutable and held)
  return read(std::string_view(data, size_t(size)), records);
}

// The values as a flat array.
template <class T>
py::array_t<T> flat(std::vector<T>&& values) {
  const auto n = py::ssize_t(values.size());
  return owning_array(std::move(values), {n});
}

// The values as (n, 3) rows.
py::array_t<double> rows(std::vector<double>&& values) {
  const auto n = py::ssize_t(values.size() / 3);
  return owning_array(std::move(values), {n, 3});
}

// (n, 3) rows of the values, or None when there are none.
py::object rows_or_none(std::vector<double>&& values) {
  if (values.empty()) return py::none();
  return rows(std::move(values));
}

py::object read_obj_records(const py::bytes& text) {
  zbuffer::ObjRecords records;
  if (!read_records(text, records, zbuffer::read_obj_records)) return py::none();
  return py::make_tuple(rows(std::move(records.positions)), rows_or_none(std::move(records.colors)),
                        flat(std::move(records.sizes)), flat(std::move(records.indices)));
}

py::object read_off_records(const py::bytes& text) {
  zbuffer::OffRecords records;
  if (!read_records(text, records, zbuffer::read_off_records)) return py::none();
  return py::make_tuple(rows(std::move(records.positions)), flat(std::move(records.sizes)),
                        flat(std::move(records.indices)),
                        rows_or_none(std::move(records.vertex_colors)), records.vertex_floats,
                        rows_or_none(std::move(records.face_colors)), records.face_floats);
}

py::object read_ascii_ply_tables(const py::bytes& body, const std::vector<int64_t>& counts) {
  std::vector<std::vector<double>> tables;
  std::vector<int64_t> columns;
  const auto read = [&](std::string_view text, std::vector<std::vector<double>>& out) {
    return zbuffer::read_ascii_ply_tables(text, counts, out, columns);
  };
  if (!read_records(body, tables, read)) return py::none();
  py::list out;
  for (size_t e = 0; e < tables.size(); ++e)
    out.append(owning_array(std::move(tables[e]),
                            {py::ssize_t(counts[e]), py::ssize_t(columns[e])}));
  return out;
}

}  // namespace

void bind_readers(py::module_& m) {
  m.def("read_obj_records", &read_obj_records, py::arg("text"),
        "The v and f records of an OBJ file's bytes: (positions (n, 3) float64, colours "
        "(n, 3) float64 as written or None, polygon sizes int64, indices int64, 0-based), or "
        "None when the file holds anything outside the common subset this reader takes, "
        "errors included (obj_reader.h): then python/zbuffer/obj.py reads it.");
  m.def("read_off_records", &read_off_records, py::arg("text"),
        "The records of an ASCII OFF file's bytes: (positions (n, 3) float64, polygon sizes "
        "int64, indices int64, vertex colours (n, 3) float64 as written or None, whether they "
        "are written as floats, face colours or None, whether they are floats), or None "
        "outside the subset this reader takes, errors included (off_reader.h): then "
        "python/zbuffer/off.py reads it.");
  m.def("read_ascii_ply_tables", &read_ascii_ply_tables, py::arg("body"), py::arg("counts"),
        "The records of an ASCII PLY file's body (after the header), counts[e] of element e: "
        "a list of (counts[e], words a record) float64 tables, or None outside the subset "
        "ply_reader.h takes: then python/zbuffer/ply.py reads them.");
}

}  // namespace zbuffer_py
