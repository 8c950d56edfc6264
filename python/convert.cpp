#include "python/convert.h"

#include <pybind11/stl.h>

#include "mocap_io/input_error.h"

namespace odyssey::python {
namespace {

// The exception classes, created once at import and kept for the interpreter's life.
PyObject* g_error = nullptr;
PyObject* g_input_error = nullptr;
PyObject* g_usage_error = nullptr;

PyObject* new_class(py::module_& m, const char* name, PyObject* base, const char* doc) {
  const std::string qualified = std::string("odyssey.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, base, nullptr);
  if (!type) throw py::error_already_set();
  m.add_object(name, py::handle(type));  // the module keeps its own reference; `type` ours stays
  return type;
}

template <class Json>
py::object json_to_python(const Json& json) {
  switch (json.type()) {
    case nlohmann::json::value_t::null: return py::none();
    case nlohmann::json::value_t::boolean: return py::bool_(json.template get<bool>());
    case nlohmann::json::value_t::number_integer: return py::int_(json.template get<std::int64_t>());
    case nlohmann::json::value_t::number_unsigned: return py::int_(json.template get<std::uint64_t>());
    case nlohmann::json::value_t::number_float: return py::float_(json.template get<double>());
    case nlohmann::json::value_t::string: return py::str(json.template get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list list;
      for (const auto& item : json) list.append(json_to_python(item));
      return list;
    }
    case nlohmann::json::value_t::object: {
      py::dict dict;
      for (auto it = json.begin(); it != json.end(); ++it) dict[py::str(it.key())] = json_to_python(it.value());
      return dict;
    }
    default: return py::none();  // binary and discarded values do not occur in reports
  }
}

}  // namespace

void register_errors(py::module_& m) {
  g_error = new_class(m, "Error", PyExc_RuntimeError,
                      "Any error odyssey reports (a RuntimeError); the message is the command line's one line.");
  g_input_error = new_class(m, "InputError", g_error,
                            "A file that cannot be read or is not valid: str() is 'FILE: PROBLEM', as the command "
                            "line prints it; .file and .problem hold the parts.");
  g_usage_error = new_class(m, "UsageError", g_error,
                            "An argument value odyssey does not accept (a quality name, a negative rate), as the "
                            "command line's usage errors.");
  py::register_exception_translator([](std::exception_ptr pointer) {
    if (!pointer) return;
    try {
      std::rethrow_exception(pointer);
    } catch (const io::InputError& error) {
      py::object instance = py::reinterpret_borrow<py::object>(g_input_error)(error.what());
      instance.attr("file") = error.file();
      instance.attr("problem") = error.problem();
      PyErr_SetObject(g_input_error, instance.ptr());
    } catch (const ArrayError& error) {
      PyErr_SetString(PyExc_ValueError, error.what());
    } catch (const UsageError& error) {
      PyErr_SetString(g_usage_error, error.what());
    } catch (const py::error_already_set&) {
      throw;  // a Python error raised in a callback: pybind11 restores it
    } catch (const py::builtin_exception&) {
      throw;
    } catch (const std::bad_alloc&) {
      PyErr_SetString(PyExc_MemoryError, "out of memory");
    } catch (const std::exception& error) {
      PyErr_SetString(g_error, error.what());
    }
  });
}

std::string shape_text(const std::vector<py::ssize_t>& shape) {
  std::string text = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    text += (i ? ", " : "") + (shape[i] < 0 ? std::string("any") : std::to_string(shape[i]));
  }
  return text + (shape.size() == 1 ? ",)" : ")");
}

template <class T>
py::array_t<T, py::array::c_style> checked_array(const py::handle& object, const char* name, std::vector<py::ssize_t> shape) {
  const std::string expected_dtype = py::str(py::dtype::of<T>());
  if (!py::isinstance<py::array>(object)) {
    throw ArrayError(std::string(name) + ": expected a numpy array of " + expected_dtype + " with shape " + shape_text(shape) +
                     ", got " + std::string(py::str(py::type::of(object).attr("__name__"))));
  }
  const auto array = py::reinterpret_borrow<py::array>(object);
  std::vector<py::ssize_t> got(array.shape(), array.shape() + array.ndim());
  bool shape_ok = got.size() == shape.size();
  for (std::size_t i = 0; shape_ok && i < shape.size(); ++i) shape_ok = shape[i] < 0 || shape[i] == got[i];
  if (!shape_ok) {
    throw ArrayError(std::string(name) + ": expected shape " + shape_text(shape) + ", got shape " + shape_text(got));
  }
  if (!py::isinstance<py::array_t<T>>(array)) {  // numpy's equivalence of dtypes
    throw ArrayError(std::string(name) + ": expected dtype " + expected_dtype + ", got dtype " +
                     std::string(py::str(array.dtype())) + " (shape " + shape_text(got) + "; convert with .astype)");
  }
  // A strided view (a slice, a transpose) is copied once into C order; the values are the caller's.
  return py::array_t<T, py::array::c_style>::ensure(array);
}

template py::array_t<double, py::array::c_style> checked_array<double>(const py::handle&, const char*, std::vector<py::ssize_t>);
template py::array_t<float, py::array::c_style> checked_array<float>(const py::handle&, const char*, std::vector<py::ssize_t>);

py::object to_python(const nlohmann::ordered_json& json) { return json_to_python(json); }
py::object to_python(const nlohmann::json& json) { return json_to_python(json); }

nlohmann::ordered_json from_python(const py::handle& object, const std::string& what) {
  if (object.is_none()) return nullptr;
  if (py::isinstance<py::bool_>(object)) return object.cast<bool>();
  if (py::isinstance<py::int_>(object)) return object.cast<std::int64_t>();
  if (py::isinstance<py::float_>(object)) return object.cast<double>();
  if (py::isinstance<py::str>(object)) return object.cast<std::string>();
  if (py::hasattr(object, "__fspath__")) return py::str(object.attr("__fspath__")()).cast<std::string>();
  if (py::isinstance<py::dict>(object)) {
    nlohmann::ordered_json json = nlohmann::ordered_json::object();
    for (const auto& [key, value] : py::reinterpret_borrow<py::dict>(object)) {
      if (!py::isinstance<py::str>(key)) throw UsageError(what + ": a key is not a string: " + std::string(py::repr(key)));
      const std::string name = key.cast<std::string>();
      json[name] = from_python(value, what + "." + name);
    }
    return json;
  }
  if (py::isinstance<py::list>(object) || py::isinstance<py::tuple>(object) || py::isinstance<py::array>(object)) {
    nlohmann::ordered_json json = nlohmann::ordered_json::array();
    std::size_t i = 0;
    for (const auto& item : object) json.push_back(from_python(item, what + "[" + std::to_string(i++) + "]"));
    return json;
  }
  if (py::hasattr(object, "item")) return from_python(object.attr("item")(), what);  // a numpy scalar
  throw UsageError(what + ": " + std::string(py::str(py::type::of(object).attr("__name__"))) +
                   " is not a JSON value (dict, list, str, number, bool or None)");
}

std::string path_argument(const py::handle& path, const char* name) {
  if (py::isinstance<py::str>(path)) return path.cast<std::string>();
  if (py::hasattr(path, "__fspath__")) {
    py::object text = path.attr("__fspath__")();
    if (py::isinstance<py::str>(text)) return text.cast<std::string>();
  }
  throw UsageError(std::string(name) + ": expected a path (str or os.PathLike), got " +
                   std::string(py::str(py::type::of(path).attr("__name__"))));
}

std::string type_name(const py::handle& value) { return py::str(py::type::of(value).attr("__name__")); }

double number_argument(const py::handle& value, const std::string& name) {
  if (!py::isinstance<py::bool_>(value)) {
    const double number = PyFloat_AsDouble(value.ptr());
    if (!(number == -1.0 && PyErr_Occurred())) return number;
    PyErr_Clear();
  }
  throw UsageError(name + ": expected a number, got " + type_name(value));
}

long long integer_argument(const py::handle& value, const std::string& name) {
  if (!py::isinstance<py::bool_>(value)) {
    PyObject* index = PyNumber_Index(value.ptr());
    if (index) {
      const long long number = PyLong_AsLongLong(index);
      Py_DECREF(index);
      if (!(number == -1 && PyErr_Occurred())) return number;
    }
    PyErr_Clear();
  }
  throw UsageError(name + ": expected an integer, got " + type_name(value));
}

std::string text_argument(const py::handle& value, const std::string& name) {
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  throw UsageError(name + ": expected a str, got " + type_name(value));
}

}  // namespace odyssey::python
