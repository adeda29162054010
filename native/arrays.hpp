// The array types the kernels take: numpy arrays on the CPU, C-contiguous. Inputs (const)
// may be converted by nanobind (a copy of another dtype or layout); outputs are bound with
// .noconvert(), so that a kernel never fills a temporary copy instead of the caller's array.
#pragma once
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstdint>

namespace texbake {

namespace nb = nanobind;

template <class T, class... Extra>
using In = nb::ndarray<const T, nb::c_contig, nb::device::cpu, Extra...>;
template <class T, class... Extra>
using Out = nb::ndarray<T, nb::c_contig, nb::device::cpu, Extra...>;

using nb::shape;
using Release = nb::call_guard<nb::gil_scoped_release>;

}  // namespace texbake
