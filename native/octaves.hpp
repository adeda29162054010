// The octave sums a block of BLOCK points at a time (see noise.hpp): each octave in stages
// over buffers that stay in the L1 cache, the arithmetic in loops the compiler vectorises,
// the table loads in one loop between them, written by hand, four points at a time (the
// loads are most of the time; AVX2 gathers of them were 0.6x as fast, AVX-512 gathers too,
// and so was letting the compiler vectorise the loop with loads inserted lane by lane).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(TEXBAKE_NO_CLONES)
#define TEXBAKE_ISAS  // the kernels are built for AVX-512 and AVX2 beside the baseline (textures.cpp)
#include <immintrin.h>
#endif

#include "noise.hpp"

// Forced inline: each instruction set's copy of a kernel (textures.cpp) then holds its own
// copy of the block's loops, vectorised for it; a function left out of line would be
// compiled once, for the baseline.
#define TEXBAKE_INLINE inline __attribute__((always_inline))

namespace texbake::noise {

struct Block {
  alignas(64) double x[BLOCK], y[BLOCK], z[BLOCK], w[BLOCK], acc[BLOCK];
  alignas(64) double tx[BLOCK], ty[BLOCK], tz[BLOCK], f[BLOCK];
  alignas(64) double x0[BLOCK], x1[BLOCK], x2[BLOCK], x3[BLOCK];  // the lerps along x of the cell's four rows
  alignas(64) uint32_t row[BLOCK];     // the cell's lattice row in hash4: (iy mod 256) * 256 + iz mod 256
  alignas(64) uint64_t corner[BLOCK];  // the address of noise2[ix mod 256]: a row h's corners are h and h + 1 on from it
  alignas(64) double n[BLOCK];         // each point's own octave count (octave_block<_, true>), a double for the vectorised compare
};

// the block of points from start (scaled and offset; footprints scaled: 0 where width is
// null), padded with the origin; returns the count it holds, and in far those it leaves out
// (0 in their place): points whose top octave is past FAR, which octave_point wraps
TEXBAKE_INLINE std::ptrdiff_t load_block(const Octaves& o, const double* points, const double* width, std::ptrdiff_t start,
                                 std::ptrdiff_t end, Block& b, int& far) {
  const std::ptrdiff_t m = std::min(BLOCK, end - start);
  const double wscale = std::fabs(o.scale);
  far = 0;
  const double* p = points + 3 * start;
  for (std::ptrdiff_t i = 0; i < m; ++i) {  // near() as selects, so that the loop vectorises
    const double x = p[3 * i] * o.scale + o.offset, y = p[3 * i + 1] * o.scale + o.offset, z = p[3 * i + 2] * o.scale + o.offset;
    const bool kept = (std::fabs(x) * o.top < FAR) & (std::fabs(y) * o.top < FAR) & (std::fabs(z) * o.top < FAR);
    b.x[i] = kept ? x : 0.0, b.y[i] = kept ? y : 0.0, b.z[i] = kept ? z : 0.0;
    far += !kept;
  }
  if (width) {
    for (std::ptrdiff_t i = 0; i < m; ++i) b.w[i] = width[start + i] * wscale;
  } else {
    for (std::ptrdiff_t i = 0; i < m; ++i) b.w[i] = 0.0 * wscale;
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
TEXBAKE_INLINE void block_cells(Block& b, double freq, const double* noise2) {
  const uint64_t corners = reinterpret_cast<uint64_t>(noise2);
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const double x = b.x[i] * freq, y = b.y[i] * freq, z = b.z[i] * freq;
    const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
    uint32_t cell;  // (iy * 256 + iz) * 256 + ix, each mod 256
    if (SMALL) {
      const uint32_t cx = uint32_t(int32_t(fx)) & 255, cy = uint32_t(int32_t(fy)) & 255, cz = uint32_t(int32_t(fz)) & 255;
      cell = (cy << 16) | (cz << 8) | cx;
    } else {
      const double cx = fx - 256.0 * std::floor(fx * (1.0 / 256.0));
      const double cy = fy - 256.0 * std::floor(fy * (1.0 / 256.0));
      const double cz = fz - 256.0 * std::floor(fz * (1.0 / 256.0));
      const double c = (cy * 256.0 + cz) * 256.0 + cx;
      cell = uint32_t(int32_t(c >= 0.0 && c < 16777216.0 ? c : 0.0));  // (a cell in range whatever comes in)
    }
    b.row[i] = cell >> 8;
    b.corner[i] = corners + uint64_t(cell & 255) * sizeof(double);
    double sx = x - fx, sy = y - fy, sz = z - fz;
    if (INTERP == 1) sx = s_curve(sx), sy = s_curve(sy), sz = s_curve(sz);
    b.tx[i] = sx, b.ty[i] = sy, b.tz[i] = sz;
  }
}

// The table loads, and the lerps along x (the same operations as lattice_value's): a row's
// two corners in one 16-byte load, a row's lerps for two points (SSE2) or four (AVX2) in one
// instruction, written to the block's x0..x3 as the vectorised loops read them.
#if defined(__SSE2__)
// the 16-byte rows a (point 0) and b (point 1): their lerps lo + s (hi - lo)
inline __m128d lerp2(__m128d a, __m128d b, __m128d s) {
  const __m128d lo = _mm_unpacklo_pd(a, b), hi = _mm_unpackhi_pd(a, b);
  return _mm_add_pd(lo, _mm_mul_pd(s, _mm_sub_pd(hi, lo)));
}

__attribute__((noinline, optimize("no-tree-vectorize"))) inline void block_loads_sse2(Block& b, const Tables& t) {
  const uint32_t* hash4 = t.hash4;
  for (std::ptrdiff_t i = 0; i < BLOCK; i += 2) {
    const uint32_t h = hash4[b.row[i]], g = hash4[b.row[i + 1]];
    const double* n = reinterpret_cast<const double*>(b.corner[i]);
    const double* m = reinterpret_cast<const double*>(b.corner[i + 1]);
    const __m128d s = _mm_load_pd(b.tx + i);
    _mm_store_pd(b.x0 + i, lerp2(_mm_loadu_pd(n + (h & 255)), _mm_loadu_pd(m + (g & 255)), s));
    _mm_store_pd(b.x1 + i, lerp2(_mm_loadu_pd(n + ((h >> 8) & 255)), _mm_loadu_pd(m + ((g >> 8) & 255)), s));
    _mm_store_pd(b.x2 + i, lerp2(_mm_loadu_pd(n + ((h >> 16) & 255)), _mm_loadu_pd(m + ((g >> 16) & 255)), s));
    _mm_store_pd(b.x3 + i, lerp2(_mm_loadu_pd(n + (h >> 24)), _mm_loadu_pd(m + (g >> 24)), s));
  }
}
#endif

#if defined(TEXBAKE_ISAS)
// the 16-byte rows of points 0 and 2 (a), 1 and 3 (b) of four: their lerps, in order
__attribute__((always_inline, target("avx2"))) inline __m256d lerp4(__m256d a, __m256d b, __m256d s) {
  const __m256d lo = _mm256_unpacklo_pd(a, b), hi = _mm256_unpackhi_pd(a, b);
  return _mm256_add_pd(lo, _mm256_mul_pd(s, _mm256_sub_pd(hi, lo)));
}

__attribute__((always_inline, target("avx2"))) inline __m256d rows2(const double* p, const double* q) {
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p)), _mm_loadu_pd(q), 1);
}

__attribute__((noinline, target("avx2"), optimize("no-tree-vectorize"))) inline void block_loads_avx2(Block& b, const Tables& t) {
  const uint32_t* hash4 = t.hash4;
  for (std::ptrdiff_t i = 0; i < BLOCK; i += 4) {
    const uint32_t h0 = hash4[b.row[i]], h1 = hash4[b.row[i + 1]], h2 = hash4[b.row[i + 2]], h3 = hash4[b.row[i + 3]];
    const double* n0 = reinterpret_cast<const double*>(b.corner[i]);
    const double* n1 = reinterpret_cast<const double*>(b.corner[i + 1]);
    const double* n2 = reinterpret_cast<const double*>(b.corner[i + 2]);
    const double* n3 = reinterpret_cast<const double*>(b.corner[i + 3]);
    const __m256d s = _mm256_load_pd(b.tx + i);
    _mm256_store_pd(b.x0 + i, lerp4(rows2(n0 + (h0 & 255), n2 + (h2 & 255)), rows2(n1 + (h1 & 255), n3 + (h3 & 255)), s));
    _mm256_store_pd(b.x1 + i, lerp4(rows2(n0 + ((h0 >> 8) & 255), n2 + ((h2 >> 8) & 255)),
                                    rows2(n1 + ((h1 >> 8) & 255), n3 + ((h3 >> 8) & 255)), s));
    _mm256_store_pd(b.x2 + i, lerp4(rows2(n0 + ((h0 >> 16) & 255), n2 + ((h2 >> 16) & 255)),
                                    rows2(n1 + ((h1 >> 16) & 255), n3 + ((h3 >> 16) & 255)), s));
    _mm256_store_pd(b.x3 + i, lerp4(rows2(n0 + (h0 >> 24), n2 + (h2 >> 24)), rows2(n1 + (h1 >> 24), n3 + (h3 >> 24)), s));
  }
}
#endif

// avx2: the call runs on AVX2 (or AVX-512)
inline void block_loads(Block& b, const Tables& t, bool avx2) {
#if defined(TEXBAKE_ISAS)
  if (avx2) return block_loads_avx2(b, t);
#endif
  (void)avx2;
#if defined(__SSE2__)
  block_loads_sse2(b, t);
#else
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const uint32_t rows = t.hash4[b.row[i]];
    const double* n = reinterpret_cast<const double*>(b.corner[i]);
    const uint32_t p[4] = {rows & 255, (rows >> 8) & 255, (rows >> 16) & 255, rows >> 24};
    double* x[4] = {b.x0 + i, b.x1 + i, b.x2 + i, b.x3 + i};
    for (int r = 0; r < 4; ++r) *x[r] = n[p[r]] + b.tx[i] * (n[p[r] + 1] - n[p[r]]);
  }
#endif
}

// the lerps along y and z, and the sum (an octave a point does not keep: its mean). COUNTED:
// octave k is added only to the points whose own count (b.n) is past it, a select rather
// than a branch, so that the loop vectorises (and acc is left as it was, not acc + 0)
template <bool FILTERED, bool COUNTED = false>
TEXBAKE_INLINE void block_sum(Block& b, double amp, double sign, double mean, double k = 0.0) {
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    const double x0 = b.x0[i], x1 = b.x1[i], x2 = b.x2[i], x3 = b.x3[i];
    const double y0 = x0 + b.ty[i] * (x1 - x0);
    const double y1 = x2 + b.ty[i] * (x3 - x2);
    const double v = sign * (y0 + b.tz[i] * (y1 - y0)) - (sign - 1.0);
    double sum;
    if (FILTERED) {
      const double f = b.f[i];
      sum = b.acc[i] + amp * (f == 0.0 ? mean : (f >= 1.0 ? v : f * v + (1.0 - f) * mean));
    } else {
      sum = b.acc[i] + amp * v;
    }
    b.acc[i] = COUNTED && !(k < b.n[i]) ? b.acc[i] : sum;
  }
}

// b.acc: the octave sums of the block's points through the derived tables; a block without
// footprints skips the shares (every point keeps every octave whole), an octave that no
// point keeps skips the loads (b's buffers hold finite values from before: read, unused).
// COUNTED: each point's sum stops at its own count (b.n; o.count the block's most, o.top
// its frequency), its octaves those of a sum of that many: the quarter kernel's points in
// one block whatever their first quarter octave
template <int INTERP, bool COUNTED = false>
TEXBAKE_INLINE void octave_block(Block& b, const Octaves& o) {
  bool filtered = false;
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    b.acc[i] = 0.0;
    filtered |= !(b.w[i] <= 0.0);
  }
  // every coordinate at the top octave under 2^31 (the block's are finite: load_block); a
  // count, not a max, so that the loop vectorises
  int large = 0;
  for (std::ptrdiff_t i = 0; i < BLOCK; ++i) {
    large += !(std::fabs(b.x[i]) * o.top < 2.0e9) | !(std::fabs(b.y[i]) * o.top < 2.0e9) | !(std::fabs(b.z[i]) * o.top < 2.0e9);
  }
  const bool small = large == 0;
  double amp = 1.0, freq = 1.0;
  for (int k = 0; k < o.count; ++k) {
    const int kept = filtered ? block_fade(b, freq) : int(BLOCK);
    if (kept > 0) {
      if (small) {
        block_cells<INTERP, true>(b, freq, o.t.noise2);
      } else {
        block_cells<INTERP, false>(b, freq, o.t.noise2);
      }
      block_loads(b, o.t, o.avx2);
    }
    if (filtered) {
      block_sum<true, COUNTED>(b, amp, o.sign, o.mean, double(k));
    } else {
      block_sum<false, COUNTED>(b, amp, o.sign, o.mean, double(k));
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
    acc[i] = octave_point(o, x, y, z, (width ? width[start + i] : 0.0) * wscale, ax, ay, az);
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

// A block's worth of points whose octave sums each have a scale, offset, width and octave
// count of their own (the quarter kernel's, textures.cpp), staged for sample_octaves. Each
// point's sum is bit for bit the one octave_sum would give it called with its own values
struct Samples {
  alignas(64) double p[3 * BLOCK];
  alignas(64) double scale[BLOCK], offset[BLOCK], width[BLOCK];
  alignas(64) double top[BLOCK];  // top_frequency(count): which points are past FAR, as octave_sum's Octaves decides
  int count[BLOCK];
  std::ptrdiff_t m;
};

// load_block over staged samples, each scaled by its own scale and offset
TEXBAKE_INLINE void load_samples(const Samples& s, Block& b, int& far) {
  far = 0;
  for (std::ptrdiff_t i = 0; i < s.m; ++i) {
    const double x = s.p[3 * i] * s.scale[i] + s.offset[i], y = s.p[3 * i + 1] * s.scale[i] + s.offset[i];
    const double z = s.p[3 * i + 2] * s.scale[i] + s.offset[i];
    const bool kept = (std::fabs(x) * s.top[i] < FAR) & (std::fabs(y) * s.top[i] < FAR) & (std::fabs(z) * s.top[i] < FAR);
    b.x[i] = kept ? x : 0.0, b.y[i] = kept ? y : 0.0, b.z[i] = kept ? z : 0.0;
    far += !kept;
  }
  for (std::ptrdiff_t i = 0; i < s.m; ++i) {
    b.w[i] = s.width[i] * std::fabs(s.scale[i]);
    b.n[i] = double(s.count[i]);
  }
  for (std::ptrdiff_t i = s.m; i < BLOCK; ++i) b.x[i] = b.y[i] = b.z[i] = b.w[i] = b.n[i] = 0.0;
}

// sample i scaled and offset, as load_samples does; returns whether it is within FAR at its top octave
inline bool sample_at(const Samples& s, std::ptrdiff_t i, double& x, double& y, double& z) {
  const double* p = s.p + 3 * i;
  x = p[0] * s.scale[i] + s.offset[i], y = p[1] * s.scale[i] + s.offset[i], z = p[2] * s.scale[i] + s.offset[i];
  return near(std::fabs(x), std::fabs(y), std::fabs(z), s.top[i]);
}

// sample i's octave sum by itself (point_octaves')
inline double sample_point(Octaves o, const Samples& s, std::ptrdiff_t i) {
  double x, y, z;
  sample_at(s, i, x, y, z);
  o.count = s.count[i];
  return octave_point(o, x, y, z, s.width[i] * std::fabs(s.scale[i]), std::fabs(x), std::fabs(y), std::fabs(z));
}

// b.acc[:s.m]: the samples' octave sums (block_octaves, each with its own scale, offset and
// count; o's count and top are the block's most: tops[c] is top_frequency(c))
TEXBAKE_INLINE void sample_octaves(Octaves o, const Samples& s, const double* tops, Block& b) {
  int most = 0;
  for (std::ptrdiff_t i = 0; i < s.m; ++i) most = std::max(most, s.count[i]);
  if (most == 0) {  // nothing to sum (the caller reads none of it)
    std::fill(b.acc, b.acc + s.m, 0.0);
    return;
  }
  o.count = most, o.top = tops[most];
  if (!o.tables()) {
    for (std::ptrdiff_t i = 0; i < s.m; ++i) b.acc[i] = sample_point(o, s, i);
    return;
  }
  int far = 0;
  load_samples(s, b, far);
  if (o.interp == 1) {
    octave_block<1, true>(b, o);
  } else {
    octave_block<0, true>(b, o);
  }
  double x, y, z;
  for (std::ptrdiff_t i = 0; far && i < s.m; ++i) {
    if (!sample_at(s, i, x, y, z)) b.acc[i] = sample_point(o, s, i);
  }
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
