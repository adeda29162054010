// Texel lookup (texbake/sampling/lookup.py): sample positions, the texels a UV triangle
// touches, and float64 barycentrics, found by a walk across UV edges. The tile threads give
// these their parallelism: each call is one tile's, on the calling thread.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "arrays.hpp"

namespace texbake {
namespace {

struct Bary {
  double b0, b1, b2;
  bool inside() const { return b0 >= 0.0 && b1 >= 0.0 && b2 >= 0.0; }
  // clamped into the triangle and renormalised
  void clamp_into(double* out) const {
    const double c0 = std::min(std::max(b0, 0.0), 1.0), c1 = std::min(std::max(b1, 0.0), 1.0),
                 c2 = std::min(std::max(b2, 0.0), 1.0);
    const double total = c0 + c1 + c2;
    out[0] = c0 / total;
    out[1] = c1 / total;
    out[2] = c2 / total;
  }
};

// point i of uv in face f (uv_inverse's origin (m, 2) and inv (m, 2, 2)), unclamped
inline Bary coordinates(const double* uv, int64_t i, int64_t f, const double* origin, const double* inv) {
  const double dx = uv[2 * i] - origin[2 * f], dy = uv[2 * i + 1] - origin[2 * f + 1];
  const double b1 = inv[4 * f] * dx + inv[4 * f + 1] * dy;
  const double b2 = inv[4 * f + 2] * dx + inv[4 * f + 3] * dy;
  return {1.0 - b1 - b2, b1, b2};
}

void sample_uv(In<int64_t, nb::ndim<1>> texels, int64_t start, int64_t width, int64_t height, In<double, shape<-1, 2>> offsets,
               Out<double, shape<-1, 2>> out) {
  const int64_t t_n = texels.shape(0), s = offsets.shape(0);
  if (int64_t(out.shape(0)) != t_n * s) throw std::invalid_argument("sample_uv: out must be (texels * samples, 2)");
  const double* off = offsets.data();
  double* o = out.data();
  for (int64_t t = 0; t < t_n; ++t) {
    const double row = double(texels.data()[t] / width + start), col = double(texels.data()[t] % width);
    for (int64_t k = 0; k < s; ++k) {
      o[2 * (t * s + k)] = (col + off[2 * k]) / double(width);
      o[2 * (t * s + k) + 1] = 1.0 - (row + off[2 * k + 1]) / double(height);
    }
  }
}

void hits(In<int32_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, Out<int64_t, nb::ndim<1>> index,
          Out<int32_t, nb::ndim<1>> found, Out<double, shape<-1, 3>> coords) {
  const int64_t n = face.shape(0), k = index.shape(0);
  if (int64_t(bary.shape(0)) != n || int64_t(found.shape(0)) != k || int64_t(coords.shape(0)) != k)
    throw std::invalid_argument("hits: bary must be (n, 3), found (k,) and coords (k, 3)");
  int64_t j = 0;
  for (int64_t i = 0; i < n && j < k; ++i) {
    if (face.data()[i] < 0) continue;
    index.data()[j] = i;
    found.data()[j] = face.data()[i];
    std::copy_n(bary.data() + 3 * i, 3, coords.data() + 3 * j);
    ++j;
  }
}

void touched(In<double, shape<-1, 3, 2>> tri, In<int64_t, nb::ndim<1>> near, int64_t width, int64_t height, int64_t start,
             int64_t rows, double margin, Out<bool, nb::ndim<1>> out) {
  if (int64_t(out.shape(0)) != rows * width) throw std::invalid_argument("touched: out must be (rows * width,)");
  const int64_t k = tri.shape(0);
  bool* hit = out.data();
  for (size_t n = 0; n < near.shape(0); ++n) {
    const int64_t f = near.data()[n];
    if (f < 0 || f >= k) throw std::invalid_argument("touched: a face outside tri");
    double xs[3], ys[3];
    for (int c = 0; c < 3; ++c) {
      xs[c] = tri.data()[6 * f + 2 * c] * width;
      ys[c] = (1.0 - tri.data()[6 * f + 2 * c + 1]) * height - start;
    }
    const double area = (xs[1] - xs[0]) * (ys[2] - ys[0]) - (ys[1] - ys[0]) * (xs[2] - xs[0]);
    const double sign = area > 0 ? 1.0 : -1.0;
    // the box in texels, clamped to the tile as floats (a UV far outside [0, 1] is no integer)
    const int64_t c0 = int64_t(std::floor(std::min(std::max(std::min({xs[0], xs[1], xs[2]}) - margin, 0.0), width - 1.0)));
    const int64_t c1 = int64_t(std::floor(std::min(std::max(std::max({xs[0], xs[1], xs[2]}) + margin, -1.0), width - 1.0)));
    const int64_t r0 = int64_t(std::floor(std::min(std::max(std::min({ys[0], ys[1], ys[2]}) - margin, 0.0), rows - 1.0)));
    const int64_t r1 = int64_t(std::floor(std::min(std::max(std::max({ys[0], ys[1], ys[2]}) + margin, -1.0), rows - 1.0)));
    for (int64_t r = r0; r <= r1; ++r) {
      for (int64_t c = c0; c <= c1; ++c) {
        const double x = c + 0.5, y = r + 0.5;
        bool inside = true;
        for (int e = 0; e < 3; ++e) {  // separating axes: the square wholly beyond an edge
          const double ax = xs[e], ay = ys[e];
          const double ex = xs[(e + 1) % 3] - ax, ey = ys[(e + 1) % 3] - ay;
          const double reach = 0.5 * (std::abs(ex) + std::abs(ey));  // the square's half-extent along the edge's normal
          if (sign * (ex * (y - ay) - ey * (x - ax)) + reach < -margin * 2.0 * reach) {
            inside = false;
            break;
          }
        }
        if (inside) hit[r * width + c] = true;
      }
    }
  }
}

struct Faces {  // uv_inverse's arrays of the atlas's m faces
  const double *origin, *inv;
  int64_t m;
};

void walk(In<double, shape<-1, 2>> uv, Out<int32_t, nb::ndim<1>> face, In<double, shape<-1, 2>> origin,
          In<double, shape<-1, 2, 2>> inv, In<int64_t, shape<-1, 3>> across, int64_t steps, Out<double, shape<-1, 3>> bary,
          Out<bool, nb::ndim<1>> inside) {
  const int64_t n = face.shape(0);
  const Faces faces{origin.data(), inv.data(), int64_t(origin.shape(0))};
  if (int64_t(uv.shape(0)) != n || int64_t(bary.shape(0)) != n || int64_t(inside.shape(0)) != n ||
      int64_t(inv.shape(0)) != faces.m || int64_t(across.shape(0)) != faces.m)
    throw std::invalid_argument("walk: uv, face, bary, inside of n rows; origin, inv, across of m");
  for (int64_t i = 0; i < n; ++i) {
    int64_t f = face.data()[i];
    if (f < 0) continue;
    for (int64_t step = 0; step <= steps; ++step) {
      if (f >= faces.m) throw std::invalid_argument("walk: a face outside the atlas");
      const Bary b = coordinates(uv.data(), i, f, faces.origin, faces.inv);
      if (b.inside()) {
        face.data()[i] = int32_t(f);
        inside.data()[i] = true;
        b.clamp_into(bary.data() + 3 * i);
        break;
      }
      if (step == 0) b.clamp_into(bary.data() + 3 * i);  // the texel's face, clamped: kept if no face is found
      const int c = b.b0 <= b.b1 && b.b0 <= b.b2 ? 0 : (b.b1 <= b.b2 ? 1 : 2);
      f = across.data()[3 * f + c];
      if (f < 0) break;
    }
  }
}

void barycentric(In<double, shape<-1, 2>> uv, In<int32_t, nb::ndim<1>> face, In<double, shape<-1, 2>> origin,
                 In<double, shape<-1, 2, 2>> inv, Out<double, shape<-1, 3>> bary, Out<bool, nb::ndim<1>> inside) {
  const int64_t n = face.shape(0), m = origin.shape(0);
  if (int64_t(uv.shape(0)) != n || int64_t(bary.shape(0)) != n || int64_t(inside.shape(0)) != n || int64_t(inv.shape(0)) != m)
    throw std::invalid_argument("barycentric: uv, face, bary, inside of n rows; origin, inv of m");
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    if (f < 0) continue;
    if (f >= m) throw std::invalid_argument("barycentric: a face outside the atlas");
    const Bary b = coordinates(uv.data(), i, f, origin.data(), inv.data());
    inside.data()[i] = b.inside();
    b.clamp_into(bary.data() + 3 * i);
  }
}

}  // namespace

void bind_lookup(nb::module_& m) {
  m.def("sample_uv", &sample_uv, nb::arg("texels"), nb::arg("start"), nb::arg("width"), nb::arg("height"), nb::arg("offsets"),
        nb::arg("out").noconvert(), Release(),
        "out[t * s + k] = ((col + dx_k) / width, 1 - (row + dy_k) / height) of texel t at (row, col), its tile from row start.");
  m.def("hits", &hits, nb::arg("face"), nb::arg("bary"), nb::arg("index").noconvert(), nb::arg("found").noconvert(),
        nb::arg("coords").noconvert(), Release(), "The rows of face >= 0, in order: their index, face and bary.");
  m.def("touched", &touched, nb::arg("tri"), nb::arg("near"), nb::arg("width"), nb::arg("height"), nb::arg("start"),
        nb::arg("rows"), nb::arg("margin"), nb::arg("out").noconvert(), Release(),
        "Set out (rows * width,) where a texel's square comes within margin texels of a triangle tri[near].");
  m.def("walk", &walk, nb::arg("uv"), nb::arg("face").noconvert(), nb::arg("origin"), nb::arg("inv"), nb::arg("across"),
        nb::arg("steps"), nb::arg("bary").noconvert(), nb::arg("inside").noconvert(), Release(),
        "Each point's barycentrics in its face, walking across UV edges (at most steps faces) to the face holding it.");
  m.def("barycentric", &barycentric, nb::arg("uv"), nb::arg("face"), nb::arg("origin"), nb::arg("inv"),
        nb::arg("bary").noconvert(), nb::arg("inside").noconvert(), Release(),
        "Each point's barycentrics in its face (clamped, renormalised) and whether it lies inside; face -1 rows left.");
}

}  // namespace texbake
