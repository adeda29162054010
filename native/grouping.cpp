// Grouping (texbake/mesh/grouping.py): equal rows; and the UV neighbours of the texel lookup
// (texbake/sampling/lookup.py), edges paired by their welded ends. Linear time (grouping.hpp).
#include <climits>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <tuple>
#include <vector>

#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include "arrays.hpp"
#include "grouping.hpp"

namespace texbake {
namespace {

using Array = nb::ndarray<nb::numpy, int64_t>;

std::tuple<Array, Array> group_rows(In<uint64_t, nb::ndim<2>> rows) {
  const int64_t n = rows.shape(0), d = rows.shape(1);
  if (d > 8) throw std::invalid_argument("group_rows: at most 8 columns");
  std::vector<int64_t> inverse(n), first;
  {
    nb::gil_scoped_release unlocked;
    first = group_words(rows.data(), n, d, inverse.data());
  }
  const size_t g = first.size();
  return {owned(std::move(first), {g}), owned(std::move(inverse), {size_t(n)})};
}

inline uint64_t bits_of(double x) {
  x += 0.0;  // -0.0 is 0.0
  uint64_t b;
  std::memcpy(&b, &x, 8);
  return b;
}

// (first, inverse) of the vertices welded by position and UV (texbake/mesh/load.py's _weld):
// rows (x, y, z, u, v, missing) with a vertex whose u and v are both NaN (a part without UVs)
// as (x, y, z, 0, 0, 1); None where a row is not finite then (the weld leaves such a mesh)
std::optional<std::tuple<Array, Array>> weld(In<double, shape<-1, 3>> vertices, std::optional<In<double, shape<-1, 2>>> uv) {
  const int64_t n = vertices.shape(0);
  if (uv && int64_t(uv->shape(0)) != n) throw std::invalid_argument("weld: uv of the vertices' rows");
  std::vector<int64_t> inverse(n), first;
  {
    nb::gil_scoped_release unlocked;
    const double* p = vertices.data();
    const double* t = uv ? uv->data() : nullptr;
    for (int64_t i = 0; i < n; ++i) {
      bool finite = std::isfinite(p[3 * i]) && std::isfinite(p[3 * i + 1]) && std::isfinite(p[3 * i + 2]);
      if (t) {
        const bool missing = std::isnan(t[2 * i]) && std::isnan(t[2 * i + 1]);
        finite = finite && (missing || (std::isfinite(t[2 * i]) && std::isfinite(t[2 * i + 1])));
      }
      if (!finite) return std::nullopt;
    }
    auto row = [p, t](int64_t i, uint64_t* out) {
      for (int k = 0; k < 3; ++k) out[k] = bits_of(p[3 * i + k]);
      if (!t) return;
      const bool missing = std::isnan(t[2 * i]) && std::isnan(t[2 * i + 1]);
      out[3] = bits_of(missing ? 0.0 : t[2 * i]);
      out[4] = bits_of(missing ? 0.0 : t[2 * i + 1]);
      out[5] = bits_of(missing ? 1.0 : 0.0);
    };
    first = group_rows_of(n, t ? 6 : 3, row, inverse.data());
  }
  const size_t g = first.size();
  return std::tuple<Array, Array>{owned(std::move(first), {g}), owned(std::move(inverse), {size_t(n)})};
}

// across (m, 3): the face across the UV edge opposite each corner (texbake/sampling/lookup.py)
void uv_neighbours(In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces, In<bool, nb::ndim<1>> usable,
                   Out<int64_t, shape<-1, 3>> across) {
  const int64_t k = uv.shape(0), m = faces.shape(0), n = 3 * m;
  if (int64_t(usable.shape(0)) != m || int64_t(across.shape(0)) != m) throw std::invalid_argument("uv_neighbours: usable, across of m rows");
  const int64_t* f = faces.data();
  for (int64_t c = 0; c < n; ++c) {
    if (f[c] < 0 || f[c] >= k) throw nb::index_error("uv_neighbours: a face index outside the UVs");
  }
  if (n >= INT32_MAX) throw std::invalid_argument("uv_neighbours: at most 715 million faces");
  nb::gil_scoped_release unlocked;
  std::vector<int64_t> weld(k);
  const double* t = uv.data();
  const int64_t positions = int64_t(group_rows_of(k, 2, [t](int64_t i, uint64_t* out) {
    out[0] = bits_of(t[2 * i]);
    out[1] = bits_of(t[2 * i + 1]);
  }, weld.data()).size());
  // the edge opposite corner c: its next two corners
  auto a = [&](int64_t c) { return weld[f[c - c % 3 + (c % 3 + 1) % 3]]; };
  auto b = [&](int64_t c) { return weld[f[c - c % 3 + (c % 3 + 2) % 3]]; };
  // of the pairs of one edge (h0, h1), (h1, h2), ...: a half-edge takes its predecessor's
  // face, else its successor's (as numpy's two assignments, the later winning); a pair comes
  // after its first half-edge's own predecessor pair, so that one is already set
  int64_t* out = across.data();
  std::fill(out, out + n, int64_t(-1));
  const bool* ok = usable.data();
  edge_pairs(a, b, n, positions, [&](int64_t h) { return ok[h / 3] && a(h) != b(h); }, [&](int64_t h, int64_t j) {
    out[j] = h / 3;
    if (out[h] < 0) out[h] = j / 3;
  });
}

}  // namespace

void bind_grouping(nb::module_& m) {
  m.def("group_rows", &group_rows, nb::arg("rows"),
        "(first (g,), inverse (n,)) int64 of the (n, d) uint64 rows grouped where all their words are equal, groups "
        "numbered in the order of their first row.");
  m.def("weld", &weld, nb::arg("vertices"), nb::arg("uv").none(),
        "(first, inverse) of the vertices (n, 3) grouped where position and uv (n, 2; a row of two NaN: none) are "
        "equal, numbered in the order of their first vertex; None where a position or a UV is not finite.");
  m.def("uv_neighbours", &uv_neighbours, nb::arg("uv"), nb::arg("faces"), nb::arg("usable"), nb::arg("across").noconvert(),
        "Fill across (m, 3) with the face across the UV edge opposite each corner (-1: none), corners matched by UV "
        "position, edges between usable faces only; of more than two on one edge, each with the next in order.");
}

}  // namespace texbake
