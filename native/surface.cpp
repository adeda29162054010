// Surface samples (texbake/sampling/surface.py): points, footprints and normals of texel
// samples, one pass over them, read from the mesh, its atlas and its normals. One tile a call: the tile threads give the parallelism.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "arrays.hpp"
#include "parallel.hpp"
#include "steps.hpp"

namespace texbake {
namespace {

using Rows3 = Out<double, shape<-1, 3>>;
using Faces = In<int64_t, shape<-1, 3>>;

inline double clip(double x, double bound) { return std::isnan(x) ? x : std::min(std::max(x, -bound), bound); }  // np.clip

// face f's steps on the surface one texel right and one down (a sample's dpdx, dpdy before clipping), with the
// arithmetic of texbake/mesh/uvgeometry.py's UV Jacobian
inline void face_steps(const double* p, const int64_t* faces, const double* t, const int64_t* uv_faces, int64_t f, double width,
                       double height, double* out) {
  const int64_t *c = faces + 3 * f, *u = uv_faces + 3 * f;
  const double *o = p + 3 * c[0], *q1 = p + 3 * c[1], *q2 = p + 3 * c[2];
  const double *a = t + 2 * u[0], *a1 = t + 2 * u[1], *a2 = t + 2 * u[2];
  const double d1u = a1[0] - a[0], d1v = a1[1] - a[1], d2u = a2[0] - a[0], d2v = a2[1] - a[1];
  const double det = d1u * d2v - d1v * d2u;
  const double r = std::fabs(det) > 0 ? 1.0 / det : 0.0;
  for (int k = 0; k < 3; ++k) {
    const double e1 = q1[k] - o[k], e2 = q2[k] - o[k];
    const double dpdu = (e1 * d2v - e2 * d1v) * r, dpdv = (e2 * d1u - e1 * d2u) * r;
    // one texel right is du = 1 / width, one texel down dv = -1 / height
    out[k] = dpdu / width;
    out[3 + k] = -dpdv / height;
  }
}

// Each sample's face read from the mesh as it is (no per-face arrays: millions of faces would
// hold hundreds of MB of them), with the arithmetic of texbake/mesh/uvgeometry.py's edges and
// UV Jacobian and of SurfaceMap's footprints, operation for operation: the same bits.
void interpolate(In<int64_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, In<double, shape<-1, 3>> vertices, Faces faces,
                 In<double, shape<-1, 2>> uv, Faces uv_faces, double width, double height, double max_footprint,
                 In<double, shape<-1, 3>> normal_table, Faces normal_faces, Rows3 points, Rows3 dpdx, Rows3 dpdy, Rows3 normals) {
  const int64_t n = face.shape(0), m = faces.shape(0), nv = vertices.shape(0), nt = uv.shape(0), nn = normal_table.shape(0);
  const bool with_normals = normal_faces.shape(0) > 0, with_footprints = dpdx.shape(0) > 0;
  if (int64_t(bary.shape(0)) != n || int64_t(points.shape(0)) != n || int64_t(uv_faces.shape(0)) != m ||
      (with_footprints && (int64_t(dpdx.shape(0)) != n || int64_t(dpdy.shape(0)) != n)) ||
      (with_normals && (int64_t(normals.shape(0)) != n || int64_t(normal_faces.shape(0)) != m)))
    throw std::invalid_argument("interpolate: samples of n rows, faces of m");
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    if (f < 0 || f >= m) throw std::invalid_argument("interpolate: a face outside the mesh");
    for (int j = 0; j < 3; ++j) {
      if (faces.data()[3 * f + j] < 0 || faces.data()[3 * f + j] >= nv || uv_faces.data()[3 * f + j] < 0 ||
          uv_faces.data()[3 * f + j] >= nt || (with_normals && (normal_faces.data()[3 * f + j] < 0 || normal_faces.data()[3 * f + j] >= nn)))
        throw std::invalid_argument("interpolate: a face's index outside its table");
    }
  }
  const double *b = bary.data(), *p = vertices.data(), *t = uv.data();
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    const double b0 = b[3 * i], b1 = b[3 * i + 1], b2 = b[3 * i + 2];
    const int64_t* c = faces.data() + 3 * f;
    const double *o = p + 3 * c[0], *q1 = p + 3 * c[1], *q2 = p + 3 * c[2];
    for (int k = 0; k < 3; ++k) points.data()[3 * i + k] = o[k] + b1 * (q1[k] - o[k]) + b2 * (q2[k] - o[k]);
    if (with_footprints) {
      double steps[6];
      face_steps(p, faces.data(), t, uv_faces.data(), f, width, height, steps);
      for (int k = 0; k < 3; ++k) {
        dpdx.data()[3 * i + k] = clip(steps[k], max_footprint);
        dpdy.data()[3 * i + k] = clip(steps[3 + k], max_footprint);
      }
    }
    if (with_normals) {
      const int64_t* g = normal_faces.data() + 3 * f;
      const double *n0 = normal_table.data() + 3 * g[0], *n1 = normal_table.data() + 3 * g[1], *n2 = normal_table.data() + 3 * g[2];
      const double x = b0 * n0[0] + b1 * n1[0] + b2 * n2[0];
      const double y = b0 * n0[1] + b1 * n1[1] + b2 * n2[1];
      const double z = b0 * n0[2] + b1 * n1[2] + b2 * n2[2];
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

// out (m,): whether either of face f's two steps differs from the same step of a face that shares
// one of its UV corners (one beside it in its chart, across an edge or a corner) by more than kink
// of its longer step (creases.py). Corners, not only edges: a texel on a corner spans the faces
// of its fan, and where their UV scales differ the centre face's footprint misreads the others
void face_bends(In<double, shape<-1, 3>> vertices, Faces faces, In<double, shape<-1, 2>> uv, Faces uv_faces,
                double width, double height, double kink, Out<bool, nb::ndim<1>> out) {
  const int64_t m = faces.shape(0), nv = vertices.shape(0), nt = uv.shape(0);
  if (int64_t(uv_faces.shape(0)) != m || int64_t(out.shape(0)) != m)
    throw std::invalid_argument("face_bends: uv_faces, out of m rows");
  for (int64_t i = 0; i < 3 * m; ++i)
    if (faces.data()[i] < 0 || faces.data()[i] >= nv || uv_faces.data()[i] < 0 || uv_faces.data()[i] >= nt)
      throw std::invalid_argument("face_bends: a face's index outside its table");
  const double *p = vertices.data(), *t = uv.data();
  const int64_t* corner = uv_faces.data();
  if (m > INT32_MAX) throw std::invalid_argument("face_bends: more than 2^31 faces");
  // each UV vertex's faces, a counting sort of the corners (int32, 12 bytes a face)
  std::vector<int64_t> start(size_t(nt) + 1, 0);
  std::vector<int32_t> fan(size_t(3 * m));
  for (int64_t i = 0; i < 3 * m; ++i) ++start[size_t(corner[i]) + 1];
  for (int64_t v = 0; v < nt; ++v) start[size_t(v) + 1] += start[size_t(v)];
  {
    std::vector<int64_t> next(start.begin(), start.end() - 1);
    for (int64_t i = 0; i < 3 * m; ++i) fan[size_t(next[size_t(corner[i])]++)] = int32_t(i / 3);
  }
  // every face's steps, made once where they fit in HELD faces (48 bytes a face, 48 MB at most):
  // otherwise each is made again at every comparison, ~19 a face (suzanne_blender_uv's 63k faces:
  // 25 ms). The same arithmetic either way, so the same answer
  constexpr int64_t HELD = int64_t(1) << 20;
  std::vector<double> held(m <= HELD ? size_t(6 * m) : 0);
  if (!held.empty())
    parallel_for(m, [&](std::ptrdiff_t f0, std::ptrdiff_t f1) {
      for (int64_t f = f0; f < f1; ++f) face_steps(p, faces.data(), t, corner, f, width, height, held.data() + 6 * f);
    });
  auto steps_of = [&](int64_t f, double* out) {
    if (held.empty())
      face_steps(p, faces.data(), t, corner, f, width, height, out);
    else
      std::copy(held.data() + 6 * f, held.data() + 6 * f + 6, out);
  };
  // a large fan's box of its faces' steps (min, max of each of the six coordinates): a face whose
  // steps lie within kink of the box's farthest corner bends from none of them, and skips the fan.
  // Without it a fan of k faces costs k^2 comparisons (a cylinder cap of 4000 segments: 32M, 0.58 s);
  // only fans above LARGE get one, so small ones hold no box (4 bytes a UV vertex for the index)
  constexpr int64_t LARGE = 16;
  std::vector<int32_t> box_of(size_t(nt), -1);
  std::vector<double> boxes;
  for (int64_t v = 0; v < nt; ++v) {
    if (start[size_t(v) + 1] - start[size_t(v)] <= LARGE) continue;
    box_of[size_t(v)] = int32_t(boxes.size() / 12);
    double box[12];
    std::fill(box, box + 6, INFINITY);
    std::fill(box + 6, box + 12, -INFINITY);
    for (int64_t j = start[size_t(v)]; j < start[size_t(v) + 1]; ++j) {
      double steps[6];
      steps_of(fan[size_t(j)], steps);
      for (int k = 0; k < 6; ++k) {
        box[k] = std::min(box[k], steps[k]);  // a NaN step leaves the box as it is ...
        box[6 + k] = std::max(box[6 + k], steps[k]);
        if (std::isnan(steps[k])) box[k] = NAN;  // ... so mark it: a NaN box never skips
      }
    }
    boxes.insert(boxes.end(), box, box + 12);
  }
  // both cores: the tile threads wait for this (Sampler.bends, once a bake)
  parallel_for(m, [&](std::ptrdiff_t f0, std::ptrdiff_t f1) {
    for (int64_t f = f0; f < f1; ++f) {
      double own[6], other[6];
      steps_of(f, own);
      const double scale = longer_step(own);
      bool bends = false;
      for (int c = 0; c < 3 && !bends; ++c) {
        const int64_t v = corner[3 * f + c];
        if (box_of[size_t(v)] >= 0) {
          const double* box = boxes.data() + 12 * size_t(box_of[size_t(v)]);
          double far[2] = {0.0, 0.0};  // squared distance from each step to the box's farthest corner
          for (int k = 0; k < 6; ++k) {
            const double e = std::max(std::fabs(box[k] - own[k]), std::fabs(box[6 + k] - own[k]));
            far[k / 3] += e * e;
          }
          // strictly inside, with room for the rounding of the comparison below: the same answer
          const double bound = kink * scale * (1.0 - 1e-9);
          if (std::sqrt(far[0]) < bound && std::sqrt(far[1]) < bound) continue;
        }
        for (int64_t j = start[size_t(v)]; j < start[size_t(v) + 1] && !bends; ++j) {
          const int64_t o = fan[size_t(j)];
          // itself, or a face across an edge already seen at an earlier corner of the edge
          if (o == f || (c > 0 && (corner[3 * o] == corner[3 * f] || corner[3 * o + 1] == corner[3 * f] ||
                                   corner[3 * o + 2] == corner[3 * f] ||
                                   (c > 1 && (corner[3 * o] == corner[3 * f + 1] || corner[3 * o + 1] == corner[3 * f + 1] ||
                                              corner[3 * o + 2] == corner[3 * f + 1])))))
            continue;
          steps_of(o, other);
          bends = step_change(own, other) > kink * scale;
        }
      }
      out.data()[f] = bends;
    }
  });
}

// out (m, 6): each face's clipped steps one texel right and one down, as interpolate gives its
// samples' dpdx, dpdy (the same bits): texel_parts compares a texel's parts with its sample's by them
void step_table(In<double, shape<-1, 3>> vertices, Faces faces, In<double, shape<-1, 2>> uv, Faces uv_faces, double width,
                double height, double max_footprint, Out<double, shape<-1, 6>> out) {
  const int64_t m = faces.shape(0), nv = vertices.shape(0), nt = uv.shape(0);
  if (int64_t(uv_faces.shape(0)) != m || int64_t(out.shape(0)) != m) throw std::invalid_argument("step_table: uv_faces, out of m rows");
  for (int64_t i = 0; i < 3 * m; ++i)
    if (faces.data()[i] < 0 || faces.data()[i] >= nv || uv_faces.data()[i] < 0 || uv_faces.data()[i] >= nt)
      throw std::invalid_argument("step_table: a face's index outside its table");
  const double *p = vertices.data(), *t = uv.data();
  parallel_for(m, [&](std::ptrdiff_t f0, std::ptrdiff_t f1) {
    for (int64_t f = f0; f < f1; ++f) {
      double* o = out.data() + 6 * f;
      face_steps(p, faces.data(), t, uv_faces.data(), f, width, height, o);
      for (int k = 0; k < 6; ++k) o[k] = clip(o[k], max_footprint);
    }
  });
}

}  // namespace

void bind_surface(nb::module_& m) {
  m.def("face_bends", &face_bends, nb::arg("vertices"), nb::arg("faces"), nb::arg("uv"), nb::arg("uv_faces"),
        nb::arg("width"), nb::arg("height"), nb::arg("kink"), nb::arg("out").noconvert(), Release(),
        "out (m,) := whether either of each face's steps one texel right and down differs from that of a face sharing "
        "a UV corner by more than kink of its longer step.");
  m.def("step_table", &step_table, nb::arg("vertices"), nb::arg("faces"), nb::arg("uv"), nb::arg("uv_faces"),
        nb::arg("width"), nb::arg("height"), nb::arg("max_footprint"), nb::arg("out").noconvert(), Release(),
        "out (m, 6) := each face's steps one texel right and one down (its samples' dpdx, dpdy), clipped to max_footprint.");
  m.def("interpolate", &interpolate, nb::arg("face"), nb::arg("bary"), nb::arg("vertices"), nb::arg("faces"), nb::arg("uv"),
        nb::arg("uv_faces"), nb::arg("width"), nb::arg("height"), nb::arg("max_footprint"), nb::arg("normal_table"),
        nb::arg("normal_faces"), nb::arg("points").noconvert(), nb::arg("dpdx").noconvert(), nb::arg("dpdy").noconvert(),
        nb::arg("normals").noconvert(), Release(),
        "Fill points (n, 3), dpdx, dpdy (n, 3, or no rows: none) and, where normal_faces (m, 3) has rows, unit normals "
        "(n, 3; zero where they cancel) of the samples at face (n,), bary (n, 3) of the mesh (vertices, faces) with its "
        "atlas (uv, uv_faces) and corner normals normal_table[normal_faces].");
}

}  // namespace texbake
