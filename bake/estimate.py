"""Error estimate of a bake, made while baking.

What is estimated: the RMSE, over covered texels and the three channels, in linear
colour, of the baked colour map against each texel's true value, the mean of the
point-sampled texture (every octave, float64) over the part of the texel the surface
covers. That is what a converged supersampled bake gives, and what ``bake.checks.sweep``
measures against.

Two methods; the bake uses the one that can see its error:

``spread`` (``samples = k * k`` with ``k`` even, point sampling, no octave cap): the
bake is then an unbiased stratified estimate of the texel mean, so its error is its
noise. The samples of a texel (one per stratum of a jittered ``k x k`` grid) are split
like the squares of a checkerboard into two halves with means ``A`` and ``B``. Strata
are independent, so the variance of the texel mean ``(A + B) / 2`` is exactly
``(Var A + Var B) / 4``, and ``E[(A - B)^2] = Var A + Var B`` whenever both halves have
the same expected mean, which holds for any colour linear across the texel (only
curvature within a texel makes it an overestimate). The estimate is
``sqrt(mean over covered texels and channels of (A - B)^2 / 4)``. The plain standard
error ``s / sqrt(n)`` would treat stratified samples as independent ones and overstate
the error about ``k`` times on smooth textures.

``probe`` (one sample a texel, footprint filtering, an octave cap, or any other sample
count): here the error is mostly bias (a point sample is not the texel mean; filtering
blurs and replaces fine octaves by their mean), which no spread of the samples shows.
A fixed random subset of covered texels (``PROBE_TEXELS``, seeded) is evaluated again
with a jittered 4 x 4 grid, point-sampled, float64, every octave: a small local
reference. With ``D^2`` the mean squared difference between the bake and the probe and
``N^2`` the probe's own noise (its checkerboard spread, as above; the probe's jitter is
independent of the bake's), the estimate is ``sqrt(max(D^2 - N^2, 0))``. The cost is
fixed (16 samples on at most ``PROBE_TEXELS`` texels): a few percent of a 1-sample
bake at 1024^2, less at larger sizes, more than the bake itself below about 128^2.

Texels on chart edges that a single sample hit show no spread; the ``spread`` method
gives them the mean per-sample variance of the other partly covered texels. Both
methods are statistical: the probe's estimate scatters between seeds, most on hard edges
such as the checker's (figures: README, Benchmarks).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .texels import Tile, sample_offsets, sample_uv

PROBE_TEXELS = 1024
PROBE_GRID = 4  # the probe samples a jittered PROBE_GRID x PROBE_GRID grid per texel

HOW = {
    "spread": "RMSE against the converged texel means, linear colour, from the spread of each texel's samples: "
              "(A - B)^2 / 4 of the means of its two checkerboard halves of strata",
    "probe": "RMSE against the converged texel means, linear colour, from a 4x4 point-sampled float64 probe of "
             "up to 1024 random covered texels, less the probe's own noise",
}


def method_for(samples: int, filtering: bool, max_octaves: int | None) -> str:
    """``"spread"`` when the bake is unbiased and its samples pair up, else ``"probe"``."""
    k = int(round(np.sqrt(samples)))
    return "spread" if k * k == samples and k % 2 == 0 and not filtering and max_octaves is None else "probe"


def checker_halves(samples: int) -> np.ndarray:
    """``(samples,)`` bool: sample ``j`` of a jittered ``k x k`` grid (``j = row * k + col``,
    the order of ``texels.sample_offsets``) lies on a "black" checkerboard square."""
    k = int(round(np.sqrt(samples)))
    row, col = np.divmod(np.arange(samples), k)
    return (row + col) % 2 == 0


def half_means(values: np.ndarray, texel: np.ndarray, sample: np.ndarray, samples: int, count: int):
    """Per-texel means of the two checkerboard halves of the samples.

    ``values``: ``(n, c)`` sample values; ``texel``: ``(n,)`` texel index in ``[0, count)``;
    ``sample``: ``(n,)`` index of each sample within its texel's grid. Returns
    ``(a, b, na, nb, squares)``: ``(count, c)`` means of the halves, ``(count,)`` sample
    counts of the halves, and ``(count, c)`` sums of the squared values.
    """
    key = 2 * texel + checker_halves(samples)[sample]  # texel t: 2t white, 2t + 1 black
    n = np.bincount(key, minlength=2 * count).reshape(count, 2)
    s = np.stack([np.bincount(key, weights=values[:, c], minlength=2 * count) for c in range(values.shape[1])], axis=1)
    squares = np.stack([np.bincount(texel, weights=values[:, c] ** 2, minlength=count) for c in range(values.shape[1])], axis=1)
    mean = s.reshape(count, 2, -1) / np.maximum(n, 1)[:, :, None]
    return mean[:, 1], mean[:, 0], n[:, 1], n[:, 0], squares


def spread_sums(values, texel, sample, samples: int, count: int) -> np.ndarray:
    """Sums over the texels of one tile for :func:`spread_estimate`.

    Returns ``[sum of squared errors, texels, sum of per-sample variances of partial
    texels, partial texels with 2+ samples, texels with one sample]`` (float64 (5,)).
    Texels with samples on both checkerboard halves give ``(A - B)^2 / 4``; partly
    covered texels with samples on one half only give the plain ``s^2 / n``.
    """
    a, b, na, nb, squares = half_means(values, texel, sample, samples, count)
    n = na + nb
    ok = (na > 0) & (nb > 0)
    total = (na[:, None] * a + nb[:, None] * b)
    var = (squares - total**2 / np.maximum(n, 1)[:, None]) / np.maximum(n - 1, 1)[:, None]  # per-sample s^2
    partial = ~ok & (n >= 2)
    return np.array([
        ((a[ok] - b[ok]) ** 2).sum() / 4.0 + (np.maximum(var[partial], 0) / n[partial, None]).sum(),
        (ok | partial).sum(),
        np.maximum(var[partial], 0).sum(),
        partial.sum(),
        (n == 1).sum(),
    ], dtype=np.float64)


def spread_estimate(sums, channels: int = 3) -> dict:
    """The ``spread`` estimate from the sums of :func:`spread_sums` over all tiles.

    Texels a single sample hit (on chart edges) show no spread: each is given the mean
    per-sample variance of the partly covered texels that have two or more.
    """
    sq, texels, partial_var, partial, single = (float(x) for x in sums)
    if single and partial:
        sq += single * partial_var / partial
    rmse = float(np.sqrt(sq / max((texels + single) * channels, 1)))
    return {"method": "spread", "how": HOW["spread"], "rmse": rmse, "texels": int(texels + single),
            "single_sample_texels": int(single)}


def probe_estimate(
    reference_at: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    image: np.ndarray,
    covered: np.ndarray,
    *,
    seed: int = 0,
    texels: int = PROBE_TEXELS,
) -> dict:
    """The ``probe`` estimate of the error of ``image`` (``(h, w, c)``, ``covered``: ``(h, w)`` bool).

    ``reference_at(uv)`` takes ``(n, 2)`` UV points and returns ``(hit (n,) bool,
    values (hit.sum(), c))``: the point-sampled, float64, every-octave texture there.
    """
    height, width = covered.shape
    rng = np.random.default_rng([seed, 0x9E37])  # not the bake's own jitter
    where = np.flatnonzero(covered.ravel())
    if len(where) == 0:
        return {"method": "probe", "how": HOW["probe"], "rmse": 0.0, "texels": 0, "probe_rmse": 0.0, "probe_noise": 0.0}
    pick = np.sort(rng.choice(where, size=min(texels, len(where)), replace=False))
    samples = PROBE_GRID * PROBE_GRID
    offsets = sample_offsets(samples, int(rng.integers(2**31)))
    hit, values = reference_at(sample_uv(Tile(0, height), pick, width, height, offsets))
    index = np.flatnonzero(hit)
    texel, sample = index // samples, index % samples
    count = np.bincount(texel, minlength=len(pick))
    sums = np.stack([np.bincount(texel, weights=values[:, c], minlength=len(pick)) for c in range(values.shape[1])], axis=1)
    seen = count > 0
    probe = sums[seen] / count[seen, None]
    baked = image.reshape(-1, image.shape[-1])[pick[seen]].astype(np.float64)
    d2 = float(np.mean((baked - probe) ** 2)) if seen.any() else 0.0
    a, b, na, nb, _ = half_means(values, texel, sample, samples, len(pick))
    ok = (na > 0) & (nb > 0)
    n2 = float(np.mean((a[ok] - b[ok]) ** 2) / 4.0) if ok.any() else 0.0
    return {
        "method": "probe",
        "how": HOW["probe"],
        "rmse": float(np.sqrt(max(d2 - n2, 0.0))),
        "texels": int(seen.sum()),
        "probe_rmse": float(np.sqrt(d2)),  # bake against the probe, probe noise included
        "probe_noise": float(np.sqrt(n2)),
    }
