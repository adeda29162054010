// The array types the kernels take: numpy arrays on the CPU, C-contiguous. Inputs (const)
// may be converted by nanobind (a copy of another dtype or layout); outputs are bound with
// .noconvert(), so that a kernel never fills a temporary copy instead of the caller's array.
#pragma once
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstdint>
#include <utility>
#include <vector>

namespace texbake {

namespace nb = nanobind;

template <class T, class... Extra>
using In = nb::ndarray<const T, nb::c_contig, nb::device::cpu, Extra...>;
template <class T, class... Extra>
using Out = nb::ndarray<T, nb::c_contig, nb::device::cpu, Extra...>;

using nb::shape;
using Release = nb::call_guard<nb::gil_scoped_release>;

// A numpy array that owns the vector's buffer (outputs whose size a kernel finds): made with
// the GIL held
template <class T>
nb::ndarray<nb::numpy, T> owned(std::vector<T>&& values, std::initializer_list<size_t> dims) {
  auto* held = new std::vector<T>(std::move(values));
  nb::capsule owner(held, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::ndarray<nb::numpy, T>(held->data(), dims, owner);
}

}  // namespace texbake
