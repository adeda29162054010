// The texture kernels (texbake/textures/): octave sums of lattice and Perlin noise filtered
// by the footprint (whole, or at its four quarters), the marble in one pass (point-sampled,
// or filtered at the quarters), colour maps, the filtered checkerboard, the bake's affine
// placement. Each takes NumPy arrays and writes into out (allocated by the
// caller, so that nothing here needs the GIL), releases the GIL and runs on one thread a
// core (parallel_for; the octave sums and the marble in chunks the threads take in turn,
// parallel_chunks). A point's value depends on nothing but the point: not on the piece
// or the block it is in, nor on the instruction set (no FMA contraction: CMakeLists.txt).
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "colour.hpp"
#include "octaves.hpp"
#include "parallel.hpp"

namespace nb = nanobind;

namespace texbake::textures {

using std::ptrdiff_t;
using noise::Block;
using noise::Octaves;

template <class T, class... Shape>
using In = nb::ndarray<const T, nb::c_contig, nb::device::cpu, Shape...>;
template <class T, class... Shape>
using Out = nb::ndarray<T, nb::c_contig, nb::device::cpu, Shape...>;
using Points = In<double, nb::shape<-1, 3>>;
using Values = In<double, nb::ndim<1>>;
using OutValues = Out<double, nb::ndim<1>>;
using OutColours = Out<double, nb::shape<-1, 3>>;

// -- instruction sets ------------------------------------------------------------------
// The kernels over a piece are compiled three times, for AVX-512 (x86-64-v4), for AVX2 and
// for the x86-64 baseline, each with its own copy of the block loops (forced inline); a
// call runs the best the CPU has, or the one use_instruction_set chose (the tests compare
// them). All three round alike (no FMA contraction: CMakeLists.txt).

enum Isa : int { BASELINE = 0, AVX2 = 1, AVX512 = 2 };
constexpr const char* ISA_NAMES[] = {"baseline", "avx2", "avx512"};

Isa best_isa() {
#if defined(TEXBAKE_ISAS)
  static const Isa best = __builtin_cpu_supports("x86-64-v4") ? AVX512 : (__builtin_cpu_supports("avx2") ? AVX2 : BASELINE);
  return best;
#else
  return BASELINE;
#endif
}

std::atomic<int> chosen_isa{-1};  // -1: the best the CPU has

Isa current_isa() {
  const int chosen = chosen_isa.load(std::memory_order_relaxed);
  return chosen < 0 ? best_isa() : Isa(chosen);
}

// a kernel's three copies, by instruction set
template <class F>
struct Variants {
  F avx512, avx2, baseline;
  F at(Isa isa) const { return isa == AVX512 ? avx512 : (isa == AVX2 ? avx2 : baseline); }
};

#if defined(TEXBAKE_ISAS)
#define TEXBAKE_AVX512 __attribute__((target("arch=x86-64-v4")))
#define TEXBAKE_AVX2 __attribute__((target("avx2")))
#else
#define TEXBAKE_AVX512
#define TEXBAKE_AVX2
#endif
#define TEXBAKE_VARIANTS(name, params, args)                            \
  TEXBAKE_AVX512 void name##_avx512 params { name args; }               \
  TEXBAKE_AVX2 void name##_avx2 params { name args; }                   \
  void name##_baseline params { name args; }                            \
  const Variants<decltype(&name##_baseline)> name##_variants{name##_avx512, name##_avx2, name##_baseline};

// -- the kernels over a piece [lo, hi) ---------------------------------------------------

TEXBAKE_INLINE void octave_range(const Octaves& o, const double* points, const double* width, double* out, ptrdiff_t lo,
                                 ptrdiff_t hi) {
  Block b{};
  for (ptrdiff_t start = lo; start < hi; start += noise::BLOCK) {
    const ptrdiff_t m = noise::block_octaves(o, points, width, start, hi, b);
    std::copy(b.acc, b.acc + m, out + start);
  }
}
TEXBAKE_VARIANTS(octave_range, (const Octaves& o, const double* points, const double* width, double* out, ptrdiff_t lo, ptrdiff_t hi),
                 (o, points, width, out, lo, hi))

// Perlin's marble: the colour of 0.5 + 0.5 sin(phase), phase = frequency * p[axis] +
// amplitude * turbulence (the octave sum plus capped, the mean of the octaves left out,
// over norm), or with a footprint the mean colour over the phase's spread
// frequency * width / sqrt(12)
struct Marble {
  Octaves o;
  int axis;
  double frequency, amplitude, capped, norm, spread_per_width;
  colour::Sines sines;
  colour::Waves waves;
};

// the colours of a block's points without a phase spread, their turbulence in b.acc: the
// phases and the table's rows in a loop the compiler vectorises, the loads in a scalar one
TEXBAKE_INLINE void sine_block(const Marble& k, const double* points, const double* width, ptrdiff_t start, ptrdiff_t m, Block& b,
                       double* out) {
  int32_t* rows = reinterpret_cast<int32_t*>(b.row);
  for (ptrdiff_t i = 0; i < m; ++i) {
    const double phase = k.frequency * points[3 * (start + i) + k.axis] + k.amplitude * ((b.acc[i] + k.capped) / k.norm);
    colour::sine_row(k.sines, phase, rows[i], b.tx[i]);
  }
  for (ptrdiff_t i = 0; i < m; ++i) {
    if (!width || !(k.spread_per_width * width[start + i] > 0.0)) colour::sine_colour(k.sines, rows[i], b.tx[i], out + 3 * (start + i));
  }
}

// width null: every point sampled
TEXBAKE_INLINE void marble_range(const Marble& k, const double* points, const double* width, double* out, ptrdiff_t lo,
                                 ptrdiff_t hi) {
  Block b{};
  for (ptrdiff_t start = lo; start < hi; start += noise::BLOCK) {
    const ptrdiff_t m = noise::block_octaves(k.o, points, width, start, hi, b);
    ptrdiff_t sampled = width ? 0 : m;  // points without a spread: the colour of their phase
    for (ptrdiff_t i = 0; width && i < m; ++i) {
      const double spread = k.spread_per_width * width[start + i];
      if (spread > 0.0) {  // the mean colour over the texel, not the colour of the mean
        const double phase = k.frequency * points[3 * (start + i) + k.axis] + k.amplitude * ((b.acc[i] + k.capped) / k.norm);
        colour::wave_colour(k.waves, phase, spread, out + 3 * (start + i));
      } else {
        ++sampled;
      }
    }
    if (sampled) sine_block(k, points, width, start, m, b, out);
  }
}
TEXBAKE_VARIANTS(marble_range, (const Marble& k, const double* points, const double* width, double* out, ptrdiff_t lo, ptrdiff_t hi),
                 (k, points, width, out, lo, hi))

// Octave sums at a footprint's four quarters (noise.quarter_octave_sums): the octaves before a
// point's first quarter octave k0 (the first whose footprint spans QUAD_CELLS of its cell) at
// its centre over the whole width, the rest at each quarter over half of it. Those are the sum
// of their own whose octave 0 is k0: scale and offset times lacunarity^k0, times gain^k0, so
// that every point's values are bit for bit the octave_sum calls the numpy version made
struct Quarters {
  Octaves o;                            // count: the octaves evaluated
  const double *shift, *weight, *tops;  // by k0 (0..count): lacunarity^k0, gain^k0 (as Python's **), top_frequency(k0)
  bool add_capped;                      // the capped octaves' mean added (unsigned sums with octaves capped)
  double capped;
};

// first_quarter_octave's loop, its frequencies multiplied out as the kernel's (a NaN width: 0)
inline int first_quarter(const Octaves& o, double width) {
  const double w = std::fabs(o.scale) * width;
  int first = 0;
  double freq = 1.0;
  for (int k = 0; k < o.count; ++k) {
    first += w * freq < noise::QUAD_CELLS;
    freq *= o.lacunarity;
  }
  return first;
}

// the four quarters' centres of a footprint (noise.quarter_points' arithmetic, QUARTERS' order)
inline void stage_quarters(const double* p, const double* dx, const double* dy, double* q) {
  for (int c = 0; c < 3; ++c) {
    const double both = 0.25 * (dx[c] + dy[c]), across = 0.25 * (dx[c] - dy[c]);
    q[c] = p[c] - both, q[3 + c] = p[c] + across, q[6 + c] = p[c] - across, q[9 + c] = p[c] + both;
  }
}

// a block of points: their first quarter octaves, and their coarse sums in b.acc
TEXBAKE_INLINE void coarse_block(const Quarters& k, const double* points, const double* width, ptrdiff_t start, ptrdiff_t m,
                                 noise::Samples& s, int* first, Block& b) {
  s.m = m;
  for (ptrdiff_t i = 0; i < m; ++i) {
    first[i] = first_quarter(k.o, width[start + i]);
    std::copy(points + 3 * (start + i), points + 3 * (start + i + 1), s.p + 3 * i);
    s.scale[i] = k.o.scale, s.offset[i] = k.o.offset, s.width[i] = width[start + i];
    s.count[i] = first[i], s.top[i] = k.tops[first[i]];
  }
  noise::sample_octaves(k.o, s, k.tops, b);
}

// the fine octaves' sums of m points from start (at most BLOCK / 4) at their four quarters, in
// b.acc (4 a point)
TEXBAKE_INLINE void fine_block(const Quarters& k, const double* points, const double* dpdx, const double* dpdy, const double* width,
                               ptrdiff_t start, ptrdiff_t m, const int* first, noise::Samples& s, Block& b) {
  s.m = 4 * m;
  for (ptrdiff_t i = 0; i < m; ++i) {
    const ptrdiff_t j = start + i;
    stage_quarters(points + 3 * j, dpdx + 3 * j, dpdy + 3 * j, s.p + 12 * i);
    const int k0 = first[i], count = k.o.count - k0;
    for (ptrdiff_t c = 4 * i; c < 4 * i + 4; ++c) {
      s.scale[c] = k.o.scale * k.shift[k0], s.offset[c] = k.o.offset * k.shift[k0], s.width[c] = 0.5 * width[j];
      s.count[c] = count, s.top[c] = k.tops[count];
    }
  }
  noise::sample_octaves(k.o, s, k.tops, b);
}

// a block's buffers for quarter_block: sums[c][i] the quarter c's sum of the block's point i
struct QuarterBlock {
  Block b;
  noise::Samples s;
  alignas(64) double coarse[noise::BLOCK];
  alignas(64) double sums[4][noise::BLOCK];
  int first[noise::BLOCK];
};

// q.sums: the quarters' sums of the block of points from start (m of them): the centres' coarse
// octaves in one block, the quarters' fine ones in four
TEXBAKE_INLINE void quarter_block(const Quarters& k, const double* points, const double* dpdx, const double* dpdy, const double* width,
                                  ptrdiff_t start, ptrdiff_t m, QuarterBlock& q) {
  constexpr ptrdiff_t PART = noise::BLOCK / 4;
  coarse_block(k, points, width, start, m, q.s, q.first, q.b);
  std::copy(q.b.acc, q.b.acc + m, q.coarse);
  for (ptrdiff_t part = 0; part < m; part += PART) {
    const ptrdiff_t mp = std::min(PART, m - part);
    fine_block(k, points, dpdx, dpdy, width, start + part, mp, q.first + part, q.s, q.b);
    for (ptrdiff_t i = part; i < part + mp; ++i) {
      const int k0 = q.first[i];
      for (ptrdiff_t c = 0; c < 4; ++c) {  // the numpy version's sums, in its order
        double v = k0 > 0 ? q.coarse[i] : 0.0;
        if (k0 < k.o.count) v = v + k.weight[k0] * q.b.acc[4 * (i - part) + c];
        q.sums[c][i] = k.add_capped ? v + k.capped : v;
      }
    }
  }
}

// out (4, n): the quarters' sums of points [lo, hi)
TEXBAKE_INLINE void quarter_range(const Quarters& k, const double* points, const double* dpdx, const double* dpdy, const double* width,
                                  double* out, ptrdiff_t n, ptrdiff_t lo, ptrdiff_t hi) {
  QuarterBlock q{};
  for (ptrdiff_t start = lo; start < hi; start += noise::BLOCK) {
    const ptrdiff_t m = std::min(noise::BLOCK, hi - start);
    quarter_block(k, points, dpdx, dpdy, width, start, m, q);
    for (ptrdiff_t c = 0; c < 4; ++c) std::copy(q.sums[c], q.sums[c] + m, out + c * n + start);
  }
}
TEXBAKE_VARIANTS(quarter_range, (const Quarters& k, const double* points, const double* dpdx, const double* dpdy, const double* width,
                                 double* out, ptrdiff_t n, ptrdiff_t lo, ptrdiff_t hi),
                 (k, points, dpdx, dpdy, width, out, n, lo, hi))

// noise.octave_spread's table (quarters): the turbulence's spread inside a quarter at log
// widths (lattice cells) from log lo to log hi, looked up as numpy does (np.log, np.interp)
struct Spreads {
  const double *at, *spread;  // np.interp's xp and fp
  ptrdiff_t count;
  double lo, hi, scale;       // scale: |scale|, a width's cells
};

// np.interp(x, at, spread): the interval numpy's search finds (at[j] <= x < at[j + 1], the
// last at the last knot) from a guess on the even spacing, and its arithmetic
inline double interp(const Spreads& t, double x) {
  const ptrdiff_t last = t.count - 1;
  if (std::isnan(x)) return x;
  if (x < t.at[0]) return t.spread[0];
  if (x > t.at[last]) return t.spread[last];
  ptrdiff_t j = std::min(last, std::max(ptrdiff_t(0), ptrdiff_t((x - t.at[0]) / (t.at[last] - t.at[0]) * double(last))));
  while (j > 0 && x < t.at[j]) --j;
  while (j < last && !(x < t.at[j + 1])) ++j;
  if (j == last || t.at[j] == x) return t.spread[j];
  const double slope = (t.spread[j + 1] - t.spread[j]) / (t.at[j + 1] - t.at[j]);
  double v = slope * (x - t.at[j]) + t.spread[j];
  if (std::isnan(v)) {  // numpy's other direction
    v = slope * (x - t.at[j + 1]) + t.spread[j + 1];
    if (std::isnan(v) && t.spread[j] == t.spread[j + 1]) v = t.spread[j];
  }
  return v;
}

// octave_spread(width, quarters=True): below the table the finest octave's spread, in
// proportion to the width; 0 at no width, NaN at NaN
inline double octave_spread(const Spreads& t, double width) {
  const double w = t.scale * width;
  if (!(w > 0.0)) return std::isnan(w) ? colour::NaN : 0.0;
  if (w < t.lo) return t.spread[0] * w / t.lo;
  return interp(t, std::log(std::min(w, t.hi)));
}

// the filtered marble at the footprints' quarters (colour.quarter_marble_colours): each
// quarter's phase frequency * x + amplitude * turbulence, its spread that of the box over
// half the width and the turbulence's inside the quarter, the mean of the four wave colours;
// a point with no spread the point-sampled marble's colour
struct QuarterMarble {
  Quarters q;
  int axis;
  double frequency, amplitude, norm;
  Spreads spreads;
  colour::Sines sines;
  colour::Waves waves;
};

constexpr double QUARTER_A[4] = {-0.25, 0.25, -0.25, 0.25}, QUARTER_B[4] = {-0.25, -0.25, 0.25, 0.25};  // noise.QUARTERS

// the phase's spread in each quarter of a footprint width wide (the numpy version's arithmetic)
inline double phase_spread(const QuarterMarble& k, double width) {
  const double turbulence = octave_spread(k.spreads, width) / k.norm;
  const double box = k.frequency * 0.5 * width, wobble = k.amplitude * turbulence;
  return std::sqrt(box * box / 12.0 + wobble * wobble);
}

// colour.marble_colours point-sampled at p (marble's sine_block for one point)
inline void sampled_marble(const QuarterMarble& k, const double* p, double* out) {
  const Octaves& o = k.q.o;
  const double x = p[0] * o.scale + o.offset, y = p[1] * o.scale + o.offset, z = p[2] * o.scale + o.offset;
  const double sum = noise::octave_point(o, x, y, z, 0.0 * std::fabs(o.scale), std::fabs(x), std::fabs(y), std::fabs(z));
  const double phase = k.frequency * p[k.axis] + k.amplitude * ((sum + k.q.capped) / k.norm);
  int32_t row;
  double fraction;
  colour::sine_row(k.sines, phase, row, fraction);
  colour::sine_colour(k.sines, row, fraction, out);
}

// point j's colour, its quarters' sums q.sums[c][i]: the four colours summed in order, as
// numpy's mean over the first axis adds them
inline void quarter_marble_colour(const QuarterMarble& k, const double* points, const double* dpdx, const double* dpdy,
                                  const double* width, ptrdiff_t j, const QuarterBlock& q, ptrdiff_t i, double* out) {
  const double spread = phase_spread(k, width[j]);
  if (spread == 0.0) return sampled_marble(k, points + 3 * j, out);
  const double p = points[3 * j + k.axis], dx = dpdx[3 * j + k.axis], dy = dpdy[3 * j + k.axis];
  double total[3], colour[3];
  for (int c = 0; c < 4; ++c) {
    const double x = p + QUARTER_A[c] * dx + QUARTER_B[c] * dy;  // not stage_quarters' sums: the numpy version's phase
    const double phase = k.frequency * x + k.amplitude * (q.sums[c][i] / k.norm);
    colour::wave_colour(k.waves, phase, spread, c == 0 ? total : colour);
    for (int ch = 0; c > 0 && ch < 3; ++ch) total[ch] += colour[ch];
  }
  for (int ch = 0; ch < 3; ++ch) out[ch] = total[ch] / 4.0;
}

TEXBAKE_INLINE void quarter_marble_range(const QuarterMarble& k, const double* points, const double* dpdx, const double* dpdy,
                                         const double* width, double* out, ptrdiff_t lo, ptrdiff_t hi) {
  QuarterBlock q{};
  for (ptrdiff_t start = lo; start < hi; start += noise::BLOCK) {
    const ptrdiff_t m = std::min(noise::BLOCK, hi - start);
    quarter_block(k.q, points, dpdx, dpdy, width, start, m, q);
    for (ptrdiff_t i = 0; i < m; ++i) quarter_marble_colour(k, points, dpdx, dpdy, width, start + i, q, i, out + 3 * (start + i));
  }
}
TEXBAKE_VARIANTS(quarter_marble_range, (const QuarterMarble& k, const double* points, const double* dpdx, const double* dpdy,
                                        const double* width, double* out, ptrdiff_t lo, ptrdiff_t hi),
                 (k, points, dpdx, dpdy, width, out, lo, hi))

inline double square_wave(double cell) { return 1.0 - 2.0 * (cell - 2.0 * std::floor(0.5 * cell)); }

// the integral from 0 to t of the square wave (+1 on [0, 1), -1 on [1, 2), period 2)
inline double triangle_wave(double t) {
  const double u = t - 2.0 * std::floor(0.5 * t);
  return 1.0 - std::fabs(u - 1.0);
}

// the signed checker's mean over split x split pieces of the footprint, each over its
// bounding box cut to [lo, hi] (basic.checker_parity); an axis with no width is sampled
inline double checker_pieces(const double* t, const double* ex, const double* ey, const double* lo, const double* hi, int m) {
  double total = 0.0;
  for (int a = 0; a < m; ++a) {
    for (int b = 0; b < m; ++b) {
      const double fa = (a + 0.5) / m - 0.5, fb = (b + 0.5) / m - 0.5;
      double prod = 1.0;
      for (int k = 0; k < 3; ++k) {
        const double centre = t[k] + fa * ex[k] + fb * ey[k];
        const double half = (std::fabs(ex[k]) + std::fabs(ey[k])) * 0.5 / m;
        const double x0 = std::max(centre - half, lo[k]), x1 = std::min(centre + half, hi[k]);
        if (x1 - x0 > 1e-12) {
          const double mean = (triangle_wave(x1) - triangle_wave(x0)) / (x1 - x0);
          prod *= std::min(1.0, std::max(-1.0, mean));  // far out, x0, x1 round: keep the mean a mean
        } else {
          prod *= square_wave(std::floor(std::min(std::max(centre, x0), std::max(x0, x1))));
        }
      }
      total += prod;
    }
  }
  return total / (m * m);
}

inline double checker_point(const double* t, const double* ex, const double* ey, const double* lo, const double* hi, int split) {
  bool oblique = false, crosses = false;  // crosses: does the footprint's whole box reach over a cell plane?
  double sign = 1.0;
  for (int k = 0; k < 3; ++k) {
    oblique = oblique || (ex[k] != 0.0 && ey[k] != 0.0);
    const double half = (std::fabs(ex[k]) + std::fabs(ey[k])) * 0.5;
    const double x0 = std::max(t[k] - half, lo[k]), x1 = std::min(t[k] + half, hi[k]);
    crosses = crosses || (x1 > x0 && std::floor(x0) != std::floor(x1));
    sign *= square_wave(std::floor(std::min(std::max(t[k], x0), std::max(x0, x1))));
  }
  if (!crosses) return sign;  // inside one cell: the mean is its sign (most texels)
  return checker_pieces(t, ex, ey, lo, hi, oblique ? split : 1);  // along the axes one box is exact
}

struct Checker {
  const double *t, *ex, *ey, *lo, *hi;
  int split;
};

TEXBAKE_INLINE void checker_range(const Checker& c, double* out, ptrdiff_t lo, ptrdiff_t hi) {
  for (ptrdiff_t i = lo; i < hi; ++i) out[i] = checker_point(c.t + 3 * i, c.ex + 3 * i, c.ey + 3 * i, c.lo + 3 * i, c.hi + 3 * i, c.split);
}
TEXBAKE_VARIANTS(checker_range, (const Checker& c, double* out, ptrdiff_t lo, ptrdiff_t hi), (c, out, lo, hi))

// the points the octave kernels' threads take at a time (parallel_chunks): a whole number of
// blocks, small enough that a thread the machine slows leaves little for the other to wait on
constexpr ptrdiff_t CHUNK = 128 * noise::BLOCK;

// -- checks and bindings -------------------------------------------------------------------

void same_rows(ptrdiff_t n, ptrdiff_t rows, const char* name) {
  if (rows != n) throw std::invalid_argument(std::string(name) + ": " + std::to_string(rows) + " rows for " + std::to_string(n) + " points");
}

// width (n,), or None (point sampling): null, which the kernels read as 0 everywhere
const double* footprints(const Values& width, ptrdiff_t n) {
  if (!width.is_valid()) return nullptr;
  same_rows(n, width.shape(0), "width");
  return width.data();
}

noise::Tables noise_tables(const Values& noise, const In<int64_t, nb::ndim<1>>& index, const Values& noise2,
                           const In<uint32_t, nb::ndim<1>>& hash4) {
  if (noise.shape(0) != 256 || index.shape(0) != 256 || noise2.shape(0) != 512 || hash4.shape(0) != 65536)
    throw std::invalid_argument("noise tables: expected 256, 256, 512 and 65536 entries");
  for (ptrdiff_t i = 0; i < 256; ++i) {
    if (index.data()[i] < 0 || index.data()[i] > 255) throw std::invalid_argument("indexTable: entries must be in [0, 255]");
  }
  return {noise.data(), index.data(), noise2.data(), hash4.data()};
}

Octaves octaves(const noise::Tables& t, int basis, int interp, int count, double lacunarity, double gain, bool signed_,
                double basis_mean, double scale, double offset) {
  if (basis < 0 || basis > 1 || interp < 0 || interp > 2) throw std::invalid_argument("basis in {0, 1}, interpolation in {0, 1, 2}");
  return {t, basis, interp, count, lacunarity, gain, signed_ ? 2.0 : 1.0, signed_ ? 2.0 * basis_mean - 1.0 : basis_mean,
          noise::top_frequency(count, lacunarity), scale, offset, current_isa() >= AVX2};
}

void octave_sum(const Points& points, const Values& width, const Values& noise, const In<int64_t, nb::ndim<1>>& index,
                const Values& noise2, const In<uint32_t, nb::ndim<1>>& hash4, int basis, int interp, int count, double lacunarity,
                double gain, bool signed_, double basis_mean, double scale, double offset, OutValues out) {
  const ptrdiff_t n = points.shape(0);
  same_rows(n, out.shape(0), "out");
  const Octaves o = octaves(noise_tables(noise, index, noise2, hash4), basis, interp, count, lacunarity, gain, signed_, basis_mean,
                            scale, offset);
  const double *p = points.data(), *w = footprints(width, n);
  const auto range = octave_range_variants.at(current_isa());
  double* dst = out.data();
  parallel_chunks(n, [&](ptrdiff_t lo, ptrdiff_t hi) { range(o, p, w, dst, lo, hi); }, CHUNK);
}

// the quarter kernels' octaves and their tables by k0; std::pow is the pow Python's float **
// int calls (the exponent as a double), so shift and weight are the numpy version's bits
struct QuarterTables {
  std::vector<double> shift, weight, tops;
  QuarterTables(int count, double lacunarity, double gain) : shift(count + 1), weight(count + 1), tops(count + 1) {
    for (int k0 = 0; k0 <= count; ++k0) {
      shift[k0] = std::pow(lacunarity, double(k0)), weight[k0] = std::pow(gain, double(k0));
      tops[k0] = noise::top_frequency(k0, lacunarity);
    }
  }
  Quarters quarters(const Octaves& o, std::optional<double> capped) const {
    return {o, shift.data(), weight.data(), tops.data(), capped.has_value(), capped.value_or(0.0)};
  }
};

void footprint_rows(ptrdiff_t n, const Points& dpdx, const Points& dpdy, const Values& width) {
  same_rows(n, dpdx.shape(0), "dpdx");
  same_rows(n, dpdy.shape(0), "dpdy");
  same_rows(n, width.shape(0), "width");
}

void quarter_octave_sums(const Points& points, const Points& dpdx, const Points& dpdy, const Values& width, const Values& noise,
                         const In<int64_t, nb::ndim<1>>& index, const Values& noise2, const In<uint32_t, nb::ndim<1>>& hash4, int basis,
                         int interp, int count, double lacunarity, double gain, bool signed_, double basis_mean, double scale,
                         double offset, std::optional<double> capped, Out<double, nb::shape<4, -1>> out) {
  const ptrdiff_t n = points.shape(0);
  footprint_rows(n, dpdx, dpdy, width);
  same_rows(n, out.shape(1), "out");
  count = std::max(count, 0);  // none evaluated (as the numpy version's empty loops)
  const QuarterTables tables(count, lacunarity, gain);
  const Quarters k = tables.quarters(octaves(noise_tables(noise, index, noise2, hash4), basis, interp, count, lacunarity, gain, signed_,
                                             basis_mean, scale, offset), capped);
  const double *p = points.data(), *dx = dpdx.data(), *dy = dpdy.data(), *w = width.data();
  const auto range = quarter_range_variants.at(current_isa());
  double* dst = out.data();
  // a point is about four of octave_sum's
  parallel_chunks(n, [&](ptrdiff_t lo, ptrdiff_t hi) { range(k, p, dx, dy, w, dst, n, lo, hi); }, CHUNK / 4, MIN_PIECE / 4);
}

void quarter_marble(const Points& points, const Points& dpdx, const Points& dpdy, const Values& width, const Values& noise,
                    const In<int64_t, nb::ndim<1>>& index, const Values& noise2, const In<uint32_t, nb::ndim<1>>& hash4, int basis,
                    int interp, int count, double lacunarity, double gain, double basis_mean, double scale, double offset,
                    std::optional<double> capped, int axis, double frequency, double amplitude, double norm, const Values& spread_at,
                    const Values& spreads, double spread_lo, double spread_hi, const In<double, nb::shape<-1, 3>>& sines,
                    const In<double, nb::shape<-1, -1, 3>>& waves, double max_spread, OutColours out) {
  const ptrdiff_t n = points.shape(0);
  footprint_rows(n, dpdx, dpdy, width);
  same_rows(n, out.shape(0), "out");
  if (axis < 0 || axis > 2 || sines.shape(0) < 2 || waves.shape(0) < 2 || waves.shape(1) < 1 || spreads.shape(0) < 2 ||
      spread_at.shape(0) != spreads.shape(0))
    throw std::invalid_argument("quarter_marble: axis in {0, 1, 2}, at least 2 sine rows and 2 spreads, a log width a spread");
  count = std::max(count, 0);
  const QuarterTables tables(count, lacunarity, gain);
  const QuarterMarble k{tables.quarters(octaves(noise_tables(noise, index, noise2, hash4), basis, interp, count, lacunarity, gain, false,
                                                basis_mean, scale, offset), capped),
                        axis, frequency, amplitude, norm,
                        {spread_at.data(), spreads.data(), ptrdiff_t(spreads.shape(0)), spread_lo, spread_hi, std::fabs(scale)},
                        {sines.data(), ptrdiff_t(sines.shape(0)) - 1},
                        {waves.data(), ptrdiff_t(waves.shape(0)), ptrdiff_t(waves.shape(1)), max_spread}};
  const double *p = points.data(), *dx = dpdx.data(), *dy = dpdy.data(), *w = width.data();
  const auto range = quarter_marble_range_variants.at(current_isa());
  double* dst = out.data();
  parallel_chunks(n, [&](ptrdiff_t lo, ptrdiff_t hi) { range(k, p, dx, dy, w, dst, lo, hi); }, CHUNK / 4, MIN_PIECE / 4);
}

void marble(const Points& points, const Values& width, const Values& noise, const In<int64_t, nb::ndim<1>>& index,
            const Values& noise2, const In<uint32_t, nb::ndim<1>>& hash4, int basis, int interp, int count, double lacunarity,
            double gain, double basis_mean, double scale, double offset, int axis, double frequency, double amplitude,
            double capped, double norm, const In<double, nb::shape<-1, 3>>& sines, const In<double, nb::shape<-1, -1, 3>>& waves,
            double max_spread, OutColours out) {
  const ptrdiff_t n = points.shape(0);
  same_rows(n, out.shape(0), "out");
  if (axis < 0 || axis > 2 || sines.shape(0) < 2 || waves.shape(0) < 2 || waves.shape(1) < 1)
    throw std::invalid_argument("marble: axis in {0, 1, 2}, at least 2 sine rows and 2 spreads");
  const Marble k{octaves(noise_tables(noise, index, noise2, hash4), basis, interp, count, lacunarity, gain, false, basis_mean,
                         scale, offset),
                 axis, frequency, amplitude, capped, norm, frequency / std::sqrt(12.0),
                 {sines.data(), ptrdiff_t(sines.shape(0)) - 1},
                 {waves.data(), ptrdiff_t(waves.shape(0)), ptrdiff_t(waves.shape(1)), max_spread}};
  const double *p = points.data(), *w = footprints(width, n);
  const auto range = marble_range_variants.at(current_isa());
  double* dst = out.data();
  parallel_chunks(n, [&](ptrdiff_t lo, ptrdiff_t hi) { range(k, p, w, dst, lo, hi); }, CHUNK);
}

void colour_map(const Values& values, const In<double, nb::shape<-1, 3>>& samples, double lo, double step, OutColours out) {
  same_rows(values.shape(0), out.shape(0), "out");
  if (samples.shape(0) < 2) throw std::invalid_argument("colour_map: at least 2 samples");
  const colour::Curve c{samples.data(), ptrdiff_t(samples.shape(0)), lo, step};
  const double* v = values.data();
  double* dst = out.data();
  parallel_for(values.shape(0), [&](ptrdiff_t a, ptrdiff_t b) {
    for (ptrdiff_t i = a; i < b; ++i) colour::map_colour(c, v[i], dst + 3 * i);
  });
}

void wave_colours(const Values& phase, const Values& spread, const In<double, nb::shape<-1, -1, 3>>& table, double max_spread,
                  OutColours out) {
  same_rows(phase.shape(0), spread.shape(0), "spread");
  same_rows(phase.shape(0), out.shape(0), "out");
  if (table.shape(0) < 2 || table.shape(1) < 1) throw std::invalid_argument("wave_colours: at least 2 spreads and 1 phase");
  const colour::Waves w{table.data(), ptrdiff_t(table.shape(0)), ptrdiff_t(table.shape(1)), max_spread};
  const double *ph = phase.data(), *sp = spread.data();
  double* dst = out.data();
  parallel_for(phase.shape(0), [&](ptrdiff_t a, ptrdiff_t b) {
    for (ptrdiff_t i = a; i < b; ++i) colour::wave_colour(w, ph[i], sp[i], dst + 3 * i);
  });
}

void checker_parity(const Points& t, const Points& ex, const Points& ey, const Points& lo, const Points& hi, int split, OutValues out) {
  const ptrdiff_t n = t.shape(0);
  same_rows(n, ex.shape(0), "ex");
  same_rows(n, ey.shape(0), "ey");
  same_rows(n, lo.shape(0), "lo");
  same_rows(n, hi.shape(0), "hi");
  same_rows(n, out.shape(0), "out");
  if (split < 1) throw std::invalid_argument("checker_parity: split must be at least 1");
  const Checker c{t.data(), ex.data(), ey.data(), lo.data(), hi.data(), split};
  const auto range = checker_range_variants.at(current_isa());
  double* dst = out.data();
  parallel_for(n, [&](ptrdiff_t a, ptrdiff_t b) { range(c, dst, a, b); });
}

// The point-sampled checker (basic.checker_parity without a footprint), one pass: t = p / box,
// nudged off a cell plane (towards centre where it is finite: inward, the side inside the
// clip box; else up) by nudge * max(1, |t|), then (-1)^(floor t summed) as the product of the
// axes' square waves (the same sign; numpy's summed floors lose the parity past 2^53)
void checker_points(const Points& points, const In<double, nb::shape<3>>& box, const In<double, nb::shape<3>>& centre, double nudge,
                    OutValues out) {
  same_rows(points.shape(0), out.shape(0), "out");
  const double *p = points.data(), *b = box.data(), *c = centre.data();
  double* dst = out.data();
  parallel_for(points.shape(0), [&](ptrdiff_t lo, ptrdiff_t hi) {
    for (ptrdiff_t i = lo; i < hi; ++i) {
      double sign = 1.0;
      for (int k = 0; k < 3; ++k) {
        double t = p[3 * i + k] / b[k];
        const double inward = std::isnan(c[k]) ? 1.0 : (t > c[k] ? -1.0 : 1.0);
        t += inward * nudge * std::max(1.0, std::fabs(t));
        sign *= square_wave(std::floor(t));
      }
      dst[i] = sign;
    }
  });
}

void affine(const Points& points, const In<double, nb::shape<3>>& origin, double scale, OutColours out) {
  same_rows(points.shape(0), out.shape(0), "out");
  const double *p = points.data(), *o = origin.data();
  double* dst = out.data();
  parallel_for(points.shape(0), [&](ptrdiff_t a, ptrdiff_t b) {
    for (ptrdiff_t i = 3 * a; i < 3 * b; i += 3) {
      for (int k = 0; k < 3; ++k) dst[i + k] = (p[i + k] - o[k]) * scale;
    }
  });
}

std::vector<std::string> instruction_sets() {
  std::vector<std::string> names;
  for (int isa = best_isa(); isa >= BASELINE; --isa) names.emplace_back(ISA_NAMES[isa]);
  return names;
}

std::string use_instruction_set(const std::optional<std::string>& name) {
  const std::string previous = ISA_NAMES[current_isa()];
  int chosen = -1;
  if (name) {
    for (int isa = BASELINE; isa <= best_isa(); ++isa) chosen = *name == ISA_NAMES[isa] ? isa : chosen;
    if (chosen < 0) throw std::invalid_argument("instruction set '" + *name + "': this CPU runs " + ISA_NAMES[best_isa()] + " at best");
  }
  chosen_isa.store(chosen, std::memory_order_relaxed);
  return previous;
}

}  // namespace texbake::textures

void bind_textures(nb::module_& m) {
  namespace t = texbake::textures;
  using nb::arg;
  const auto release = nb::call_guard<nb::gil_scoped_release>();
  m.attr("DROP_CELLS") = texbake::noise::DROP_CELLS;
  m.def("box_keep", &texbake::noise::box_keep, arg("s"),
        "The share of a noise octave that a box filter s lattice cells wide keeps (1 at 0, (1.5 / s)^2 from 4 on).");
  m.def("fade_factor", &texbake::noise::fade_factor, arg("s"),
        "box_keep(s), or 0 once the octave's cells are under 1/DROP_CELLS of the footprint (s >= DROP_CELLS, or NaN).");
  m.def("octave_sum", &t::octave_sum, arg("points"), arg("width").none(), arg("noise"), arg("index"), arg("noise2"), arg("hash4"),
        arg("basis"), arg("interpolation"), arg("octaves"), arg("lacunarity"), arg("gain"), arg("signed"), arg("basis_mean"),
        arg("scale"), arg("offset"), arg("out").noconvert(), release,
        "out[i]: the sum of octaves gain^k n(lacunarity^k q), q = points[i] * scale + offset, each shrunk towards its mean by "
        "the share of it a box filter over the footprint width[i] * |scale| keeps (width None: point sampling; "
        "texbake.textures.noise.octave_sum).");
  m.attr("QUAD_CELLS") = texbake::noise::QUAD_CELLS;
  m.def("quarter_octave_sums", &t::quarter_octave_sums, arg("points"), arg("dpdx"), arg("dpdy"), arg("width"), arg("noise"),
        arg("index"), arg("noise2"), arg("hash4"), arg("basis"), arg("interpolation"), arg("octaves"), arg("lacunarity"), arg("gain"),
        arg("signed"), arg("basis_mean"), arg("scale"), arg("offset"), arg("capped").none(), arg("out").noconvert(), release,
        "out (4, n): the octave sums at the four quarters of each footprint points[i] + a dpdx[i] + b dpdy[i], the octaves "
        "whose footprint spans QUAD_CELLS of a cell or more at the quarters over half the width, the coarser at the centre; "
        "capped (None: none) added to each (texbake.textures.noise.quarter_octave_sums).");
  m.def("quarter_marble", &t::quarter_marble, arg("points"), arg("dpdx"), arg("dpdy"), arg("width"), arg("noise"), arg("index"),
        arg("noise2"), arg("hash4"), arg("basis"), arg("interpolation"), arg("octaves"), arg("lacunarity"), arg("gain"),
        arg("basis_mean"), arg("scale"), arg("offset"), arg("capped").none(), arg("axis"), arg("frequency"), arg("amplitude"),
        arg("norm"), arg("spread_at"), arg("spreads"), arg("spread_lo"), arg("spread_hi"), arg("sines"), arg("waves"),
        arg("max_spread"), arg("out").noconvert(), release,
        "out (n, 3): the filtered marble's colours, the mean of its footprint quarters' wave colours "
        "(texbake.textures.colour.quarter_marble_colours).");
  m.def("marble", &t::marble, arg("points"), arg("width").none(), arg("noise"), arg("index"), arg("noise2"), arg("hash4"), arg("basis"),
        arg("interpolation"), arg("octaves"), arg("lacunarity"), arg("gain"), arg("basis_mean"), arg("scale"), arg("offset"),
        arg("axis"), arg("frequency"), arg("amplitude"), arg("capped"), arg("norm"), arg("sines"), arg("waves"), arg("max_spread"),
        arg("out").noconvert(), release, "out (n, 3): Perlin's marble colours in one pass (width None: point sampling; texbake.textures.colour.marble_colours).");
  m.def("instruction_sets", &t::instruction_sets, "The instruction sets the texture kernels can run on here, the best first.");
  m.def("instruction_set", [] { return std::string(t::ISA_NAMES[t::current_isa()]); },
        "The instruction set the texture kernels run on (the best the CPU has unless use_instruction_set chose another).");
  m.def("use_instruction_set", &t::use_instruction_set, arg("name").none(),
        "Run the texture kernels on the instruction set name (one of instruction_sets(); None: the best); returns the "
        "previous one. Every one gives the same values: the tests compare them.");
  m.def("colour_map", &t::colour_map, arg("values"), arg("samples"), arg("lo"), arg("step"), arg("out").noconvert(), release,
        "out (n, 3): the tabulated colour curve samples (m, 3) at values, knots from lo, step samples a unit.");
  m.def("wave_colours", &t::wave_colours, arg("phase"), arg("spread"), arg("table"), arg("max_spread"), arg("out").noconvert(),
        release, "out (n, 3): the wave table (spreads, phases, 3) at each phase and spread, bilinear.");
  m.def("checker_parity", &t::checker_parity, arg("t"), arg("ex"), arg("ey"), arg("lo"), arg("hi"), arg("split"),
        arg("out").noconvert(), release, "out (n,): the signed checker's mean (unit cells) over each point's footprint.");
  m.def("checker_points", &t::checker_points, arg("points"), arg("box"), arg("centre"), arg("nudge"), arg("out").noconvert(), release,
        "out (n,): the signed checker (cells box) at each point, nudged off a cell plane towards centre (NaN: up).");
  m.def("affine", &t::affine, arg("points"), arg("origin"), arg("scale"), arg("out").noconvert(), release,
        "out (n, 3) = (points - origin) * scale.");
}
