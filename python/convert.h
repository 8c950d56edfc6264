// What every binding file shares: numpy arrays in (checked, never silently converted) and out
// (owning their C++ buffer, no copy), JSON to Python objects, the exception classes, and the GIL.
//
// Arrays out: a std::vector moved into a heap holder that a capsule owns; the numpy array views
// the vector's buffer and frees it with the last reference. Arrays in: a float64 or float32 array
// of the shape the function documents, C-contiguous, else ValueError naming the argument and both
// shapes (or both dtypes): a wrong shape is a caller's bug, and converting silently would hide it.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace odyssey::python {

namespace py = pybind11;

// Raised for a bad argument value that is not an array (a quality name, a negative fps): the
// CLI's usage errors. Translated to odyssey.UsageError.
class UsageError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Raised for a wrong array argument; translated to Python's ValueError.
class ArrayError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Registers odyssey.Error (a RuntimeError), odyssey.InputError and odyssey.UsageError (both
// odyssey.Error) and the translator mapping io::InputError, UsageError, ArrayError and every
// other std::exception onto them (and ValueError).
void register_errors(py::module_& m);

// A numpy array of `shape` over `values` (moved, not copied; values.size() must be the product).
template <class T>
py::array owning_array(std::vector<T>&& values, std::vector<py::ssize_t> shape) {
  auto* holder = new std::vector<T>(std::move(values));
  py::capsule owner(holder, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(shape, holder->data(), owner);
}

// The same with a dtype other than T's (bytes holding 0/1 as numpy bool).
template <class T>
py::array owning_array(std::vector<T>&& values, std::vector<py::ssize_t> shape, const py::dtype& dtype) {
  auto* holder = new std::vector<T>(std::move(values));
  py::capsule owner(holder, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  std::vector<py::ssize_t> strides(shape.size());
  py::ssize_t stride = sizeof(T);
  for (std::size_t i = shape.size(); i-- > 0;) {
    strides[i] = stride;
    stride *= shape[i];
  }
  return py::array(dtype, shape, strides, holder->data(), owner);
}

// "(3, 4)", "(5,)"; a negative extent prints as "any" ("(any, 165)").
std::string shape_text(const std::vector<py::ssize_t>& shape);

// `array` as a C-contiguous array of T with `shape` (-1: any extent); ValueError naming `name` and
// both shapes or dtypes otherwise. The result views the caller's memory (no copy).
template <class T>
py::array_t<T, py::array::c_style> checked_array(const py::handle& array, const char* name, std::vector<py::ssize_t> shape);

// A JSON value as the Python object json.loads would give (dicts keep their order).
py::object to_python(const nlohmann::ordered_json& json);
py::object to_python(const nlohmann::json& json);
// A dict, list, str, number, bool or None as JSON (for scene dicts); UsageError naming `what` for
// anything else.
nlohmann::ordered_json from_python(const py::handle& object, const std::string& what);

// A str or os.PathLike as a path string; UsageError naming `name` otherwise.
std::string path_argument(const py::handle& path, const char* name);

// A real number (a Python or numpy number), an integer (anything with __index__) or a str;
// UsageError naming `name` and the type given otherwise, never pybind11's cast error.
double number_argument(const py::handle& value, const std::string& name);
long long integer_argument(const py::handle& value, const std::string& name);
std::string text_argument(const py::handle& value, const std::string& name);

}  // namespace odyssey::python
