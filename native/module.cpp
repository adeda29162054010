// texbake._native: the compiled kernels. Each stage's file defines its bind_* function;
// this file only gathers them.
#include <nanobind/nanobind.h>

#include "parallel.hpp"

namespace nb = nanobind;

void bind_textures(nb::module_& m);

NB_MODULE(_native, m) {
  m.doc() = "texbake's compiled kernels (C++, nanobind); the GIL is released inside each";
  m.def("cores", &texbake::cores, "the threads a kernel runs on (one a core)");
  bind_textures(m);
}
