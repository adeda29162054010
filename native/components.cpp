// Connected components by union-find: each set's root is its smallest node, and sets are
// numbered in the order of their smallest node (scipy.sparse.csgraph's labels).
#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "unionfind.hpp"

namespace texbake {
namespace {

void check_node(int64_t i, int64_t n) {
  if (i < 0 || i >= n) throw nb::index_error(("node " + std::to_string(i) + " outside [0, " + std::to_string(n) + ")").c_str());
}

void labels(int64_t n, In<int64_t, nb::ndim<1>> a, In<int64_t, nb::ndim<1>> b, Out<int64_t, nb::ndim<1>> out) {
  const int64_t e = a.shape(0);
  if (int64_t(b.shape(0)) != e || int64_t(out.shape(0)) != n) throw std::invalid_argument("labels: a, b of one length, out of n");
  for (int64_t i = 0; i < e; ++i) {  // checked up front: an edge end outside would write anywhere
    if (a.data()[i] < 0 || a.data()[i] >= n || b.data()[i] < 0 || b.data()[i] >= n)
      throw std::invalid_argument("labels: an edge end outside [0, n)");
  }
  std::vector<int64_t> parent(n);
  std::iota(parent.begin(), parent.end(), int64_t(0));
  for (int64_t i = 0; i < e; ++i) join(parent.data(), a.data()[i], b.data()[i]);
  number(parent.data(), n, out.data());
}

// the chart of each face: faces joined through their (m, 3) corners' k vertices, numbered as
// labels numbers the m + k nodes (faces first: a chart's label is given at its first face)
void face_components(In<int64_t, nb::shape<-1, 3>> faces, int64_t k, Out<int64_t, nb::ndim<1>> out) {
  const int64_t m = faces.shape(0);
  if (int64_t(out.shape(0)) != m) throw std::invalid_argument("face_components: out of m rows");
  const int64_t* f = faces.data();
  for (int64_t i = 0; i < 3 * m; ++i) {
    if (f[i] < 0 || f[i] >= k) throw std::invalid_argument("face_components: a corner outside [0, k)");
  }
  std::vector<int64_t> parent(m + k), label(m + k);
  std::iota(parent.begin(), parent.end(), int64_t(0));
  for (int64_t i = 0; i < 3 * m; ++i) join(parent.data(), i / 3, m + f[i]);
  number(parent.data(), m + k, label.data());
  std::copy_n(label.begin(), m, out.data());
}

int64_t sets_root(Out<int64_t, nb::ndim<1>> parent, int64_t i) {
  check_node(i, parent.shape(0));
  return root(parent.data(), i);
}

int64_t sets_join(Out<int64_t, nb::ndim<1>> parent, int64_t i, int64_t j) {
  check_node(i, parent.shape(0));
  check_node(j, parent.shape(0));
  return join(parent.data(), i, j);
}

void sets_labels(Out<int64_t, nb::ndim<1>> parent, Out<int64_t, nb::ndim<1>> out) {
  if (out.shape(0) != parent.shape(0)) throw std::invalid_argument("sets_labels: out must be parent's length");
  number(parent.data(), parent.shape(0), out.data());
}

}  // namespace

void bind_components(nb::module_& m) {
  m.def("labels", &labels, nb::arg("n"), nb::arg("a"), nb::arg("b"), nb::arg("out").noconvert(), Release(),
        "Fill out (n,) int64 with the component of each node joined by the edges (a[i], b[i]).");
  m.def("face_components", &face_components, nb::arg("faces"), nb::arg("k"), nb::arg("out").noconvert(), Release(),
        "Fill out (m,) with the component of each face, faces joined where they share one of the k vertices.");
  // one pair at a time from Python: these hold the GIL (taking it back, when another thread
  // holds it, would cost more than the join)
  m.def("sets_root", &sets_root, nb::arg("parent").noconvert(), nb::arg("i"), "The root of node i's set.");
  m.def("sets_join", &sets_join, nb::arg("parent").noconvert(), nb::arg("i"), nb::arg("j"),
        "Join the sets of i and j; returns the joined set's root (its smallest node).");
  m.def("sets_labels", &sets_labels, nb::arg("parent").noconvert(), nb::arg("out").noconvert(), Release(),
        "Fill out (n,) int64 with the sets' labels, in the order of their smallest node.");
}

}  // namespace texbake
