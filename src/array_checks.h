// Checks on numpy arrays crossing into the core, done with the GIL held.
// The Python package converts user input to the exact dtypes; anything else
// reaching the binding is a programming error and gets a precise message.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

namespace zbuffer_py {

namespace py = pybind11;

// obj must be a C-contiguous numpy array of dtype T whose shape matches
// `shape` (-1 matches any extent). Returns it without copying.
template <class T>
py::array_t<T> require_array(py::handle obj, const char* name,
                             const std::vector<py::ssize_t>& shape) {
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
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(name) + " must be C-contiguous");
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

// An array a call reads or writes, named for messages.
struct NamedArray {
  py::array array;
  const char* name;
};

// ValueError if the memory of `out` (an array the core writes) overlaps
// that of any of `others` (arrays the same call reads or writes): the core
// would read what it has just written. Empty arrays overlap nothing.
inline void require_apart(const NamedArray& out, const std::vector<NamedArray>& others) {
  const auto* lo = static_cast<const char*>(out.array.data());
  const auto* hi = lo + out.array.nbytes();
  for (const NamedArray& other : others) {
    if (!other.array || other.array.nbytes() == 0 || out.array.nbytes() == 0) continue;
    const auto* o_lo = static_cast<const char*>(other.array.data());
    const auto* o_hi = o_lo + other.array.nbytes();
    if (lo < o_hi && o_lo < hi)
      throw py::value_error(std::string(out.name) + " shares memory with " + other.name +
                            ": pass arrays of their own to render into");
  }
}

}  // namespace zbuffer_py
