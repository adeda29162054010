// Per-face triangle geometry (texbake/mesh/uvgeometry.py): edges, areas, UV determinants,
// the UV inverse and Jacobian. Each face's arithmetic is numpy's, operation for operation
// (no contraction into FMA: the same bits), so the arrays equal what the numpy expressions
// gave; here in one pass without (m, 3, d) temporaries, on the cores.
#include <cmath>
#include <stdexcept>
#include <string>

#include "arrays.hpp"
#include "parallel.hpp"

namespace texbake {
namespace {

using Faces = In<int64_t, shape<-1, 3>>;
using Points = In<double, nb::ndim<2>>;

// faces index [0, n): checked up front, as numpy's indexing would
void check_faces(const Faces& faces, int64_t n, const char* what) {
  const int64_t* f = faces.data();
  const int64_t count = 3 * int64_t(faces.shape(0));
  for (int64_t i = 0; i < count; ++i) {
    if (f[i] < 0 || f[i] >= n)
      throw nb::index_error((std::string(what) + ": face index " + std::to_string(f[i]) + " outside [0, " + std::to_string(n) + ")").c_str());
  }
}

void face_edges(Points points, Faces faces, Out<double, nb::ndim<2>> p0, Out<double, nb::ndim<2>> e1,
                Out<double, nb::ndim<2>> e2) {
  const int64_t m = faces.shape(0), d = points.shape(1);
  for (auto* a : {&p0, &e1, &e2}) {
    if (int64_t(a->shape(0)) != m || int64_t(a->shape(1)) != d) throw std::invalid_argument("face_edges: outputs of (m, d)");
  }
  check_faces(faces, points.shape(0), "face_edges");
  const double* p = points.data();
  const int64_t* f = faces.data();
  parallel_for(m, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const double *a = p + d * f[3 * i], *b = p + d * f[3 * i + 1], *c = p + d * f[3 * i + 2];
      for (int64_t k = 0; k < d; ++k) {
        p0.data()[d * i + k] = a[k];
        e1.data()[d * i + k] = b[k] - a[k];
        e2.data()[d * i + k] = c[k] - a[k];
      }
    }
  });
}

// 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
void face_areas(In<double, shape<-1, 3>> vertices, Faces faces, Out<double, nb::ndim<1>> out) {
  const int64_t m = faces.shape(0);
  if (int64_t(out.shape(0)) != m) throw std::invalid_argument("face_areas: out of (m,)");
  check_faces(faces, vertices.shape(0), "face_areas");
  const double* p = vertices.data();
  const int64_t* f = faces.data();
  parallel_for(m, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const double *a = p + 3 * f[3 * i], *b = p + 3 * f[3 * i + 1], *c = p + 3 * f[3 * i + 2];
      const double u0 = b[0] - a[0], u1 = b[1] - a[1], u2 = b[2] - a[2];
      const double v0 = c[0] - a[0], v1 = c[1] - a[1], v2 = c[2] - a[2];
      const double x = u1 * v2 - u2 * v1, y = u2 * v0 - u0 * v2, z = u0 * v1 - u1 * v0;
      out.data()[i] = 0.5 * std::sqrt(x * x + y * y + z * z);
    }
  });
}

// The UV edges d1, d2 of face i and det = d1 x d2
struct UVFace {
  double d1u, d1v, d2u, d2v, det;
};

inline UVFace uv_face(const double* uv, const int64_t* f, int64_t i) {
  const double *a = uv + 2 * f[3 * i], *b = uv + 2 * f[3 * i + 1], *c = uv + 2 * f[3 * i + 2];
  UVFace t{b[0] - a[0], b[1] - a[1], c[0] - a[0], c[1] - a[1], 0.0};
  t.det = t.d1u * t.d2v - t.d1v * t.d2u;
  return t;
}

// uvgeometry.inverse_det: 1 / det where |det| > 0, else 0
inline double inverse_det(double det) { return std::fabs(det) > 0 ? 1.0 / det : 0.0; }

void uv_dets(In<double, shape<-1, 2>> uv, Faces faces, Out<double, nb::ndim<1>> det) {
  const int64_t m = faces.shape(0);
  if (int64_t(det.shape(0)) != m) throw std::invalid_argument("uv_dets: det of (m,)");
  check_faces(faces, uv.shape(0), "uv_dets");
  parallel_for(m, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) det.data()[i] = uv_face(uv.data(), faces.data(), i).det;
  });
}

void uv_inverse(In<double, shape<-1, 2>> uv, Faces faces, Out<double, shape<-1, 2>> t0, Out<double, shape<-1, 2, 2>> inv,
                Out<bool, nb::ndim<1>> ok) {
  const int64_t m = faces.shape(0);
  if (int64_t(t0.shape(0)) != m || int64_t(inv.shape(0)) != m || int64_t(ok.shape(0)) != m)
    throw std::invalid_argument("uv_inverse: outputs of m rows");
  check_faces(faces, uv.shape(0), "uv_inverse");
  parallel_for(m, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const UVFace t = uv_face(uv.data(), faces.data(), i);
      const double* a = uv.data() + 2 * faces.data()[3 * i];
      const double r = inverse_det(t.det);
      double* out = inv.data() + 4 * i;
      t0.data()[2 * i] = a[0];
      t0.data()[2 * i + 1] = a[1];
      out[0] = t.d2v * r;
      out[1] = -t.d2u * r;
      out[2] = -t.d1v * r;
      out[3] = t.d1u * r;
      ok.data()[i] = std::fabs(t.det) > 0;
    }
  });
}

void uv_jacobian(In<double, shape<-1, 3>> vertices, Faces faces, In<double, shape<-1, 2>> uv, Faces uv_faces,
                 Out<double, shape<-1, 3>> dpdu, Out<double, shape<-1, 3>> dpdv, Out<double, nb::ndim<1>> det) {
  const int64_t m = faces.shape(0);
  if (int64_t(uv_faces.shape(0)) != m || int64_t(dpdu.shape(0)) != m || int64_t(dpdv.shape(0)) != m ||
      int64_t(det.shape(0)) != m)
    throw std::invalid_argument("uv_jacobian: faces, uv_faces and outputs of m rows");
  check_faces(faces, vertices.shape(0), "uv_jacobian");
  check_faces(uv_faces, uv.shape(0), "uv_jacobian");
  const double* p = vertices.data();
  const int64_t* f = faces.data();
  parallel_for(m, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const UVFace t = uv_face(uv.data(), uv_faces.data(), i);
      const double r = inverse_det(t.det);
      const double *a = p + 3 * f[3 * i], *b = p + 3 * f[3 * i + 1], *c = p + 3 * f[3 * i + 2];
      for (int k = 0; k < 3; ++k) {
        const double e1 = b[k] - a[k], e2 = c[k] - a[k];
        dpdu.data()[3 * i + k] = (e1 * t.d2v - e2 * t.d1v) * r;
        dpdv.data()[3 * i + k] = (e2 * t.d1u - e1 * t.d2u) * r;
      }
      det.data()[i] = t.det;
    }
  });
}

// np.minimum / np.maximum: NaN wins
inline double nan_min(double a, double b) { return (b < a || std::isnan(b)) ? b : a; }
inline double nan_max(double a, double b) { return (b > a || std::isnan(b)) ? b : a; }

// lo, hi (k, 2) (in: their start) := the bounding box of the UV corners of each label's faces,
// as np.minimum.at / np.maximum.at of each face's corner minimum and maximum
void label_boxes(In<double, shape<-1, 2>> uv, Faces faces, In<int64_t, nb::ndim<1>> label, Out<double, shape<-1, 2>> lo,
                 Out<double, shape<-1, 2>> hi) {
  const int64_t m = faces.shape(0), k = lo.shape(0);
  if (int64_t(label.shape(0)) != m || int64_t(hi.shape(0)) != k) throw std::invalid_argument("label_boxes: label of m, lo and hi of k rows");
  check_faces(faces, uv.shape(0), "label_boxes");
  const double* t = uv.data();
  const int64_t* f = faces.data();
  for (int64_t i = 0; i < m; ++i) {
    const int64_t g = label.data()[i];
    if (g < 0 || g >= k) throw nb::index_error("label_boxes: a label outside [0, k)");
    for (int j = 0; j < 2; ++j) {
      const double a = t[2 * f[3 * i] + j], b = t[2 * f[3 * i + 1] + j], c = t[2 * f[3 * i + 2] + j];
      double* l = lo.data() + 2 * g + j;
      double* h = hi.data() + 2 * g + j;
      *l = nan_min(*l, nan_min(nan_min(a, b), c));
      *h = nan_max(*h, nan_max(nan_max(a, b), c));
    }
  }
}

// out (m, 3) := each face rotated to start at its smallest corner (the first of equals)
void rotated_faces(Faces faces, Out<int64_t, shape<-1, 3>> out) {
  const int64_t m = faces.shape(0);
  if (int64_t(out.shape(0)) != m) throw std::invalid_argument("rotated_faces: out of m rows");
  parallel_for(m, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const int64_t* f = faces.data() + 3 * i;
      const int s = f[1] < f[0] ? (f[2] < f[1] ? 2 : 1) : (f[2] < f[0] ? 2 : 0);
      for (int j = 0; j < 3; ++j) out.data()[3 * i + j] = f[(s + j) % 3];
    }
  });
}

}  // namespace

void bind_geometry(nb::module_& m) {
  m.def("label_boxes", &label_boxes, nb::arg("uv"), nb::arg("faces"), nb::arg("label"), nb::arg("lo").noconvert(),
        nb::arg("hi").noconvert(), Release(),
        "Grow lo, hi (k, 2) to the UV bounding box of each label's faces (label (m,) in [0, k)); NaN wins.");
  m.def("rotated_faces", &rotated_faces, nb::arg("faces"), nb::arg("out").noconvert(), Release(),
        "Fill out (m, 3) with each face rotated to start at its smallest corner (np.argmin's: the first of equals).");
  m.def("face_edges", &face_edges, nb::arg("points"), nb::arg("faces"), nb::arg("p0").noconvert(), nb::arg("e1").noconvert(),
        nb::arg("e2").noconvert(), Release(),
        "Fill p0, e1, e2 (m, d) with each face's first corner and its edges from it, of points (n, d) and faces (m, 3).");
  m.def("face_areas", &face_areas, nb::arg("vertices"), nb::arg("faces"), nb::arg("out").noconvert(), Release(),
        "Fill out (m,) with the area of each face of vertices (n, 3).");
  m.def("uv_dets", &uv_dets, nb::arg("uv"), nb::arg("faces"), nb::arg("det").noconvert(), Release(),
        "Fill det (m,) with d1 x d2 of each face's UV edges (twice its signed UV area).");
  m.def("uv_inverse", &uv_inverse, nb::arg("uv"), nb::arg("faces"), nb::arg("t0").noconvert(), nb::arg("inv").noconvert(),
        nb::arg("ok").noconvert(), Release(),
        "Fill t0 (m, 2), inv (m, 2, 2) (zero where UV-degenerate) and ok (m,): each face's UV origin and inverse edge matrix.");
  m.def("uv_jacobian", &uv_jacobian, nb::arg("vertices"), nb::arg("faces"), nb::arg("uv"), nb::arg("uv_faces"),
        nb::arg("dpdu").noconvert(), nb::arg("dpdv").noconvert(), nb::arg("det").noconvert(), Release(),
        "Fill dpdu, dpdv (m, 3) (zero where UV-degenerate) and det (m,): each face's UV-to-surface Jacobian.");
}

}  // namespace texbake
