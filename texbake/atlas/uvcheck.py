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
def _edge(ax, ay, bx, by, px, py):
    """The edge function of a -> b at p, computed from the edge's lesser end whichever way
    it runs: exactly antisymmetric, so the top-left rule gives a centre on an edge two
    faces share to exactly one of them (from either end the rounding would differ)."""
    if ax > bx or (ax == bx and ay > by):
        return -((ax - bx) * (py - by) - (ay - by) * (px - bx))
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


@nb.njit(cache=True, nogil=True)
def _span(x0, y0, x1, y1, x2, y2, py):
    """``(lo, hi)``: the x-interval of the row at ``py`` inside the counter-clockwise
    triangle, from each edge's crossing (so a sliver's row is not walked end to end);
    the exact test is still made texel by texel."""
    lo, hi = -np.inf, np.inf
    for xa, ya, xb, yb in ((x1, y1, x2, y2), (x2, y2, x0, y0), (x0, y0, x1, y1)):
        dy = yb - ya  # inside: (xb - xa) * (py - ya) - dy * (px - xa) >= 0
        if dy == 0.0:
            continue
        root = xa + (xb - xa) * (py - ya) / dy
        if dy > 0.0:
            hi = min(hi, root)
        else:
            lo = max(lo, root)
    return lo, hi


@nb.njit(cache=True, nogil=True)
def _raster(uv, faces, size, counts, flags, count):
    """``count``: add each face to ``counts`` of the centres it covers and flag the faces
    that cover one; else flag the faces that cover a centre ``counts`` has more than one
    face over."""
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
            lo, hi = _span(x0, y0, x1, y1, x2, y2, py)  # the row's inside, give or take a texel
            for c in range(max(c0, int(np.floor(lo - 0.5))), min(c1, int(np.ceil(hi - 0.5))) + 1):
                px = c + 0.5
                w0 = _edge(x1, y1, x2, y2, px, py)
                w1 = _edge(x2, y2, x0, y0, px, py)
                w2 = _edge(x0, y0, x1, y1, px, py)
                if ((w0 > 0 or (w0 == 0 and own0)) and (w1 > 0 or (w1 == 0 and own1))
                        and (w2 > 0 or (w2 == 0 and own2))):
                    if count:
                        counts[r, c] += 1
                        flags[f] = True
                    elif counts[r, c] > 1:
                        flags[f] = True


def _counts(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    counts = np.zeros((size, size), dtype=np.uint16)
    covering = np.zeros(len(faces), dtype=np.bool_)
    _raster(uv, faces, int(size), counts, covering, True)
    return uv, faces, counts, covering


def coverage_counts(uv: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """``(size, size)`` uint16: how many faces cover each texel centre (row 0 at the top).

    ``uv``: ``(k, 2)`` float in the unit square (v up); ``faces``: ``(m, 3)`` int into it.
    """
    return _counts(uv, faces, size)[2]


def covering_faces(uv: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """``(m,)`` bool: the faces that hold at least one texel centre."""
    return _counts(uv, faces, size)[3]


def overlapping_faces(uv: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """``(m,)`` bool: the faces that cover a texel centre another face covers too."""
    uv, faces, counts, _ = _counts(uv, faces, size)
    flags = np.zeros(len(faces), dtype=np.bool_)
    _raster(uv, faces, int(size), counts, flags, False)
    return flags


def coverage(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``(counts (size, size) uint16, covering (m,) bool)``: :func:`coverage_counts` and
    :func:`covering_faces` of one rasterisation."""
    return _counts(uv, faces, size)[2:]


def overlap(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[float, int]:
    """``(share, most)``: the share of covered texel centres that two or more faces cover,
    and the most faces over one centre."""
    return overlap_of(coverage_counts(uv, faces, size))


def overlap_of(counts: np.ndarray) -> tuple[float, int]:
    """:func:`overlap` from :func:`coverage_counts`."""
    covered = int((counts > 0).sum())
    return (float((counts > 1).sum()) / covered if covered else 0.0), int(counts.max())
