// Colour lookups of texbake/textures/colour.py's tables: a tabulated spline colour map, the
// mean colour of a wave over its phase spread, the colour of a sine's phase. Linear between
// samples; NaN in, NaN out (and no index read from a NaN).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

namespace texbake::colour {

constexpr double TWO_PI = 2.0 * 3.141592653589793;
constexpr double NaN = std::numeric_limits<double>::quiet_NaN();

inline void nan3(double* out) { out[0] = out[1] = out[2] = NaN; }

// a colour map tabulated at rows samples (rows, 3), its knots from lo, step samples a unit;
// clamped to the ends
struct Curve {
  const double* samples;
  std::ptrdiff_t rows;
  double lo, step;
};

inline void map_colour(const Curve& c, double value, double* out) {
  const std::ptrdiff_t last = c.rows - 1;
  const double x = std::min(std::max((value - c.lo) * c.step, 0.0), double(last));
  if (!(x >= 0.0)) return nan3(out);
  const std::ptrdiff_t j = std::min(std::ptrdiff_t(x), last - 1);
  const double f = x - double(j);
  for (int k = 0; k < 3; ++k) out[k] = c.samples[3 * j + k] * (1.0 - f) + c.samples[3 * (j + 1) + k] * f;
}

// colour.wave_table: (spreads, phases, 3), the mean colour at a phase and its spread, spreads
// from 0 to max_spread
struct Waves {
  const double* table;
  std::ptrdiff_t spreads, phases;
  double max_spread;
};

// the table at phase (wrapped to its period) and spread (clamped to [0, max_spread]), bilinear
inline void wave_colour(const Waves& w, double phase, double spread, double* out) {
  double x = phase / TWO_PI;
  x = (x - std::floor(x)) * double(w.phases);
  const double y = std::min(std::max(spread / w.max_spread, 0.0), 1.0) * double(w.spreads - 1);
  if (!(x <= double(w.phases)) || !(y >= 0.0)) return nan3(out);
  const std::ptrdiff_t j = std::min(std::ptrdiff_t(x), w.phases - 1), j1 = (j + 1) % w.phases;
  const std::ptrdiff_t r = std::min(std::ptrdiff_t(y), w.spreads - 2);
  const double fx = x - double(j), fy = y - double(r);
  const double* row0 = w.table + 3 * w.phases * r;
  const double* row1 = row0 + 3 * w.phases;
  for (int k = 0; k < 3; ++k) {
    const double low = row0[3 * j + k] * (1.0 - fx) + row0[3 * j1 + k] * fx;
    const double high = row1[3 * j + k] * (1.0 - fx) + row1[3 * j1 + k] * fx;
    out[k] = low * (1.0 - fy) + high * fy;
  }
}

// colour.sine_table: (rows + 1, 3), the colour of 0.5 + 0.5 sin(phase) over a period, the
// first row repeated
struct Sines {
  const double* table;
  std::ptrdiff_t rows;
};

// the row below phase and the fraction past it (a phase that is not finite: NaN fraction)
inline void sine_row(const Sines& s, double phase, int32_t& row, double& fraction) {
  double x = phase / TWO_PI;
  x = (x - std::floor(x)) * double(s.rows);  // in [0, rows] (rows: a tiny negative phase rounds up to the period)
  const int32_t j = std::min(int32_t(x <= double(s.rows) ? x : 0.0), int32_t(s.rows - 1));
  row = j;
  fraction = x - double(j);
}

inline void sine_colour(const Sines& s, int32_t row, double fraction, double* out) {
  const double* t = s.table + 3 * std::ptrdiff_t(row);
  for (int k = 0; k < 3; ++k) out[k] = t[k] * (1.0 - fraction) + t[3 + k] * fraction;
}

}  // namespace texbake::colour
