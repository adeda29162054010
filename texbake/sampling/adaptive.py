"""Adaptive sampling: after one filtered sample a texel, more samples only where that
sample's error is likely high.

A texel's first sample is scored by how far its value lies from its neighbours' in the
tile (the largest difference, over the four neighbours and the channels): a filtered
sample is close to the texel's mean where the texture varies slowly, and errs where
detail near the texel's size varies inside it (veins, the finest kept octaves, checks'
corners). The ``share`` of a tile's texels that score highest get 2x2 filtered
sub-samples, each with half the footprint, and their mean replaces the first sample:
four more samples on ``share`` of the texels, a mean of ``1 + 4 share`` a texel.

A texel its chart covers in part is refined only if its four neighbours have samples (a
texel two charts share, or one beside a seam's gap), not on a chart's outer edge. There
its first sample's footprint is cut to the part of the texel the chart covers
(``Sampler.at_located``); sub-samples are not, and average their whole half-footprints,
off the surface too. On Suzanne's marble (against 256 point samples), refining every
texel at 256²: whole texels RMSE 4.5e-4 -> 1.8e-4, outer-edge texels 5.6e-4 -> 2.1e-3.
With ``share`` 0.25, RMSE against 1 filtered sample: 1.05x refining any texel, 0.88x
only whole ones, 0.90x with this rule at 256²; 0.87x, 0.92x and 0.76x at 512².
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .lookup import Tile, sample_uv
from .sampler import Sampler, Samples

SUB_OFFSETS = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]])  # 2x2 sub-texels' centres


def hardest(texel: np.ndarray, values: np.ndarray, rows: int, width: int, share: float,
            eligible: np.ndarray | None = None) -> np.ndarray:
    """``(k,)`` int64 positions into ``texel`` ``(n,)`` (indices within a tile of ``rows x
    width``, distinct) of the ``ceil(share * n)`` samples whose ``(n, c)`` ``values`` differ
    most from a neighbour's (4-neighbours in the tile that have a sample); ``eligible``
    ``(n,)`` bool: only those may be picked (None: all), fewer if fewer are."""
    n = len(texel)
    k = min(n if eligible is None else int(np.count_nonzero(eligible)), int(np.ceil(share * n)))
    if k == 0:
        return np.zeros(0, dtype=np.int64)
    grid = np.full((rows + 2, width + 2, values.shape[1]), np.nan)
    r, c = np.divmod(np.asarray(texel, dtype=np.int64), width)
    grid[r + 1, c + 1] = values
    score = np.zeros(n)
    for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        d = np.abs(grid[r + 1 + dr, c + 1 + dc] - values).max(axis=1)
        score = np.fmax(score, d)  # a missing neighbour (NaN) counts for nothing
    if eligible is not None:
        score[~eligible] = -np.inf
    return np.argpartition(-score, k - 1)[:k] if k < n else np.arange(n)


def surrounded(texel: np.ndarray, rows: int, width: int) -> np.ndarray:
    """``(n,)`` bool: whether each of ``texel`` ``(n,)`` (distinct, within a tile of ``rows x
    width``) has its four neighbours among them (a neighbour outside the tile counts as
    missing)."""
    have = np.zeros((rows + 2, width + 2), dtype=bool)
    r, c = np.divmod(np.asarray(texel, dtype=np.int64), width)
    have[r + 1, c + 1] = True
    return have[r, c + 1] & have[r + 2, c + 1] & have[r + 1, c] & have[r + 1, c + 2]


def refine(sampler: Sampler, values_of: Callable[[Samples], dict[str, np.ndarray]], tile: Tile, texel: np.ndarray,
           values: dict[str, np.ndarray], score_map: str, share: float, coverage: np.ndarray | None = None) -> int:
    """Replace, in place, the values of the ``share`` of a tile's samples :func:`hardest`
    picks (by ``values[score_map]``) with the mean of their 2x2 filtered sub-samples.

    ``texel``: ``(n,)`` each first sample's texel within the tile (distinct); ``values``: map name -> ``(n, c)``;
    ``values_of``: the maps' values at surface samples; ``coverage``: ``(n,)`` the share of
    each first sample's texel its chart covers (``Samples.coverage``; None: all whole), only
    whole ones refined. Returns the sub-samples looked up.
    """
    rows, width, height = tile.stop - tile.start, sampler.width, sampler.height
    eligible = None if coverage is None else (coverage >= 1.0) | surrounded(texel, rows, width)
    pick = hardest(texel, values[score_map], rows, width, share, eligible)
    if not len(pick):
        return 0
    located = sampler.locate(sample_uv(tile, texel[pick], width, height, SUB_OFFSETS), len(SUB_OFFSETS))
    s = sampler.at_located(located)
    if s.dpdx is not None and s.dpdy is not None:
        s.dpdx *= 0.5
        s.dpdy *= 0.5
    found = values_of(s)
    group = s.index // len(SUB_OFFSETS)  # the picked sample each sub-sample refines
    count = np.bincount(group, minlength=len(pick))
    held = count > 0  # a texel whose sub-samples all missed (off its chart) keeps its first sample
    for name, v in found.items():
        total = np.zeros((len(pick), v.shape[1]))
        np.add.at(total, group, v)
        values[name][pick[held]] = total[held] / count[held][:, None]
    return located.count
