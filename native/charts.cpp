// Planar charts' loops (texbake/atlas/charts.py): the faces that share an edge, a chart's
// outline as loops of vertices, and Douglas-Peucker simplification of one loop. Each gives
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
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include <nanobind/stl/optional.h>
#include <nanobind/stl/tuple.h>

#include "arrays.hpp"
#include "grouping.hpp"

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

// (a, b): the faces of consecutive half-edges on one undirected edge, the half-edges ordered
// by (smaller end, larger end, half-edge): numpy's stable argsort of e0 * (n + 1) + e1. A
// counting sort by the smaller end, then each vertex's few half-edges by their larger end.
std::tuple<Array, Array> face_pairs(Faces faces) {
  const int64_t m = faces.shape(0);
  const int64_t* f = faces.data();
  check_corners(f, m, "edge_pairs");
  std::vector<int64_t> a, b;
  {
    nb::gil_scoped_release unlocked;
    int64_t n = 0;
    for (int64_t i = 0; i < 3 * m; ++i) n = std::max(n, f[i] + 1);
    std::vector<int64_t> start(n + 1, 0);
    for (int64_t h = 0; h < 3 * m; ++h) {
      const int64_t x = f[3 * (h / 3) + FROM[h % 3]], y = f[3 * (h / 3) + TO[h % 3]];
      ++start[std::min(x, y) + 1];
    }
    for (int64_t v = 0; v < n; ++v) start[v + 1] += start[v];
    std::vector<std::pair<int64_t, int64_t>> order(3 * m);  // (larger end, half-edge), bucketed by the smaller
    std::vector<int64_t> fill(start.begin(), start.end() - 1);
    for (int64_t h = 0; h < 3 * m; ++h) {
      const int64_t x = f[3 * (h / 3) + FROM[h % 3]], y = f[3 * (h / 3) + TO[h % 3]];
      order[fill[std::min(x, y)]++] = {std::max(x, y), h};
    }
    for (int64_t v = 0; v < n; ++v) std::sort(order.begin() + start[v], order.begin() + start[v + 1]);
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

struct PairHash {
  size_t operator()(const std::pair<int64_t, int64_t>& p) const {
    return size_t(mix64(uint64_t(p.first) * 0x9E3779B97F4A7C15ULL ^ uint64_t(p.second)));
  }
};

// The outline of a chart's faces: its border edges (directed edges whose reverse no face has)
// walked into loops, each from the first border edge not yet walked, in the border's order
// (faces[:, [0, 1, 1, 2, 2, 0]]). (ring, lengths): the loops' vertices one after the other;
// None where the outline is not simple loops (no border, a vertex starting two border edges,
// a border that ends or runs into another loop).
std::optional<std::tuple<Array, Array>> outline_loops(Faces faces) {
  const int64_t m = faces.shape(0);
  const int64_t* f = faces.data();
  check_corners(f, m, "outline_loops");
  std::vector<int64_t> ring, lengths;
  {
    nb::gil_scoped_release unlocked;
    std::unordered_set<std::pair<int64_t, int64_t>, PairHash> directed;
    directed.reserve(3 * m);
    for (int64_t h = 0; h < 3 * m; ++h) directed.insert({f[3 * (h / 3) + FROM[h % 3]], f[3 * (h / 3) + TO[h % 3]]});
    std::vector<int64_t> starts;
    std::unordered_map<int64_t, int64_t> after;
    for (int64_t h = 0; h < 3 * m; ++h) {
      const int64_t x = f[3 * (h / 3) + FROM[h % 3]], y = f[3 * (h / 3) + TO[h % 3]];
      if (directed.count({y, x})) continue;
      if (!after.emplace(x, y).second) return std::nullopt;  // two border edges from one vertex
      starts.push_back(x);
    }
    if (starts.empty()) return std::nullopt;
    std::unordered_set<int64_t> seen;
    seen.reserve(starts.size());
    for (const int64_t s : starts) {
      if (seen.count(s)) continue;
      int64_t v = s, length = 0;
      while (!seen.count(v)) {
        seen.insert(v);
        ring.push_back(v);
        ++length;
        const auto next = after.find(v);
        if (next == after.end()) return std::nullopt;
        v = next->second;
      }
      if (v != s) return std::nullopt;
      lengths.push_back(length);
    }
  }
  const size_t r = ring.size(), l = lengths.size();
  return std::tuple<Array, Array>{owned(std::move(ring), {r}), owned(std::move(lengths), {l})};
}

// The indices of a closed loop's (n, 2) points that Douglas-Peucker keeps within tolerance,
// ascending (at least three): from point 0 and the point farthest from it, each chain split
// at its point farthest from its chord while that is farther than tolerance. Each distance
// is computed as the numpy it replaced computed it (same operations, same order).
Array simplified(In<double, shape<-1, 2>> points, double tolerance) {
  const int64_t n = points.shape(0);
  if (n < 3) throw std::invalid_argument("simplified: a loop of at least three points");
  const double* p = points.data();
  std::vector<int64_t> out;
  {
    nb::gil_scoped_release unlocked;
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
  const size_t k = out.size();
  return owned(std::move(out), {k});
}

}  // namespace

void bind_charts(nb::module_& m) {
  m.def("edge_pairs", &face_pairs, nb::arg("faces"),
        "(a, b): the faces of consecutive half-edges on one edge of faces (m, 3), half-edges ordered by their ends "
        "(smaller, larger) and index (a non-manifold edge gives a chain).");
  m.def("outline_loops", &outline_loops, nb::arg("faces"),
        "(ring, lengths): the border of faces (m, 3) walked into loops, or None where it is not simple loops.");
  m.def("simplified", &simplified, nb::arg("points"), nb::arg("tolerance"),
        "Indices of a closed loop's points (n, 2) that Douglas-Peucker keeps within tolerance (at least three).");
}

}  // namespace texbake
