// A face's steps on the surface one texel right and one down (6 values: dpdx, then dpdy), and
// how far two faces' steps differ: the crease test's measures, for the faces that bend
// (surface.cpp face_bends) and the texels whose parts bend (lookup.cpp texel_parts). Each
// caller keeps its own comparison (face_bends': change > kink * longer; texel_parts': change /
// longer > kink, creases.py's numpy arithmetic), so each answer stays as it was.
#pragma once
#include <algorithm>
#include <cmath>

namespace texbake {

inline double norm3(const double* v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

// the longer of the two steps
inline double longer_step(const double* steps) { return std::max(norm3(steps), norm3(steps + 3)); }

// the larger change of either step from own to other
inline double step_change(const double* own, const double* other) {
  double d[6];
  for (int k = 0; k < 6; ++k) d[k] = other[k] - own[k];
  return std::max(norm3(d), norm3(d + 3));
}

}  // namespace texbake
