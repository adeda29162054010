// How the extension was built (compiler, flags), for the report's versions.
#include <nanobind/stl/string.h>

#include <string>

#include "arrays.hpp"

#ifndef TEXBAKE_CXX_FLAGS
#define TEXBAKE_CXX_FLAGS "unknown"
#endif
#ifndef TEXBAKE_BUILD_TYPE
#define TEXBAKE_BUILD_TYPE "unknown"
#endif

namespace texbake {

void bind_build_info(nb::module_& m) {
  m.def("build_info", [] {
    nb::dict info;
#if defined(__clang__)
    info["compiler"] = std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
    info["compiler"] = std::string("gcc ") + __VERSION__;
#else
    info["compiler"] = std::string("unknown");
#endif
    info["flags"] = std::string(TEXBAKE_CXX_FLAGS);
    info["build_type"] = std::string(TEXBAKE_BUILD_TYPE);
    info["nanobind"] = std::string(std::to_string(NB_VERSION_MAJOR) + "." + std::to_string(NB_VERSION_MINOR) + "." +
                                   std::to_string(NB_VERSION_PATCH));
    return info;
  }, "How the kernels were built: compiler, flags, build type, nanobind's version.");
}

}  // namespace texbake
