"""Margin: fill empty texels near charts so that bilinear filtering and mipmaps show no seams.

"extend" gives each empty texel within ``margin`` texels (Euclidean) of a chart the value
of the nearest covered texel. Work is done in row bands with a halo of ``margin`` rows,
so memory stays bounded for large images, and bands run in threads (the feature
transform is compiled, ``texbake._native``, and releases the GIL).

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

import numpy as np

from .. import _native


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


def feature_transform(covered: np.ndarray) -> np.ndarray:
    """``(2, h, w)`` int32: the row (``[0]``) and column (``[1]``) of the covered texel
    nearest to each texel of ``covered`` ``(h, w)`` bool; a covered texel is its own. The
    same array as ``scipy.ndimage.distance_transform_edt(~covered, return_indices=True)[1]``,
    ties included. Where nothing is covered, rows are -1 and columns 0 (as SciPy's). No GIL.

    SciPy's two passes (``native/margin.cpp``): first along each column, then along each
    row of the result; the columns, then the rows, shared among the cores.
    """
    covered = np.ascontiguousarray(covered, dtype=np.bool_)
    ft = np.empty((2, *covered.shape), dtype=np.int32)
    _native.feature_transform(covered, ft)
    return ft
