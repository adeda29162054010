"""How many faces cover each texel centre of a UV layout: overlap measured on the texel
grid the bake uses (a mirrored half mapped onto the other half is overlap too).

A texel centre lies in a face when it is inside the face's UV triangle or on an edge that
the top-left rule gives it (as GPUs rasterise), so two faces that share an edge never both
count a centre on that edge.
"""

from __future__ import annotations

import numba as nb  # pip install numba
import numpy as np


@nb.njit(cache=True, nogil=True)
def _edge_owns(ax, ay, bx, by) -> bool:
    """Top-left rule for a counter-clockwise edge a -> b (y down after the flip below)."""
    return (ay == by and bx < ax) or by < ay


@nb.njit(cache=True, nogil=True)
def _count(uv, faces, size, counts):
    for f in range(faces.shape[0]):
        x0, y0 = uv[faces[f, 0], 0] * size, (1.0 - uv[faces[f, 0], 1]) * size
        x1, y1 = uv[faces[f, 1], 0] * size, (1.0 - uv[faces[f, 1], 1]) * size
        x2, y2 = uv[faces[f, 2], 0] * size, (1.0 - uv[faces[f, 2], 1]) * size
        area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
        if area == 0.0:
            continue
        if area < 0.0:  # make it counter-clockwise
            x1, y1, x2, y2 = x2, y2, x1, y1
        c0 = max(0, int(np.ceil(min(x0, x1, x2) - 0.5)))
        c1 = min(size - 1, int(np.floor(max(x0, x1, x2) - 0.5)))
        r0 = max(0, int(np.ceil(min(y0, y1, y2) - 0.5)))
        r1 = min(size - 1, int(np.floor(max(y0, y1, y2) - 0.5)))
        own0, own1, own2 = _edge_owns(x1, y1, x2, y2), _edge_owns(x2, y2, x0, y0), _edge_owns(x0, y0, x1, y1)
        for r in range(r0, r1 + 1):
            py = r + 0.5
            for c in range(c0, c1 + 1):
                px = c + 0.5
                w0 = (x2 - x1) * (py - y1) - (y2 - y1) * (px - x1)
                w1 = (x0 - x2) * (py - y2) - (y0 - y2) * (px - x2)
                w2 = (x1 - x0) * (py - y0) - (y1 - y0) * (px - x0)
                if ((w0 > 0 or (w0 == 0 and own0)) and (w1 > 0 or (w1 == 0 and own1))
                        and (w2 > 0 or (w2 == 0 and own2))):
                    counts[r, c] += 1


def coverage_counts(uv: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """``(size, size)`` uint16: how many faces cover each texel centre (row 0 at the top).

    ``uv``: ``(k, 2)`` float in the unit square (v up); ``faces``: ``(m, 3)`` int into it.
    """
    counts = np.zeros((size, size), dtype=np.uint16)
    _count(np.ascontiguousarray(uv, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64), int(size), counts)
    return counts


def overlap(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[float, int]:
    """``(share, most)``: the share of covered texel centres that two or more faces cover,
    and the most faces over one centre."""
    counts = coverage_counts(uv, faces, size)
    covered = int((counts > 0).sum())
    return (float((counts > 1).sum()) / covered if covered else 0.0), int(counts.max())
