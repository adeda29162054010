"""Margin: fill empty texels near charts so that bilinear filtering and mipmaps show no seams.

"extend" gives each empty texel within ``margin`` texels (Euclidean) of a chart the value
of the nearest covered texel. Work is done in row bands with a halo of ``margin`` rows,
so memory stays bounded for large images.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def extend(image: np.ndarray, covered: np.ndarray, margin: int, band: int = 1024) -> np.ndarray:
    """Fill, in place, empty texels of ``image`` near covered ones; return the filled mask.

    ``image``: ``(h, w, c)`` float; ``covered``: ``(h, w)`` bool. Returns ``(h, w)`` bool,
    True for the texels that were filled (the margin).
    """
    h, w = covered.shape
    filled = np.zeros_like(covered)
    if margin <= 0 or not covered.any() or covered.all():
        return filled
    for top in range(0, h, band):
        bottom = min(h, top + band)
        lo, hi = max(0, top - margin), min(h, bottom + margin)
        cov = covered[lo:hi]
        if cov.all() or not cov.any():
            continue
        dist, (ri, ci) = ndimage.distance_transform_edt(~cov, return_indices=True)
        rows = slice(top - lo, bottom - lo)
        fill = (dist[rows] <= margin) & ~cov[rows]
        src_r = ri[rows][fill] + lo
        src_c = ci[rows][fill]
        image[top:bottom][fill] = image[src_r, src_c]
        filled[top:bottom] = fill
    return filled
