// Texel lookup (texbake/sampling/lookup.py): sample positions, the texels a UV triangle
// touches, and float64 barycentrics, found by a walk across UV edges. The tile threads give
// these their parallelism: each call is one tile's, on the calling thread.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "arrays.hpp"
#include "steps.hpp"

namespace texbake {
namespace {

// The x-range [xmin, xmax] of the triangle (xs, ys) within the band lo <= y <= hi: the range of
// the parts of its edges inside the band (its corners there are their ends). Empty (xmin >
// xmax, both infinite) where it misses the band. Row by row, a sliver's cells or texels are
// those along it, not its box's: a fan of 200k slivers' boxes span half the disc each.
inline void band_range(const double* xs, const double* ys, double lo, double hi, double& xmin, double& xmax) {
  xmin = INFINITY, xmax = -INFINITY;
  for (int e = 0; e < 3; ++e) {
    const double px = xs[e], py = ys[e], qx = xs[(e + 1) % 3], qy = ys[(e + 1) % 3];
    double t0 = 0.0, t1 = 1.0;  // the part of the edge p + t (q - p) within the band
    if (py == qy) {
      if (!(py >= lo && py <= hi)) continue;
    } else {
      double ta = (lo - py) / (qy - py), tb = (hi - py) / (qy - py);
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta), t1 = std::min(t1, tb);
      if (!(t0 <= t1)) continue;
    }
    const double xa = px + t0 * (qx - px), xb = px + t1 * (qx - px);
    xmin = std::min({xmin, xa, xb}), xmax = std::max({xmax, xa, xb});
  }
}

// whether the texel square of centre (px, py) (side 1, grown by slack of its half-extent along
// the edge's normal) lies wholly beyond the edge a -> a + (ex, ey) of a triangle that winds as
// sign says: one separating axis of a square and a triangle
inline bool beyond_edge(double sign, double ax, double ay, double ex, double ey, double px, double py, double slack) {
  const double reach = 0.5 * (std::abs(ex) + std::abs(ey));  // the square's half-extent along the edge's normal
  return sign * (ex * (py - ay) - ey * (px - ax)) + reach < -slack * reach;
}

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

// The atlas: UVs (k, 2) and faces (m, 3) into them, read as they are (per-face arrays of
// millions of faces would take hundreds of MB)
struct Atlas {
  const double* uv;
  const int64_t* faces;
  int64_t k, m;
  Atlas(const In<double, shape<-1, 2>>& uv_, const In<int64_t, shape<-1, 3>>& faces_)
      : uv(uv_.data()), faces(faces_.data()), k(uv_.shape(0)), m(faces_.shape(0)) {}
  // checked as read (a call reads few of the faces: checking all would cost each tile O(m))
  const double* corner(int64_t f, int c) const {
    const int64_t v = faces[3 * f + c];
    if (v < 0 || v >= k) throw std::invalid_argument("lookup: a face index outside the UVs");
    return uv + 2 * v;
  }
};

// point i of points in face f, unclamped: (b1, b2) = inv @ (t - t0) with uv_inverse's inverse
// (texbake/mesh/uvgeometry.py), each entry as it computes it
inline Bary coordinates(const double* points, int64_t i, int64_t f, const Atlas& atlas) {
  const double *a = atlas.corner(f, 0), *a1 = atlas.corner(f, 1), *a2 = atlas.corner(f, 2);
  const double d1u = a1[0] - a[0], d1v = a1[1] - a[1], d2u = a2[0] - a[0], d2v = a2[1] - a[1];
  const double det = d1u * d2v - d1v * d2u;
  const double r = std::fabs(det) > 0 ? 1.0 / det : 0.0;
  const double i00 = d2v * r, i01 = -d2u * r, i10 = -d1v * r, i11 = d1u * r;
  const double dx = points[2 * i] - a[0], dy = points[2 * i + 1] - a[1];
  const double b1 = i00 * dx + i01 * dy;
  const double b2 = i10 * dx + i11 * dy;
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

void touched(In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces, In<int64_t, nb::ndim<1>> near, int64_t width,
             int64_t height, int64_t start, int64_t rows, double margin, Out<bool, nb::ndim<1>> out) {
  if (int64_t(out.shape(0)) != rows * width) throw std::invalid_argument("touched: out must be (rows * width,)");
  const Atlas atlas(uv, faces);
  bool* hit = out.data();
  for (size_t n = 0; n < near.shape(0); ++n) {
    const int64_t f = near.data()[n];
    if (f < 0 || f >= atlas.m) throw std::invalid_argument("touched: a face outside the atlas");
    double xs[3], ys[3];
    for (int c = 0; c < 3; ++c) {
      xs[c] = atlas.corner(f, c)[0] * width;
      ys[c] = (1.0 - atlas.corner(f, c)[1]) * height - start;
    }
    const double area = (xs[1] - xs[0]) * (ys[2] - ys[0]) - (ys[1] - ys[0]) * (xs[2] - xs[0]);
    const double sign = area > 0 ? 1.0 : -1.0;
    // the box in texels, clamped to the tile as floats (a UV far outside [0, 1] is no integer)
    const int64_t c0 = int64_t(std::floor(std::min(std::max(std::min({xs[0], xs[1], xs[2]}) - margin, 0.0), width - 1.0)));
    const int64_t c1 = int64_t(std::floor(std::min(std::max(std::max({xs[0], xs[1], xs[2]}) + margin, -1.0), width - 1.0)));
    const int64_t r0 = int64_t(std::floor(std::min(std::max(std::min({ys[0], ys[1], ys[2]}) - margin, 0.0), rows - 1.0)));
    const int64_t r1 = int64_t(std::floor(std::min(std::max(std::max({ys[0], ys[1], ys[2]}) + margin, -1.0), rows - 1.0)));
    for (int64_t r = r0; r <= r1; ++r) {
      // only the columns near the triangle's x-range in this row's band (a texel wider each
      // way than the margin reaches): the separating axes below still decide each texel
      double xmin, xmax;
      band_range(xs, ys, r - margin - 1.0, r + 2.0 + margin, xmin, xmax);
      if (!(xmin <= xmax)) continue;
      const int64_t from = std::max(c0, int64_t(std::floor(std::min(std::max(xmin - margin - 1.0, -1.0), width - 1.0))));
      const int64_t to = std::min(c1, int64_t(std::floor(std::min(std::max(xmax + margin + 1.0, -1.0), width - 1.0))));
      for (int64_t c = from; c <= to; ++c) {
        const double x = c + 0.5, y = r + 0.5;
        bool inside = true;
        for (int e = 0; e < 3; ++e) {  // separating axes: the square (grown by the margin) wholly beyond an edge
          if (beyond_edge(sign, xs[e], ys[e], xs[(e + 1) % 3] - xs[e], ys[(e + 1) % 3] - ys[e], x, y, margin * 2.0)) {
            inside = false;
            break;
          }
        }
        if (inside) hit[r * width + c] = true;
      }
    }
  }
}

// top, bottom (m,) := the first and last texel row each UV triangle touches, within margin, in
// an image height rows high: floor((1 - max v) * height - margin), floor((1 - min v) * height + margin)
void row_range(In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces, int64_t height, double margin,
               Out<double, nb::ndim<1>> top, Out<double, nb::ndim<1>> bottom) {
  const Atlas atlas(uv, faces);
  if (int64_t(top.shape(0)) != atlas.m || int64_t(bottom.shape(0)) != atlas.m) throw std::invalid_argument("row_range: top, bottom of m");
  for (int64_t f = 0; f < atlas.m; ++f) {
    const double v0 = atlas.corner(f, 0)[1], v1 = atlas.corner(f, 1)[1], v2 = atlas.corner(f, 2)[1];
    // np.maximum / np.minimum: NaN wins
    const double hi01 = (v1 > v0 || std::isnan(v1)) ? v1 : v0, hi = (v2 > hi01 || std::isnan(v2)) ? v2 : hi01;
    const double lo01 = (v1 < v0 || std::isnan(v1)) ? v1 : v0, lo = (v2 < lo01 || std::isnan(v2)) ? v2 : lo01;
    top.data()[f] = std::floor((1.0 - hi) * double(height) - margin);
    bottom.data()[f] = std::floor((1.0 - lo) * double(height) + margin);
  }
}

void walk(In<double, shape<-1, 2>> points, Out<int32_t, nb::ndim<1>> face, In<double, shape<-1, 2>> uv,
          In<int64_t, shape<-1, 3>> faces, In<int64_t, shape<-1, 3>> across, int64_t steps, Out<double, shape<-1, 3>> bary,
          Out<bool, nb::ndim<1>> inside) {
  const int64_t n = face.shape(0);
  const Atlas atlas(uv, faces);
  if (int64_t(points.shape(0)) != n || int64_t(bary.shape(0)) != n || int64_t(inside.shape(0)) != n ||
      int64_t(across.shape(0)) != atlas.m)
    throw std::invalid_argument("walk: points, face, bary, inside of n rows; faces, across of m");
  for (int64_t i = 0; i < n; ++i) {
    int64_t f = face.data()[i];
    if (f < 0) continue;
    for (int64_t step = 0; step <= steps; ++step) {
      if (f >= atlas.m) throw std::invalid_argument("walk: a face outside the atlas");
      const Bary b = coordinates(points.data(), i, f, atlas);
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

void barycentric(In<double, shape<-1, 2>> points, In<int32_t, nb::ndim<1>> face, In<double, shape<-1, 2>> uv,
                 In<int64_t, shape<-1, 3>> faces, Out<double, shape<-1, 3>> bary, Out<bool, nb::ndim<1>> inside) {
  const int64_t n = face.shape(0);
  const Atlas atlas(uv, faces);
  if (int64_t(points.shape(0)) != n || int64_t(bary.shape(0)) != n || int64_t(inside.shape(0)) != n)
    throw std::invalid_argument("barycentric: points, face, bary, inside of n rows");
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    if (f < 0) continue;
    if (f >= atlas.m) throw std::invalid_argument("barycentric: a face outside the atlas");
    const Bary b = coordinates(points.data(), i, f, atlas);
    inside.data()[i] = b.inside();
    b.clamp_into(bary.data() + 3 * i);
  }
}


// ---- point location through a uniform grid over the UV triangles (no Embree) ----------
// The grid: nx * ny cells over [lo_u, lo_u + nx / inv_u) x [lo_v, lo_v + ny / inv_v); a face
// is listed in every cell its UV triangle touches (Grid::cells_of; CSR: start (nx * ny + 1,), cells' faces in
// increasing face order). A point is in the first listed face of its cell that holds it.
struct Grid {
  double lo_u, lo_v, inv_u, inv_v;
  int64_t nx, ny;
  // the cell range [c0, c1] along one axis of the interval [a, b], clamped into the grid
  static void span(double a, double b, double lo, double inv, int64_t n, int64_t& c0, int64_t& c1) {
    c0 = int64_t(std::floor(std::min(std::max((a - lo) * inv, 0.0), double(n - 1))));
    c1 = int64_t(std::floor(std::min(std::max((b - lo) * inv, 0.0), double(n - 1))));
  }
  // the cells face f's triangle touches, row by row: in each row of its box, the cells of the
  // triangle's u-range within that row's band (widened by SLACK of a cell, so that rounding never
  // leaves out a cell it touches). Not the whole box: a sliver of a fan of 200k faces spans half
  // its disc's box, and its box's cells made a list of 8.8e9 entries (32 GiB); its cells along
  // it, a few hundred. A face with a corner not finite keeps its box's cells.
  template <class F>
  void cells_of(const Atlas& atlas, int64_t f, F&& visit) const {
    constexpr double SLACK = 1e-6;
    const double *a = atlas.corner(f, 0), *b = atlas.corner(f, 1), *c = atlas.corner(f, 2);
    int64_t u0, u1, v0, v1;
    span(std::min({a[0], b[0], c[0]}), std::max({a[0], b[0], c[0]}), lo_u, inv_u, nx, u0, u1);
    span(std::min({a[1], b[1], c[1]}), std::max({a[1], b[1], c[1]}), lo_v, inv_v, ny, v0, v1);
    const bool finite = std::isfinite(a[0] + a[1] + b[0] + b[1] + c[0] + c[1]);
    if (v0 == v1 || u0 == u1 || !finite) {  // one row or one column: the box is the triangle's cells
      for (int64_t v = v0; v <= v1; ++v)
        for (int64_t u = u0; u <= u1; ++u) visit(v * nx + u);
      return;
    }
    const double us[3] = {(a[0] - lo_u) * inv_u, (b[0] - lo_u) * inv_u, (c[0] - lo_u) * inv_u};
    const double vs[3] = {(a[1] - lo_v) * inv_v, (b[1] - lo_v) * inv_v, (c[1] - lo_v) * inv_v};
    for (int64_t v = v0; v <= v1; ++v) {
      // the band of row v in cell units, widened; the first and last rows reach past the grid
      const double lo = v == 0 ? -INFINITY : double(v) - SLACK, hi = v == ny - 1 ? INFINITY : double(v + 1) + SLACK;
      double umin, umax;
      band_range(us, vs, lo, hi, umin, umax);
      if (!(umin <= umax)) continue;
      const int64_t c0 = int64_t(std::floor(std::min(std::max(umin - SLACK, double(u0)), double(u1))));
      const int64_t c1 = int64_t(std::floor(std::min(std::max(umax + SLACK, double(u0)), double(u1))));
      for (int64_t u = c0; u <= c1; ++u) visit(v * nx + u);
    }
  }
};

// (b - a) x (p - a) with the edge's endpoints in one order whichever face has it: the two
// faces of a shared edge compute the same number, negated, so that no point on it falls
// between them (watertight)
inline double edge_side(const double* a, const double* b, double px, double py) {
  const bool swap = a[0] > b[0] || (a[0] == b[0] && a[1] > b[1]);
  const double *p0 = swap ? b : a, *p1 = swap ? a : b;
  const double side = (p1[0] - p0[0]) * (py - p0[1]) - (p1[1] - p0[1]) * (px - p0[0]);
  return swap ? -side : side;
}

inline bool holds(const Atlas& atlas, int64_t f, double px, double py) {
  const double *a = atlas.corner(f, 0), *b = atlas.corner(f, 1), *c = atlas.corner(f, 2);
  const double area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
  if (!(std::fabs(area) > 0)) return false;  // UV-degenerate (or NaN): never holds a point
  const double s0 = edge_side(a, b, px, py), s1 = edge_side(b, c, px, py), s2 = edge_side(c, a, px, py);
  return area > 0 ? (s0 >= 0 && s1 >= 0 && s2 >= 0) : (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

Grid grid_of(double lo_u, double lo_v, double inv_u, double inv_v, int64_t nx, int64_t ny) {
  if (nx < 1 || ny < 1 || !(inv_u > 0) || !(inv_v > 0)) throw std::invalid_argument("grid: nx, ny >= 1 and positive inverse cell sizes");
  return {lo_u, lo_v, inv_u, inv_v, nx, ny};
}

void grid_count(In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces, In<bool, nb::ndim<1>> usable, double lo_u,
                double lo_v, double inv_u, double inv_v, int64_t nx, int64_t ny, Out<int64_t, nb::ndim<1>> count) {
  const Atlas atlas(uv, faces);
  const Grid g = grid_of(lo_u, lo_v, inv_u, inv_v, nx, ny);
  if (int64_t(usable.shape(0)) != atlas.m || int64_t(count.shape(0)) != nx * ny + 1)
    throw std::invalid_argument("grid_count: usable of m, count of nx * ny + 1");
  int64_t* n = count.data();
  std::fill_n(n, nx * ny + 1, int64_t(0));
  for (int64_t f = 0; f < atlas.m; ++f)
    if (usable.data()[f]) g.cells_of(atlas, f, [&](int64_t cell) { ++n[cell + 1]; });
  for (int64_t i = 0; i < nx * ny; ++i) n[i + 1] += n[i];  // start of each cell
}

void grid_fill(In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces, In<bool, nb::ndim<1>> usable, double lo_u,
               double lo_v, double inv_u, double inv_v, int64_t nx, int64_t ny, In<int64_t, nb::ndim<1>> start,
               Out<int32_t, nb::ndim<1>> listed) {
  const Atlas atlas(uv, faces);
  const Grid g = grid_of(lo_u, lo_v, inv_u, inv_v, nx, ny);
  if (int64_t(usable.shape(0)) != atlas.m || int64_t(start.shape(0)) != nx * ny + 1 ||
      int64_t(listed.shape(0)) != start.data()[nx * ny])
    throw std::invalid_argument("grid_fill: usable of m, start of nx * ny + 1, listed of start[-1]");
  std::vector<int64_t> at(start.data(), start.data() + nx * ny);
  for (int64_t f = 0; f < atlas.m; ++f)
    if (usable.data()[f]) g.cells_of(atlas, f, [&](int64_t cell) { listed.data()[at[cell]++] = int32_t(f); });
}

void grid_locate(In<double, shape<-1, 2>> points, In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces, double lo_u,
                 double lo_v, double inv_u, double inv_v, int64_t nx, int64_t ny, In<int64_t, nb::ndim<1>> start,
                 In<int32_t, nb::ndim<1>> listed, Out<int32_t, nb::ndim<1>> face) {
  const Atlas atlas(uv, faces);
  const Grid g = grid_of(lo_u, lo_v, inv_u, inv_v, nx, ny);
  const int64_t n = points.shape(0);
  if (int64_t(face.shape(0)) != n || int64_t(start.shape(0)) != nx * ny + 1 || int64_t(listed.shape(0)) != start.data()[nx * ny])
    throw std::invalid_argument("grid_locate: face of n, start of nx * ny + 1, listed of start[-1]");
  const double* p = points.data();
  for (int64_t i = 0; i < n; ++i) {
    const double px = p[2 * i], py = p[2 * i + 1];
    const double cu = (px - g.lo_u) * g.inv_u, cv = (py - g.lo_v) * g.inv_v;
    int32_t found = -1;
    // a point on the grid's far side (cu == nx) is in its last cell; outside (or NaN): no face
    if (cu >= 0 && cv >= 0 && cu <= double(nx) && cv <= double(ny)) {
      const int64_t cell = std::min(int64_t(cv), ny - 1) * nx + std::min(int64_t(cu), nx - 1);
      for (int64_t k = start.data()[cell]; k < start.data()[cell + 1]; ++k) {
        const int64_t f = listed.data()[k];
        if (holds(atlas, f, px, py)) {
          found = int32_t(f);
          break;
        }
      }
    }
    face.data()[i] = found;
  }
}



// Sorted texel indices (row * width + col) that a chart's border touches: the UV edges with no
// face across them (across -1) of the usable faces, each tested against the texels of its box
// (the segment's line within half the square's extent along its normal). A texel none touches
// lies wholly in its chart, or wholly outside.
nb::ndarray<nb::numpy, int64_t> border_texels(In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces,
                                              In<int64_t, shape<-1, 3>> across, In<bool, nb::ndim<1>> usable, int64_t width,
                                              int64_t height) {
  const Atlas atlas(uv, faces);
  if (int64_t(across.shape(0)) != atlas.m || int64_t(usable.shape(0)) != atlas.m)
    throw std::invalid_argument("border_texels: across, usable of m");
  std::vector<int64_t> found;
  {
    nb::gil_scoped_release release;
    const double w = double(width), h = double(height);
    for (int64_t f = 0; f < atlas.m; ++f) {
      if (!usable.data()[f]) continue;
      for (int c = 0; c < 3; ++c) {
        if (across.data()[3 * f + c] >= 0) continue;
        const double *a = atlas.corner(f, (c + 1) % 3), *b = atlas.corner(f, (c + 2) % 3);
        const double ax = a[0] * w, ay = (1.0 - a[1]) * h, bx = b[0] * w, by = (1.0 - b[1]) * h;
        if (!std::isfinite(ax + ay + bx + by)) continue;
        const double ex = bx - ax, ey = by - ay, reach = 0.5 * (std::abs(ex) + std::abs(ey)) * (1.0 + 1e-9) + 1e-12;
        const int64_t c0 = int64_t(std::max(std::floor(std::min(ax, bx) - 1e-9), 0.0));
        const int64_t c1 = int64_t(std::min(std::floor(std::max(ax, bx) + 1e-9), w - 1.0));
        const int64_t r0 = int64_t(std::max(std::floor(std::min(ay, by) - 1e-9), 0.0));
        const int64_t r1 = int64_t(std::min(std::floor(std::max(ay, by) + 1e-9), h - 1.0));
        for (int64_t r = r0; r <= r1; ++r)
          for (int64_t q = c0; q <= c1; ++q)
            if (std::abs(ex * (r + 0.5 - ay) - ey * (q + 0.5 - ax)) <= reach) found.push_back(r * width + q);
      }
    }
    std::sort(found.begin(), found.end());
    found.erase(std::unique(found.begin(), found.end()), found.end());
  }
  const size_t n = found.size();
  return owned(std::move(found), {n});
}

// ---- the part of a texel its chart covers (the filter's footprint at a chart's edge) --------
// Texel-local coordinates: x = u * width - (col + 1/2) right, y = (1 - v) * height - (row + 1/2)
// down, the texel the square [-1/2, 1/2]^2 (dpdx, dpdy are the surface's steps along x, y).
struct Moments {
  double a = 0, x = 0, y = 0, xx = 0, yy = 0, xy = 0;
};

// keep the part of polygon in (n points) with sign * coordinate axis <= 1/2 (Sutherland-Hodgman)
inline int clip_side(const double* in, int n, double* out, int axis, double sign) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const double *p = in + 2 * i, *q = in + 2 * ((i + 1) % n);
    const double dp = sign * p[axis] - 0.5, dq = sign * q[axis] - 0.5;
    if (dp <= 0) {
      out[2 * m] = p[0];
      out[2 * m + 1] = p[1];
      ++m;
    }
    if ((dp < 0 && dq > 0) || (dp > 0 && dq < 0)) {
      const double t = dp / (dp - dq);
      out[2 * m] = p[0] + t * (q[0] - p[0]);
      out[2 * m + 1] = p[1] + t * (q[1] - p[1]);
      ++m;
    }
  }
  return m;
}

// area, first and second moments of triangle tri (3 points, local coordinates) cut to the texel;
// the cut polygon's corners appended to corners when given
inline void add_clipped(const double* tri, Moments& sum, std::vector<double>* corners = nullptr) {
  double a[32], b[32];
  std::copy_n(tri, 6, a);
  int n = 3;
  n = clip_side(a, n, b, 0, 1.0);
  n = clip_side(b, n, a, 0, -1.0);
  n = clip_side(a, n, b, 1, 1.0);
  n = clip_side(b, n, a, 1, -1.0);
  if (n < 3) return;
  if (corners != nullptr) corners->insert(corners->end(), a, a + 2 * n);
  Moments m;
  for (int i = 0; i < n; ++i) {
    const double x0 = a[2 * i], y0 = a[2 * i + 1], x1 = a[2 * ((i + 1) % n)], y1 = a[2 * ((i + 1) % n) + 1];
    const double c = x0 * y1 - x1 * y0;
    m.a += c / 2;
    m.x += (x0 + x1) * c / 6;
    m.y += (y0 + y1) * c / 6;
    m.xx += (x0 * x0 + x0 * x1 + x1 * x1) * c / 12;
    m.yy += (y0 * y0 + y0 * y1 + y1 * y1) * c / 12;
    m.xy += (x0 * y1 + 2 * x0 * y0 + 2 * x1 * y1 + x1 * y0) * c / 24;
  }
  const double s = m.a < 0 ? -1.0 : 1.0;  // either winding
  sum.a += s * m.a, sum.x += s * m.x, sum.y += s * m.y, sum.xx += s * m.xx, sum.yy += s * m.yy, sum.xy += s * m.xy;
}

constexpr int CLIP_FACES = 256;  // faces of one chart a texel's cut takes at most
// faces a texel's parts (texel_parts) take at most: past them its faces are slivers of a fine
// mesh (a cone's apex fan of 100k faces: every sliver's texel spans ~100 of them, and looking
// for them cost 17.7 s at 1024², to find no part that bends), and the texel is filtered whole
constexpr int PARTS_FACES = 32;

// The texel under a sample (face f at barycentrics b), and any face in its texel-local
// coordinates (the call: the face's corners into tri, 6 values)
struct TexelFrame {
  const Atlas& atlas;
  double w, h, col, row;
  TexelFrame(const Atlas& a, int64_t f, const double* b, double width, double height) : atlas(a), w(width), h(height) {
    double pu = 0, pv = 0;
    for (int c = 0; c < 3; ++c) pu += b[c] * atlas.corner(f, c)[0], pv += b[c] * atlas.corner(f, c)[1];
    col = std::floor(pu * w), row = std::floor((1.0 - pv) * h);
  }
  void operator()(int64_t g, double* tri) const {
    for (int c = 0; c < 3; ++c) {
      tri[2 * c] = atlas.corner(g, c)[0] * w - (col + 0.5);
      tri[2 * c + 1] = (1.0 - atlas.corner(g, c)[1]) * h - (row + 0.5);
    }
  }
};

// The faces a texel's cut may take: each face's chart (faces joined across UV edges, numbered
// by labels) and the UV grid that lists the faces of each cell (UVGrid's box, start and listed)
struct Cells {
  const int64_t* chart;
  Grid grid;
  const int64_t* start;
  const int32_t* listed;
};

inline double winding(const Atlas& atlas, int64_t f) {
  const double *a = atlas.corner(f, 0), *b = atlas.corner(f, 1), *c = atlas.corner(f, 2);
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

// whether the texel square [-1/2, 1/2]^2 lies wholly beyond one of triangle tri's edges
// (texel-local corners; either winding; a degenerate triangle never separates)
inline bool square_beyond(const double* tri) {
  const double orient = (tri[2] - tri[0]) * (tri[5] - tri[1]) - (tri[3] - tri[1]) * (tri[4] - tri[0]);
  if (!(orient != 0)) return false;
  const double sign = orient > 0 ? 1.0 : -1.0;
  for (int e = 0; e < 3; ++e) {
    const double ax = tri[2 * e], ay = tri[2 * e + 1];
    if (beyond_edge(sign, ax, ay, tri[2 * ((e + 1) % 3)] - ax, tri[2 * ((e + 1) % 3) + 1] - ay, 0.0, 0.0, 1e-9)) return true;
  }
  return false;
}

// each face g of f's chart that the grid lists in the texel's cells and that winds as f does
// (a folded face lies on another: not counted twice), once, as visit(g, tri) with tri its
// corners in texel-local coordinates (local(g, tri)), also those not reached from f across
// UV edges (a crack in a scan, where a chart's two sides meet in one texel); false (and
// visits stop) past most (at most CLIP_FACES) faces
template <typename Local, typename Visit>
bool chart_faces(const Atlas& atlas, const Cells& cells, int64_t f, const Local& local, Visit&& visit, int most = CLIP_FACES) {
  int64_t taken[CLIP_FACES];
  int count = 0;
  most = std::min(most, CLIP_FACES);
  const int64_t chart = cells.chart[f];
  const bool positive = winding(atlas, f) > 0;
  const double u0 = local.col / local.w, u1 = (local.col + 1.0) / local.w;
  const double v0 = 1.0 - (local.row + 1.0) / local.h, v1 = 1.0 - local.row / local.h;
  int64_t x0, x1, y0, y1;
  Grid::span(u0, u1, cells.grid.lo_u, cells.grid.inv_u, cells.grid.nx, x0, x1);
  Grid::span(v0, v1, cells.grid.lo_v, cells.grid.inv_v, cells.grid.ny, y0, y1);
  double tri[6];
  for (int64_t y = y0; y <= y1; ++y)
    for (int64_t x = x0; x <= x1; ++x) {
      const int64_t cell = y * cells.grid.nx + x;
      for (int64_t k = cells.start[cell]; k < cells.start[cell + 1]; ++k) {
        const int64_t g = cells.listed[k];
        if (g < 0 || g >= atlas.m) throw std::invalid_argument("footprint cut: a listed face outside the atlas");
        if (cells.chart[g] != chart || (winding(atlas, g) > 0) != positive) continue;
        local(g, tri);
        // off the texel's square by its box: not a face of the texel (most of a cell's faces)
        if (std::max({tri[0], tri[2], tri[4]}) <= -0.5 || std::min({tri[0], tri[2], tri[4]}) >= 0.5 ||
            std::max({tri[1], tri[3], tri[5]}) <= -0.5 || std::min({tri[1], tri[3], tri[5]}) >= 0.5)
          continue;
        // nor wholly beyond one of its edges (a sliver whose box reaches over the texel): such a
        // face adds nothing to the cut, and not counting it keeps CLIP_FACES for the faces that do
        // (a fan of 200k slivers: 121 faces on a texel, 293 boxes on it)
        if (square_beyond(tri)) continue;
        if (std::find(taken, taken + count, g) != taken + count) continue;  // listed in another cell too
        if (count == most) return false;
        taken[count++] = g;
        visit(g, tri);
      }
    }
  return true;
}

// the moments of the part of a texel that face f's chart covers (chart_faces' faces, each cut
// to the texel; NaN area past CLIP_FACES faces: taken as whole); the cut pieces' corners
// appended to corners when given
template <typename Local>
Moments chart_part(const Atlas& atlas, const Cells& cells, int64_t f, const Local& local, std::vector<double>* corners = nullptr) {
  Moments sum;
  if (!chart_faces(atlas, cells, f, local, [&](int64_t, const double* tri) { add_clipped(tri, sum, corners); }))
    return Moments{std::numeric_limits<double>::quiet_NaN()};
  return sum;
}

// whether the texel square [-1/2, 1/2]^2 lies wholly inside triangle tri (texel-local)
inline bool texel_inside(const double* tri) {
  const double orient = (tri[2] - tri[0]) * (tri[5] - tri[1]) - (tri[3] - tri[1]) * (tri[4] - tri[0]);
  bool inside = orient != 0;
  for (int k = 0; k < 4 && inside; ++k) {
    const double x = (k & 1) ? 0.5 : -0.5, y = (k & 2) ? 0.5 : -0.5;
    for (int c = 0; c < 3 && inside; ++c) {
      const double *p = tri + 2 * c, *q = tri + 2 * ((c + 1) % 3);
      inside = orient * ((q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])) >= 0;
    }
  }
  return inside;
}

// the box of the same mean and covariance as the region of moments m: its centre (mx, my) into
// shift, its edges as the columns of e (row-major 2 x 2; the whole texel: the identity)
inline void box_of(const Moments& m, double* shift, double* e) {
  const double mx = m.x / m.a, my = m.y / m.a;
  // 12 x the covariance: the identity for the whole texel; its square root is the box's edges
  const double cxx = 12.0 * (m.xx / m.a - mx * mx), cyy = 12.0 * (m.yy / m.a - my * my), cxy = 12.0 * (m.xy / m.a - mx * my);
  const double s = std::sqrt(std::max(cxx * cyy - cxy * cxy, 0.0)), t = std::sqrt(std::max(cxx + cyy + 2.0 * s, 1e-300));
  shift[0] = mx, shift[1] = my;
  e[0] = (cxx + s) / t, e[1] = cxy / t, e[2] = cxy / t, e[3] = (cyy + s) / t;
}

// the convex hull of points (n pairs), counter-clockwise (Andrew's monotone chain), into hull;
// returns its corner count
inline int convex_hull(std::vector<double>& points, double* hull, int most) {
  const size_t n = points.size() / 2;
  std::vector<std::pair<double, double>> p(n);
  for (size_t i = 0; i < n; ++i) p[i] = {points[2 * i], points[2 * i + 1]};
  std::sort(p.begin(), p.end());
  p.erase(std::unique(p.begin(), p.end()), p.end());
  if (p.size() < 3) return 0;
  std::vector<std::pair<double, double>> h(2 * p.size());
  size_t k = 0;
  auto cross = [](const std::pair<double, double>& o, const std::pair<double, double>& a, const std::pair<double, double>& b) {
    return (a.first - o.first) * (b.second - o.second) - (a.second - o.second) * (b.first - o.first);
  };
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i - 1]) <= 0) --k;
    h[k++] = p[i - 1];
  }
  const int corners = int(k) - 1;
  for (int i = 0; i < std::min(corners, most); ++i) hull[2 * i] = h[i].first, hull[2 * i + 1] = h[i].second;
  return corners;
}

// Cells over checked arrays: chart of m, start of nx * ny + 1, listed of start's last
inline Cells cells_of(const Atlas& atlas, const In<int64_t, nb::ndim<1>>& chart, const In<double, shape<4>>& box, int64_t nx,
                      int64_t ny, const In<int64_t, nb::ndim<1>>& start, const In<int32_t, nb::ndim<1>>& listed) {
  if (int64_t(chart.shape(0)) != atlas.m || nx < 1 || ny < 1 || int64_t(start.shape(0)) != nx * ny + 1 ||
      int64_t(listed.shape(0)) != start.data()[nx * ny])
    throw std::invalid_argument("footprint cut: chart of m, start of nx * ny + 1, listed of start[-1]");
  return Cells{chart.data(), grid_of(box.data()[0], box.data()[1], box.data()[2], box.data()[3], nx, ny), start.data(),
               listed.data()};
}

// Per sample (face, bary) of one sample a texel: the part of its texel that its chart covers
// (only texels in border, border_texels' sorted list, can be partly covered)
// (chart_part: the faces of its chart whose triangles overlap the texel), as the
// box of the same mean and covariance: shift (n, 2) its centre, edges (n, 4) the matrix E
// (row-major) whose columns are its edges in texel units (the whole texel: 0 and the identity),
// area (n,) the covered share. Returns the number of partly covered samples.
int64_t footprint_clip(In<int32_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, In<double, shape<-1, 2>> uv,
                       In<int64_t, shape<-1, 3>> faces, In<int64_t, nb::ndim<1>> chart, In<double, shape<4>> box, int64_t nx,
                       int64_t ny, In<int64_t, nb::ndim<1>> start, In<int32_t, nb::ndim<1>> listed, In<int64_t, nb::ndim<1>> border,
                       int64_t width, int64_t height, Out<double, shape<-1, 2>> shift, Out<double, shape<-1, 4>> edges, Out<double, nb::ndim<1>> area) {
  const int64_t n = face.shape(0);
  const Atlas atlas(uv, faces);
  if (int64_t(bary.shape(0)) != n || int64_t(shift.shape(0)) != n || int64_t(edges.shape(0)) != n ||
      int64_t(area.shape(0)) != n)
    throw std::invalid_argument("footprint_clip: face, bary, shift, edges, area of n rows");
  const Cells cells = cells_of(atlas, chart, box, nx, ny, start, listed);
  const double w = double(width), h = double(height);
  int64_t partial = 0;
  for (int64_t i = 0; i < n; ++i) {
    const int64_t f = face.data()[i];
    double* sh = shift.data() + 2 * i;
    double* e = edges.data() + 4 * i;
    sh[0] = sh[1] = 0.0;
    e[0] = 1.0, e[1] = 0.0, e[2] = 0.0, e[3] = 1.0;
    area.data()[i] = 1.0;
    if (f < 0) continue;
    if (f >= atlas.m) throw std::invalid_argument("footprint_clip: a face outside the atlas");
    const TexelFrame local(atlas, f, bary.data() + 3 * i, w, h);
    const int64_t texel = int64_t(local.row) * width + int64_t(local.col);
    if (!std::binary_search(border.data(), border.data() + border.shape(0), texel)) continue;  // no border crosses it
    double tri[6];
    local(f, tri);
    if (texel_inside(tri)) continue;  // the whole texel inside the sample's face: nothing to cut (most texels)
    const Moments sum = chart_part(atlas, cells, f, local);
    if (!(sum.a < 1.0 - 1e-9) || !(sum.a > 1e-12)) continue;  // covered (or a cut too small to trust)
    box_of(sum, sh, e);
    area.data()[i] = sum.a;
    ++partial;
  }
  return partial;
}

// Per sample (face, bary) of one sample a texel whose texel its chart covers whole, over
// two faces or more (a crease, where the surface bends and one face's footprint stands for a
// texel shaped otherwise): the texel's part in each face (chart_faces'; parts under least of
// the texel left out, the rest's shares renormalised), as the box of the same mean and
// covariance. Returns (sample (k,) int64 the row of each part's sample, face (k,) int32,
// share (k,), uv (k, 2) the part's centre, edges (k, 4) its box's edges as columns, texel
// units, row-major), the parts of a sample together; no parts for a sample whose face does not
// bend (bends (m,): false), a texel inside its face, partly covered (the cut's: footprint_clip),
// or covered more than once (overlapping UVs), nor, given steps (m, 6), one none of whose parts
// bends from its own face by kink (most texels of a bending face: bunny.ply at 512², 63k parts
// of 172k; made and dropped in Python before, they were half the crease stage's time).
nb::tuple texel_parts(In<int32_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, In<double, shape<-1, 2>> uv,
                      In<int64_t, shape<-1, 3>> faces, In<int64_t, nb::ndim<1>> chart, In<double, shape<4>> box, int64_t nx,
                      int64_t ny, In<int64_t, nb::ndim<1>> start, In<int32_t, nb::ndim<1>> listed, In<bool, nb::ndim<1>> bends,
                      int64_t width, int64_t height, double least, In<double, shape<-1, 6>> steps, double kink) {
  const int64_t n = face.shape(0);
  const Atlas atlas(uv, faces);
  if (int64_t(bary.shape(0)) != n || int64_t(bends.shape(0)) != atlas.m ||
      (steps.shape(0) != 0 && int64_t(steps.shape(0)) != atlas.m))
    throw std::invalid_argument("texel_parts: face, bary of n rows, bends of m, steps of m rows or none");
  // whether a part in face g bends from the sample's face f: either step differs by more than
  // kink of f's longer step (creases.py's test, its arithmetic); without steps, every part does
  auto bent = [&](int64_t f, int64_t g) {
    if (steps.shape(0) == 0) return true;
    const double *own = steps.data() + 6 * f, *other = steps.data() + 6 * g;
    return step_change(own, other) / std::max(longer_step(own), 1e-300) > kink;
  };
  const Cells cells = cells_of(atlas, chart, box, nx, ny, start, listed);
  std::vector<int64_t> sample;
  std::vector<int32_t> part_face;
  std::vector<double> share, part_uv, part_edges;
  {
    nb::gil_scoped_release release;
    const double w = double(width), h = double(height);
    std::vector<std::pair<int64_t, Moments>> parts;
    for (int64_t i = 0; i < n; ++i) {
      const int64_t f = face.data()[i];
      if (f < 0) continue;
      if (f >= atlas.m) throw std::invalid_argument("texel_parts: a face outside the atlas");
      if (!bends.data()[f]) continue;
      const TexelFrame local(atlas, f, bary.data() + 3 * i, w, h);
      double tri[6];
      local(f, tri);
      if (texel_inside(tri)) continue;
      parts.clear();
      const bool all = chart_faces(atlas, cells, f, local, [&](int64_t g, const double* t) {
        Moments m;
        add_clipped(t, m);
        if (m.a > 0) parts.emplace_back(g, m);
      }, PARTS_FACES);
      double total = 0.0, kept = 0.0;
      for (const auto& [g, m] : parts) total += m.a;
      if (!all || !(total >= 1.0 - 1e-9) || total > 1.0 + 1e-9) continue;
      int count = 0;
      bool bends_here = false;
      for (const auto& [g, m] : parts)
        if (m.a >= least) kept += m.a, ++count, bends_here = bends_here || bent(f, g);
      if (count < 2 || !bends_here) continue;
      for (const auto& [g, m] : parts) {
        if (m.a < least) continue;
        double centre[2], e[4];
        box_of(m, centre, e);
        sample.push_back(i);
        part_face.push_back(int32_t(g));
        share.push_back(m.a / kept);
        part_uv.push_back((local.col + 0.5 + centre[0]) / w);
        part_uv.push_back(1.0 - (local.row + 0.5 + centre[1]) / h);
        part_edges.insert(part_edges.end(), e, e + 4);
      }
    }
  }
  const size_t k = sample.size();
  return nb::make_tuple(owned(std::move(sample), {k}), owned(std::move(part_face), {k}), owned(std::move(share), {k}),
                        owned(std::move(part_uv), {k, 2}), owned(std::move(part_edges), {k, 4}));
}

constexpr int HULL = 8;  // corners of a cut texel's convex hull kept (more: no hull)

// Per partly covered sample (face, bary; shift, edges: footprint_clip's for it): the convex
// hull of the part of its texel that its chart covers, its corners (a, b) in the box's own
// frame (the point p + a dpdx' + b dpdy' of the cut footprint: local = shift + E (a, b)),
// counter-clockwise, the rest of its HULL rows NaN; all NaN where the hull has more corners,
// the box no area, or the texel is whole.
void footprint_hull(In<int32_t, nb::ndim<1>> face, In<double, shape<-1, 3>> bary, In<double, shape<-1, 2>> uv,
                    In<int64_t, shape<-1, 3>> faces, In<int64_t, nb::ndim<1>> chart, In<double, shape<4>> box, int64_t nx,
                    int64_t ny, In<int64_t, nb::ndim<1>> start, In<int32_t, nb::ndim<1>> listed, int64_t width, int64_t height,
                    In<double, shape<-1, 2>> shift, In<double, shape<-1, 4>> edges, Out<double, shape<-1, HULL, 2>> hull) {
  const int64_t n = face.shape(0);
  const Atlas atlas(uv, faces);
  if (int64_t(bary.shape(0)) != n || int64_t(shift.shape(0)) != n || int64_t(edges.shape(0)) != n ||
      int64_t(hull.shape(0)) != n)
    throw std::invalid_argument("footprint_hull: face, bary, shift, edges, hull of n rows");
  const Cells cells = cells_of(atlas, chart, box, nx, ny, start, listed);
  const double w = double(width), h = double(height), nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> corners;
  double local_hull[2 * HULL];
  for (int64_t i = 0; i < n; ++i) {
    double* out = hull.data() + 2 * HULL * i;
    std::fill(out, out + 2 * HULL, nan);
    const int64_t f = face.data()[i];
    if (f < 0) continue;
    if (f >= atlas.m) throw std::invalid_argument("footprint_hull: a face outside the atlas");
    const TexelFrame local(atlas, f, bary.data() + 3 * i, w, h);
    corners.clear();
    const Moments sum = chart_part(atlas, cells, f, local, &corners);
    const double* e = edges.data() + 4 * i;
    const double det = e[0] * e[3] - e[1] * e[2];
    if (!(sum.a < 1.0 - 1e-9) || !(sum.a > 1e-12) || !(std::fabs(det) > 1e-12)) continue;
    const int k = convex_hull(corners, local_hull, HULL);
    if (k < 3 || k > HULL) continue;
    const double* sh = shift.data() + 2 * i;
    for (int c = 0; c < k; ++c) {  // (a, b) = E^-1 (local - shift)
      const double x = local_hull[2 * c] - sh[0], y = local_hull[2 * c + 1] - sh[1];
      out[2 * c] = (e[3] * x - e[1] * y) / det;
      out[2 * c + 1] = (-e[2] * x + e[0] * y) / det;
    }
  }
}

}  // namespace

void bind_lookup(nb::module_& m) {
  m.def("sample_uv", &sample_uv, nb::arg("texels"), nb::arg("start"), nb::arg("width"), nb::arg("height"), nb::arg("offsets"),
        nb::arg("out").noconvert(), Release(),
        "out[t * s + k] = ((col + dx_k) / width, 1 - (row + dy_k) / height) of texel t at (row, col), its tile from row start.");
  m.def("hits", &hits, nb::arg("face"), nb::arg("bary"), nb::arg("index").noconvert(), nb::arg("found").noconvert(),
        nb::arg("coords").noconvert(), Release(), "The rows of face >= 0, in order: their index, face and bary.");
  m.def("touched", &touched, nb::arg("uv"), nb::arg("faces"), nb::arg("near"), nb::arg("width"), nb::arg("height"),
        nb::arg("start"), nb::arg("rows"), nb::arg("margin"), nb::arg("out").noconvert(), Release(),
        "Set out (rows * width,) where a texel's square comes within margin texels of a UV triangle faces[near].");
  m.def("row_range", &row_range, nb::arg("uv"), nb::arg("faces"), nb::arg("height"), nb::arg("margin"), nb::arg("top").noconvert(),
        nb::arg("bottom").noconvert(), Release(), "Fill top, bottom (m,) with the texel rows each UV triangle touches.");
  m.def("walk", &walk, nb::arg("points"), nb::arg("face").noconvert(), nb::arg("uv"), nb::arg("faces"), nb::arg("across"),
        nb::arg("steps"), nb::arg("bary").noconvert(), nb::arg("inside").noconvert(), Release(),
        "Each point's barycentrics in its face, walking across UV edges (at most steps faces) to the face holding it.");
  m.def("grid_count", &grid_count, nb::arg("uv"), nb::arg("faces"), nb::arg("usable"), nb::arg("lo_u"), nb::arg("lo_v"),
        nb::arg("inv_u"), nb::arg("inv_v"), nb::arg("nx"), nb::arg("ny"), nb::arg("count").noconvert(), Release(),
        "count (nx * ny + 1,) := each cell's start in the grid's face list (the usable faces' UV boxes), then its total.");
  m.def("grid_fill", &grid_fill, nb::arg("uv"), nb::arg("faces"), nb::arg("usable"), nb::arg("lo_u"), nb::arg("lo_v"),
        nb::arg("inv_u"), nb::arg("inv_v"), nb::arg("nx"), nb::arg("ny"), nb::arg("start"), nb::arg("listed").noconvert(),
        Release(), "listed := the faces of each grid cell, in increasing order, from start (grid_count's).");
  m.def("grid_locate", &grid_locate, nb::arg("points"), nb::arg("uv"), nb::arg("faces"), nb::arg("lo_u"), nb::arg("lo_v"),
        nb::arg("inv_u"), nb::arg("inv_v"), nb::arg("nx"), nb::arg("ny"), nb::arg("start"), nb::arg("listed"),
        nb::arg("face").noconvert(), Release(),
        "face (n,) := the first face of each point's grid cell that holds it (watertight edge tests), -1 where none does.");
  m.def("barycentric", &barycentric, nb::arg("points"), nb::arg("face"), nb::arg("uv"), nb::arg("faces"),
        nb::arg("bary").noconvert(), nb::arg("inside").noconvert(), Release(),
        "Each point's barycentrics in its face (clamped, renormalised) and whether it lies inside; face -1 rows left.");
  m.def("border_texels", &border_texels, nb::arg("uv"), nb::arg("faces"), nb::arg("across"), nb::arg("usable"),
        nb::arg("width"), nb::arg("height"), "Sorted (k,) int64 texels (row * width + col) that a chart's border edge touches.");
  m.def("footprint_clip", &footprint_clip, nb::arg("face"), nb::arg("bary"), nb::arg("uv"), nb::arg("faces"), nb::arg("chart"),
        nb::arg("box"), nb::arg("nx"), nb::arg("ny"), nb::arg("start"), nb::arg("listed"), nb::arg("border"), nb::arg("width"),
        nb::arg("height"), nb::arg("shift").noconvert(), nb::arg("edges").noconvert(),
        nb::arg("area").noconvert(), Release(),
        "The part of each sample's texel its chart covers, as a box of its mean and covariance: shift (n, 2), edges "
        "(n, 4: columns its edges, texel units), area (n,); returns the number of partly covered samples.");
  m.def("texel_parts", &texel_parts, nb::arg("face"), nb::arg("bary"), nb::arg("uv"), nb::arg("faces"), nb::arg("chart"),
        nb::arg("box"), nb::arg("nx"), nb::arg("ny"), nb::arg("start"), nb::arg("listed"), nb::arg("bends"), nb::arg("width"),
        nb::arg("height"), nb::arg("least"), nb::arg("steps"), nb::arg("kink"),
        "(sample, face, share, uv, edges): the part of each sample's texel in each face of its chart, where the chart covers "
        "the texel whole over two faces or more, as boxes of their mean and covariance (parts under least left out); with "
        "steps (m, 6: each face's dpdx, dpdy), only texels with a part whose steps differ from its sample's by more than kink.");
  m.def("footprint_hull", &footprint_hull, nb::arg("face"), nb::arg("bary"), nb::arg("uv"), nb::arg("faces"), nb::arg("chart"),
        nb::arg("box"), nb::arg("nx"), nb::arg("ny"), nb::arg("start"), nb::arg("listed"), nb::arg("width"), nb::arg("height"),
        nb::arg("shift"), nb::arg("edges"), nb::arg("hull").noconvert(), Release(),
        "hull (n, 8, 2): the convex hull of the part of each (partly covered) sample's texel its chart covers, in the frame "
        "of footprint_clip's box (shift, edges), NaN-padded; all NaN where it has more corners or the texel is whole.");
}

}  // namespace texbake
