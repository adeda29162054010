// Planar charts' loops (texbake/atlas/charts.py): the faces that share an edge, the charts'
// outlines as loops of vertices, and Douglas-Peucker simplification of the loops, for one
// chart or one loop, or for all of them in one call (the packing proxies of a CAD part's
// thousand charts: one call each had cost more than the work). Each gives
// what the numpy it replaced gave, element for element and in the same order (the atlas must
// not change with the port), in time linear in its input where numpy sorted or looped in
// Python.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include "arrays.hpp"
#include "grouping.hpp"
#include "slits.hpp"

namespace texbake {
namespace {

using Array = nb::ndarray<nb::numpy, int64_t>;
using Faces = In<int64_t, shape<-1, 3>>;

// the corners (j, j + 1 mod 3) of half-edge j of a face: faces[:, [0, 1, 1, 2, 2, 0]]'s order
constexpr int FROM[3] = {0, 1, 2}, TO[3] = {1, 2, 0};

void check_corners(const int64_t* f, int64_t m, const char* what) {
  for (int64_t i = 0; i < 3 * m; ++i) {
    if (f[i] < 0) throw std::invalid_argument(std::string(what) + ": a negative vertex index");
  }
}

// The half-edges of faces f (m, 3), vertices below n, bucketed by their smaller end (a counting
// sort) and each bucket sorted by (larger end, half-edge): order[start[v]:start[v + 1]] holds
// (larger end, half-edge) of the half-edges whose smaller end is v, numpy's stable argsort of
// e0 * (n + 1) + e1. Shared by the faces that share an edge and by the charts' borders.
void sorted_half_edges(const int64_t* f, int64_t m, int64_t n, std::vector<int64_t>& start,
                       std::vector<std::pair<int64_t, int64_t>>& order) {
  start.assign(n + 1, 0);
  for (int64_t h = 0; h < 3 * m; ++h) ++start[std::min(f[3 * (h / 3) + FROM[h % 3]], f[3 * (h / 3) + TO[h % 3]]) + 1];
  for (int64_t v = 0; v < n; ++v) start[v + 1] += start[v];
  order.resize(3 * m);
  std::vector<int64_t> fill(start.begin(), start.end() - 1);
  for (int64_t h = 0; h < 3 * m; ++h) {
    const int64_t x = f[3 * (h / 3) + FROM[h % 3]], y = f[3 * (h / 3) + TO[h % 3]];
    order[fill[std::min(x, y)]++] = {std::max(x, y), h};
  }
  for (int64_t v = 0; v < n; ++v) std::sort(order.begin() + start[v], order.begin() + start[v + 1]);
}

// (a, b): the faces of consecutive half-edges on one undirected edge, the half-edges ordered
// by (smaller end, larger end, half-edge) (sorted_half_edges).
std::tuple<Array, Array> face_pairs(Faces faces) {
  const int64_t m = faces.shape(0);
  const int64_t* f = faces.data();
  check_corners(f, m, "edge_pairs");
  std::vector<int64_t> a, b;
  {
    nb::gil_scoped_release unlocked;
    int64_t n = 0;
    for (int64_t i = 0; i < 3 * m; ++i) n = std::max(n, f[i] + 1);
    std::vector<int64_t> start;
    std::vector<std::pair<int64_t, int64_t>> order;
    sorted_half_edges(f, m, n, start, order);
    for (int64_t v = 0; v < n; ++v) {
      for (int64_t i = start[v]; i + 1 < start[v + 1]; ++i) {
        if (order[i].first == order[i + 1].first) {
          a.push_back(order[i].second / 3);
          b.push_back(order[i + 1].second / 3);
        }
      }
    }
  }
  const size_t e = a.size();
  return {owned(std::move(a), {e}), owned(std::move(b), {e})};
}

// The outlines of charts: chart c's faces are f[3 * starts[c]:3 * starts[c + 1]]. Each
// chart's border edges (directed edges whose reverse no face of that chart has) walked into
// loops, each from the first border edge not yet walked, in the border's order
// (faces[:, [0, 1, 1, 2, 2, 0]]), appended to ring and lengths; loops[c], the count of
// chart c's loops, or -1 where its outline is not simple loops (no border, a vertex starting
// two border edges, a border that ends or runs into another loop: none of its loops kept).
// Linear: the half-edges leaving each vertex in one counting sort over every chart, and
// per-vertex arrays reset after each chart, not a hash table a chart.
void walk_outlines(const int64_t* f, const int64_t* starts, int64_t k, std::vector<int64_t>& ring,
                   std::vector<int64_t>& lengths, std::vector<int64_t>& loops) {
  const int64_t m = k > 0 ? starts[k] : 0;
  int64_t n = 0;
  for (int64_t i = 3 * starts[0]; i < 3 * m; ++i) n = std::max(n, f[i] + 1);
  std::vector<int64_t> first(n + 1, 0), leaving(3 * m);  // the half-edges leaving each vertex
  for (int64_t h = 3 * starts[0]; h < 3 * m; ++h) ++first[f[3 * (h / 3) + FROM[h % 3]] + 1];
  for (int64_t v = 0; v < n; ++v) first[v + 1] += first[v];
  {
    std::vector<int64_t> fill(first.begin(), first.end() - 1);
    for (int64_t h = 3 * starts[0]; h < 3 * m; ++h) leaving[fill[f[3 * (h / 3) + FROM[h % 3]]]++] = h;
  }
  // each vertex's leaving half-edges by where they go (then by half-edge): the reverse of an edge
  // is found by a binary search, not a scan of its end's fan (a cylinder cap's centre leaves by
  // 200k half-edges, each looked for from it: 4e10 steps, minutes)
  const auto to = [&](int64_t h) { return f[3 * (h / 3) + TO[h % 3]]; };
  for (int64_t v = 0; v < n; ++v)
    if (first[v + 1] - first[v] > 1)
      std::sort(leaving.begin() + first[v], leaving.begin() + first[v + 1],
                [&](int64_t a, int64_t b) { return to(a) != to(b) ? to(a) < to(b) : a < b; });
  std::vector<int64_t> after(n, -1);  // a border edge's end, by its start
  std::vector<uint8_t> seen(n, 0);
  std::vector<int64_t> border;
  loops.assign(k, -1);
  for (int64_t c = 0; c < k; ++c) {
    const int64_t lo = 3 * starts[c], hi = 3 * starts[c + 1];
    border.clear();
    bool simple = true;
    for (int64_t h = lo; h < hi && simple; ++h) {
      const int64_t x = f[3 * (h / 3) + FROM[h % 3]], y = f[3 * (h / 3) + TO[h % 3]];
      bool reversed = false;  // y -> x in this chart
      const auto from_y = leaving.begin() + first[y], end_y = leaving.begin() + first[y + 1];
      for (auto i = std::lower_bound(from_y, end_y, x, [&](int64_t g, int64_t target) { return to(g) < target; });
           i != end_y && to(*i) == x && !reversed; ++i)
        reversed = *i >= lo && *i < hi;
      if (reversed) continue;
      if (after[x] >= 0) simple = false;  // two border edges from one vertex
      else after[x] = y, border.push_back(x);
    }
    simple = simple && !border.empty();
    const size_t ring_size = ring.size(), loop_count = lengths.size();
    for (size_t b = 0; b < border.size() && simple; ++b) {
      const int64_t s = border[b];
      if (seen[s]) continue;
      int64_t v = s, length = 0;
      while (!seen[v]) {
        seen[v] = 1;
        ring.push_back(v);
        ++length;
        v = after[v];
        if (v < 0) {
          simple = false;
          break;
        }
      }
      if (!simple || v != s) simple = false;
      else lengths.push_back(length);
    }
    for (const int64_t x : border) after[x] = -1, seen[x] = 0;  // every vertex walked starts a border edge
    for (size_t i = ring_size; i < ring.size(); ++i) seen[ring[i]] = 0;
    if (simple) {
      loops[c] = int64_t(lengths.size() - loop_count);
    } else {
      ring.resize(ring_size);
      lengths.resize(loop_count);
    }
  }
}

// One chart's outline (walk_outlines): (ring, lengths), or None where it is not simple loops.
std::optional<std::tuple<Array, Array>> outline_loops(Faces faces) {
  const int64_t m = faces.shape(0);
  const int64_t* f = faces.data();
  check_corners(f, m, "outline_loops");
  std::vector<int64_t> ring, lengths, loops;
  {
    nb::gil_scoped_release unlocked;
    const int64_t starts[2] = {0, m};
    walk_outlines(f, starts, 1, ring, lengths, loops);
  }
  if (loops[0] < 0) return std::nullopt;
  const size_t r = ring.size(), l = lengths.size();
  return std::tuple<Array, Array>{owned(std::move(ring), {r}), owned(std::move(lengths), {l})};
}

// Many charts' outlines at once: the faces of chart c are faces[starts[c]:starts[c + 1]]
// (walk_outlines). (ring, lengths, loops): the loops one chart after the other, and each
// chart's count of loops, -1 for a chart whose outline is not simple loops (none in ring).
std::tuple<Array, Array, Array> outlines(Faces faces, In<int64_t, shape<-1>> starts) {
  const int64_t m = faces.shape(0), k = int64_t(starts.shape(0)) - 1;
  const int64_t* f = faces.data();
  const int64_t* st = starts.data();
  check_corners(f, m, "outlines");
  if (k < 0 || (k > 0 && st[0] != 0)) throw std::invalid_argument("outlines: starts must begin at 0");
  for (int64_t c = 0; c < k; ++c) {
    if (st[c] > st[c + 1] || st[c + 1] > m) throw std::invalid_argument("outlines: starts out of order or range");
  }
  std::vector<int64_t> ring, lengths, loops;
  {
    nb::gil_scoped_release unlocked;
    if (k > 0) walk_outlines(f, st, k, ring, lengths, loops);
  }
  const size_t r = ring.size(), l = lengths.size(), n = loops.size();
  return {owned(std::move(ring), {r}), owned(std::move(lengths), {l}), owned(std::move(loops), {n})};
}

// The indices (from 0) of a closed loop's n >= 3 points p (x, y interleaved) that
// Douglas-Peucker keeps within tolerance, ascending (at least three), appended to out: from
// point 0 and the point farthest from it, each chain split at its point farthest from its
// chord while that is farther than tolerance. Each distance is computed as the numpy it
// replaced computed it (same operations, same order).
void douglas_peucker(const double* p, int64_t n, double tolerance, std::vector<int64_t>& out) {
  std::vector<uint8_t> keep(n, 0);
  int64_t far = 0;
  double best = -1.0;
  for (int64_t i = 0; i < n; ++i) {
    const double dx = p[2 * i] - p[0], dy = p[2 * i + 1] - p[1];
    const double d = std::sqrt(dx * dx + dy * dy);
    if (d > best) best = d, far = i;  // np.argmax: the first of equals
  }
  keep[0] = keep[far] = 1;
  std::vector<std::pair<int64_t, int64_t>> stack{{0, far}, {far, n}};  // chains i..j (j == n: back to 0)
  while (!stack.empty()) {
    const auto [i, j] = stack.back();
    stack.pop_back();
    if (j - i < 2) continue;
    const double ax = p[2 * i], ay = p[2 * i + 1], bx = p[2 * (j % n)], by = p[2 * (j % n) + 1];
    const double d0 = bx - ax, d1 = by - ay;
    const double length = std::hypot(d0, d1);
    int64_t worst = -1;
    double most = 0.0;
    for (int64_t k = i + 1; k < j; ++k) {
      double dist;
      if (length > 0) {
        dist = std::fabs(d0 * (p[2 * k + 1] - ay) - d1 * (p[2 * k] - ax)) / length;
      } else {
        const double ex = p[2 * k] - ax, ey = p[2 * k + 1] - ay;
        dist = std::sqrt(ex * ex + ey * ey);
      }
      if (worst < 0 || dist > most) most = dist, worst = k;
    }
    if (most > tolerance) {
      keep[worst] = 1;
      stack.push_back({i, worst});
      stack.push_back({worst, j});
    }
  }
  int64_t kept = 0;
  for (int64_t i = 0; i < n; ++i) kept += keep[i];
  if (kept < 3) keep[0] = keep[(n - 1) / 2] = keep[n - 1] = 1;  // np.linspace(0, n - 1, 3).astype(int)
  for (int64_t i = 0; i < n; ++i) {
    if (keep[i]) out.push_back(i);
  }
}

Array simplified(In<double, shape<-1, 2>> points, double tolerance) {
  const int64_t n = points.shape(0);
  if (n < 3) throw std::invalid_argument("simplified: a loop of at least three points");
  std::vector<int64_t> out;
  {
    nb::gil_scoped_release unlocked;
    douglas_peucker(points.data(), n, tolerance, out);
  }
  const size_t k = out.size();
  return owned(std::move(out), {k});
}

// Many loops at once: loop i is points[sum(lengths[:i]):][:lengths[i]], simplified as
// simplified() does where tolerances[i] > 0, else kept whole. (kept, counts): the indices
// into points kept, loop after loop, and each loop's count.
std::tuple<Array, Array> simplified_loops(In<double, shape<-1, 2>> points, In<int64_t, shape<-1>> lengths,
                                          In<double, shape<-1>> tolerances) {
  const int64_t l = lengths.shape(0);
  if (int64_t(tolerances.shape(0)) != l) throw std::invalid_argument("simplified_loops: a tolerance a loop");
  const int64_t* len = lengths.data();
  int64_t total = 0;
  for (int64_t i = 0; i < l; ++i) {
    if (len[i] < 3) throw std::invalid_argument("simplified_loops: loops of at least three points");
    total += len[i];
  }
  if (total != int64_t(points.shape(0))) throw std::invalid_argument("simplified_loops: the lengths do not add up to the points");
  std::vector<int64_t> kept, counts(l);
  {
    nb::gil_scoped_release unlocked;
    const double* p = points.data();
    const double* tol = tolerances.data();
    std::vector<int64_t> one;
    int64_t first = 0;
    for (int64_t i = 0; i < l; ++i) {
      if (tol[i] > 0) {
        one.clear();
        douglas_peucker(p + 2 * first, len[i], tol[i], one);
        for (const int64_t j : one) kept.push_back(first + j);
        counts[i] = int64_t(one.size());
      } else {
        for (int64_t j = 0; j < len[i]; ++j) kept.push_back(first + j);
        counts[i] = len[i];
      }
      first += len[i];
    }
  }
  const size_t r = kept.size();
  return {owned(std::move(kept), {r}), owned(std::move(counts), {size_t(l)})};
}

// The faces of a planar chart layout on either side of a slit (slits.hpp); faces of a
// negative chart are not looked at. The border: undirected edges of one half-edge
// (sorted_half_edges).
void slit_faces(In<double, shape<-1, 2>> uv, In<double, shape<-1, 3>> points, In<int64_t, shape<-1, 3>> faces,
                In<int64_t, shape<-1>> chart, double r, Out<bool, shape<-1>> flags) {
  const int64_t k = uv.shape(0), m = faces.shape(0);
  if (int64_t(points.shape(0)) != k) throw std::invalid_argument("slit_faces: a point a UV vertex");
  if (int64_t(chart.shape(0)) != m || int64_t(flags.shape(0)) != m) throw std::invalid_argument("slit_faces: a chart and a flag a face");
  if (!(r > 0) || !std::isfinite(r)) throw std::invalid_argument("slit_faces: r must be positive and finite");
  const int64_t* f = faces.data();
  for (int64_t i = 0; i < 3 * m; ++i) {
    if (f[i] < 0 || f[i] >= k) throw std::invalid_argument("slit_faces: a face indexes a missing UV vertex");
  }
  nb::gil_scoped_release unlocked;
  const double* t = uv.data();
  const double* p = points.data();
  const int64_t* c = chart.data();
  std::vector<int64_t> start;
  std::vector<std::pair<int64_t, int64_t>> order;
  sorted_half_edges(f, m, k, start, order);
  std::vector<SlitSample> raw;
  for (int64_t v = 0; v < k; ++v) {
    for (int64_t i = start[v]; i < start[v + 1]; ++i) {
      const bool single = (i == start[v] || order[i - 1].first != order[i].first) &&
                          (i + 1 == start[v + 1] || order[i + 1].first != order[i].first);
      const int64_t h = order[i].second, a = f[3 * (h / 3) + FROM[h % 3]], b = f[3 * (h / 3) + TO[h % 3]];
      if (single && c[h / 3] >= 0) sample_edge(raw, t + 2 * a, t + 2 * b, p + 3 * a, p + 3 * b, h / 3, r);
    }
  }
  slit_pairs(raw, c, r, flags.data());
}

}  // namespace

void bind_charts(nb::module_& m) {
  m.def("edge_pairs", &face_pairs, nb::arg("faces"),
        "(a, b): the faces of consecutive half-edges on one edge of faces (m, 3), half-edges ordered by their ends "
        "(smaller, larger) and index (a non-manifold edge gives a chain).");
  m.def("outline_loops", &outline_loops, nb::arg("faces"),
        "(ring, lengths): the border of faces (m, 3) walked into loops, or None where it is not simple loops.");
  m.def("outlines", &outlines, nb::arg("faces"), nb::arg("starts"),
        "(ring, lengths, loops): the outlines of charts faces[starts[c]:starts[c + 1]] as outline_loops walks each, "
        "loops[c] the count of chart c's loops (-1: not simple loops).");
  m.def("simplified_loops", &simplified_loops, nb::arg("points"), nb::arg("lengths"), nb::arg("tolerances"),
        "(kept, counts): the indices of the loops' points (one after the other) that simplified() keeps where a "
        "loop's tolerance > 0 (else all), and each loop's count.");
  m.def("simplified", &simplified, nb::arg("points"), nb::arg("tolerance"),
        "Indices of a closed loop's points (n, 2) that Douglas-Peucker keeps within tolerance (at least three).");
  m.def("slit_faces", &slit_faces, nb::arg("uv"), nb::arg("points"), nb::arg("faces"), nb::arg("chart"), nb::arg("r"),
        nb::arg("flags").noconvert(),
        "Flag (or into flags (m,) bool) the faces (m, 3) of a UV layout uv (k, 2) on either side of a slit: border "
        "stretches of one chart (chart (m,)) within r in UV whose 3D points (k, 3) are more than 2 r + 3 times that apart.");
}

}  // namespace texbake
