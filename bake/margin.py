"""Margin: fill empty texels near charts so that bilinear filtering and mipmaps show no seams.

"extend" gives each empty texel within ``margin`` texels (Euclidean) of a chart the value
of the nearest covered texel. Work is done in row bands with a halo of ``margin`` rows,
so memory stays bounded for large images, and bands run in threads (SciPy's distance
transform releases the GIL).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
from scipy import ndimage


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
        dist, (ri, ci) = ndimage.distance_transform_edt(~cov, return_indices=True)
        rows = slice(top - lo, bottom - lo)
        fill = (dist[rows] <= margin) & ~cov[rows]
        # sources are covered texels, which no band writes: bands are independent
        src_r, src_c = ri[rows][fill] + lo, ci[rows][fill]
        for image in images:
            image[top:bottom][fill] = image[src_r, src_c]
        filled[top:bottom] = fill

    with ThreadPoolExecutor(max(1, workers)) as pool:
        list(pool.map(fill_band, range(0, h, band)))
    return filled
