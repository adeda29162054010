// A material's node program (texbake/materials/program.py): the nodes between the leaves
// (textures, position, normal, constants) and the channels, run a block of points at a
// time, every node once per point, so that a node several channels use costs once and the
// channels come out of one pass. Each value travels as its mean over the texel's footprint
// and its variance there (the variance is left out when nothing is filtered): linear nodes
// carry means as they are (and variances as sums); a non-linear node takes its input as a
// Gaussian of that mean and variance and gives the mean of its function over it (closed
// form for threshold, clamp, smoothstep and overlay, 12-point Gauss-Hermite quadrature for
// power, divide and the curves), as the marble's colour map does (textures/colour.py).
// Inputs are taken as independent of one another. NaN in, NaN out.
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/vector.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "colour.hpp"
#include "noise.hpp"
#include "parallel.hpp"

namespace texbake::materials {
namespace {

using std::ptrdiff_t;

constexpr ptrdiff_t BLOCK = 128;
constexpr double NaN = std::numeric_limits<double>::quiet_NaN();
constexpr double LUMA[3] = {0.2126, 0.7152, 0.0722};

// program.py's OPCODES
enum Op : int32_t {
  ADD = 1, SUBTRACT, MULTIPLY, DIVIDE, POWER, INVERT, CLAMP, THRESHOLD, SMOOTHSTEP, MIX, SCREEN, OVERLAY, CHANNEL, COMBINE,
  CURVE, COLORMAP
};
enum Kind : int32_t { LEAF = 0, CONSTANT = 1, TEMP = 2 };

struct Instr {
  int32_t op, dst, a, b, c, param, column, spread_column;  // where the mean and the variance are exported (-1: not)
};
struct SlotDef {
  int32_t kind, channels, ref;  // ref: the leaf, the constant's offset in params, or the temporary buffer
};

// a slot as a block sees it: point i's channel k at i * stride + (channels == 1 ? 0 : k)
struct View {
  double* mean;
  double* var;  // null: no spread
  ptrdiff_t stride;
  int channels;
  double m(ptrdiff_t i, int k) const { return mean[i * stride + (channels == 1 ? 0 : k)]; }
  double v(ptrdiff_t i, int k) const { return var ? var[i * stride + (channels == 1 ? 0 : k)] : 0.0; }
};

struct Program {
  std::vector<Instr> code;
  std::vector<SlotDef> slots;
  std::vector<const double*> leaf_mean, leaf_var;  // leaf_var[j] null: no spread
  const double* params;
  const double* tables;
  int temps;
  bool spread;  // variances are carried
  double *out_mean, *out_var;
  ptrdiff_t columns, spread_columns;
};

// -- the Gaussian's pieces ----------------------------------------------------------------

inline double Phi(double z) { return 0.5 * std::erfc(-z * 0.7071067811865476); }
inline double phi(double z) { return 0.3989422804014327 * std::exp(-0.5 * z * z); }

// I[k] = integral over [alpha, beta] of z^k phi(z) dz, k = 0..K (the ends clamped to +-30,
// past which phi is below 1e-195)
inline void partial_moments(double alpha, double beta, int K, double* I) {
  alpha = std::min(std::max(alpha, -30.0), 30.0), beta = std::min(std::max(beta, -30.0), 30.0);
  const double pa = phi(alpha), pb = phi(beta);
  I[0] = Phi(beta) - Phi(alpha);
  if (K >= 1) I[1] = pa - pb;
  double ak = alpha, bk = beta;  // alpha^(k-1), beta^(k-1)
  for (int k = 2; k <= K; ++k) {
    I[k] = (k - 1) * I[k - 2] + ak * pa - bk * pb;
    ak *= alpha, bk *= beta;
  }
}

// the mean, under phi, of the polynomial sum c[j] u^j, u = a + b z, given I[i] = the mean of
// z^i over the part of the line in question (partial_moments, or a whole Gaussian's: WHOLE)
inline double poly_mean(const double* c, int degree, double a, double b, const double* I) {
  double z[8] = {0.0}, binom[8] = {1.0}, ap[8] = {1.0}, bp[8] = {1.0};  // z: the coefficients in z
  for (int j = 1; j <= degree; ++j) ap[j] = ap[j - 1] * a, bp[j] = bp[j - 1] * b;
  for (int j = 0; j <= degree; ++j) {  // (a + b z)^j = sum_i C(j, i) a^(j-i) b^i z^i
    for (int i = j; i > 0; --i) binom[i] += binom[i - 1];
    for (int i = 0; i <= j; ++i) z[i] += c[j] * binom[i] * ap[j - i] * bp[i];
  }
  double total = 0.0;
  for (int i = 0; i <= degree; ++i) total += z[i] * I[i];
  return total;
}

constexpr double WHOLE[7] = {1.0, 0.0, 1.0, 0.0, 3.0, 0.0, 15.0};  // E z^i of a standard normal
// past FAR standard deviations a Gaussian's tail is under 1e-15: a piece's edge that far is not crossed
constexpr double FAR = 8.0;

// Gauss-Hermite: the mean of f(mu + sigma Z) is sum w_j f(mu + sigma x_j); 12 points, or 3
// (exact for polynomials up to degree 5) where sigma is under SMALL_SPREAD: a spread that
// narrow next to the [0, 1] the values mostly span leaves the functions near polynomial
constexpr double GH_X[6] = {0.444403001944139, 1.340375197151617, 2.2594644510007993, 3.2237098287700974, 4.2718258479322815,
                            5.500901704467748};
constexpr double GH_W[6] = {0.32166436151283, 0.14696704804532998, 0.02911668791236418, 0.002203380687533198,
                            4.8371849225906334e-05, 1.4999271676371695e-07};
constexpr double SMALL_SPREAD = 0.02;
constexpr ptrdiff_t SMOOTH_ROWS = 64, SMOOTH_VALUES = 1024;  // program.SPREAD_ROWS, SMOOTH_VALUES

template <class F>
inline void quadrature(double mu, double sigma, F&& f, double& mean, double& square) {
  if (sigma < SMALL_SPREAD) {
    const double c = f(mu), lo = f(mu - 1.7320508075688772 * sigma), hi = f(mu + 1.7320508075688772 * sigma);
    mean = (4.0 * c + lo + hi) / 6.0, square = (4.0 * c * c + lo * lo + hi * hi) / 6.0;
    return;
  }
  mean = square = 0.0;
  for (int j = 0; j < 6; ++j) {
    const double lo = f(mu - sigma * GH_X[j]), hi = f(mu + sigma * GH_X[j]);
    mean += GH_W[j] * (lo + hi);
    square += GH_W[j] * (lo * lo + hi * hi);
  }
}

inline double spread_of(double mean, double square) { return std::max(square - mean * mean, 0.0); }

// -- the ops on one point and channel: (mean, variance) in, out --------------------------

inline void clamp_op(double mu, double var, double lo, double hi, double& m, double& v) {
  const double s = var > 0.0 ? std::sqrt(var) : 0.0, alpha = (lo - mu) / s, beta = (hi - mu) / s;
  if (!(var > 0.0) || std::isnan(mu)) {
    m = std::isnan(mu) ? NaN : std::min(std::max(mu, lo), hi), v = 0.0;
  } else if (alpha > FAR || beta < -FAR) {  // all below lo, or all above hi
    m = alpha > FAR ? lo : hi, v = 0.0;
  } else if (alpha < -FAR && beta > FAR) {  // all inside: as it is
    m = mu, v = var;
  } else {
    double I[3];
    partial_moments(alpha, beta, 2, I);
    const double below = Phi(std::min(alpha, 30.0)), above = 1.0 - Phi(std::max(beta, -30.0));
    const double inside1 = mu * I[0] + s * I[1], inside2 = mu * mu * I[0] + 2.0 * mu * s * I[1] + var * I[2];
    m = lo * below + hi * above + inside1;
    v = spread_of(m, lo * lo * below + hi * hi * above + inside2);
  }
}

inline void threshold_op(double mu, double var, double at, double& m, double& v) {
  const double z = var > 0.0 ? (mu - at) / std::sqrt(var) : 0.0;
  if (std::isnan(mu)) {
    m = NaN, v = 0.0;
  } else if (!(var > 0.0) || std::fabs(z) > FAR) {
    m = mu >= at ? 1.0 : 0.0, v = 0.0;
  } else {
    m = Phi(z), v = m * (1.0 - m);
  }
}

inline void smoothstep_op(double mu, double var, double e0, double e1, double& m, double& v) {
  const double d = e1 - e0;
  constexpr double step[4] = {0.0, 0.0, 3.0, -2.0};  // 3u^2 - 2u^3
  constexpr double square[7] = {0.0, 0.0, 0.0, 0.0, 9.0, -12.0, 4.0};  // its square
  const double s = var > 0.0 ? std::sqrt(var) : 0.0, alpha = (e0 - mu) / s, beta = (e1 - mu) / s;
  if (std::isnan(mu)) {
    m = NaN, v = 0.0;
  } else if (!(var > 0.0) || alpha > FAR || beta < -FAR) {  // a point, or all on one flat side
    const double u = std::min(std::max((mu - e0) / d, 0.0), 1.0);
    m = u * u * (3.0 - 2.0 * u), v = 0.0;
  } else if (alpha < -FAR && beta > FAR) {  // all on the cubic: its Gaussian moments
    m = poly_mean(step, 3, (mu - e0) / d, s / d, WHOLE);
    v = spread_of(m, poly_mean(square, 6, (mu - e0) / d, s / d, WHOLE));
  } else {
    double I[7];
    partial_moments(alpha, beta, 6, I);
    const double a = (mu - e0) / d, b = s / d, above = 1.0 - Phi(std::max(beta, -30.0));
    m = above + poly_mean(step, 3, a, b, I);
    v = spread_of(m, above + poly_mean(square, 6, a, b, I));
  }
}

// a over b (overlay): 2ab below a = 1/2, 1 - 2(1 - a)(1 - b) above, with a Gaussian
inline void overlay_op(double ma, double va, double mb, double vb, double& m, double& v) {
  const double b2 = vb + mb * mb, nb = 1.0 - mb, nb2 = 1.0 - 2.0 * mb + b2;  // E b^2, E(1 - b), E(1 - b)^2
  if (!(va > 0.0) || std::isnan(ma) || std::fabs(0.5 - ma) > FAR * std::sqrt(va)) {  // on one side of 1/2
    if (std::isnan(ma)) {
      m = NaN, v = 0.0;
    } else if (ma < 0.5) {  // 2ab of independent a and b
      m = 2.0 * ma * mb, v = 4.0 * (va * vb + va * mb * mb + vb * ma * ma);
    } else {
      m = 1.0 - 2.0 * (1.0 - ma) * nb, v = 4.0 * (va * vb + va * nb * nb + vb * (1.0 - ma) * (1.0 - ma));
    }
    return;
  }
  const double s = std::sqrt(va), beta = std::min(std::max((0.5 - ma) / s, -30.0), 30.0), pb = phi(beta);
  const double low = Phi(beta), high = 1.0 - low;
  const double a1 = ma * low - s * pb;                              // E[a; a < 1/2]
  const double a2 = (ma * ma + va) * low - s * (ma + 0.5) * pb;     // E[a^2; a < 1/2]
  const double u1 = (1.0 - ma) * high - s * pb;                     // E[1 - a; a >= 1/2]
  const double u2 = high - 2.0 * (ma * high + s * pb) + (ma * ma + va - a2);  // E[(1 - a)^2; a >= 1/2]
  m = 2.0 * mb * a1 + high - 2.0 * nb * u1;
  v = spread_of(m, 4.0 * b2 * a2 + high - 4.0 * nb * u1 + 4.0 * nb2 * u2);
}

inline double table_value(const double* table, ptrdiff_t rows, double lo, double step, double x) {
  const double t = std::min(std::max((x - lo) * step, 0.0), double(rows - 1));
  if (!(t >= 0.0)) return NaN;
  const ptrdiff_t j = std::min(ptrdiff_t(t), rows - 2);
  const double f = t - double(j);
  return table[j] * (1.0 - f) + table[j + 1] * f;
}

// -- the program over a block ---------------------------------------------------------------

// the binary ops whose result, channel k of point i, is f(means and variances of a and b)
template <class F>
inline void binary(const View& a, const View& b, View& d, ptrdiff_t n, F&& f) {
  for (ptrdiff_t i = 0; i < n; ++i) {
    for (int k = 0; k < d.channels; ++k) {
      double m, v;
      f(a.m(i, k), a.v(i, k), b.m(i, k), b.v(i, k), m, v);
      d.mean[i * d.channels + k] = m;
      if (d.var) d.var[i * d.channels + k] = v;
    }
  }
}

template <class F>
inline void unary(const View& a, View& d, ptrdiff_t n, F&& f) {
  for (ptrdiff_t i = 0; i < n; ++i) {
    for (int k = 0; k < d.channels; ++k) {
      double m, v;
      f(a.m(i, k), a.v(i, k), m, v);
      d.mean[i * d.channels + k] = m;
      if (d.var) d.var[i * d.channels + k] = v;
    }
  }
}

void mix_op(const View& a, const View& b, const View& c, View& d, ptrdiff_t n) {
  for (ptrdiff_t i = 0; i < n; ++i) {
    const double mm = c.m(i, 0), vm = c.v(i, 0), m2 = vm + mm * mm;
    for (int k = 0; k < d.channels; ++k) {
      const double ma = a.m(i, k), mb = b.m(i, k);
      const double mean = ma + mm * (mb - ma);
      d.mean[i * d.channels + k] = mean;
      if (d.var) {
        const double a2 = a.v(i, k) + ma * ma, b2 = b.v(i, k) + mb * mb;
        const double square = a2 * (1.0 - 2.0 * mm + m2) + 2.0 * ma * mb * (mm - m2) + b2 * m2;
        d.var[i * d.channels + k] = spread_of(mean, square);
      }
    }
  }
}

// a remap's smoothed table (program.smoothed_table): (2, rows, values, c), the mean and the
// mean square of the curve over a Gaussian of each spread about each value, bilinear
struct Smoothed {
  const double* table;
  ptrdiff_t rows, values;
  int channels;
  double start, per_unit, top;
};

inline void smoothed(const Smoothed& s, double x, double sigma, double* mean, double* square) {
  const double u = std::min(std::max((x - s.start) * s.per_unit, 0.0), double(s.values - 1));
  const double r = std::min(sigma / s.top, 1.0) * double(s.rows - 1);
  const ptrdiff_t j = std::min(ptrdiff_t(u), s.values - 2), i = std::min(ptrdiff_t(r), s.rows - 2);
  const double fu = u - double(j), fr = r - double(i);
  const ptrdiff_t c = s.channels, plane = s.rows * s.values * c;
  for (int k = 0; k < c; ++k) {
    double out[2];
    for (int q = 0; q < 2; ++q) {
      const double* row0 = s.table + q * plane + i * s.values * c;
      const double* row1 = row0 + s.values * c;
      const double low = row0[j * c + k] * (1.0 - fu) + row0[(j + 1) * c + k] * fu;
      const double high = row1[j * c + k] * (1.0 - fu) + row1[(j + 1) * c + k] * fu;
      out[q] = low * (1.0 - fr) + high * fr;
    }
    mean[k] = out[0], square[k] = out[1];
  }
}

// a remap: its curve at the mean, or where the input spreads the mean over it: three points
// (quadrature()) under SMALL_SPREAD, the smoothed table above it
void curve_op(const Program& p, const Instr& in, const View& a, View& d, ptrdiff_t n) {
  const double* q = p.params + in.param;
  const colour::Curve curve{p.tables + ptrdiff_t(q[0]), ptrdiff_t(q[1]), q[2], q[3]};
  const int c = in.op == COLORMAP ? 3 : 1;
  const Smoothed table{p.tables + ptrdiff_t(q[4]), SMOOTH_ROWS, SMOOTH_VALUES, c, q[5], q[6], q[7]};
  const auto at = [&](double t, double w, double* mean, double* square) {
    double rgb[3];
    if (c == 3) {
      colour::map_colour(curve, t, rgb);
    } else {
      rgb[0] = table_value(curve.samples, curve.rows, curve.lo, curve.step, t);
    }
    for (int k = 0; k < c; ++k) mean[k] += w * rgb[k], square[k] += w * rgb[k] * rgb[k];
  };
  for (ptrdiff_t i = 0; i < n; ++i) {
    const double x = a.m(i, 0), var = a.v(i, 0), sigma = var > 0.0 ? std::sqrt(var) : 0.0;
    double mean[3] = {0.0, 0.0, 0.0}, square[3] = {0.0, 0.0, 0.0};
    if (std::isnan(x)) {
      mean[0] = mean[1] = mean[2] = NaN;
    } else if (sigma >= SMALL_SPREAD) {
      smoothed(table, x, sigma, mean, square);
    } else if (sigma > 0.0) {
      const double h = 1.7320508075688772 * sigma;
      at(x, 4.0 / 6.0, mean, square), at(x - h, 1.0 / 6.0, mean, square), at(x + h, 1.0 / 6.0, mean, square);
    } else {
      at(x, 1.0, mean, square);
    }
    for (int k = 0; k < d.channels; ++k) {
      d.mean[i * d.channels + k] = mean[k];
      if (d.var) d.var[i * d.channels + k] = spread_of(mean[k], square[k]);
    }
  }
}

void channel_op(const Program& p, const Instr& in, const View& a, View& d, ptrdiff_t n) {
  const int which = int(p.params[in.param]);
  for (ptrdiff_t i = 0; i < n; ++i) {
    double m = 0.0, v = 0.0;
    if (which == 3) {
      for (int k = 0; k < 3; ++k) m += LUMA[k] * a.m(i, k), v += LUMA[k] * LUMA[k] * a.v(i, k);
    } else {
      m = a.m(i, which), v = a.v(i, which);
    }
    d.mean[i] = m;
    if (d.var) d.var[i] = v;
  }
}

double safe_inverse(double b) { return b != 0.0 ? 1.0 / b : 0.0; }

void run_op(const Program& p, const Instr& in, std::vector<View>& views, ptrdiff_t n) {
  const View &a = views[in.a], &b = views[std::max(in.b, 0)], &c = views[std::max(in.c, 0)];
  View& d = views[in.dst];
  const double* q = p.params + std::max(in.param, 0);
  switch (in.op) {
    case ADD:
      return binary(a, b, d, n, [](double ma, double va, double mb, double vb, double& m, double& v) { m = ma + mb, v = va + vb; });
    case SUBTRACT:
      return binary(a, b, d, n, [](double ma, double va, double mb, double vb, double& m, double& v) { m = ma - mb, v = va + vb; });
    case MULTIPLY:
      return binary(a, b, d, n, [](double ma, double va, double mb, double vb, double& m, double& v) {
        m = ma * mb, v = va * vb + va * mb * mb + vb * ma * ma;
      });
    case SCREEN:
      return binary(a, b, d, n, [](double ma, double va, double mb, double vb, double& m, double& v) {
        m = 1.0 - (1.0 - ma) * (1.0 - mb), v = va * vb + va * (1.0 - mb) * (1.0 - mb) + vb * (1.0 - ma) * (1.0 - ma);
      });
    case OVERLAY:
      return binary(a, b, d, n, overlay_op);
    case DIVIDE:
      return binary(a, b, d, n, [](double ma, double va, double mb, double vb, double& m, double& v) {
        double r = safe_inverse(mb), r2 = r * r;
        if (vb > 0.0) quadrature(mb, std::sqrt(vb), safe_inverse, r, r2);
        m = ma * r, v = spread_of(m, (va + ma * ma) * r2);
      });
    case POWER:
      return binary(a, b, d, n, [](double ma, double va, double mb, double, double& m, double& v) {
        const auto f = [mb](double x) { return std::pow(std::max(x, 0.0), mb); };
        double square;
        if (va > 0.0) {
          quadrature(ma, std::sqrt(va), f, m, square);
        } else {
          m = f(ma), square = m * m;
        }
        v = spread_of(m, square);
      });
    case INVERT:
      return unary(a, d, n, [](double ma, double va, double& m, double& v) { m = 1.0 - ma, v = va; });
    case CLAMP:
      return unary(a, d, n, [q](double ma, double va, double& m, double& v) { clamp_op(ma, va, q[0], q[1], m, v); });
    case THRESHOLD:
      return unary(a, d, n, [q](double ma, double va, double& m, double& v) { threshold_op(ma, va, q[0], m, v); });
    case SMOOTHSTEP:
      return unary(a, d, n, [q](double ma, double va, double& m, double& v) { smoothstep_op(ma, va, q[0], q[1], m, v); });
    case MIX:
      return mix_op(a, b, c, d, n);
    case CHANNEL:
      return channel_op(p, in, a, d, n);
    case COMBINE:
      for (ptrdiff_t i = 0; i < n; ++i) {
        const View* parts[3] = {&a, &b, &c};
        for (int k = 0; k < 3; ++k) {
          d.mean[3 * i + k] = parts[k]->m(i, 0);
          if (d.var) d.var[3 * i + k] = parts[k]->v(i, 0);
        }
      }
      return;
    case CURVE:
    case COLORMAP:
      return curve_op(p, in, a, d, n);
    default:
      throw std::invalid_argument("material program: unknown op " + std::to_string(in.op));
  }
}

void run_range(const Program& p, ptrdiff_t lo, ptrdiff_t hi) {
  std::vector<double> buffers(size_t(p.temps) * 2 * BLOCK * 3);
  std::vector<View> views(p.slots.size());
  for (size_t s = 0; s < p.slots.size(); ++s) {
    const SlotDef& def = p.slots[s];
    if (def.kind == CONSTANT) views[s] = {const_cast<double*>(p.params + def.ref), nullptr, 0, def.channels};
    if (def.kind == TEMP) {
      double* buffer = buffers.data() + ptrdiff_t(def.ref) * 2 * BLOCK * 3;
      views[s] = {buffer, p.spread ? buffer + BLOCK * 3 : nullptr, def.channels, def.channels};
    }
  }
  for (ptrdiff_t start = lo; start < hi; start += BLOCK) {
    const ptrdiff_t n = std::min(BLOCK, hi - start);
    for (size_t s = 0; s < p.slots.size(); ++s) {
      const SlotDef& def = p.slots[s];
      if (def.kind != LEAF) continue;
      const double* var = p.leaf_var[def.ref];
      views[s] = {const_cast<double*>(p.leaf_mean[def.ref]) + start * def.channels,
                  var ? const_cast<double*>(var) + start * def.channels : nullptr, def.channels, def.channels};
    }
    for (const Instr& in : p.code) {
      run_op(p, in, views, n);
      const View& d = views[in.dst];
      for (ptrdiff_t i = 0; in.column >= 0 && i < n; ++i) {
        for (int k = 0; k < d.channels; ++k) p.out_mean[(start + i) * p.columns + in.column + k] = d.mean[i * d.channels + k];
      }
      for (ptrdiff_t i = 0; p.spread && in.spread_column >= 0 && i < n; ++i) {
        for (int k = 0; k < d.channels; ++k) {
          p.out_var[(start + i) * p.spread_columns + in.spread_column + k] = d.var ? d.var[i * d.channels + k] : 0.0;
        }
      }
    }
  }
}

using Array = In<double>;

void run_program(In<int32_t, shape<-1, 8>> code, In<int32_t, shape<-1, 3>> slots, const std::vector<Array>& leaf_mean,
                 const std::vector<Array>& leaf_var, In<double, nb::ndim<1>> params, In<double, nb::ndim<1>> tables,
                 int temps, bool spread, Out<double, nb::ndim<2>> out_mean, Out<double, nb::ndim<2>> out_var) {
  const ptrdiff_t n = out_mean.shape(0);
  Program p;
  p.params = params.data(), p.tables = tables.data(), p.temps = temps, p.spread = spread;
  p.columns = out_mean.shape(1), p.out_mean = out_mean.data();
  p.spread_columns = out_var.shape(1), p.out_var = out_var.data();
  if (p.spread_columns > 0 && ptrdiff_t(out_var.shape(0)) != n)
    throw std::invalid_argument("material program: out_var must have out_mean's rows, or no columns");
  if (leaf_mean.size() != leaf_var.size()) throw std::invalid_argument("material program: a variance (or none) for each leaf");
  for (ptrdiff_t s = 0; s < ptrdiff_t(slots.shape(0)); ++s) {
    const SlotDef def{slots(s, 0), slots(s, 1), slots(s, 2)};
    const bool leaf_ok = def.kind != LEAF || (def.ref >= 0 && size_t(def.ref) < leaf_mean.size() &&
                                              ptrdiff_t(leaf_mean[def.ref].size()) == n * def.channels);
    if ((def.channels != 1 && def.channels != 3) || !leaf_ok || (def.kind == TEMP && (def.ref < 0 || def.ref >= temps)) ||
        (def.kind == CONSTANT && (def.ref < 0 || def.ref + def.channels > ptrdiff_t(params.shape(0)))))
      throw std::invalid_argument("material program: slot " + std::to_string(s) + " is not a leaf of n rows, a constant or a buffer");
    p.slots.push_back(def);
  }
  for (const auto& leaf : leaf_mean) p.leaf_mean.push_back(leaf.data());
  for (size_t j = 0; j < leaf_var.size(); ++j) {
    const bool some = leaf_var[j].size() > 0 && spread;
    if (leaf_var[j].size() > 0 && leaf_var[j].size() != leaf_mean[j].size())
      throw std::invalid_argument("material program: a leaf's variance must be its mean's shape, or empty");
    p.leaf_var.push_back(some ? leaf_var[j].data() : nullptr);
  }
  const ptrdiff_t count = ptrdiff_t(p.slots.size());
  for (ptrdiff_t r = 0; r < ptrdiff_t(code.shape(0)); ++r) {
    const Instr in{code(r, 0), code(r, 1), code(r, 2), code(r, 3), code(r, 4), code(r, 5), code(r, 6), code(r, 7)};
    const bool ok = in.dst >= 0 && in.dst < count && p.slots[in.dst].kind == TEMP && in.a >= 0 && in.a < count && in.b < count &&
                    in.c < count && in.param < ptrdiff_t(params.shape(0)) &&
                    (in.column < 0 || in.column + p.slots[in.dst].channels <= p.columns) &&
                    (!spread || in.spread_column < 0 || in.spread_column + p.slots[in.dst].channels <= p.spread_columns);
    if (!ok) throw std::invalid_argument("material program: instruction " + std::to_string(r) + " refers outside its slots");
    p.code.push_back(in);
  }
  {
    nb::gil_scoped_release release;
    parallel_for(n, [&](ptrdiff_t lo, ptrdiff_t hi) { run_range(p, lo, hi); });
  }
}

// out[i] = sum over k < octaves of gain^(2k) (1 - fade_factor(width[i] |scale| lacunarity^k)): the
// variance of a unit octave sum that the footprint's filtering leaves inside the texel
void octave_spread(In<double, nb::ndim<1>> width, int octaves, double lacunarity, double gain, double scale,
                   Out<double, nb::ndim<1>> out) {
  const ptrdiff_t n = width.shape(0);
  if (ptrdiff_t(out.shape(0)) != n) throw std::invalid_argument("octave_spread: out must be width's length");
  const double* w = width.data();
  double* dst = out.data();
  const double s = std::fabs(scale);
  parallel_for(n, [&](ptrdiff_t lo, ptrdiff_t hi) {
    std::fill(dst + lo, dst + hi, 0.0);
    double weight = 1.0, freq = s;
    for (int k = 0; k < octaves; ++k, weight *= gain * gain, freq *= lacunarity) {
      for (ptrdiff_t i = lo; i < hi; ++i) {  // fade_factor as selects (octaves.hpp's block_fade), so that it vectorises
        const double x = w[i] * freq, a = 0.5 * x, c = 2.0 - a;
        const double low = a * (2.0 / 3.0) - a * a * a / 3.0 + a * a * a * a / 8.0;
        const double mid = 11.0 / 24.0 + (1.0 - c * c * c * c) / 24.0;
        const double rho = 3.0 * (a < 1.0 ? low : (a < 2.0 ? mid : 0.5)) / (x > 0.0 ? x : 1.0);
        const double keep = x > 0.0 ? (x < noise::DROP_CELLS ? rho * rho : 0.0) : (x == 0.0 ? 1.0 : 0.0);
        dst[i] += weight * (1.0 - keep);
      }
    }
  });
}

inline void unit3(double* v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (n > 0.0) v[0] /= n, v[1] /= n, v[2] /= n;
}

inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// maps/bump.py's height_normal_map after its heights (its reference, in one pass): the
// forward differences along the texel's edges to the surface gradient, the tilted normal in
// the tangent frame (frame (n, 3, 3), or the atlas's from the edges), a detail normal laid
// over it, encoded; green flipped for DirectX
void height_normals(In<double, nb::ndim<1>> centre, In<double, nb::ndim<1>> shifted, In<double, shape<-1, 3>> dpdx,
                    In<double, shape<-1, 3>> dpdy, In<double, shape<-1, 3>> normals, In<double, shape<-1, 3, 3>> frame, double scale,
                    In<double, shape<-1, 3>> detail, bool directx, Out<double, shape<-1, 3>> out) {
  const ptrdiff_t n = centre.shape(0);
  const bool framed = frame.shape(0) > 0, detailed = detail.shape(0) > 0;
  if (ptrdiff_t(shifted.shape(0)) != 2 * n || ptrdiff_t(dpdx.shape(0)) != n || ptrdiff_t(dpdy.shape(0)) != n ||
      ptrdiff_t(out.shape(0)) != n || (framed ? ptrdiff_t(frame.shape(0)) != n : ptrdiff_t(normals.shape(0)) != n) ||
      (detailed && ptrdiff_t(detail.shape(0)) != n))
    throw std::invalid_argument("height_normals: n heights, 2n shifted, n edges, normals or frames (and details)");
  const double *h = centre.data(), *hs = shifted.data(), *ex = dpdx.data(), *ey = dpdy.data();
  const double *nr = normals.data(), *fr = frame.data(), *dt = detail.data();
  double* o = out.data();
  parallel_for(n, [&](ptrdiff_t lo, ptrdiff_t hi) {
    for (ptrdiff_t i = lo; i < hi; ++i) {
      const double *x = ex + 3 * i, *y = ey + 3 * i;
      const double along_x = 2.0 * (hs[i] - h[i]), along_y = 2.0 * (hs[n + i] - h[i]);
      const double xx = dot3(x, x), xy = dot3(x, y), yy = dot3(y, y), det = xx * yy - xy * xy;
      const bool ok = det > 1e-12 * std::max(xx * yy, 1e-300);
      const double alpha = ok ? (yy * along_x - xy * along_y) / det : 0.0, beta = ok ? (xx * along_y - xy * along_x) / det : 0.0;
      double nn[3], t[3], b[3], g[3];
      for (int k = 0; k < 3; ++k) nn[k] = framed ? fr[9 * i + 6 + k] : nr[3 * i + k], g[k] = alpha * x[k] + beta * y[k];
      unit3(nn);
      const double gn = dot3(g, nn);
      double bent[3];
      for (int k = 0; k < 3; ++k) bent[k] = nn[k] - scale * (g[k] - gn * nn[k]);
      unit3(bent);
      if (framed) {
        for (int k = 0; k < 3; ++k) t[k] = fr[9 * i + k], b[k] = fr[9 * i + 3 + k];
      } else {  // the atlas's frame: T along +u (dpdx), B along +v (against dpdy)
        const double xn = dot3(x, nn);
        for (int k = 0; k < 3; ++k) t[k] = x[k] - xn * nn[k];
        unit3(t);
        b[0] = nn[1] * t[2] - nn[2] * t[1], b[1] = nn[2] * t[0] - nn[0] * t[2], b[2] = nn[0] * t[1] - nn[1] * t[0];
        const double side = -dot3(y, b) + 1e-300;
        for (int k = 0; k < 3; ++k) b[k] *= side > 0.0 ? 1.0 : (side < 0.0 ? -1.0 : 0.0);
      }
      double local[3] = {dot3(bent, t), dot3(bent, b), dot3(bent, nn)};
      if (!(std::sqrt(dot3(nn, nn)) > 0.0)) local[0] = 0.0, local[1] = 0.0, local[2] = 1.0;
      if (detailed) {  // whiteout: the slopes added, the z multiplied
        double d[3] = {2.0 * dt[3 * i] - 1.0, 2.0 * dt[3 * i + 1] - 1.0, 2.0 * dt[3 * i + 2] - 1.0};
        unit3(d);
        local[0] += d[0], local[1] += d[1], local[2] *= d[2];
        unit3(local);
      }
      o[3 * i] = 0.5 + 0.5 * local[0];
      o[3 * i + 1] = directx ? 0.5 - 0.5 * local[1] : 0.5 + 0.5 * local[1];
      o[3 * i + 2] = 0.5 + 0.5 * local[2];
    }
  });
}

}  // namespace

void bind_materials(nb::module_& m) {
  using nb::arg;
  m.def("material_program", &run_program, arg("code"), arg("slots"), arg("leaf_mean"), arg("leaf_var"), arg("params"),
        arg("tables"), arg("temps"), arg("spread"), arg("out_mean").noconvert(), arg("out_var").noconvert(),
        "Run a material's node program (texbake.materials.program) over n points: code (k, 8) int32 rows of op, dst, a, b, c, "
        "param, column, spread column; slots (s, 3) int32 of kind (0 leaf, 1 constant, 2 buffer), channels, ref; the leaves' "
        "means (n, channels) and variances (the same, or empty); spread: carry variances; exports into out_mean (n, columns) "
        "and out_var (n, spread columns).");
  m.def("height_normals", &height_normals, arg("centre"), arg("shifted"), arg("dpdx"), arg("dpdy"), arg("normals"), arg("frame"),
        arg("scale"), arg("detail"), arg("directx"), arg("out").noconvert(), Release(),
        "out (n, 3): encoded tangent-space normals from heights (n,) and those half a texel on along dpdx then dpdy (2n,) "
        "(texbake.maps.bump.height_normal_map); normals (n, 3) or frame (n, 3, 3) (the other empty), detail (n, 3) or empty.");
  m.def("octave_spread", &octave_spread, arg("width"), arg("octaves"), arg("lacunarity"), arg("gain"), arg("scale"),
        arg("out").noconvert(), Release(),
        "out[i]: the sum over k < octaves of gain^(2k) (1 - fade_factor(width[i] |scale| lacunarity^k)).");
}

}  // namespace texbake::materials
