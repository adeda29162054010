// Tangent frames at texel samples (texbake/mesh/tangents.py's sample_frames, which is the
// reference): the output mesh's corner normals and tangents of each sample's face,
// interpolated as a glTF viewer does, in one pass with no per-sample copies of the corners.
#include <cmath>
#include <stdexcept>

#include "arrays.hpp"

namespace texbake {
namespace {

inline double unit3(double* v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (n > 0.0) v[0] /= n, v[1] /= n, v[2] /= n;
  return n;
}

inline void cross3(const double* a, const double* b, double* out) {
  out[0] = a[1] * b[2] - a[2] * b[1], out[1] = a[2] * b[0] - a[0] * b[2], out[2] = a[0] * b[1] - a[1] * b[0];
}

// out (n, 3, 3), rows T, B, N: N the unit interpolated normal, T the interpolated tangent made
// orthogonal to it (any unit vector orthogonal to N where it vanishes), B = w N x T, w the
// sign of the interpolated w
void sample_frames(In<int64_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, In<double, shape<-1, 3, 3>> corner_normals,
                   In<double, shape<-1, 3, 4>> corner_tangents, Out<double, shape<-1, 3, 3>> out) {
  const int64_t n = face.shape(0), m = corner_normals.shape(0);
  if (int64_t(bary.shape(0)) != n || int64_t(out.shape(0)) != n || int64_t(corner_tangents.shape(0)) != m)
    throw std::invalid_argument("sample_frames: bary and out of the faces' rows, tangents of the normals'");
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    if (f < 0 || f >= m) throw std::invalid_argument("sample_frames: a face outside the mesh");
  }
  const double *b = bary.data(), *cn = corner_normals.data(), *ct = corner_tangents.data();
  double* o = out.data();
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    double nn[3] = {0.0, 0.0, 0.0}, t[4] = {0.0, 0.0, 0.0, 0.0};
    for (int c = 0; c < 3; ++c) {
      const double w = b[3 * i + c];
      for (int k = 0; k < 3; ++k) nn[k] += w * cn[9 * f + 3 * c + k];
      for (int k = 0; k < 4; ++k) t[k] += w * ct[12 * f + 4 * c + k];
    }
    const double normal_length = unit3(nn);
    const double handed = t[3] < 0.0 ? -1.0 : 1.0;
    const double along = t[0] * nn[0] + t[1] * nn[1] + t[2] * nn[2];
    for (int k = 0; k < 3; ++k) t[k] -= along * nn[k];
    const double tangent_length = unit3(t);
    if (!(tangent_length > 0.0 && std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]) > 0.5) && normal_length > 0.0 &&
        std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]) > 0.5) {
      const double axis[3] = {std::fabs(nn[0]) < 0.9 ? 1.0 : 0.0, std::fabs(nn[0]) < 0.9 ? 0.0 : 1.0, 0.0};
      cross3(nn, axis, t);
      unit3(t);
    }
    double bt[3];
    cross3(nn, t, bt);
    double* row = o + 9 * i;
    for (int k = 0; k < 3; ++k) row[k] = t[k], row[3 + k] = handed * bt[k], row[6 + k] = nn[k];
  }
}

}  // namespace

void bind_frames(nb::module_& m) {
  m.def("sample_frames", &sample_frames, nb::arg("face"), nb::arg("bary"), nb::arg("corner_normals"), nb::arg("corner_tangents"),
        nb::arg("out").noconvert(), Release(),
        "out (n, 3, 3): the tangent frames (rows T, B, N) at barycentric points bary of faces face, from their corners' normals "
        "(m, 3, 3) and tangents (m, 3, 4) (texbake.mesh.tangents.sample_frames).");
}

}  // namespace texbake
