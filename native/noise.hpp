// Lattice noise, Perlin's improved noise and their octave sums filtered by the texel
// footprint: the per-point arithmetic of texbake/textures/noise.py's kernels.
//
// Lattice noise as the lecture states it: PERM(x) = indexTable[x & 255],
// INDEX(i, j, k) = PERM(i + PERM(j + PERM(k))), the value noiseTable[INDEX(i, j, k)], lerps
// along x, then y, then z. A point is split in float64 into its cell (floor) and fraction,
// so negative coordinates and points far from the origin keep their precision; past 4e18 a
// coordinate has no fraction left and is wrapped mod 256 (the tables repeat every 256 cells).
//
// Value noise (linear or cubic) reads two tables derived from a seed's (noise.hash_tables):
// hash4, for a lattice row (j, k) at j * 256 + k, the four hashes PERM(j + PERM(k)),
// PERM(j + 1 + PERM(k)), PERM(j + PERM(k + 1)), PERM(j + 1 + PERM(k + 1)), a byte each of one
// uint32: one load for the four rows of a cell; noise2, noiseTable[PERM(h)] twice over (512),
// so a row's corners i and i + 1 are noise2[row + i] and noise2[row + i + 1]. Nine loads a
// cell instead of twelve, the same values.
//
// The octave sums go a block of BLOCK points at a time, an octave at a time in stages over
// buffers that stay in the L1 cache: the arithmetic (floor, fractions, s-curves, the lerps
// along y and z, the footprint's share, the sum) in loops the compiler vectorises, the table
// loads and the lerps along x in one scalar loop between them. Per point the operations and
// their order are those of the one-point path (octave_point), and which path a point takes
// depends on the point alone, so its value does not depend on the block it is in. Built
// without FMA contraction (CMakeLists.txt), every instruction set rounds alike.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace texbake::noise {

constexpr double FAR = 4.0e18;       // |coordinate| past which it is wrapped (no fraction left; int64 still holds it)
constexpr double DROP_CELLS = 8.0;   // octaves with cells under 1/DROP_CELLS of the footprint are not evaluated
constexpr double QUAD_CELLS = 1.0 / 20.0;  // octaves whose footprint spans this much of a cell or more: at its quarters (textures.cpp)
constexpr std::ptrdiff_t BLOCK = 128;

struct Tables {
  const double* noise;    // noiseTable (256)
  const int64_t* index;   // indexTable (256): a permutation of 0..255
  const double* noise2;   // noiseTable[PERM(h)] twice over (512)
  const uint32_t* hash4;  // a lattice row's four PERM(j + PERM(k)), a byte each (65536)
};

struct Octaves {
  Tables t;
  int basis;        // 0: value noise, 1: Perlin's
  int interp;       // 0: linear, 1: cubic, 2: Catmull-Rom (value noise)
  int count;        // octaves evaluated
  double lacunarity, gain;
  double sign;      // 1, or 2 for signed octaves (2n - 1)
  double mean;      // an octave's mean (signed: 2 mean - 1)
  double top;       // the highest octave frequency, lacunarity^k as the loop computes it
  double scale, offset;
  bool avx2;        // the call runs on AVX2 (or AVX-512): the table loads take 32-byte registers
  bool tables() const { return basis == 0 && interp < 2; }
};

inline int64_t perm(const int64_t* index, int64_t x) { return index[x & 255]; }

// x itself, or past FAR (no fraction left) x mod 256 (exact); an overflow to infinity (or
// NaN) becomes lattice point 0
inline double wrap(double x) {
  if (std::fabs(x) < FAR) return x;
  return std::isfinite(x) ? std::fmod(x, 256.0) : 0.0;
}

// every coordinate times f below FAR (as max(|x|, |y|, |z|) * f < FAR); false for NaN
inline bool near(double ax, double ay, double az, double f) { return ax * f < FAR && ay * f < FAR && az * f < FAR; }

inline double lattice(const Tables& t, int64_t i, int64_t j, int64_t k) {
  return t.noise[perm(t.index, i + perm(t.index, j + perm(t.index, k)))];
}

inline double catmull_rom(double t, double a, double b, double c, double d) {
  return 0.5 * ((2.0 * b) + (c - a) * t + (2.0 * a - 5.0 * b + 4.0 * c - d) * t * t + (3.0 * b - a - 3.0 * c + d) * t * t * t);
}

inline double s_curve(double t) { return t * t * (3.0 - 2.0 * t); }

inline double catmull_rom_noise(const Tables& t, int64_t ix, int64_t iy, int64_t iz, double tx, double ty, double tz) {
  double planes[4];
  for (int c = 0; c < 4; ++c) {
    double rows[4];
    for (int b = 0; b < 4; ++b) {
      const int64_t j = iy + b - 1, k = iz + c - 1;
      rows[b] = catmull_rom(tx, lattice(t, ix - 1, j, k), lattice(t, ix, j, k), lattice(t, ix + 1, j, k), lattice(t, ix + 2, j, k));
    }
    planes[c] = catmull_rom(ty, rows[0], rows[1], rows[2], rows[3]);
  }
  return catmull_rom(tz, planes[0], planes[1], planes[2], planes[3]);
}

// value noise at any point (wrapped past FAR), from the plain tables
inline double value_noise(const Tables& t, double x, double y, double z, int interp) {
  x = wrap(x), y = wrap(y), z = wrap(z);
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int64_t ix = int64_t(fx), iy = int64_t(fy), iz = int64_t(fz);
  double tx = x - fx, ty = y - fy, tz = z - fz;
  if (interp == 2) return catmull_rom_noise(t, ix, iy, iz, tx, ty, tz);
  if (interp == 1) tx = s_curve(tx), ty = s_curve(ty), tz = s_curve(tz);
  // INDEX(i, j, k) = PERM(i + PERM(j + PERM(k))), sharing the inner PERMs
  const int64_t* index = t.index;
  const int64_t pz0 = perm(index, iz), pz1 = perm(index, iz + 1);
  const int64_t p00 = perm(index, iy + pz0) + ix, p10 = perm(index, iy + 1 + pz0) + ix;
  const int64_t p01 = perm(index, iy + pz1) + ix, p11 = perm(index, iy + 1 + pz1) + ix;
  const double* n = t.noise;
  const double x0 = n[perm(index, p00)] + tx * (n[perm(index, p00 + 1)] - n[perm(index, p00)]);
  const double x1 = n[perm(index, p10)] + tx * (n[perm(index, p10 + 1)] - n[perm(index, p10)]);
  const double x2 = n[perm(index, p01)] + tx * (n[perm(index, p01 + 1)] - n[perm(index, p01)]);
  const double x3 = n[perm(index, p11)] + tx * (n[perm(index, p11 + 1)] - n[perm(index, p11)]);
  const double y0 = x0 + ty * (x1 - x0), y1 = x2 + ty * (x3 - x2);
  return y0 + tz * (y1 - y0);
}

// linear (interp 0) or cubic (1) value noise at a point within FAR of the origin, from the
// derived tables: the same lattice values and lerps as value_noise
inline double lattice_value(const Tables& t, double x, double y, double z, int interp) {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int64_t ix = int64_t(fx) & 255, iy = int64_t(fy) & 255, iz = int64_t(fz) & 255;
  double tx = x - fx, ty = y - fy, tz = z - fz;
  if (interp == 1) tx = s_curve(tx), ty = s_curve(ty), tz = s_curve(tz);
  const int64_t rows = t.hash4[iy * 256 + iz];  // the four rows' PERM(j + PERM(k)), a byte each
  const int64_t p00 = (rows & 255) + ix, p10 = ((rows >> 8) & 255) + ix, p01 = ((rows >> 16) & 255) + ix, p11 = (rows >> 24) + ix;
  const double* n = t.noise2;
  const double x0 = n[p00] + tx * (n[p00 + 1] - n[p00]);
  const double x1 = n[p10] + tx * (n[p10 + 1] - n[p10]);
  const double x2 = n[p01] + tx * (n[p01 + 1] - n[p01]);
  const double x3 = n[p11] + tx * (n[p11 + 1] - n[p11]);
  const double y0 = x0 + ty * (x1 - x0), y1 = x2 + ty * (x3 - x2);
  return y0 + tz * (y1 - y0);
}

inline double grad(int64_t h, double x, double y, double z) {
  h &= 15;
  const double u = h < 8 ? x : y;
  const double v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
  return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

inline double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

// Perlin's improved noise (2002), in about [-1, 1]
inline double perlin_noise(const Tables& t, double x, double y, double z) {
  x = wrap(x), y = wrap(y), z = wrap(z);
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int64_t ix = int64_t(fx), iy = int64_t(fy), iz = int64_t(fz);
  x -= fx, y -= fy, z -= fz;
  const double u = fade(x), v = fade(y), w = fade(z);
  const int64_t* p = t.index;
  const int64_t a = perm(p, ix) + iy, aa = perm(p, a) + iz, ab = perm(p, a + 1) + iz;
  const int64_t b = perm(p, ix + 1) + iy, ba = perm(p, b) + iz, bb = perm(p, b + 1) + iz;
  const double l0 = grad(perm(p, aa), x, y, z) + u * (grad(perm(p, ba), x - 1, y, z) - grad(perm(p, aa), x, y, z));
  const double l1 = grad(perm(p, ab), x, y - 1, z) + u * (grad(perm(p, bb), x - 1, y - 1, z) - grad(perm(p, ab), x, y - 1, z));
  const double l2 = grad(perm(p, aa + 1), x, y, z - 1) + u * (grad(perm(p, ba + 1), x - 1, y, z - 1) - grad(perm(p, aa + 1), x, y, z - 1));
  const double l3 = grad(perm(p, ab + 1), x, y - 1, z - 1)
                    + u * (grad(perm(p, bb + 1), x - 1, y - 1, z - 1) - grad(perm(p, ab + 1), x, y - 1, z - 1));
  const double m0 = l0 + v * (l1 - l0), m1 = l2 + v * (l3 - l2);
  return m0 + w * (m1 - m0);
}

// one octave, about [0, 1] (Catmull-Rom: about [-0.10, 1.11])
inline double basis_value(const Tables& t, double x, double y, double z, int basis, int interp) {
  if (basis == 1) return 0.5 + 0.5 * perlin_noise(t, x, y, z);
  return value_noise(t, x, y, z, interp);
}

// The share of an octave that survives a box filter s lattice cells wide: the least-squares
// guess of its box average from one sample is mean + rho (v - mean), rho the correlation of
// the box average with the centre value. For linearly interpolated lattice noise the
// autocorrelation along an axis is the cubic B-spline R (R(0) = 2/3), so along one axis
// rho1(s) = 3 I(s/2) / s with I(a) the integral of R over [0, a]; the footprint spans two
// axes: rho1(s)^2. 1 at s = 0, 0.944 at 1/2, 0.81 at 1, 0.47 at 2, (1.5 / s)^2 from 4 on.
inline double box_keep(double s) {
  if (s <= 0.0) return 1.0;
  const double a = 0.5 * s;
  double integral;
  if (a < 1.0) {
    integral = a * (2.0 / 3.0) - a * a * a / 3.0 + a * a * a * a / 8.0;
  } else if (a < 2.0) {
    const double b = 2.0 - a;
    integral = 11.0 / 24.0 + (1.0 - b * b * b * b) / 24.0;
  } else {
    integral = 0.5;
  }
  const double rho = 3.0 * integral / s;
  return rho * rho;
}

// weight of an octave whose cell is 1/s of the footprint: its box share, or 0 once it is
// below 1/DROP_CELLS of it (or s is NaN)
inline double fade_factor(double s) { return s < DROP_CELLS ? box_keep(s) : 0.0; }

// one point's octave sum, octave by octave, each through the derived tables or (wrapped far
// out, or another basis) the plain ones; ax, ay, az: |x|, |y|, |z|
inline double octave_point(const Octaves& o, double x, double y, double z, double w, double ax, double ay, double az) {
  const bool tables = o.tables();
  double acc = 0.0, amp = 1.0, freq = 1.0;
  for (int k = 0; k < o.count; ++k) {
    const double f = w <= 0.0 ? 1.0 : fade_factor(w * freq);
    if (f == 0.0) {
      acc += amp * o.mean;
    } else {
      double v = tables && near(ax, ay, az, freq) ? lattice_value(o.t, x * freq, y * freq, z * freq, o.interp)
                                                  : basis_value(o.t, x * freq, y * freq, z * freq, o.basis, o.interp);
      v = o.sign * v - (o.sign - 1.0);
      acc += amp * (f >= 1.0 ? v : f * v + (1.0 - f) * o.mean);  // kept whole: v exactly
    }
    amp *= o.gain;
    freq *= o.lacunarity;
  }
  return acc;
}

}  // namespace texbake::noise
