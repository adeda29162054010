// Shading normals split at hard edges (texbake/mesh/normals.py): corners joined into fans
// across soft edges, one area-weighted normal a fan, one new vertex per (vertex, fan).
// Linear time (a hash table and buckets, where the numpy version sorted twice); the sums run in corner
// order, as numpy's bincount adds, so the normals have the same bits.
#include <algorithm>
#include <cmath>
#include <climits>
#include <cstring>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <nanobind/stl/tuple.h>

#include "arrays.hpp"
#include "grouping.hpp"
#include "unionfind.hpp"

namespace texbake {
namespace {

// each vertex's position id: equal ids where the coordinates are (-0.0 is 0.0)
std::vector<int64_t> position_ids(const double* v, int64_t k) {
  std::vector<int64_t> id(k);
  group_rows_of(k, 3, [v](int64_t i, uint64_t* out) {
    for (int j = 0; j < 3; ++j) {
      const double x = v[3 * i + j] + 0.0;
      std::memcpy(&out[j], &x, 8);
    }
  }, id.data());
  return id;
}

// the fan of each corner 3 f + c: corners joined across the soft edges
std::vector<int64_t> fans(const int64_t* faces, int64_t m, const std::vector<int64_t>& pos, const std::vector<double>& weighted,
                          double cos_angle) {
  const int64_t n = 3 * m;
  auto next = [](int64_t c) { return c - c % 3 + (c % 3 + 1) % 3; };  // the corner after c in its face
  auto start = [&](int64_t c) { return pos[faces[c]]; };
  auto end = [&](int64_t c) { return pos[faces[next(c)]]; };
  const int64_t ends = m ? *std::max_element(pos.begin(), pos.end()) + 1 : 0;
  // face f's unit normal (zero for a face of zero area), as numpy's divide where length > 0
  auto unit = [&](int64_t f, double* out) {
    const double* x = &weighted[3 * f];
    const double length = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int j = 0; j < 3; ++j) out[j] = length > 0 ? x[j] / length : 0.0;
  };
  std::vector<int64_t> parent(n);
  std::iota(parent.begin(), parent.end(), int64_t(0));
  edge_pairs(start, end, n, ends, [](int64_t) { return true; }, [&](int64_t h, int64_t k) {
    double a[3], b[3];
    unit(h / 3, a);
    unit(k / 3, b);
    // numpy's einsum("ij,ij->i") of three terms adds the first and the last first
    if (!((a[0] * b[0] + a[2] * b[2]) + a[1] * b[1] >= cos_angle)) return;  // a hard edge
    // the half-edges may run either way: match the corners by position
    const bool forward = start(k) == start(h);
    join(parent.data(), h, forward ? k : next(k));
    join(parent.data(), next(h), forward ? next(k) : k);
  });
  std::vector<int64_t> fan(n);
  number(parent.data(), n, fan.data());
  return fan;
}

using Ints = nb::ndarray<nb::numpy, int64_t>;
using Doubles = nb::ndarray<nb::numpy, double>;

// e1 x e2 of each face: its normal times twice its area
std::vector<double> weighted_normals(const double* v, const int64_t* faces, int64_t m) {
  std::vector<double> weighted(3 * m);
  for (int64_t f = 0; f < m; ++f) {
    const double *a = v + 3 * faces[3 * f], *b = v + 3 * faces[3 * f + 1], *c = v + 3 * faces[3 * f + 2];
    const double u0 = b[0] - a[0], u1 = b[1] - a[1], u2 = b[2] - a[2], w0 = c[0] - a[0], w1 = c[1] - a[1], w2 = c[2] - a[2];
    double* x = &weighted[3 * f];
    x[0] = u1 * w2 - u2 * w1;
    x[1] = u2 * w0 - u0 * w2;
    x[2] = u0 * w1 - u1 * w0;
  }
  return weighted;
}

// each fan's unit normal: the sum of its corners' faces' weighted normals (in corner order, as
// np.bincount adds), +z for a fan of zero-area faces only
std::vector<double> fan_normals(const std::vector<int64_t>& fan, const std::vector<double>& weighted) {
  const int64_t n = int64_t(fan.size()), n_fans = n ? *std::max_element(fan.begin(), fan.end()) + 1 : 0;
  std::vector<double> normal(3 * n_fans, 0.0);
  for (int64_t c = 0; c < n; ++c) {
    for (int j = 0; j < 3; ++j) normal[3 * fan[c] + j] += weighted[3 * (c / 3) + j];
  }
  for (int64_t g = 0; g < n_fans; ++g) {
    double* x = &normal[3 * g];
    const double length = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    if (length > 0) {
      for (int j = 0; j < 3; ++j) x[j] /= length;
    } else {
      x[0] = x[1] = 0.0;
      x[2] = 1.0;
    }
  }
  return normal;
}

// one new vertex per (vertex, fan), numbered in that order (np.unique's): the corners bucketed
// by vertex, and each vertex's fans sorted; source, normals of the new vertices, out_faces (3m,)
void split_vertices(const int64_t* faces, int64_t k, const std::vector<int64_t>& fan, const std::vector<double>& fan_normal,
                    std::vector<int64_t>& source, std::vector<double>& normals, std::vector<int64_t>& out_faces) {
  const int64_t n = int64_t(fan.size());
  std::vector<int64_t> offset(k + 1, 0), corners(n);
  for (int64_t c = 0; c < n; ++c) ++offset[faces[c] + 1];
  std::partial_sum(offset.begin(), offset.end(), offset.begin());
  std::vector<int64_t> fill(offset.begin(), offset.end() - 1);
  for (int64_t c = 0; c < n; ++c) corners[fill[faces[c]]++] = c;
  std::vector<int64_t> seen;
  source.reserve(k);  // one new vertex a vertex, more at hard edges
  normals.reserve(3 * k);
  for (int64_t i = 0; i < k; ++i) {
    seen.clear();
    for (int64_t j = offset[i]; j < offset[i + 1]; ++j) seen.push_back(fan[corners[j]]);
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    const int64_t base = int64_t(source.size());
    for (int64_t g : seen) {
      source.push_back(i);
      normals.insert(normals.end(), &fan_normal[3 * g], &fan_normal[3 * g] + 3);
    }
    for (int64_t j = offset[i]; j < offset[i + 1]; ++j) {
      const int64_t c = corners[j];
      out_faces[c] = base + (std::lower_bound(seen.begin(), seen.end(), fan[c]) - seen.begin());
    }
  }
}

std::tuple<Ints, Ints, Doubles> split_normals(In<double, shape<-1, 3>> vertices, In<int64_t, shape<-1, 3>> faces_in,
                                              double cos_angle) {
  const int64_t k = vertices.shape(0), m = faces_in.shape(0), n = 3 * m;
  const int64_t* faces = faces_in.data();
  for (int64_t c = 0; c < n; ++c) {
    if (faces[c] < 0 || faces[c] >= k)
      throw nb::index_error(("split_normals: face index " + std::to_string(faces[c]) + " outside [0, " + std::to_string(k) + ")").c_str());
  }
  if (n >= INT32_MAX) throw std::invalid_argument("split_normals: at most 715 million faces");
  std::vector<int64_t> source, out_faces(n);
  std::vector<double> normals;
  {
    nb::gil_scoped_release unlocked;
    const std::vector<double> weighted = weighted_normals(vertices.data(), faces, m);
    const std::vector<int64_t> fan = m ? fans(faces, m, position_ids(vertices.data(), k), weighted, cos_angle) : std::vector<int64_t>();
    split_vertices(faces, k, fan, fan_normals(fan, weighted), source, normals, out_faces);
  }
  const size_t k2 = source.size();
  return {owned(std::move(source), {k2}), owned(std::move(out_faces), {size_t(m), 3}), owned(std::move(normals), {k2, 3})};
}

// out (g, 3): the unit normal of each vertex group (group (k,) of the vertices, ids 0..g-1):
// the sum, over the corners at its vertices, of their face's unit normal times the face's
// angle there, atan2(|e1 x e2|, e1 . e2); summed corner 0 of every face, then 1, then 2 (as
// np.bincount adds the numpy formula's); 0 for a group of zero-area faces only
void angle_normals(In<double, shape<-1, 3>> vertices, In<int64_t, shape<-1, 3>> faces_in, In<int64_t, nb::ndim<1>> group,
                   Out<double, shape<-1, 3>> out) {
  const int64_t k = vertices.shape(0), m = faces_in.shape(0), g = out.shape(0);
  const int64_t *faces = faces_in.data(), *id = group.data();
  if (int64_t(group.shape(0)) != k) throw std::invalid_argument("angle_normals: group must have a row a vertex");
  for (int64_t c = 0; c < 3 * m; ++c) {
    if (faces[c] < 0 || faces[c] >= k) throw nb::index_error("angle_normals: a face index outside the vertices");
  }
  for (int64_t i = 0; i < k; ++i) {
    if (id[i] < 0 || id[i] >= g) throw nb::index_error("angle_normals: a group id outside out's rows");
  }
  nb::gil_scoped_release unlocked;
  const double* v = vertices.data();
  double* n = out.data();
  std::fill(n, n + 3 * g, 0.0);
  const std::vector<double> weighted = weighted_normals(v, faces, m);
  for (int corner = 0; corner < 3; ++corner) {
    for (int64_t f = 0; f < m; ++f) {
      const int64_t* t = faces + 3 * f;
      const double *p = v + 3 * t[corner], *a = v + 3 * t[(corner + 1) % 3], *b = v + 3 * t[(corner + 2) % 3];
      const double* w = &weighted[3 * f];
      const double twice_area = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      if (!(twice_area > 0)) continue;
      const double dot = (a[0] - p[0]) * (b[0] - p[0]) + (a[1] - p[1]) * (b[1] - p[1]) + (a[2] - p[2]) * (b[2] - p[2]);
      const double scale = std::atan2(twice_area, dot) / twice_area;
      double* x = n + 3 * id[t[corner]];
      for (int j = 0; j < 3; ++j) x[j] += w[j] * scale;
    }
  }
  for (int64_t i = 0; i < g; ++i) {
    double* x = n + 3 * i;
    const double length = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int j = 0; j < 3; ++j) x[j] = length > 0 ? x[j] / length : 0.0;
  }
}

}  // namespace

void bind_normals(nb::module_& m) {
  m.def("angle_normals", &angle_normals, nb::arg("vertices"), nb::arg("faces"), nb::arg("group"), nb::arg("out").noconvert(),
        "out (g, 3): each vertex group's unit normal, its corners' face normals weighted by their angles (0 where none).");
  m.def("split_normals", &split_normals, nb::arg("vertices"), nb::arg("faces"), nb::arg("cos_angle"),
        "(source (k2,) int64, faces (m, 3) int64, normals (k2, 3) float64): vertices split into one per (vertex, fan "
        "of corners joined across edges whose faces' normals meet at cosines >= cos_angle), with their fans' normals.");
}

}  // namespace texbake
