// Image writing (texbake/output/images.py): 8-bit codes of float (or 0/1) pixels, sRGB
// encoded exactly with a table and two thresholds a code.
#include <cmath>
#include <stdexcept>

#include "arrays.hpp"
#include "parallel.hpp"

namespace texbake {
namespace {

template <class T>
using Pixels = nb::ndarray<const T, nb::ndim<3>, nb::device::cpu>;  // any strides: a band or a channel slice

// out (h, w, c) uint8: the first `colour` channels round(255 * srgb_encode(x)) (the table's
// code, moved by one where x lies beyond the thresholds above/below), the others
// round(255 * x); each value first rounded to float32, NaN taken as 0, the rest clipped to [0, 1]
template <class T>
void encode8(Pixels<T> pixels, int64_t colour, In<uint8_t, nb::ndim<1>> table, In<float, nb::ndim<1>> above,
             In<float, nb::ndim<1>> below, Out<uint8_t, nb::ndim<3>> out) {
  const int64_t h = pixels.shape(0), w = pixels.shape(1), c = pixels.shape(2);
  if (out.shape(0) != pixels.shape(0) || out.shape(1) != pixels.shape(1) || out.shape(2) != pixels.shape(2))
    throw std::invalid_argument("encode8: out must have pixels' shape");
  if (above.shape(0) != 256 || below.shape(0) != 256 || table.shape(0) < 2)
    throw std::invalid_argument("encode8: above and below must hold 256 thresholds");
  const float scale = float(table.shape(0) - 1), half = 0.5f, top = 255.0f;
  const auto px = pixels.view();
  const uint8_t* lut = table.data();
  const float *up = above.data(), *down = below.data();
  uint8_t* o = out.data();
  parallel_for(h, [&](std::ptrdiff_t r0, std::ptrdiff_t r1) {
    for (int64_t i = r0; i < r1; ++i) {
      for (int64_t j = 0; j < w; ++j) {
        for (int64_t k = 0; k < c; ++k) {
          float x = float(px(i, j, k));
          if (!(x > 0)) x = 0.0f;  // NaN too
          else if (x > 1) x = 1.0f;
          uint8_t& code = o[(i * w + j) * c + k];
          if (k < colour) {
            const int64_t t = lut[int32_t(x * scale + half)];
            code = uint8_t(t + (x >= up[t]) - (x < down[t]));
          } else {
            code = uint8_t(std::nearbyint(x * top));
          }
        }
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
}

}  // namespace texbake
