"""The atlas that always works: every triangle in its own cell of a square grid.

Used when both chartings failed (xatlas crashed, hung past the deadline or gave bad UVs).
Each triangle is laid flat by its edge lengths, so it keeps its shape; texel density then
varies from triangle to triangle and the charts are tiny. The unwrap uses the same flat
triangles for the faces its charts left out (:mod:`texbake.atlas.pack`). numpy only.
"""

from __future__ import annotations

import numpy as np


def normalised(vertices: np.ndarray) -> np.ndarray:
    """``(n, 3)`` float64 copy of the vertices centred in a box of largest side 1."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    scale = float(np.max(hi - lo))
    if not scale > 0 or not np.isfinite(scale):
        scale = 1.0
    return (vertices - 0.5 * (lo + hi)) / scale


def flat_triangles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m, 3, 2)`` each triangle laid flat in 2D by its edge lengths (same size).

    A degenerate triangle becomes a unit right triangle (so it still has a UV area).
    """
    m = len(faces)
    t = vertices[faces]
    ab = np.linalg.norm(t[:, 1] - t[:, 0], axis=1)
    e2 = t[:, 2] - t[:, 0]
    cx = np.einsum("ij,ij->i", e2, t[:, 1] - t[:, 0]) / np.where(ab > 0, ab, 1)
    cy = np.sqrt(np.maximum(np.einsum("ij,ij->i", e2, e2) - cx**2, 0))
    flat = np.zeros((m, 3, 2))
    flat[:, 1, 0] = ab
    flat[:, 2, 0] = cx
    flat[:, 2, 1] = cy
    flat -= flat.min(axis=1, keepdims=True)
    area = 0.5 * np.abs(flat[:, 1, 0] * flat[:, 2, 1] - flat[:, 1, 1] * flat[:, 2, 0])
    extent = flat.max(axis=(1, 2))
    bad = ~(area > 1e-12 * np.maximum(extent, 1e-300) ** 2) | ~np.isfinite(flat).all(axis=(1, 2))
    flat[bad] = [[0, 0], [1, 0], [0, 1]]
    return flat


def grid_atlas(vertices: np.ndarray, faces: np.ndarray, padding: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One chart per triangle, each in its own cell of a square grid: ``(vmapping (3m,)
    int64, faces (m, 3) int64, uv (3m, 2) float64)``.

    Each triangle keeps its shape (laid flat by its edge lengths), scaled to fill its
    cell less ``padding`` (UV units, at most a quarter cell) on every side.
    """
    m = len(faces)
    g = int(np.ceil(np.sqrt(m)))
    flat = flat_triangles(normalised(vertices), faces)
    flat /= flat.max(axis=(1, 2))[:, None, None]
    cell = 1.0 / g
    pad = min(padding, cell / 4)
    inner = cell - 2 * pad
    origin = np.stack([np.arange(m) % g, np.arange(m) // g], axis=1) * cell + pad
    uv = (origin[:, None, :] + flat * inner).reshape(-1, 2)
    return faces.reshape(-1).astype(np.int64), np.arange(3 * m, dtype=np.int64).reshape(m, 3), uv
