"""The texels a mesh map is made of: one sample at each texel centre, through the bake's own
lookup and surface stages (``texbake.sampling.Sampler``), with the face under it kept (the
ID maps and the curvature read it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..sampling import Sampler, Tile, sample_offsets, sample_uv


@dataclass
class TexelPoints:
    """The covered texel centres of one row tile; ``n`` rows each.

    ``texel``: ``(n,)`` int64 index of the texel in the whole image (row-major);
    ``face``: ``(n,)`` int64 face of the sampler's mesh under it; ``bary``: ``(n, 3)`` float64;
    ``points``: ``(n, 3)`` float64 object space; ``normals``: ``(n, 3)`` float64 unit
    shading normals (interpolated from the output mesh's, as the lit map sees them);
    ``frame``: ``(n, 3, 3)`` float64 rows T, B, N of the output mesh's tangent frame, or None
    (the sampler has none).
    """

    texel: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    frame: np.ndarray | None = None


def texel_points(sampler: Sampler, tile: Tile) -> TexelPoints:
    """The texel centres of ``tile`` that a face covers, on the surface (``sampler`` made
    with normals)."""
    width, height = sampler.width, sampler.height
    texels = sampler.candidates(tile)
    located = sampler.locate(sample_uv(tile, texels, width, height, sample_offsets(1)), 1)
    s = sampler.surface.samples(located.face, located.bary, False)
    if s.normals is None:
        raise ValueError("texel_points: the sampler was made without normals")
    texel = tile.start * width + np.asarray(texels, dtype=np.int64)[located.index]
    return TexelPoints(texel, np.asarray(located.face, dtype=np.int64), located.bary, s.points, s.normals, s.frame)
