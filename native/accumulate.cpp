// Maps (texbake/maps/accumulate.py): each texel's samples, contiguous, averaged in order.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "arrays.hpp"
#include "parallel.hpp"

namespace texbake {
namespace {

// the texel and the length of each run of equal values of a non-decreasing texel (n,),
// into where and count (n,) from the front; returns the number of runs
int64_t runs(In<int64_t, nb::ndim<1>> texel, Out<int64_t, nb::ndim<1>> where, Out<int64_t, nb::ndim<1>> count) {
  const int64_t n = texel.shape(0);
  if (int64_t(where.shape(0)) < n || int64_t(count.shape(0)) < n) throw std::invalid_argument("runs: where and count of texel's length");
  const int64_t* t = texel.data();
  int64_t r = -1;
  for (int64_t i = 0; i < n; ++i) {
    if (i == 0 || t[i] != t[i - 1]) {
      ++r;
      where.data()[r] = t[i];
      count.data()[r] = 0;
    }
    ++count.data()[r];
  }
  return r + 1;
}

// out (k, 3): the mean of v (n, 3) over each run of count[r] samples, summed in order (as
// np.bincount sums)
void run_means(In<double, shape<-1, 3>> v, In<int64_t, nb::ndim<1>> count, Out<double, shape<-1, 3>> out) {
  const int64_t k = count.shape(0), n = v.shape(0);
  if (int64_t(out.shape(0)) != k) throw std::invalid_argument("run_means: out must be (k, 3)");
  int64_t total = 0;
  for (int64_t r = 0; r < k; ++r) total += count.data()[r];
  if (total > n) throw std::invalid_argument("run_means: the runs hold more samples than v");
  const double* x = v.data();
  int64_t i = 0;
  for (int64_t r = 0; r < k; ++r) {
    double s0 = 0.0, s1 = 0.0, s2 = 0.0;
    for (int64_t j = 0; j < count.data()[r]; ++j, ++i) {
      s0 += x[3 * i];
      s1 += x[3 * i + 1];
      s2 += x[3 * i + 2];
    }
    const double c = double(count.data()[r]);
    out.data()[3 * r] = s0 / c;
    out.data()[3 * r + 1] = s1 / c;
    out.data()[3 * r + 2] = s2 / c;
  }
}

// out (r, w): rows [top, top + r) of image's (h, w, c) contrast: each covered texel's largest
// difference, over the channels, from a covered texel left, right, above or below (0 for
// an uncovered one); the rows above and below the band are read, not written
void contrast(In<float, nb::ndim<3>> image, In<bool, nb::ndim<2>> covered, int64_t top, Out<float, nb::ndim<2>> out) {
  const int64_t h = image.shape(0), w = image.shape(1), c = image.shape(2), r = out.shape(0);
  if (int64_t(covered.shape(0)) != h || int64_t(covered.shape(1)) != w || int64_t(out.shape(1)) != w || top < 0 || top + r > h)
    throw std::invalid_argument("contrast: covered (h, w), out (r, w) rows from top inside the image");
  const float* img = image.data();
  const bool* cov = covered.data();
  float* dst = out.data();
  parallel_for(r, [&](std::ptrdiff_t i0, std::ptrdiff_t i1) {
    for (std::ptrdiff_t i = i0; i < i1; ++i) {
      const int64_t y = top + i;
      for (int64_t x = 0; x < w; ++x) {
        const int64_t at = y * w + x;
        float most = 0.0f;
        if (cov[at]) {
          auto against = [&](int64_t other) {
            if (!cov[other]) return;
            for (int64_t k = 0; k < c; ++k) most = std::max(most, std::fabs(img[at * c + k] - img[other * c + k]));
          };
          if (x > 0) against(at - 1);
          if (x + 1 < w) against(at + 1);
          if (y > 0) against(at - w);
          if (y + 1 < h) against(at + w);
        }
        dst[i * w + x] = most;
      }
    }
  });
}

}  // namespace

void bind_accumulate(nb::module_& m) {
  m.def("contrast", &contrast, nb::arg("image"), nb::arg("covered"), nb::arg("top"), nb::arg("out").noconvert(), Release(),
        "out (r, w) float32: rows from top of image (h, w, c) float32's contrast: each covered texel's largest difference "
        "over the channels from a covered 4-neighbour (0 where uncovered).");
  m.def("runs", &runs, nb::arg("texel"), nb::arg("where").noconvert(), nb::arg("count").noconvert(), Release(),
        "The runs of equal values of a non-decreasing texel (n,): their texels in where, lengths in count; returns how many.");
  m.def("run_means", &run_means, nb::arg("v"), nb::arg("count"), nb::arg("out").noconvert(), Release(),
        "out (k, 3) float64: the mean of v (n, 3) over each run of count[r] samples, summed in order.");
}

}  // namespace texbake
