// The octave sums a block of BLOCK points at a time (see noise.hpp): each octave in stages
// over buffers that stay in the L1 cache, the arithmetic in loops the compiler vectorises,
// the table loads in one loop between them, a point at a time (the loads are most of the
// time; AVX2 gathers of them were 0.6x as fast, and so was letting the compiler vectorise
// the loop with loads inserted lane by lane).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "noise.hpp"

// Forced inline: each instruction set's copy of a kernel (target_clones, textures.cpp) then
// holds its own copy of the block's loops, vectorised for it; a function left out of line
// would be compiled once, for the baseline.
#define TEXBAKE_INLINE inline __attribute__((always_inline))

namespace texbake::noise {

struct Block {
  alignas(64) double x[BLOCK], y[BLOCK], z[BLOCK], w[BLOCK], acc[BLOCK];
  alignas(64) double tx[BLOCK], ty[BLOCK], tz[BLOCK], f[BLOCK];
  alignas(64) double x01[2 * BLOCK], x23[2 * BLOCK];  // the lerps along x of rows 0 and 1, 2 and 3, interleaved
  alignas(64) uint32_t cell[BLOCK];  // (iy * 256 + iz) * 256 + ix, each mod 256
};

// the block of points from start (scaled and offset; footprints scaled), padded with the
// origin; returns the count it holds, and in far those it leaves out (0 in their place):
// points whose top octave is past FAR, which octave_point wraps
TEXBAKE_INLINE std::ptrdiff_t load_block(const Octaves& o, const double* points, const double* width, std::ptrdiff_t start,
                                 std::ptrdiff_t end, Block& b, int& far) {
  const std::ptrdiff_t m = std::min(BLOCK, end - start);
  const double wscale = std::fabs(o.scale);
  far = 0;
  for (std::ptrdiff_t i = 0; i < m; ++i) {
    const double* p = points + 3 * (start + i);
    double x = p[0] * o.scale + o.offset, y = p[1] * o.scale + o.offset, z = p[2] * o.scale + o.offset;
    if (!near(std::fabs(x), std::fabs(y), std::fabs(z), o.top)) {
      x = y = z = 0.0;
      ++far;
    }
    b.x[i] = x, b.y[i] = y, b.z[i] = z;
    b.w[i] = width[start + i] * wscale;
  }
  for (std::ptrdiff_t i = m; i < BLOCK; ++i) b.x[i] = b.y[i] = b.z[i] = b.w[i] = 0.0;
  return m;
}

// each point's share of the octave at freq (b.f): fade_factor(w * freq), its branches
// written as selects of the same operations, so that the loop vectorises; returns how many
// points keep some of it
TEXBAKE_INLINE int block_fade(Block& b, double freq) {
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const double w = b.w[i], s = w * freq, a = 0.5 * s, c = 2.0 - a;
    const double low = a * (2.0 / 3.0) - a * a * a / 3.0 + a * a * a * a / 8.0;
    const double mid = 11.0 / 24.0 + (1.0 - c * c * c * c) / 24.0;
    const double rho = 3.0 * (a < 1.0 ? low : (a < 2.0 ? mid : 0.5)) / s;
    b.f[i] = w <= 0.0 ? 1.0 : (s < DROP_CELLS ? (s <= 0.0 ? 1.0 : rho * rho) : 0.0);
  }
  int kept = 0;
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) kept += b.f[i] != 0.0;
  return kept;
}

// lattice cells and fractions at freq. SMALL (every coordinate times freq under 2^31): the
// cells through int32; else mod 256 in floating point (c - 256 floor(c / 256): exact for
// integers), which vectorises where int64 & 255 does not. Both give int64(c) & 255
template <int INTERP, bool SMALL>
TEXBAKE_INLINE void block_cells(Block& b, double freq) {
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const double x = b.x[i] * freq, y = b.y[i] * freq, z = b.z[i] * freq;
    const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
    if (SMALL) {
      const uint32_t cx = uint32_t(int32_t(fx)) & 255, cy = uint32_t(int32_t(fy)) & 255, cz = uint32_t(int32_t(fz)) & 255;
      b.cell[i] = (cy << 16) | (cz << 8) | cx;
    } else {
      const double cx = fx - 256.0 * std::floor(fx * (1.0 / 256.0));
      const double cy = fy - 256.0 * std::floor(fy * (1.0 / 256.0));
      const double cz = fz - 256.0 * std::floor(fz * (1.0 / 256.0));
      const double c = (cy * 256.0 + cz) * 256.0 + cx;
      b.cell[i] = uint32_t(int32_t(c >= 0.0 && c < 16777216.0 ? c : 0.0));  // (a cell in range whatever comes in)
    }
    double sx = x - fx, sy = y - fy, sz = z - fz;
    if (INTERP == 1) sx = s_curve(sx), sy = s_curve(sy), sz = s_curve(sz);
    b.tx[i] = sx, b.ty[i] = sy, b.tz[i] = sz;
  }
}

// the table loads, and the lerps along x: a row's two corners in one 16-byte load, two
// rows' lerps in one instruction (the same operations as lattice_value's)
#if defined(__SSE2__)
__attribute__((noinline, optimize("no-tree-vectorize"))) inline void block_loads(Block& b, const Tables& t) {
  const double* n = t.noise2;
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const uint32_t c = b.cell[i];
    const uint32_t rows = t.hash4[c >> 8], ix = c & 255;
    const __m128d r0 = _mm_loadu_pd(n + (rows & 255) + ix), r1 = _mm_loadu_pd(n + ((rows >> 8) & 255) + ix);
    const __m128d r2 = _mm_loadu_pd(n + ((rows >> 16) & 255) + ix), r3 = _mm_loadu_pd(n + (rows >> 24) + ix);
    const __m128d s = _mm_set1_pd(b.tx[i]);
    const __m128d a01 = _mm_unpacklo_pd(r0, r1), b01 = _mm_unpackhi_pd(r0, r1);
    const __m128d a23 = _mm_unpacklo_pd(r2, r3), b23 = _mm_unpackhi_pd(r2, r3);
    _mm_store_pd(b.x01 + 2 * i, _mm_add_pd(a01, _mm_mul_pd(s, _mm_sub_pd(b01, a01))));
    _mm_store_pd(b.x23 + 2 * i, _mm_add_pd(a23, _mm_mul_pd(s, _mm_sub_pd(b23, a23))));
  }
}
#else
inline void block_loads(Block& b, const Tables& t) {
  const double* n = t.noise2;
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const uint32_t c = b.cell[i];
    const uint32_t rows = t.hash4[c >> 8], ix = c & 255;
    const uint32_t p[4] = {(rows & 255) + ix, ((rows >> 8) & 255) + ix, ((rows >> 16) & 255) + ix, (rows >> 24) + ix};
    double* x[4] = {b.x01 + 2 * i, b.x01 + 2 * i + 1, b.x23 + 2 * i, b.x23 + 2 * i + 1};
    for (int r = 0; r < 4; ++r) *x[r] = n[p[r]] + b.tx[i] * (n[p[r] + 1] - n[p[r]]);
  }
}
#endif

// the lerps along y and z, and the sum (an octave a point does not keep: its mean)
template <bool FILTERED>
TEXBAKE_INLINE void block_sum(Block& b, double amp, double sign, double mean) {
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const double x0 = b.x01[2 * i], x1 = b.x01[2 * i + 1], x2 = b.x23[2 * i], x3 = b.x23[2 * i + 1];
    const double y0 = x0 + b.ty[i] * (x1 - x0);
    const double y1 = x2 + b.ty[i] * (x3 - x2);
    const double v = sign * (y0 + b.tz[i] * (y1 - y0)) - (sign - 1.0);
    if (FILTERED) {
      const double f = b.f[i];
      b.acc[i] += amp * (f == 0.0 ? mean : (f >= 1.0 ? v : f * v + (1.0 - f) * mean));
    } else {
      b.acc[i] += amp * v;
    }
  }
}

// b.acc: the octave sums of the block's points through the derived tables; a block without
// footprints skips the shares (every point keeps every octave whole), an octave that no
// point keeps skips the loads (b's buffers hold finite values from before: read, unused)
template <int INTERP>
TEXBAKE_INLINE void octave_block(Block& b, const Octaves& o) {
  bool filtered = false;
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    b.acc[i] = 0.0;
    filtered |= !(b.w[i] <= 0.0);
  }
  double big = 0.0;
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) big = std::max(big, std::max(std::fabs(b.x[i]), std::max(std::fabs(b.y[i]), std::fabs(b.z[i]))));
  const bool small = big * o.top < 2.0e9;
  double amp = 1.0, freq = 1.0;
  for (int k = 0; k < o.count; ++k) {
    const int kept = filtered ? block_fade(b, freq) : int(BLOCK);
    if (kept > 0) {
      if (small) {
        block_cells<INTERP, true>(b, freq);
      } else {
        block_cells<INTERP, false>(b, freq);
      }
      block_loads(b, o.t);
    }
    if (filtered) {
      block_sum<true>(b, amp, o.sign, o.mean);
    } else {
      block_sum<false>(b, amp, o.sign, o.mean);
    }
    amp *= o.gain;
    freq *= o.lacunarity;
  }
}

// acc[i]: octave_point of point start + i for i < m (far_only: of those load_block left out)
inline void point_octaves(const Octaves& o, const double* points, const double* width, std::ptrdiff_t start, std::ptrdiff_t m,
                          bool far_only, double* acc) {
  const double wscale = std::fabs(o.scale);
  for (std::ptrdiff_t i = 0; i < m; ++i) {
    const double* p = points + 3 * (start + i);
    const double x = p[0] * o.scale + o.offset, y = p[1] * o.scale + o.offset, z = p[2] * o.scale + o.offset;
    const double ax = std::fabs(x), ay = std::fabs(y), az = std::fabs(z);
    if (far_only && near(ax, ay, az, o.top)) continue;
    acc[i] = octave_point(o, x, y, z, width[start + i] * wscale, ax, ay, az);
  }
}

// b.acc[:m]: the octave sums of the m points from start (a block's, or fewer before end);
// returns m. Value noise (linear or cubic) in a block, a point far out (and every point of
// another basis or interpolation) by itself
TEXBAKE_INLINE std::ptrdiff_t block_octaves(const Octaves& o, const double* points, const double* width, std::ptrdiff_t start,
                                    std::ptrdiff_t end, Block& b) {
  if (!o.tables()) {
    const std::ptrdiff_t m = std::min(BLOCK, end - start);
    point_octaves(o, points, width, start, m, false, b.acc);
    return m;
  }
  int far = 0;
  const std::ptrdiff_t m = load_block(o, points, width, start, end, b, far);
  if (o.interp == 1) {
    octave_block<1>(b, o);
  } else {
    octave_block<0>(b, o);
  }
  if (far) point_octaves(o, points, width, start, m, true, b.acc);
  return m;
}

// the highest of the octaves' frequencies (lacunarity^k, as the loops compute them)
inline double top_frequency(int count, double lacunarity) {
  double top = 1.0, freq = 1.0;
  for (int k = 0; k + 1 < count; ++k) {
    freq *= lacunarity;
    top = std::max(top, freq);
  }
  return top;
}

}  // namespace texbake::noise
