// odyssey._odyssey: the compiled half of the Python package `odyssey` (python/odyssey/__init__.py
// re-exports it). One expose_* function per part of the library.
#include <pybind11/pybind11.h>

#include "python/convert.h"
#include "python/expose.h"

PYBIND11_MODULE(_odyssey, m) {
  m.doc() = "odyssey: motion retargeting and synthetic point-tracking data (the C++ library's bindings)";
  odyssey::python::register_errors(m);
  odyssey::python::expose_motion(m);
  odyssey::python::expose_retarget(m);
  odyssey::python::expose_scene(m);
  odyssey::python::expose_batch(m);
#ifdef ODYSSEY_PYTHON_DATASET
  odyssey::python::expose_dataset(m);
#endif
}
