// texbake._native: the compiled kernels. Each stage's file defines its bind_* function;
// this file only gathers them.
#include <nanobind/nanobind.h>

#include "parallel.hpp"

namespace nb = nanobind;

void bind_textures(nb::module_& m);
namespace texbake::materials {
void bind_materials(nb::module_&);
}
namespace texbake {
void bind_accumulate(nb::module_&);
void bind_build_info(nb::module_&);
void bind_charts(nb::module_&);
void bind_components(nb::module_&);
void bind_embree(nb::module_&);
void bind_frames(nb::module_&);
void bind_geometry(nb::module_&);
void bind_grouping(nb::module_&);
void bind_images(nb::module_&);
void bind_lookup(nb::module_&);
void bind_margin(nb::module_&);
void bind_normals(nb::module_&);
void bind_objfile(nb::module_&);
void bind_surface(nb::module_&);
void bind_uvcheck(nb::module_&);
}  // namespace texbake

NB_MODULE(_native, m) {
  m.doc() = "texbake's compiled kernels (C++, nanobind); the GIL is released inside each";
  m.def("cores", &texbake::cores, "the threads a kernel runs on (one a core)");
  bind_textures(m);
  texbake::materials::bind_materials(m);
  texbake::bind_build_info(m);
  texbake::bind_charts(m);
  texbake::bind_components(m);
  texbake::bind_embree(m);
  texbake::bind_geometry(m);
  texbake::bind_grouping(m);
  texbake::bind_normals(m);
  texbake::bind_objfile(m);
  texbake::bind_uvcheck(m);
  texbake::bind_lookup(m);
  texbake::bind_surface(m);
  texbake::bind_frames(m);
  texbake::bind_accumulate(m);
  texbake::bind_margin(m);
  texbake::bind_images(m);
}
