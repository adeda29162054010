"""Margin: fill empty texels near charts so that bilinear filtering and mipmaps show no seams.

"extend" gives each empty texel within ``margin`` texels (Euclidean) of a chart the value
of the nearest covered texel. Work is done in row bands with a halo of ``margin`` rows,
so memory stays bounded for large images, and bands run in threads (the feature
transform is a numba kernel that releases the GIL).

The nearest covered texel is found by an exact Euclidean feature transform, Maurer, Qi
and Raghavan's ("A linear time algorithm for computing exact Euclidean distance
transforms of binary images in arbitrary dimensions", IEEE PAMI 25, 2003), as SciPy's
``scipy.ndimage.distance_transform_edt`` does it (``_ComputeFT`` and ``_VoronoiFT`` in
``scipy/ndimage/src/ni_morphology.c``), for two dimensions: down the columns, then along
the rows, the second pass with SciPy's sums and comparisons (the first, where SciPy's
routine only ever keeps the nearest texel of a column, as two sweeps giving the same), so
that of several equally near texels it picks the one SciPy picks: the baked images are
those SciPy's transform gave, texel for texel (``tests/texbake/maps/test_margin.py`` compares the
two). SciPy computes in doubles; here the same sums are exact integers (as SciPy's
doubles are, below 2^53).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba as nb  # pip install numba
import numpy as np


def extend(images, covered: np.ndarray, margin: int, band: int = 256, workers: int = 2) -> np.ndarray:
    """Fill, in place, empty texels of each image near covered ones; return the filled mask.

    ``images``: one ``(h, w, c)`` float array or a list of them (filled from the same
    nearest texels); ``covered``: ``(h, w)`` bool. Returns ``(h, w)`` bool, True for the
    texels that were filled (the margin).
    """
    images = [images] if isinstance(images, np.ndarray) else list(images)
    h, w = covered.shape
    filled = np.zeros_like(covered)
    if margin <= 0 or not covered.any() or covered.all():
        return filled

    def fill_band(top: int) -> None:
        bottom = min(h, top + band)
        lo, hi = max(0, top - margin), min(h, bottom + margin)
        cov = covered[lo:hi]
        if cov.all() or not cov.any():
            return
        ri, ci = feature_transform(np.ascontiguousarray(cov))
        rows = slice(top - lo, bottom - lo)
        ri, ci = ri[rows], ci[rows]
        dr = ri - np.arange(top - lo, bottom - lo, dtype=np.int32)[:, None]
        dc = ci - np.arange(w, dtype=np.int32)
        # squared distances as integers (at most h² + w², well within int64)
        near = dr.astype(np.int64) ** 2 + dc.astype(np.int64) ** 2 <= margin * margin
        fill = near & ~cov[rows]
        # sources are covered texels, which no band writes: bands are independent
        src_r, src_c = ri[fill] + lo, ci[fill]
        for image in images:
            image[top:bottom][fill] = image[src_r, src_c]
        filled[top:bottom] = fill

    with ThreadPoolExecutor(max(1, workers)) as pool:
        list(pool.map(fill_band, range(0, h, band)))
    return filled


@nb.njit(cache=True, nogil=True)
def feature_transform(covered):  # pragma: no cover - compiled
    """``(2, h, w)`` int32: the row (``[0]``) and column (``[1]``) of the covered texel
    nearest to each texel of ``covered`` ``(h, w)`` bool; a covered texel is its own. The
    same array as ``scipy.ndimage.distance_transform_edt(~covered, return_indices=True)[1]``,
    ties included. Where nothing is covered, rows are -1 and columns 0 (as SciPy's). No GIL.

    SciPy's two passes: first along each column, then along each row of the result.
    """
    h, w = covered.shape
    ft = np.zeros((2, h, w), dtype=np.int32)
    _nearest_in_columns(covered, ft)
    near = np.empty(w, dtype=np.int64)
    stack = np.empty(w, dtype=np.int64)
    for r in range(h):
        _nearest_along_row(ft[0, r], ft[1, r], r, near, stack)
    return ft


@nb.njit(cache=True, nogil=True)
def _nearest_in_columns(covered, ft):  # pragma: no cover - compiled
    """The first pass, in ``ft`` ``(2, h, w)`` int32 (zeros): for each texel the nearest
    covered texel of its column, the upper one of two equally near (row -1 and column 0
    where the column has none).

    SciPy runs ``_VoronoiFT`` down each column; on one line nothing is ever popped off its
    stack and the nearest feature wins, the first of equal ones, which is what two sweeps
    (the last covered row above, the next below) give, row by row in memory order."""
    h, w = covered.shape
    last = np.full(w, -1, dtype=np.int64)
    for r in range(h):  # downwards: the nearest covered row at or above
        for c in range(w):
            if covered[r, c]:
                last[c] = r
            ft[0, r, c] = last[c]
    last[:] = -1
    for r in range(h - 1, -1, -1):  # upwards: the one at or below, where it is nearer
        for c in range(w):
            if covered[r, c]:
                last[c] = r
            above, below = ft[0, r, c], last[c]
            if below >= 0 and (above < 0 or below - r < r - above):
                ft[0, r, c] = below
            if ft[0, r, c] >= 0:
                ft[1, r, c] = c


@nb.njit(cache=True, nogil=True)
def _nearest_along_row(rows, cols, r, near, stack):  # pragma: no cover - compiled
    """The second pass on row ``r`` (SciPy's ``_VoronoiFT`` along axis 1), in place: on
    entry ``rows`` ``(w,)`` int32 holds each column's nearest covered row (-1: none), on
    exit ``rows`` and ``cols`` hold the nearest covered texel of the row's texels, the
    first in column order of equally near ones. ``near`` and ``stack`` ``(w,)`` int64 are
    scratch. The sums are SciPy's, in integers (exact, as its doubles are here)."""
    w = rows.shape[0]
    for i in range(w):
        near[i] = rows[i]
    top = -1  # the columns whose nearest texels can be the nearest of some texel of the row
    for i in range(w):
        if near[i] < 0:
            continue
        t = near[i] - r
        wr = t * t
        while top >= 1:  # pop the candidates that the new one and the one before hide
            v, u = stack[top], stack[top - 1]
            a, b = v - u, i - v
            c = a + b
            tu, tv = near[u] - r, near[v] - r
            if c * tv * tv - b * tu * tu - a * wr - a * b * c <= 0:
                break
            top -= 1
        top += 1
        stack[top] = i
    if top < 0:
        return
    k = 0
    for j in range(w):
        s, t = stack[k] - j, near[stack[k]] - r
        best = s * s + t * t
        while k < top:
            s, t = stack[k + 1] - j, near[stack[k + 1]] - r
            d = s * s + t * t
            if best <= d:
                break
            best = d
            k += 1
        rows[j] = near[stack[k]]
        cols[j] = stack[k]
