// Grouping (texbake/mesh/grouping.py): equal rows, and the items of equal keys paired in
// index order, by hashing (hashing.hpp) in linear time.
#include <stdexcept>
#include <tuple>
#include <vector>

#include <nanobind/stl/tuple.h>

#include "arrays.hpp"
#include "hashing.hpp"

namespace texbake {
namespace {

using Array = nb::ndarray<nb::numpy, int64_t>;

std::tuple<Array, Array> group_rows(In<uint64_t, nb::ndim<2>> rows) {
  const int64_t n = rows.shape(0), d = rows.shape(1);
  std::vector<int64_t> inverse(n), first;
  {
    nb::gil_scoped_release unlocked;
    first = group_words(rows.data(), n, d, inverse.data());
  }
  const size_t g = first.size();
  return {owned(std::move(first), {g}), owned(std::move(inverse), {size_t(n)})};
}

std::tuple<Array, Array> key_pairs(In<uint64_t, nb::ndim<1>> key, In<bool, nb::ndim<1>> take) {
  const int64_t n = key.shape(0);
  if (int64_t(take.shape(0)) != n) throw std::invalid_argument("key_pairs: key and take of one length");
  std::vector<int64_t> lo, hi;
  {
    nb::gil_scoped_release unlocked;
    const bool* t = take.data();
    consecutive_pairs(key.data(), n, [t](int64_t i) { return t[i]; }, [&](int64_t h, int64_t k) {
      lo.push_back(h);
      hi.push_back(k);
    });
  }
  const size_t p = lo.size();
  return {owned(std::move(lo), {p}), owned(std::move(hi), {p})};
}

}  // namespace

void bind_grouping(nb::module_& m) {
  m.def("group_rows", &group_rows, nb::arg("rows"),
        "(first (g,), inverse (n,)) int64 of the (n, d) uint64 rows grouped where all their words are equal, groups "
        "numbered in the order of their first row.");
  m.def("key_pairs", &key_pairs, nb::arg("key"), nb::arg("take"),
        "(lo (p,), hi (p,)) int64: the items i < j with take, one key and no taken item of that key between them.");
}

}  // namespace texbake
