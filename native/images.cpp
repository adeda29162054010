// Image writing (texbake/output/images.py): 8-bit codes of float (or 0/1) pixels, sRGB
// encoded exactly with a table and two thresholds a code; 16-bit codes of data.
#include <cmath>
#include <stdexcept>
#include <vector>

#include "arrays.hpp"
#include "parallel.hpp"

namespace texbake {
namespace {

template <class T>
using Pixels = nb::ndarray<const T, nb::ndim<3>, nb::device::cpu>;  // any strides: a band or a channel slice

// an AVX2 build of a function beside the portable one, chosen when the module loads (the
// codes are the same: no FMA either way)
#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define TEXBAKE_AVX2_CLONE __attribute__((target_clones("avx2", "default")))
#else
#define TEXBAKE_AVX2_CLONE
#endif

// the 8-bit codes of values x, each first rounded to float32, NaN taken as 0, the rest
// clipped to [0, 1]: sRGB codes (the table's, moved by one where x lies beyond the
// thresholds above/below) or round(255 * x)
struct Codes {
  const uint8_t* lut;
  const float *up, *down;
  float scale;

  static float clipped(float x) { return !(x > 0) ? 0.0f : (x > 1 ? 1.0f : x); }  // NaN: 0
  uint8_t srgb(float x) const {
    x = clipped(x);
    const int64_t t = lut[int32_t(x * scale + 0.5f)];
    return uint8_t(t + (x >= up[t]) - (x < down[t]));
  }
  static uint8_t plain(float x) { return uint8_t(std::nearbyint(clipped(x) * 255.0f)); }
};

// n values of one contiguous run of pixels of c channels, the first `colour` of each sRGB
template <class T>
TEXBAKE_AVX2_CLONE void encode_run(const T* in, uint8_t* out, int64_t n, int64_t c, int64_t colour, const Codes& code) {
  if (colour >= c) {
    for (int64_t i = 0; i < n; ++i) out[i] = code.srgb(float(in[i]));
  } else if (colour == 0) {
    for (int64_t i = 0; i < n; ++i) out[i] = Codes::plain(float(in[i]));
  } else {
    for (int64_t i = 0; i < n; i += c) {
      for (int64_t k = 0; k < c; ++k) out[i + k] = k < colour ? code.srgb(float(in[i + k])) : Codes::plain(float(in[i + k]));
    }
  }
}

// out (h, w, c) uint8: the codes of pixels (h, w, c), the first `colour` channels sRGB
template <class T>
void encode8(Pixels<T> pixels, int64_t colour, In<uint8_t, nb::ndim<1>> table, In<float, nb::ndim<1>> above,
             In<float, nb::ndim<1>> below, Out<uint8_t, nb::ndim<3>> out) {
  const int64_t h = pixels.shape(0), w = pixels.shape(1), c = pixels.shape(2);
  if (out.shape(0) != pixels.shape(0) || out.shape(1) != pixels.shape(1) || out.shape(2) != pixels.shape(2))
    throw std::invalid_argument("encode8: out must have pixels' shape");
  if (above.shape(0) != 256 || below.shape(0) != 256 || table.shape(0) < 2)
    throw std::invalid_argument("encode8: above and below must hold 256 thresholds");
  const Codes code{table.data(), above.data(), below.data(), float(table.shape(0) - 1)};
  const bool packed = pixels.stride(2) == 1 && pixels.stride(1) == c && pixels.stride(0) == w * c;
  const auto px = pixels.view();
  uint8_t* o = out.data();
  parallel_for(h, [&](std::ptrdiff_t r0, std::ptrdiff_t r1) {
    std::vector<T> gathered(packed ? 0 : w * c);
    for (int64_t i = r0; i < r1; ++i) {
      const T* row = pixels.data() + i * w * c;
      if (!packed) {  // a strided row (a channel slice) copied into one run first
        for (int64_t j = 0; j < w; ++j) {
          for (int64_t k = 0; k < c; ++k) gathered[j * c + k] = px(i, j, k);
        }
        row = gathered.data();
      }
      encode_run(row, o + i * w * c, w * c, c, colour, code);
    }
  }, std::max<int64_t>(1, MIN_PIECE / std::max<int64_t>(w * c, 1)));
}

// out (h, w, c) uint16: round(65535 x) of pixels (h, w, c) first rounded to float32, NaN
// taken as 0, the rest clipped to [0, 1] (numpy's rint of the float32 product: the same codes)
template <class T>
void encode16(Pixels<T> pixels, Out<uint16_t, nb::ndim<3>> out) {
  const int64_t h = pixels.shape(0), w = pixels.shape(1), c = pixels.shape(2);
  if (out.shape(0) != pixels.shape(0) || out.shape(1) != pixels.shape(1) || out.shape(2) != pixels.shape(2))
    throw std::invalid_argument("encode16: out must have pixels' shape");
  const auto px = pixels.view();
  uint16_t* o = out.data();
  parallel_for(h, [&](std::ptrdiff_t r0, std::ptrdiff_t r1) {
    for (int64_t i = r0; i < r1; ++i) {
      uint16_t* row = o + i * w * c;
      for (int64_t j = 0; j < w; ++j) {
        for (int64_t k = 0; k < c; ++k) row[j * c + k] = uint16_t(std::nearbyint(Codes::clipped(float(px(i, j, k))) * 65535.0f));
      }
    }
  }, std::max<int64_t>(1, MIN_PIECE / std::max<int64_t>(w * c, 1)));
}

}  // namespace

void bind_images(nb::module_& m) {
  const char* doc = "out (h, w, c) uint8: the 8-bit codes of pixels (h, w, c), the first colour channels sRGB-encoded exactly.";
  // float32, float64, and bool viewed as uint8; float16 is widened by the caller
  m.def("encode8", &encode8<float>, nb::arg("pixels").noconvert(), nb::arg("colour"), nb::arg("table"), nb::arg("above"),
        nb::arg("below"), nb::arg("out").noconvert(), Release(), doc);
  m.def("encode8", &encode8<double>, nb::arg("pixels").noconvert(), nb::arg("colour"), nb::arg("table"), nb::arg("above"),
        nb::arg("below"), nb::arg("out").noconvert(), Release(), doc);
  m.def("encode8", &encode8<uint8_t>, nb::arg("pixels").noconvert(), nb::arg("colour"), nb::arg("table"), nb::arg("above"),
        nb::arg("below"), nb::arg("out").noconvert(), Release(), doc);
  const char* doc16 = "out (h, w, c) uint16: round(65535 x) of pixels (h, w, c) as float32, NaN as 0, clipped to [0, 1].";
  m.def("encode16", &encode16<float>, nb::arg("pixels").noconvert(), nb::arg("out").noconvert(), Release(), doc16);
  m.def("encode16", &encode16<double>, nb::arg("pixels").noconvert(), nb::arg("out").noconvert(), Release(), doc16);
}

}  // namespace texbake
