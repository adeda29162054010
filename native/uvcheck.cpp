// UV checks: the faces over each texel centre of a UV layout, rasterised with the top-left
// rule (texbake/atlas/uvcheck.py).
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "arrays.hpp"
#include "parallel.hpp"

namespace texbake {
namespace {

// top-left rule for a counter-clockwise edge a -> b (y down)
inline bool edge_owns(double ax, double ay, double bx, double by) { return (ay == by && bx < ax) || by < ay; }

// the edge function of a -> b at p, computed from the edge's lesser end whichever way it
// runs: exactly antisymmetric, so a centre on an edge two faces share goes to one of them
inline double edge(double ax, double ay, double bx, double by, double px, double py) {
  if (ax > bx || (ax == bx && ay > by)) return -((ax - bx) * (py - by) - (ay - by) * (px - bx));
  return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

// narrows [lo, hi], the x-interval of the row at py inside a counter-clockwise triangle,
// by its edge a -> b's crossing (a sliver's row is not walked end to end; the exact test
// is still made per texel)
inline void cross(double xa, double ya, double xb, double yb, double py, double& lo, double& hi) {
  const double dy = yb - ya;  // inside: (xb - xa) * (py - ya) - dy * (px - xa) >= 0
  if (dy == 0.0) return;
  const double root = xa + (xb - xa) * (py - ya) / dy;
  if (dy > 0.0) hi = std::min(hi, root);
  else lo = std::max(lo, root);
}

// floor/ceil of a texel bound as an index clamped into [lo, hi] (as a double first: a bound
// far outside the grid is no integer)
inline int64_t clamped(double v, int64_t lo, int64_t hi) {
  return int64_t(std::min(std::max(v, double(lo)), double(hi)));
}

// an AVX2 build beside the portable one, chosen when the module loads (no FMA in either)
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define TEXBAKE_AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#else
#define TEXBAKE_AVX2_CLONE
#endif

struct Layout {
  const double* uv;
  const int64_t* faces;
  int64_t m, size;
  uint16_t* counts;
  bool count;
};

// the faces over the rows [row0, row1): count them in, or flag those over a centre counted twice
TEXBAKE_AVX2_CLONE void raster_rows(const Layout& l, int64_t row0, int64_t row1, uint8_t* flags) {
  const int64_t size = l.size;
  for (int64_t f = 0; f < l.m; ++f) {
    const int64_t* v = l.faces + 3 * f;
    const double x0 = l.uv[2 * v[0]] * size, y0 = (1.0 - l.uv[2 * v[0] + 1]) * size;
    double x1 = l.uv[2 * v[1]] * size, y1 = (1.0 - l.uv[2 * v[1] + 1]) * size;
    double x2 = l.uv[2 * v[2]] * size, y2 = (1.0 - l.uv[2 * v[2] + 1]) * size;
    const double area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    if (area == 0.0 || !std::isfinite(area)) continue;  // not finite: no centre passes the tests below either
    if (area < 0.0) {  // make it counter-clockwise
      std::swap(x1, x2);
      std::swap(y1, y2);
    }
    const int64_t r0 = std::max(row0, clamped(std::ceil(std::min({y0, y1, y2}) - 0.5), 0, size));
    const int64_t r1 = std::min(row1 - 1, clamped(std::floor(std::max({y0, y1, y2}) - 0.5), -1, size - 1));
    if (r0 > r1) continue;
    const int64_t c0 = clamped(std::ceil(std::min({x0, x1, x2}) - 0.5), 0, size);
    const int64_t c1 = clamped(std::floor(std::max({x0, x1, x2}) - 0.5), -1, size - 1);
    const bool own0 = edge_owns(x1, y1, x2, y2), own1 = edge_owns(x2, y2, x0, y0), own2 = edge_owns(x0, y0, x1, y1);
    for (int64_t r = r0; r <= r1; ++r) {
      const double py = r + 0.5;
      double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
      cross(x1, y1, x2, y2, py, lo, hi);  // the row's inside, give or take a texel
      cross(x2, y2, x0, y0, py, lo, hi);
      cross(x0, y0, x1, y1, py, lo, hi);
      const int64_t a = std::max(c0, clamped(std::floor(lo - 0.5), -1, size));
      const int64_t b = std::min(c1, clamped(std::ceil(hi - 0.5), -1, size));
      uint16_t* row = l.counts + r * size;
      for (int64_t c = a; c <= b; ++c) {
        const double px = c + 0.5;
        const double w0 = edge(x1, y1, x2, y2, px, py);
        const double w1 = edge(x2, y2, x0, y0, px, py);
        const double w2 = edge(x0, y0, x1, y1, px, py);
        if ((w0 > 0 || (w0 == 0 && own0)) && (w1 > 0 || (w1 == 0 && own1)) && (w2 > 0 || (w2 == 0 && own2))) {
          if (l.count) {
            ++row[c];
            flags[f] = 1;
          } else if (row[c] > 1) {
            flags[f] = 1;
          }
        }
      }
    }
  }
}

void raster(In<double, shape<-1, 2>> uv, In<int64_t, shape<-1, 3>> faces, int64_t size,
            Out<uint16_t, nb::ndim<2>> counts, Out<bool, nb::ndim<1>> flags, bool count) {
  const int64_t m = faces.shape(0), k = uv.shape(0);
  if (int64_t(counts.shape(0)) != size || int64_t(counts.shape(1)) != size || int64_t(flags.shape(0)) != m)
    throw std::invalid_argument("raster: counts must be (size, size) and flags (m,)");
  for (int64_t i = 0; i < 3 * m; ++i) {
    if (faces.data()[i] < 0 || faces.data()[i] >= k) throw std::invalid_argument("raster: a face indexes a missing UV vertex");
  }
  const Layout layout{uv.data(), faces.data(), m, size, counts.data(), count};
  // row bands in threads, each over every face; each band's own flags, or-ed after
  const int64_t pieces = std::max<int64_t>(1, std::min<int64_t>(cores(), size * size / MIN_PIECE));
  std::vector<std::vector<uint8_t>> band_flags(pieces, std::vector<uint8_t>(m, 0));
  const int64_t rows = (size + pieces - 1) / pieces;
  parallel_for(pieces, [&](std::ptrdiff_t p0, std::ptrdiff_t p1) {
    for (std::ptrdiff_t p = p0; p < p1; ++p) raster_rows(layout, p * rows, std::min(size, (p + 1) * rows), band_flags[p].data());
  }, 1);
  bool* out = flags.data();
  for (const auto& band : band_flags) {
    for (int64_t f = 0; f < m; ++f) out[f] = out[f] || band[f];
  }
}

}  // namespace

void bind_uvcheck(nb::module_& m) {
  m.def("raster", &raster, nb::arg("uv"), nb::arg("faces"), nb::arg("size"), nb::arg("counts").noconvert(),
        nb::arg("flags").noconvert(), nb::arg("count"), Release(),
        "count: add each face of a UV layout to counts (size, size) uint16 at the texel centres it covers "
        "(top-left rule) and flag the faces that cover one; else flag the faces over a centre counted twice.");
}

}  // namespace texbake
