// Checks on numpy arrays crossing into the core, done with the GIL held.
// The Python package converts user input to the exact dtypes; anything else
// reaching the binding is a programming error and gets a precise message.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace zbuffer_py {

namespace py = pybind11;

// obj must be a numpy array of dtype T whose shape matches `shape` (-1
// matches any extent), laid out in any way. Returns it without copying.
template <class T>
py::array typed_array(py::handle obj, const char* name, const std::vector<py::ssize_t>& shape) {
  if (!py::isinstance<py::array>(obj))
    throw py::type_error(std::string(name) + " must be a numpy array, got " +
                         std::string(py::str(py::type::of(obj).attr("__name__"))));
  auto a = py::reinterpret_borrow<py::array>(obj);
  // Equivalent, not the same object: an unpickled array's float64 is a dtype
  // of its own (a byte-swapped one is not equivalent).
  if (!py::detail::npy_api::get().PyArray_EquivTypes_(a.dtype().ptr(),
                                                       py::dtype::of<T>().ptr()))
    throw py::type_error(std::string(name) + " must have dtype " +
                         std::string(py::str(py::dtype::of<T>())) + ", got " +
                         std::string(py::str(a.dtype())));
  bool ok = a.ndim() == py::ssize_t(shape.size());
  for (size_t k = 0; ok && k < shape.size(); ++k)
    ok = shape[k] < 0 || a.shape(py::ssize_t(k)) == shape[k];
  if (!ok) {
    std::string want = "(", got = "(";
    for (size_t k = 0; k < shape.size(); ++k)
      want += (k ? ", " : "") + (shape[k] < 0 ? std::string("n") : std::to_string(shape[k]));
    for (py::ssize_t k = 0; k < a.ndim(); ++k)
      got += (k ? ", " : "") + std::to_string(a.shape(k));
    throw py::value_error(std::string(name) + " must have shape " + want + "), got " + got + ")");
  }
  return a;
}

// obj must be a C-contiguous numpy array of dtype T whose shape matches
// `shape` (-1 matches any extent). Returns it without copying.
template <class T>
py::array_t<T> require_array(py::handle obj, const char* name,
                             const std::vector<py::ssize_t>& shape) {
  py::array a = typed_array<T>(obj, name, shape);
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(name) + " must be C-contiguous");
  return py::reinterpret_borrow<py::array_t<T>>(a);
}

// obj must be a 2-D numpy array of dtype T and shape `shape` whose rows are
// contiguous: C-contiguous, or with padded rows -- each row's elements
// adjacent, rows a whole number of elements apart, at least the width --
// as the planes a render returns at some widths (types.h, padded_pitch).
// Returns it without copying; `pitch` gets the elements from one row's
// start to the next's.
template <class T>
py::array_t<T> require_rows(py::handle obj, const char* name, const std::vector<py::ssize_t>& shape,
                            int& pitch) {
  py::array a = typed_array<T>(obj, name, shape);
  const py::ssize_t item = py::ssize_t(sizeof(T)), width = a.shape(1);
  if (width > std::numeric_limits<int>::max())
    throw py::value_error(std::string(name) + " has rows of more than 2**31 - 1 elements");
  if (a.flags() & py::array::c_style) {
    pitch = int(width);
  } else if (a.strides(1) == item && a.strides(0) % item == 0 && a.strides(0) >= width * item &&
             a.strides(0) / item <= std::numeric_limits<int>::max()) {
    pitch = int(a.strides(0) / item);
  } else {
    throw py::value_error(std::string(name) + " must be C-contiguous or have contiguous, padded rows "
                          "(strides (k * " + std::to_string(item) + ", " + std::to_string(item) +
                          ") with k >= its width), got strides (" + std::to_string(a.strides(0)) +
                          ", " + std::to_string(a.strides(1)) + ")");
  }
  return py::reinterpret_borrow<py::array_t<T>>(a);
}

// An array the core writes into: require_array's checks, and writeable.
template <class T>
py::array_t<T> require_output(py::handle obj, const char* name,
                              const std::vector<py::ssize_t>& shape) {
  auto a = require_array<T>(obj, name, shape);
  if (!a.writeable()) throw py::value_error(std::string(name) + " must be writeable");
  return a;
}

// A plane the core writes into: require_rows' checks, and writeable.
template <class T>
py::array_t<T> require_output_rows(py::handle obj, const char* name,
                                   const std::vector<py::ssize_t>& shape, int& pitch) {
  auto a = require_rows<T>(obj, name, shape, pitch);
  if (!a.writeable()) throw py::value_error(std::string(name) + " must be writeable");
  return a;
}

// The bytes from an array's first element to just past its last: its
// nbytes when contiguous, more for a view with gaps (padded rows).
inline std::pair<const char*, const char*> byte_range(const py::array& a) {
  const char* lo = static_cast<const char*>(a.data());
  const char* hi = lo + a.itemsize();
  for (py::ssize_t k = 0; k < a.ndim(); ++k) {
    const py::ssize_t reach = (a.shape(k) - 1) * a.strides(k);
    (reach < 0 ? lo : hi) += reach;
  }
  return {lo, hi};
}

// An array a call reads or writes, named for messages.
struct NamedArray {
  py::array array;
  const char* name;
};

// Whether two 2-D arrays whose rows are runs of adjacent elements the same
// number of bytes apart (`pitch`) have a byte in common, exactly: row i of
// a covers [a + i pitch, a + i pitch + wa), row j of b [b + j pitch,
// b + j pitch + wb), so they meet where -wb < (b - a) + k pitch < wa for
// some k = j - i, -(rows of a - 1) <= k <= rows of b - 1. (The left and
// right halves of one wider array do not.)
inline bool rows_meet(const py::array& a, const py::array& b) {
  const auto row_bytes = [](const py::array& x) { return x.shape(1) * x.itemsize(); };
  const py::ssize_t pitch = a.strides(0), wa = row_bytes(a), wb = row_bytes(b);
  const py::ssize_t d = static_cast<const char*>(b.data()) - static_cast<const char*>(a.data());
  // The k with d + k pitch > -wb, then the least of them must be < wa - d.
  auto floor_div = [](py::ssize_t n, py::ssize_t m) { return n / m - (n % m != 0 && n < 0); };
  py::ssize_t k = floor_div(-wb - d, pitch) + 1;  // the least k above (-wb - d) / pitch
  k = std::max<py::ssize_t>(k, -(a.shape(0) - 1));
  return k <= b.shape(0) - 1 && d + k * pitch < wa;
}

// Whether arrays a and b may have a byte in common: exactly for 2-D arrays
// of contiguous rows the same positive pitch apart (the planes), else by
// their byte ranges.
inline bool may_meet(const py::array& a, const py::array& b) {
  const bool rows = a.ndim() == 2 && b.ndim() == 2 && a.strides(0) == b.strides(0) &&
                    a.strides(0) > 0 && a.strides(1) == a.itemsize() &&
                    b.strides(1) == b.itemsize() && a.strides(0) >= a.shape(1) * a.itemsize() &&
                    b.strides(0) >= b.shape(1) * b.itemsize();
  if (rows) return rows_meet(a, b);
  const auto [lo, hi] = byte_range(a);
  const auto [o_lo, o_hi] = byte_range(b);
  return lo < o_hi && o_lo < hi;
}

// ValueError if the memory of `out` (an array the core writes) overlaps
// that of any of `others` (arrays the same call reads or writes): the core
// would read what it has just written. Empty arrays overlap nothing.
inline void require_apart(const NamedArray& out, const std::vector<NamedArray>& others) {
  for (const NamedArray& other : others) {
    if (!other.array || other.array.nbytes() == 0 || out.array.nbytes() == 0) continue;
    if (may_meet(out.array, other.array))
      throw py::value_error(std::string(out.name) + " shares memory with " + other.name +
                            ": pass arrays of their own to render into");
  }
}

}  // namespace zbuffer_py
