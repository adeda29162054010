// Tangent frames at texel samples (texbake/mesh/tangents.py's sample_frames, which is the
// reference): the output mesh's corner normals and tangents of each sample's face,
// interpolated as a glTF viewer does, in one pass with no per-sample copies of the corners.
#include <algorithm>
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

// out (n, 3): the unit interpolation of vertex_normals (k, 3) at barycentric points bary of
// faces face (rows of faces (m, 3)); 0 where it vanishes (texbake.meshmaps.bake's numpy:
// divided by max(length, 1e-300))
void interpolated_normals(In<int64_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, In<int64_t, shape<-1, 3>> faces,
                          In<double, shape<-1, 3>> vertex_normals, Out<double, shape<-1, 3>> out) {
  const int64_t n = face.shape(0), m = faces.shape(0), k = vertex_normals.shape(0);
  if (int64_t(bary.shape(0)) != n || int64_t(out.shape(0)) != n)
    throw std::invalid_argument("interpolated_normals: bary and out need a row a face");
  const int64_t *f = face.data(), *fv = faces.data();
  for (int64_t i = 0; i < n; ++i) {
    if (f[i] < 0 || f[i] >= m) throw std::invalid_argument("interpolated_normals: a face outside the mesh");
  }
  for (int64_t i = 0; i < 3 * m; ++i) {
    if (fv[i] < 0 || fv[i] >= k) throw std::invalid_argument("interpolated_normals: a face's vertex outside the normals");
  }
  const double *b = bary.data(), *vn = vertex_normals.data();
  double* o = out.data();
  for (int64_t i = 0; i < n; ++i) {
    double s[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < 3; ++c) {
      const double w = b[3 * i + c];
      const double* v = vn + 3 * fv[3 * f[i] + c];
      for (int a = 0; a < 3; ++a) s[a] += w * v[a];
    }
    const double length = std::max(std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]), 1e-300);
    for (int a = 0; a < 3; ++a) o[3 * i + a] = s[a] / length;
  }
}

// out (n, 3): where hit, 0.5 + 0.5 c of the unit coefficients c of normals (n, 3) in the
// frames (n, 3, 3) (rows T, B, N; c = frame . normal, made unit; (0, 0, 1) where it
// vanishes), its y flipped for directx; elsewhere (0.5, 0.5, 1): texbake.meshmaps.highpoly's
// tangent_space, compiled
void tangent_codes(In<double, shape<-1, 3>> normals, In<double, shape<-1, 3, 3>> frame, In<uint8_t, nb::ndim<1>> hit, bool directx,
                   Out<double, shape<-1, 3>> out) {
  const int64_t n = normals.shape(0);
  if (int64_t(frame.shape(0)) != n || int64_t(hit.shape(0)) != n || int64_t(out.shape(0)) != n)
    throw std::invalid_argument("tangent_codes: normals, frame, hit and out need the same rows");
  const double *nn = normals.data(), *fr = frame.data();
  const uint8_t* h = hit.data();
  double* o = out.data();
  for (int64_t i = 0; i < n; ++i) {
    double c[3] = {0.0, 0.0, 1.0};
    if (h[i]) {
      for (int r = 0; r < 3; ++r) {
        const double* row = fr + 9 * i + 3 * r;
        c[r] = row[0] * nn[3 * i] + row[1] * nn[3 * i + 1] + row[2] * nn[3 * i + 2];
      }
      const double length = std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
      if (length > 0.0) {
        for (double& v : c) v /= length;
      } else {
        c[0] = 0.0, c[1] = 0.0, c[2] = 1.0;
      }
    }
    o[3 * i] = 0.5 + 0.5 * c[0];
    o[3 * i + 1] = 0.5 + 0.5 * c[1];
    o[3 * i + 2] = 0.5 + 0.5 * c[2];
    if (directx && h[i]) o[3 * i + 1] = 1.0 - o[3 * i + 1];
  }
}

}  // namespace

void bind_frames(nb::module_& m) {
  m.def("interpolated_normals", &interpolated_normals, nb::arg("face"), nb::arg("bary"), nb::arg("faces"), nb::arg("vertex_normals"),
        nb::arg("out").noconvert(), Release(),
        "out (n, 3): the unit interpolated vertex normals (k, 3) at barycentric points bary of faces face (rows of faces (m, 3)); 0 where none.");
  m.def("tangent_codes", &tangent_codes, nb::arg("normals"), nb::arg("frame"), nb::arg("hit"), nb::arg("directx"), nb::arg("out").noconvert(),
        Release(),
        "out (n, 3): 0.5 + 0.5 c, c the unit coefficients of normals (n, 3) in the frames (n, 3, 3) where hit, else (0.5, 0.5, 1) "
        "(texbake.meshmaps.highpoly.tangent_space).");
  m.def("sample_frames", &sample_frames, nb::arg("face"), nb::arg("bary"), nb::arg("corner_normals"), nb::arg("corner_tangents"),
        nb::arg("out").noconvert(), Release(),
        "out (n, 3, 3): the tangent frames (rows T, B, N) at barycentric points bary of faces face, from their corners' normals "
        "(m, 3, 3) and tangents (m, 3, 4) (texbake.mesh.tangents.sample_frames).");
}

}  // namespace texbake
