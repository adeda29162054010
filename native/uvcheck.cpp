// UV checks: the faces over each texel centre of a UV layout, rasterised with the top-left
// rule (texbake/atlas/uvcheck.py).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <cstdint>
#include <vector>

#include "arrays.hpp"
#include "parallel.hpp"
#include "slits.hpp"
#include "unionfind.hpp"

namespace texbake {
namespace {

using Array = nb::ndarray<nb::numpy, int64_t>;

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

// visit(face, texel index) for each texel centre of rows [row0, row1) that a face of the
// layout covers (top-left rule); a visit returning true stops the walk
template <class Visit>
inline void walk_rows(const double* uv, const int64_t* faces, int64_t m, int64_t size, int64_t row0, int64_t row1,
                      Visit&& visit) {
  for (int64_t f = 0; f < m; ++f) {
    const int64_t* v = faces + 3 * f;
    const double x0 = uv[2 * v[0]] * size, y0 = (1.0 - uv[2 * v[0] + 1]) * size;
    double x1 = uv[2 * v[1]] * size, y1 = (1.0 - uv[2 * v[1] + 1]) * size;
    double x2 = uv[2 * v[2]] * size, y2 = (1.0 - uv[2 * v[2] + 1]) * size;
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
      for (int64_t c = a; c <= b; ++c) {
        const double px = c + 0.5;
        const double w0 = edge(x1, y1, x2, y2, px, py);
        const double w1 = edge(x2, y2, x0, y0, px, py);
        const double w2 = edge(x0, y0, x1, y1, px, py);
        if ((w0 > 0 || (w0 == 0 && own0)) && (w1 > 0 || (w1 == 0 && own1)) && (w2 > 0 || (w2 == 0 && own2))) {
          if (visit(f, r * size + c)) return;
        }
      }
    }
  }
}

// the faces over the rows [row0, row1): count them in, or flag those over a centre counted twice
TEXBAKE_AVX2_CLONE void raster_rows(const Layout& l, int64_t row0, int64_t row1, uint8_t* flags) {
  walk_rows(l.uv, l.faces, l.m, l.size, row0, row1, [&](int64_t f, int64_t texel) {
    if (l.count) {
      ++l.counts[texel];
      flags[f] = 1;
    } else if (l.counts[texel] > 1) {
      flags[f] = 1;
    }
    return false;
  });
}

// Planar charts' merge of cut pieces (texbake/atlas/charts.py, _merge_cuts): the candidate
// pairs of islands in order, each pair's sets joined where their union, projected on the
// first's plane and scaled to texels, covers no texel centre twice, within a budget of faces
// rasterised. Here, not in charts.cpp, for the rasteriser: one walk per pair, stopped at the
// first centre covered twice, on a grid of stamps (no grid cleared or allocated per pair).
// Each value is computed as the numpy it replaced computed it, but the projection's
// three-term dot product (BLAS may fuse it).
struct Stamps {
  std::vector<uint32_t> stamp;  // the pair that last covered each texel
  uint32_t now = 0;
};

TEXBAKE_AVX2_CLONE bool covers_twice(const std::vector<double>& uv, int64_t m, int64_t size, Stamps& grid) {
  if (grid.stamp.size() < size_t(size * size)) grid.stamp.assign(size_t(size * size), grid.now);
  ++grid.now;
  if (grid.now == 0) {  // wrapped round: start afresh
    std::fill(grid.stamp.begin(), grid.stamp.end(), 0);
    grid.now = 1;
  }
  std::vector<int64_t> corners(3 * m);
  for (int64_t i = 0; i < 3 * m; ++i) corners[i] = i;
  bool twice = false;
  walk_rows(uv.data(), corners.data(), m, size, 0, size, [&](int64_t, int64_t texel) {
    if (grid.stamp[texel] == grid.now) return twice = true;
    grid.stamp[texel] = grid.now;
    return false;
  });
  return twice;
}

Array merged_islands(In<double, shape<-1, 3>> vertices, In<int64_t, shape<-1, 3>> faces, In<int64_t, nb::ndim<1>> island,
                     In<int64_t, nb::ndim<1>> direction, In<double, shape<-1, 2, 3>> bases, In<int64_t, shape<-1, 2>> pairs,
                     double texels_per_unit, int64_t budget, double slit_r, double slit_chart) {
  const int64_t m = faces.shape(0), n = vertices.shape(0), k = direction.shape(0), d = bases.shape(0);
  if (int64_t(island.shape(0)) != m) throw std::invalid_argument("merged_islands: island of m");
  for (int64_t i = 0; i < 3 * m; ++i) {
    if (faces.data()[i] < 0 || faces.data()[i] >= n) throw std::invalid_argument("merged_islands: a face indexes a missing vertex");
  }
  for (int64_t i = 0; i < m; ++i) {
    if (island.data()[i] < 0 || island.data()[i] >= k) throw std::invalid_argument("merged_islands: an island outside [0, k)");
  }
  for (int64_t i = 0; i < k; ++i) {
    if (direction.data()[i] < 0 || direction.data()[i] >= d) throw std::invalid_argument("merged_islands: a direction outside [0, d)");
  }
  for (int64_t i = 0; i < 2 * int64_t(pairs.shape(0)); ++i) {
    if (pairs.data()[i] < 0 || pairs.data()[i] >= k) throw std::invalid_argument("merged_islands: a pair outside [0, k)");
  }
  std::vector<int64_t> labels(k);
  {
    nb::gil_scoped_release unlocked;
    const double* p = vertices.data();
    const int64_t* f = faces.data();
    std::vector<std::vector<int64_t>> members(k);  // each set's faces, at its root
    for (int64_t i = 0; i < m; ++i) members[island.data()[i]].push_back(i);
    std::vector<int64_t> parent(k);
    for (int64_t i = 0; i < k; ++i) parent[i] = i;
    Stamps grid;
    std::vector<double> uv;
    std::vector<SlitSample> samples;
    // each island's border: the edges (mesh vertices, as its face has them) no other face of
    // the island has, from one sort of every face's edges by (smaller end, larger end, island)
    std::vector<std::vector<std::pair<int64_t, int64_t>>> border(slit_r > 0 ? k : 0);
    if (slit_r > 0) {
      std::vector<std::array<int64_t, 4>> edges(3 * m);
      for (int64_t i = 0; i < m; ++i) {
        for (int j = 0; j < 3; ++j) {
          const int64_t x = f[3 * i + j], y = f[3 * i + (j + 1) % 3];
          edges[3 * i + j] = {std::min(x, y), std::max(x, y), island.data()[i], 3 * i + j};
        }
      }
      std::sort(edges.begin(), edges.end());
      const auto same = [&](size_t a, size_t c) { return edges[a][0] == edges[c][0] && edges[a][1] == edges[c][1] && edges[a][2] == edges[c][2]; };
      for (size_t i = 0; i < edges.size(); ++i) {
        if ((i > 0 && same(i - 1, i)) || (i + 1 < edges.size() && same(i + 1, i))) continue;
        const int64_t h = edges[i][3];
        border[edges[i][2]].push_back({f[h], f[3 * (h / 3) + (h % 3 + 1) % 3]});
      }
    }
    for (int64_t e = 0; e < int64_t(pairs.shape(0)); ++e) {
      const int64_t rx = root(parent.data(), pairs.data()[2 * e]), ry = root(parent.data(), pairs.data()[2 * e + 1]);
      const int64_t count = int64_t(members[rx].size() + members[ry].size());
      if (rx == ry || count > budget) continue;
      budget -= count;
      const double* b = bases.data() + 6 * direction.data()[rx];  // (2, 3): the plane of rx's direction
      uv.resize(size_t(6 * count));
      double lo[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
      int64_t at = 0;
      for (const int64_t r : {rx, ry}) {
        for (const int64_t face : members[r]) {
          for (int j = 0; j < 3; ++j, ++at) {
            const double* q = p + 3 * f[3 * face + j];
            for (int a = 0; a < 2; ++a) {
              uv[2 * at + a] = q[0] * b[3 * a] + q[1] * b[3 * a + 1] + q[2] * b[3 * a + 2];
              lo[a] = std::min(lo[a], uv[2 * at + a]);  // np.min: NaN aside, the same
            }
          }
        }
      }
      double most = -std::numeric_limits<double>::infinity();
      for (int64_t i = 0; i < 6 * count; ++i) {
        uv[i] = (uv[i] - lo[i % 2]) * texels_per_unit;
        most = std::max(most, uv[i]);
      }
      const int64_t side = int64_t(std::ceil(most)) + 2;
      for (double& x : uv) x /= double(side);
      if (covers_twice(uv, count, side, grid)) continue;
      // nor a slit (slits.hpp) between the two, unless the union is under slit_chart widths
      // across: the samples of one's border against the other's (each is clean; their shared
      // edges, border of both, lie on each other over the same places)
      if (slit_r > 0 && most / texels_per_unit >= slit_chart * slit_r) {
        samples.clear();
        double box[2][4];  // each side's samples' box: u lo, u hi, v lo, v hi
        for (int sd = 0; sd < 2; ++sd) {
          const size_t from = samples.size();
          for (const auto& [va, vb] : border[sd == 0 ? rx : ry]) {
            const double *pa = p + 3 * va, *pb = p + 3 * vb;
            const double ua[2] = {pa[0] * b[0] + pa[1] * b[1] + pa[2] * b[2], pa[0] * b[3] + pa[1] * b[4] + pa[2] * b[5]};
            const double ub[2] = {pb[0] * b[0] + pb[1] * b[1] + pb[2] * b[2], pb[0] * b[3] + pb[1] * b[4] + pb[2] * b[5]};
            sample_edge(samples, ua, ub, pa, pb, sd, slit_r);
          }
          box[sd][0] = box[sd][2] = std::numeric_limits<double>::infinity();
          box[sd][1] = box[sd][3] = -std::numeric_limits<double>::infinity();
          for (size_t i = from; i < samples.size(); ++i) {
            box[sd][0] = std::min(box[sd][0], samples[i].u), box[sd][1] = std::max(box[sd][1], samples[i].u);
            box[sd][2] = std::min(box[sd][2], samples[i].v), box[sd][3] = std::max(box[sd][3], samples[i].v);
          }
        }
        // only the samples within r of the other side's box can be in a pair
        size_t kept = 0;
        for (size_t i = 0; i < samples.size(); ++i) {
          const double* o = box[1 - samples[i].face];
          if (samples[i].u >= o[0] - slit_r && samples[i].u <= o[1] + slit_r && samples[i].v >= o[2] - slit_r &&
              samples[i].v <= o[3] + slit_r)
            samples[kept++] = samples[i];
        }
        samples.resize(kept);
        if (slit_pairs(samples, nullptr, slit_r, nullptr)) continue;  // "face": the side, so pairs across only
      }
      const int64_t joined = join(parent.data(), rx, ry);
      auto& into = members[joined];
      auto& from = members[joined == rx ? ry : rx];
      into.insert(into.end(), from.begin(), from.end());
      std::vector<int64_t>().swap(from);
      if (slit_r > 0) {
        auto& edges_into = border[joined];
        auto& edges_from = border[joined == rx ? ry : rx];
        edges_into.insert(edges_into.end(), edges_from.begin(), edges_from.end());
        std::vector<std::pair<int64_t, int64_t>>().swap(edges_from);
      }
    }
    number(parent.data(), k, labels.data());
  }
  return owned(std::move(labels), {size_t(k)});
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
  m.def("merged_islands", &merged_islands, nb::arg("vertices"), nb::arg("faces"), nb::arg("island"), nb::arg("direction"),
        nb::arg("bases"), nb::arg("pairs"), nb::arg("texels_per_unit"), nb::arg("budget"), nb::arg("slit_r") = 0.0,
        nb::arg("slit_chart") = 0.0,
        "(k,) labels of islands (island (m,) of each face; direction (k,) into bases (d, 2, 3)) joined pair by pair "
        "(pairs (p, 2), in order) where their union, projected and scaled to texels, covers no texel centre twice "
        "and, for slit_r > 0, has no slit (slits.hpp) of that width in mesh units where it is at least slit_chart "
        "such widths across.");
}

}  // namespace texbake
