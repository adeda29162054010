// Surface samples (texbake/sampling/surface.py): points, footprints and normals of texel
// samples, one pass over them. One tile a call: the tile threads give the parallelism.
#include <cmath>
#include <stdexcept>

#include "arrays.hpp"

namespace texbake {
namespace {

using Rows3 = Out<double, shape<-1, 3>>;

void interpolate(In<int64_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, In<double, shape<-1, 3>> p0,
                 In<double, shape<-1, 3>> e1, In<double, shape<-1, 3>> e2, In<double, shape<-1, 3>> face_dpdx,
                 In<double, shape<-1, 3>> face_dpdy, In<double, shape<-1, 3, 3>> corner_normals, Rows3 points, Rows3 dpdx,
                 Rows3 dpdy, Rows3 normals) {
  const int64_t n = face.shape(0), m = p0.shape(0);
  const bool with_normals = corner_normals.shape(0) > 0, with_footprints = dpdx.shape(0) > 0;
  if (int64_t(bary.shape(0)) != n || int64_t(points.shape(0)) != n || int64_t(e1.shape(0)) != m || int64_t(e2.shape(0)) != m ||
      (with_footprints && (int64_t(dpdx.shape(0)) != n || int64_t(dpdy.shape(0)) != n || int64_t(face_dpdx.shape(0)) != m ||
                           int64_t(face_dpdy.shape(0)) != m)) ||
      (with_normals && (int64_t(normals.shape(0)) != n || int64_t(corner_normals.shape(0)) != m)))
    throw std::invalid_argument("interpolate: samples of n rows, faces of m");
  for (int64_t i = 0; i < n; ++i) {
    if (face.data()[i] < 0 || face.data()[i] >= m) throw std::invalid_argument("interpolate: a face outside the mesh");
  }
  const double *b = bary.data(), *o = p0.data(), *u = e1.data(), *v = e2.data();
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    const double b0 = b[3 * i], b1 = b[3 * i + 1], b2 = b[3 * i + 2];
    for (int k = 0; k < 3; ++k) points.data()[3 * i + k] = o[3 * f + k] + b1 * u[3 * f + k] + b2 * v[3 * f + k];
    if (with_footprints) {
      for (int k = 0; k < 3; ++k) {
        dpdx.data()[3 * i + k] = face_dpdx.data()[3 * f + k];
        dpdy.data()[3 * i + k] = face_dpdy.data()[3 * f + k];
      }
    }
    if (with_normals) {
      const double* cn = corner_normals.data() + 9 * f;
      const double x = b0 * cn[0] + b1 * cn[3] + b2 * cn[6];
      const double y = b0 * cn[1] + b1 * cn[4] + b2 * cn[7];
      const double z = b0 * cn[2] + b1 * cn[5] + b2 * cn[8];
      const double length = std::sqrt(x * x + y * y + z * z);
      double* out = normals.data() + 3 * i;
      if (length > 0) {
        out[0] = x / length;
        out[1] = y / length;
        out[2] = z / length;
      } else {
        out[0] = out[1] = out[2] = 0.0;
      }
    }
  }
}

}  // namespace

void bind_surface(nb::module_& m) {
  m.def("interpolate", &interpolate, nb::arg("face"), nb::arg("bary"), nb::arg("p0"), nb::arg("e1"), nb::arg("e2"),
        nb::arg("face_dpdx"), nb::arg("face_dpdy"), nb::arg("corner_normals"), nb::arg("points").noconvert(),
        nb::arg("dpdx").noconvert(), nb::arg("dpdy").noconvert(), nb::arg("normals").noconvert(), Release(),
        "Fill points (n, 3), dpdx, dpdy (n, 3, or no rows: none) and, where corner_normals (m, 3, 3) has rows, "
        "unit normals (n, 3; zero where they cancel) of the samples at face (n,), bary (n, 3).");
}

}  // namespace texbake
