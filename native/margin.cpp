// Margin: the exact Euclidean feature transform of a coverage mask (Maurer, Qi and
// Raghavan), with SciPy's sums and comparisons, so that ties go where
// scipy.ndimage.distance_transform_edt sends them (texbake/maps/margin.py says how).
#include <stdexcept>
#include <vector>

#include "arrays.hpp"
#include "parallel.hpp"

namespace texbake {
namespace {

// First pass, columns [c0, c1): each texel's nearest covered row in its column, the upper
// of two equally near (SciPy's _VoronoiFT down a column keeps the first of equal ones);
// row -1 and column 0 where the column has none.
void nearest_in_columns(const bool* cov, int32_t* rows, int32_t* cols, int64_t h, int64_t w, int64_t c0, int64_t c1) {
  std::vector<int64_t> last(c1 - c0, -1);
  for (int64_t r = 0; r < h; ++r) {  // downwards: the nearest covered row at or above
    for (int64_t c = c0; c < c1; ++c) {
      if (cov[r * w + c]) last[c - c0] = r;
      rows[r * w + c] = int32_t(last[c - c0]);
    }
  }
  std::fill(last.begin(), last.end(), -1);
  for (int64_t r = h - 1; r >= 0; --r) {  // upwards: the one at or below, where it is nearer
    for (int64_t c = c0; c < c1; ++c) {
      const int64_t i = r * w + c;
      if (cov[i]) last[c - c0] = r;
      const int64_t above = rows[i], below = last[c - c0];
      if (below >= 0 && (above < 0 || below - r < r - above)) rows[i] = int32_t(below);
      cols[i] = rows[i] >= 0 ? int32_t(c) : 0;
    }
  }
}

// Second pass on row r (SciPy's _VoronoiFT along axis 1), in place: rows[j] holds column
// j's nearest covered row on entry, rows and cols the nearest covered texel on exit, the
// first in column order of equally near ones. The sums are SciPy's, in exact integers.
void nearest_along_row(int32_t* rows, int32_t* cols, int64_t r, int64_t w, int64_t* near, int64_t* stack) {
  for (int64_t i = 0; i < w; ++i) near[i] = rows[i];
  int64_t top = -1;  // the columns whose nearest texels can be the nearest of some texel of the row
  for (int64_t i = 0; i < w; ++i) {
    if (near[i] < 0) continue;
    const int64_t t = near[i] - r, wr = t * t;
    while (top >= 1) {  // pop the candidates that the new one and the one before hide
      const int64_t v = stack[top], u = stack[top - 1];
      const int64_t a = v - u, b = i - v, c = a + b;
      const int64_t tu = near[u] - r, tv = near[v] - r;
      if (c * tv * tv - b * tu * tu - a * wr - a * b * c <= 0) break;
      --top;
    }
    stack[++top] = i;
  }
  if (top < 0) return;
  int64_t k = 0;
  for (int64_t j = 0; j < w; ++j) {
    int64_t s = stack[k] - j, t = near[stack[k]] - r;
    int64_t best = s * s + t * t;
    while (k < top) {
      s = stack[k + 1] - j;
      t = near[stack[k + 1]] - r;
      const int64_t d = s * s + t * t;
      if (best <= d) break;
      best = d;
      ++k;
    }
    rows[j] = int32_t(near[stack[k]]);
    cols[j] = int32_t(stack[k]);
  }
}

void feature_transform(In<bool, nb::ndim<2>> covered, Out<int32_t, shape<2, -1, -1>> ft) {
  const int64_t h = covered.shape(0), w = covered.shape(1);
  if (ft.shape(1) != size_t(h) || ft.shape(2) != size_t(w))
    throw std::invalid_argument("feature_transform: ft must be (2, h, w) of covered's (h, w)");
  const bool* cov = covered.data();
  int32_t *rows = ft.data(), *cols = ft.data() + h * w;
  const std::ptrdiff_t per_piece = std::max<int64_t>(1, MIN_PIECE / std::max<int64_t>(h, 1));
  parallel_for(w, [&](std::ptrdiff_t c0, std::ptrdiff_t c1) { nearest_in_columns(cov, rows, cols, h, w, c0, c1); }, per_piece);
  parallel_for(h, [&](std::ptrdiff_t r0, std::ptrdiff_t r1) {
    std::vector<int64_t> near(w), stack(w);
    for (std::ptrdiff_t r = r0; r < r1; ++r) nearest_along_row(rows + r * w, cols + r * w, r, w, near.data(), stack.data());
  }, std::max<int64_t>(1, MIN_PIECE / std::max<int64_t>(w, 1)));
}

}  // namespace

void bind_margin(nb::module_& m) {
  m.def("feature_transform", &feature_transform, nb::arg("covered"), nb::arg("ft").noconvert(), Release(),
        "Fill ft (2, h, w) int32 with the row and column of the covered texel nearest to each "
        "texel of covered (h, w) bool: scipy.ndimage.distance_transform_edt's indices, ties included.");
}

}  // namespace texbake
