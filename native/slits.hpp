// Slits in a chart: two stretches of its border that lie on each other in UV where the
// surface under them is far apart (a box's top face and side face that meet at one vertex and
// project onto one line, in a chart bent over the box's edge). A texel across such a line
// mixes two places of the surface, and nothing is covered twice, so the overlap raster cannot
// see it. Border edges are sampled every r in UV (sample_edge); two samples of one chart and of
// different faces within r of each other in UV and farther apart in 3D than 2 r + 3 times their
// UV distance are a slit (a chart's slopes, within 66 degrees of its direction, stretch a UV
// distance 2.46 times at most). Used by the planar charts (charts.cpp slit_faces) and by their
// joins (uvcheck.cpp merged_islands).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace texbake {

struct SlitSample {
  double u, v, x, y, z;
  int64_t face;
};

// Samples of the border edge from corner a to corner b (uv, 3D point) of face, every r from a
// (not b: the start of the border edge after it).
inline void sample_edge(std::vector<SlitSample>& out, const double* ua, const double* ub, const double* pa, const double* pb,
                        int64_t face, double r) {
  const double du = ub[0] - ua[0], dv = ub[1] - ua[1];
  const double length = std::sqrt(du * du + dv * dv);
  if (!std::isfinite(length)) return;
  const int64_t steps = std::max<int64_t>(1, int64_t(std::ceil(length / r)));
  for (int64_t s = 0; s < steps; ++s) {
    const double w = double(s) / double(steps);
    out.push_back({ua[0] + w * du, ua[1] + w * dv, pa[0] + w * (pb[0] - pa[0]), pa[1] + w * (pb[1] - pa[1]),
                   pa[2] + w * (pb[2] - pa[2]), face});
  }
}

// Whether the samples show a slit; with flags, each face on one is flagged (else the search
// stops at the first). chart: each face's chart (samples of different charts are not
// compared), or null for one chart. The samples are sorted into cells r wide, numbered column
// by column with a spare row each side so that the cells (cx, cy - 1 .. cy + 1) are one run of
// keys; each sample is compared with the three runs round it, at most SLIT_BUDGET comparisons a
// sample in all (a pile of faces in one texel is not worth a quadratic search).
constexpr int64_t SLIT_BUDGET = 64;

inline bool slit_pairs(const std::vector<SlitSample>& raw, const int64_t* chart, double r, bool* flags) {
  if (raw.empty()) return false;
  double lo[2] = {raw[0].u, raw[0].v}, hi[2] = {raw[0].u, raw[0].v};
  for (const SlitSample& q : raw) {
    lo[0] = std::min(lo[0], q.u), lo[1] = std::min(lo[1], q.v);
    hi[0] = std::max(hi[0], q.u), hi[1] = std::max(hi[1], q.v);
  }
  const double columns = std::floor((hi[0] - lo[0]) / r) + 3, rows = std::floor((hi[1] - lo[1]) / r) + 3;
  if (!(columns * rows < 4e18)) return false;  // a layout far wider than r (or not finite): no texel scale to look at
  const uint64_t height = uint64_t(rows);
  const size_t n = raw.size();
  std::vector<std::pair<uint64_t, uint32_t>> keyed(n);
  for (size_t i = 0; i < n; ++i) {
    keyed[i] = {uint64_t(std::floor((raw[i].u - lo[0]) / r) + 1) * height + uint64_t(std::floor((raw[i].v - lo[1]) / r) + 1),
                uint32_t(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<SlitSample> samples(n);
  for (size_t i = 0; i < n; ++i) samples[i] = raw[keyed[i].second];
  bool found = false;
  int64_t budget = SLIT_BUDGET * int64_t(n);
  size_t run[3] = {0, 0, 0};  // each run's start: only forward as the keys grow
  for (size_t i = 0; i < n && budget > 0; ++i) {
    const SlitSample& a = samples[i];
    for (int dx = 0; dx < 3; ++dx) {
      const uint64_t first = keyed[i].first + uint64_t(dx) * height - height - 1;  // (cx + dx - 1, cy - 1)
      size_t& j = run[dx];
      while (j < n && keyed[j].first < first) ++j;
      for (size_t l = j; l < n && keyed[l].first <= first + 2 && budget > 0; ++l, --budget) {
        const SlitSample& b = samples[l];
        if (b.face == a.face || (chart != nullptr && chart[b.face] != chart[a.face])) continue;
        const double du = a.u - b.u, dv = a.v - b.v, flat = std::sqrt(du * du + dv * dv);
        if (!(flat < r)) continue;
        const double ex = a.x - b.x, ey = a.y - b.y, ez = a.z - b.z;
        if (std::sqrt(ex * ex + ey * ey + ez * ez) > 2 * r + 3 * flat) {
          if (flags == nullptr) return true;
          found = flags[a.face] = flags[b.face] = true;
        }
      }
    }
  }
  return found;
}

}  // namespace texbake
