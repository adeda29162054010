"""What a texture is evaluated with, besides its spec: the texture-space points and an
:class:`EvalContext` (after pbrt's ``TextureEvalContext``), and the placement that takes
object-space points and their differentials there together (pbrt's ``TextureMapping3D``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class EvalContext:
    """Everything a texture may read besides its points.

    ``dpdx``, ``dpdy``: ``(n, 3)`` float texture-space change of the point over one texel
    in x and in y, or None to point-sample. ``bounds``: ``(2, 3)`` float bounding box of
    the mesh in the bake's texture space (``position`` normalises to it). ``max_octaves``:
    cap on the octaves of noise-based textures (None: the spec's own count). ``hull``:
    ``(rows (k,) int64, corners (k, H, 2) float)`` for footprints cut at a chart's border
    (``texbake.sampling.Samples.hull``): the corners ``(a, b)`` of the convex hull of the
    surface inside each such texel, the point ``p + a dpdx + b dpdy``, NaN-padded (a row all
    NaN: none), or None; a filter may bound its footprint by it (the checker does).
    """

    dpdx: np.ndarray | None = None
    dpdy: np.ndarray | None = None
    bounds: np.ndarray | None = None
    max_octaves: int | None = None
    hull: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def width(self) -> np.ndarray | None:
        """``(n,)`` footprint width per point: the longer of the two texel edges (None: point sampling)."""
        if self.dpdx is None or self.dpdy is None:
            return None
        return np.sqrt(np.maximum(np.einsum("ij,ij->i", self.dpdx, self.dpdx), np.einsum("ij,ij->i", self.dpdy, self.dpdy)))


@dataclass(frozen=True)
class Placement:
    """Affine steps ``x -> x @ matrix (+ offset)`` from object space to a texture's space,
    applied in order to points and (without the offset) to their differentials."""

    steps: tuple[tuple[np.ndarray, np.ndarray | None], ...] = ()

    def __call__(self, points: np.ndarray, dpdx: np.ndarray | None, dpdy: np.ndarray | None):
        """``(q (n, 3), dqdx, dqdy)``: the points and their differentials in texture space."""
        for matrix, offset in self.steps:
            points = points @ matrix if offset is None else points @ matrix + offset
            if dpdx is not None and dpdy is not None:
                dpdx, dpdy = dpdx @ matrix, dpdy @ matrix
        return points, dpdx, dpdy
