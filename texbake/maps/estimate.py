"""Error estimate of a bake, made while baking.

What is estimated: the RMSE, over covered texels and the three channels, in linear
colour, of the baked colour map against each texel's true value, the mean of the
point-sampled texture (every octave, float64) over the part of the texel the surface
covers. That is what a converged supersampled bake gives, and what ``texbake.checks.sweep``
measures against.

One method for every setting, the ``probe``: covered texels (all of them in images of up
to ``4 * PROBE_TEXELS`` covered texels, else ``PROBE_TEXELS`` drawn in four seeded strata:
up to half on chart edges, where partly covered texels carry most of the error, the rest
inside the charts, and each of those two split into its sharp texels, the fifth whose
colour changes most from a neighbour's (:func:`contrast`: a filtered bake's error sits on
cell and ring borders, and a texel far off stands out), and the others, a sharp texel
drawn three times as often) are evaluated again with a jittered point grid (:func:`probe_grid`:
4 x 4 for one sample a texel, twice the bake's grid for more, at most 16 x 16; on chart
edges of a several-sample bake twice that again), point-sampled, float64, every octave:
a small local reference. Per texel, the squared difference from the bake less the
probe's own noise (the squared difference of the means of the grid's two checkerboard
halves, over 4: strata are independent, so for a colour linear across the texel this is
unbiased for the variance of the probe's mean) estimates that texel's squared error, the
bake's bias (a point sample is not the texel mean; filtering blurs and replaces fine
octaves by their mean) and its noise together. The stratified mean is the MSE, with a
standard error from the strata's spreads: the report gives ``rmse`` (never 0 when the
probe sees an error: an MSE below its own standard error reads as that) and
``rmse_interval`` (about 95 %).

An error below the probe's own noise (one filtered sample of a checker or wood, whose
error sits on cell and ring borders; adaptive samples) leaves that standard error large
after every drawn texel, and the estimate read as it: 2-3.4 times the error. Then a second
look (``fine_texels`` in the report): the probed texels that weigh most, mostly those an
edge crosses, are probed again with two independent 17 x 17 grids (``FINE_SAMPLES`` point
samples in all, 2^18: about 0.05 s at 512²), each with a chance in proportion to its weight
and its value weighted by it, so that the mean stays unbiased (:func:`_fine_look`).
Measured against a converged reference at 512² (four seeds): fandisk.obj's filtered
wood 0.63-0.92 (2.0-2.5 without), the torus' checker with adaptive samples 0.80-0.86
(2.7-3.3), its filtered checker 0.78-0.94 (0.93-1.54).

Why not the spread of the bake's own samples (the method this replaced for ``k x k``
point samples): on partly covered texels and where the colour curves within a texel the
two checkerboard halves differ by more than noise, and at 64-256^2 that read up to 5.4
times the error. Measured (``texbake.checks.sweep``, Suzanne, marble and checker, 64-512^2,
1 filtered, 4, 16 point, 64 filtered samples, three seeds each): estimate / RMSE
0.61-1.37.

The cost: a 1-sample bake's probe is 64 point samples (8 x 8) a probed texel, so 4096
texels are 262k samples, more than a 512^2 bake's own (about 140k). The drawn texels are
therefore probed in rounds, a quarter, a half, then all, until the MSE's standard error is
at most ``PROBE_PRECISION`` (0.2) of it. Marble and turbulence, whose error is spread
over the texels, stop after 1,000-1,800 texels (bench_batch's 50 meshes, marble 512^2: 124 -> 38 ms
a mesh); checker and wood, whose error sits on cell and ring borders, go on to all
4096. An error on far fewer texels than the first round holds may be missed by it, and
the estimate then reads low, less often where those texels are sharp (the sharp strata
hold a fifth of the texels and get three sevenths of the draw); the rounds do not change
an image small enough to be probed whole.

Why the sharp strata (``texbake.checks.sweep`` against 256 point samples, 512², one
filtered sample, twelve seeds, estimate / RMSE before and after): gear_cad.stl's checker
0.40-1.36, four under 0.5, and 0.62-1.29; Suzanne's checker 0.46-1.48 (three under 0.5)
and 0.48-1.17 (one); featuretype.STL's marble 0.12-1.41 (seven) and 0.13-1.48 (three: its
error sits on texels two faces share without a padding, and a first round that misses
them stops); bunny.ply's wood 0.45-1.03 (two) and 0.45-1.21 (one); Suzanne's marble
0.58-0.83 and 0.58-0.93, as many texels probed. Sharp texels drawn in proportion to
their summed contrast instead (the checker's plain ones then hardly at all) spread
Suzanne's checker to 0.34-1.97; shares that followed the errors a first round saw
(Neyman's) read bunny's wood at 0.51-0.82, every seed low, a stratum whose first round
missed its few large errors then getting few more texels. The shares are therefore fixed
before any texel is probed. The strata's contrast costs 0.2 s at 4096² (compiled), none
to see at 512².
"""

from __future__ import annotations

from collections.abc import Callable
from typing import cast

import numpy as np

from ..sampling import Tile, sample_offsets, sample_uv

PROBE_TEXELS = 4096  # texels probed (at most; all of them when there are up to 4 times as many)
PROBE_GRID = 4  # the probe samples a jittered PROBE_GRID x PROBE_GRID grid per texel
# The drawn texels are probed in rounds (shares of each stratum) until the MSE's standard
# error is at most PROBE_PRECISION of it (the RMSE then within about 10 %, one sigma).
PROBE_ROUNDS = (0.25, 0.5, 1.0)
PROBE_PRECISION = 0.2
# An error still below the probe's own noise after the rounds gets a second look: the probed
# texels that weigh most in the MSE probed again with two FINE_GRID x FINE_GRID grids
# (at least twice the coarse one's side, at most 34; _probe_twice), FINE_SAMPLES samples in all.
FINE_GRID = 17
FINE_SAMPLES = 1 << 18
FINE_SHARE = 0.5  # ... when the texels it looks at hold this share of the noise (weighted by their chances) or more

HOW = {
    "probe": "RMSE against the converged texel means, linear colour, from a point-sampled float64 probe of the "
             "covered texels (up to 4096, stratified: chart edges and inside), less the probe's own noise",
}


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


BAKE_PROBE_GRID = 8  # the least side of a bake's probe grid (probe_grid)


def probe_grid(samples: int) -> int:
    """Side of the probe's jittered grid for a bake of ``samples`` a texel: at least
    ``BAKE_PROBE_GRID`` (8), else twice the bake's grid (so the probe's own noise is a
    quarter of a point-sampled bake's), at most 16.

    At least 8: a 1-sample filtered bake's error fell below a 4x4 probe's own noise once
    turbulence and marble were filtered at the footprint's quarters, and the estimate with
    it (Suzanne, its own UVs, estimate / RMSE with a 4x4 probe and an 8x8 one: marble 0.63
    and 1.06 at 256², 1.37 and 0.87 at 512², 0.33 and 0.80 at 1024²; turbulence 0.38 and
    1.08, 1.21 and 0.92, 0.31 and 0.85), for 0.03-0.06 s more a bake there."""
    return int(min(16, max(BAKE_PROBE_GRID, 2 * int(np.ceil(np.sqrt(samples))))))


def chart_edges(covered: np.ndarray, rows: slice | None = None) -> np.ndarray:
    """``(h, w)`` bool (or the ``rows`` of it): covered texels with an uncovered texel (or
    the image's border) among their 8 neighbours; the partly covered texels on chart edges
    are among them."""
    h, w = covered.shape
    r0, r1 = (0, h) if rows is None else (rows.start, min(h, rows.stop))
    lo, hi = max(0, r0 - 1), min(h, r1 + 1)
    padded = np.pad(covered[lo:hi], ((1 - (r0 - lo), 1 - (hi - r1)), (1, 1)), constant_values=False)
    inner = np.ones((r1 - r0, w), dtype=bool)
    for dr in (0, 1, 2):
        for dc in (0, 1, 2):
            inner &= padded[dr:dr + r1 - r0, dc:dc + w]
    return covered[r0:r1] & ~inner


def contrast(image: np.ndarray, covered: np.ndarray, rows: slice | None = None) -> np.ndarray:
    """``(h, w)`` float32 (or the ``rows`` of it): each covered texel's largest difference, over
    the channels, from a covered texel beside it (left, right, above or below); 0 elsewhere.
    Where a filtered bake's error is, its image changes fast (cell and ring borders).
    Compiled (``native/accumulate.cpp``): numpy's reductions over three channels took 2 s
    at 4096²; an image of another dtype (float16) is read a band at a time as float32."""
    from .. import _native

    h, w = covered.shape
    r0, r1 = (0, h) if rows is None else (rows.start, min(h, rows.stop))
    lo, hi = max(0, r0 - 1), min(h, r1 + 1)
    band = np.ascontiguousarray(image[lo:hi], dtype=np.float32)
    out = np.empty((r1 - r0, w), dtype=np.float32)
    _native.contrast(band.reshape(hi - lo, w, -1), np.ascontiguousarray(covered[lo:hi]), r0 - lo, out)
    return out


def _bands(covered: np.ndarray, band: int, image: np.ndarray | None = None):
    """Per band of ``band`` rows, lazily: ``(r0, r1, edge, inside, contrast)`` (the contrast
    :func:`contrast`'s with ``image``, else None)."""
    for r0 in range(0, covered.shape[0], band):
        edge = chart_edges(covered, slice(r0, r0 + band))
        r1 = r0 + len(edge)
        yield r0, r1, edge, covered[r0:r1] & ~edge, None if image is None else contrast(image, covered, slice(r0, r1))


def _strata(bands, cuts: tuple[float, float] | None = None):
    """Per band of :func:`_bands` (lazily: the masks of a 16384² image are not held at once):
    ``(r0, r1, masks)``, masks ``(edge, inside)``, or, with ``cuts`` (the contrasts above
    which an edge texel and an inside texel count as sharp), ``(sharp edge, edge, sharp
    inside, inside)`` (:data:`STRATA`)."""
    for r0, r1, edge, inside, c in bands:
        if c is None or cuts is None:
            yield r0, r1, (edge, inside)
            continue
        sharp_edge, sharp_inside = edge & (c > cuts[0]), inside & (c > cuts[1])
        yield r0, r1, (sharp_edge, edge & ~sharp_edge, sharp_inside, inside & ~sharp_inside)


def _cuts(bands, step: int) -> tuple[float, float]:
    """The contrasts above which the sharpest ``SHARP`` of the edge texels and of the inside
    texels of :func:`_bands` lie, from every ``step``-th of them (in row-major order: the
    same whatever the bands)."""
    edges: list[np.ndarray] = []
    insides: list[np.ndarray] = []
    seen = [0, 0]
    for _, _, edge, inside, c in bands:
        for k, (mask, into) in enumerate(((edge, edges), (inside, insides))):
            values = c[mask]
            into.append(values[(-seen[k]) % step :: step])
            seen[k] += len(values)
    return (_top(edges), _top(insides))


def _top(values: list[np.ndarray]) -> float:
    """The value above which the largest ``SHARP`` of ``values`` lie (0 for none)."""
    v = np.concatenate(values)
    return float(np.quantile(v, 1.0 - SHARP)) if len(v) else 0.0


def _pick(strata, width: int, stratum: int, ranks: np.ndarray) -> np.ndarray:
    """Flat texel indices of the sorted ``ranks``-th texels of a stratum (0: edges, 1:
    inside; ``strata()`` iterates :func:`_strata`), in row-major order."""
    out, seen = [], 0
    for r0, _, masks in strata():
        where = np.flatnonzero(masks[stratum])
        mine = ranks[(ranks >= seen) & (ranks < seen + len(where))]
        out.append(where[mine - seen] + r0 * width)
        seen += len(where)
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


# The strata of drawn texels: chart edges and inside, each split by the bake's own contrast
# (texels beside a sharp change: a filtered bake's error sits on cell and ring borders).
STRATA = ("sharp edge", "edge", "sharp inside", "inside")
SHARP = 0.2  # the share of the edge texels, and of the inside ones, counted sharp
SHARP_WEIGHT = 3.0  # a sharp texel is drawn this many times as often as a plain one of its half
BAND = 1024  # rows of the coverage looked at a time
HELD = 1 << 24  # texels up to which the strata's masks are made once and held (32 MB), not again per stratum


def probe_estimate(
    reference_at: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    image: np.ndarray,
    covered: np.ndarray,
    *,
    seed: int = 0,
    texels: int = PROBE_TEXELS,
    grid: int = PROBE_GRID,
    edge_grid: int | None = None,
    precision: float = PROBE_PRECISION,
    fine: int = FINE_SAMPLES,
) -> dict:
    """The ``probe`` estimate of the error of ``image`` (``(h, w, c)``, ``covered``: ``(h, w)`` bool).

    ``reference_at(uv)`` takes ``(n, 2)`` UV points and returns ``(hit (n,) bool,
    values (hit.sum(), c))``: the point-sampled, float64, every-octave texture there.
    Texels are drawn in the four strata of :data:`STRATA` (seeded): chart-edge texels
    (:func:`chart_edges`; up to half of ``texels``) and the others, each split into its
    sharpest ``SHARP`` by :func:`contrast` and the rest, a sharp texel ``SHARP_WEIGHT``
    times as likely to be drawn (:func:`_allotted`); every covered texel, in two strata
    (edge, inside), when there are at most ``4 * texels``. Each is probed with a jittered
    point grid, ``grid x grid`` inside
    the charts and ``edge_grid x edge_grid`` (default ``grid``) on their edges, where
    partly covered texels make the probe's own noise hard to tell. Per probed texel,
    ``e = d^2 - n^2``: its squared difference from the bake less the probe's own noise
    (half the squared difference of the means of the grid's two checkerboard halves, or
    ``s^2 / n`` where only one half has samples), an unbiased estimate of the texel's
    squared error. The stratified mean of ``e`` is the MSE, with its standard error
    ``se`` from the strata's spreads; ``rmse`` is ``sqrt(max(MSE, se))`` (never 0 when
    the probe sees an error: an MSE below its own uncertainty reads as that),
    ``rmse_interval`` is ``sqrt`` of ``MSE -+ 2 se`` (about 95 %).

    Drawn texels are probed in rounds, a random share of each stratum at a time
    (``PROBE_ROUNDS``), until ``se <= precision * MSE`` (0: all of them, in one round); an image whose
    texels are all drawn is probed whole. If then ``se > PROBE_PRECISION * MSE``, the error
    is below what the probe resolves, and the probed texels that weigh most in the MSE are
    probed again, ``fine`` samples in all (0: none; see :func:`_fine_look`).
    """
    height, width = covered.shape
    rng = np.random.default_rng([seed, 0x9E37])  # not the bake's own jitter
    total = int(np.count_nonzero(covered))
    if total == 0:
        return {"method": "probe", "how": HOW["probe"], "rmse": 0.0, "rmse_interval": [0.0, 0.0], "texels": 0,
                "probe_grid": [grid, edge_grid or grid], "probe_rmse": 0.0, "probe_noise": 0.0, "fine_texels": 0}
    whole = total <= 4 * texels  # a small image: probe every texel (no sampling error), in one round
    strata, sizes = _strata_of(image, covered, total, whole)
    edgy = [True, False] if whole else [True, True, False, False]
    sides = [edge_grid or grid if e else grid for e in edgy]
    if whole:
        rounds: tuple[float, ...] = (1.0,)
        budget = total
    else:
        rounds = PROBE_ROUNDS if precision > 0 else (1.0,)
        budget = texels
    counts = sizes if whole else _allotted(budget, sizes)
    result = _probe_rounds(reference_at, image, (strata, sizes, counts), sides, rounds, rng, precision, total, fine)
    mse, se = result["mse"], result["se"]
    return {
        "method": "probe",
        "how": HOW["probe"],
        "rmse": float(np.sqrt(max(mse, se, 0.0))),
        "rmse_interval": [float(np.sqrt(max(mse - 2 * se, 0.0))), float(np.sqrt(max(mse + 2 * se, 0.0)))],
        "texels": result["probed"],
        "probe_grid": [grid, edge_grid or grid],
        # bake against the probe, probe noise included, and that noise (after a fine look an
        # unbiased mean of terms some of which are negative, so at least 0 here)
        "probe_rmse": float(np.sqrt(max(result["d2"], 0.0))),
        "probe_noise": float(np.sqrt(max(result["n2"], 0.0))),
        "fine_texels": result["fine"],
    }


def _probe_rounds(reference_at, image: np.ndarray, drawn_from, sides: list[int], rounds: tuple[float, ...],
                  rng: np.random.Generator, precision: float, total: int, fine: int = 0) -> dict:
    """:func:`_pooled` of the texels probed in ``rounds``: ``drawn_from`` is ``(strata,
    sizes, counts)``, the strata (:func:`_strata_of`), their texels and the texels drawn
    from each; ``sides[k]`` the probe grid of stratum ``k``. Each stratum's texels are drawn
    in the first round (one permutation, probed a ``rounds`` share at a time) and the
    rounds stop once ``se <= precision * mse``; then, where ``se > PROBE_PRECISION * mse``,
    :func:`_fine_look` with ``fine`` samples (``result["fine"]``: the texels it probed)."""
    strata, sizes, counts = drawn_from
    width = image.shape[1]
    n = len(sizes)
    picks: list[np.ndarray | None] = [None] * n  # per stratum: its drawn texels, in the order they are probed
    done = [0] * n
    found: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in range(n)]  # per stratum: (d2, n2) of each round's texels
    for share in rounds:
        for k, (m, upto) in enumerate(zip(counts, _shares(share, counts), strict=True)):
            if m == 0:
                continue
            if picks[k] is None:  # drawn in the first round (the random stream as one round draws it)
                drawn = _pick(strata, width, k, np.sort(rng.choice(sizes[k], size=m, replace=False)))
                picks[k] = drawn if len(rounds) == 1 else drawn[rng.permutation(m)]
            if upto > done[k]:
                pick = cast(np.ndarray, picks[k])
                found[k].append(_probe_texels(reference_at, image, pick[done[k]:upto], sides[k], int(rng.integers(2**31))))
                done[k] = upto
        result = _pooled(found, sizes, total)
        if result["se"] <= precision * result["mse"]:
            break
    result["fine"] = 0
    if fine > 0 and result["se"] > PROBE_PRECISION * result["mse"]:
        side = min(34, max(FINE_GRID, 2 * max(sides)))
        looked, again = _fine_look(reference_at, image, [None if p is None else p[:d] for p, d in zip(picks, done, strict=True)],
                                   found, sizes, total, side, fine // (2 * side * side), rng)
        result = _pooled(again, sizes, total)
        result["fine"] = looked
    return result


def _fine_look(reference_at, image: np.ndarray, picks: list, found: list, sizes: list[int], total: int, side: int,
               most: int, rng: np.random.Generator) -> tuple[int, list]:
    """``(texels looked at, found)``: ``found`` (per stratum, the ``(d2, n2)`` of its probed
    texels ``picks[k]``, in order) with about ``most`` of them probed again with a ``side x
    side`` grid (two, :func:`_probe_twice`): each with a chance ``p`` in proportion to how
    much it weighs in the stratified MSE (``d2 + n2`` times its weight, its stratum's share
    of the covered texels over the texels probed in it; at most 1: the noisiest are all
    looked at, :func:`chances`), its values then ``coarse + (fine - coarse) / p``. Not
    ``n2`` alone: a texel whose halves happened to agree (``n2`` 0) would never be looked
    at, and its ``d2 - n2`` reads high. None is looked at when those looked at would hold
    less than ``FINE_SHARE`` of the summed score: where the noise is spread evenly, a look
    at some texels adds the chances' own noise and takes little away.

    Why: a bake whose error is below the probe's own noise (one filtered sample of a
    checker or wood, whose error sits on few texels, or adaptive samples) reads as the
    MSE's standard error, which that noise sets, so the estimate read 2.3-3.4 times the
    error (bench_error against a corrected reference, 512²). The noise sits on few texels
    (cell and ring borders, partly covered texels), and a finer grid there lowers it
    fastest (a jittered grid's variance falls as samples^-1.5 across an edge). Why the
    chances: the texels left with their coarse values must not depend on those values;
    kept where their noise read low, their ``d2 - n2`` reads high (fandisk.obj's filtered
    wood at 512² read 4.3 times its error so). With ``coarse + (fine - coarse) / p`` every
    texel's expected value is the fine probe's, an unbiased estimate of its squared error,
    whatever the chances (Horvitz and Thompson's weighting)."""
    weights = [size / total / max(len(p), 1) if p is not None else 0.0 for p, size in zip(picks, sizes, strict=True)]
    merged: list[tuple[np.ndarray, np.ndarray] | None] = []
    scores = []
    for k, parts in enumerate(found):
        if not parts:
            merged.append(None)
            scores.append(np.zeros(0))
            continue
        d2, n2 = (np.concatenate([part[i] for part in parts]) for i in (0, 1))
        merged.append((d2, n2))
        scores.append(np.where(np.isnan(d2), 0.0, weights[k] * (d2 + n2)))
    score = np.concatenate(scores)
    chance = chances(score, most)
    if not float(chance @ score) >= FINE_SHARE * float(score.sum()):
        return 0, found  # the noise is spread over the texels: a look at some of them would add noise, not take it away
    looked, at = 0, 0
    for k, m in enumerate(merged):
        p = chance[at:at + len(scores[k])]
        at += len(scores[k])
        if m is None:
            continue
        rows = np.flatnonzero(rng.random(len(p)) < p)
        if not len(rows):
            continue
        d2, n2 = m
        fine_d2, fine_n2 = _probe_twice(reference_at, image, picks[k][rows], side, rng)
        seen = ~np.isnan(fine_d2)  # the finer grid found the surface too (else the coarse values stand)
        rows, pr = rows[seen], p[rows[seen]]
        d2[rows] += (fine_d2[seen] - d2[rows]) / pr
        n2[rows] += (fine_n2[seen] - n2[rows]) / pr
        looked += len(rows)
    return looked, [[] if m is None else [m] for m in merged]


def _probe_twice(reference_at, image: np.ndarray, pick: np.ndarray, side: int, rng: np.random.Generator):
    """``(d2, n2)`` as :func:`_probe_texels`'s, from two independent ``side x side`` jittered
    grids a texel, each texel's jitter its own: the probe is their mean, and its noise a
    quarter of their squared difference, exact in expectation since the two grids are
    alike (the halves of one checkerboard are not: across an edge their expected means
    differ, and a quarter of their squared difference read the noise of a 24 x 24 grid a
    third to a half high, the estimate of fandisk.obj's filtered wood at 512² 0.54-0.91 of
    its error). Not one jitter for all texels (``sample_offsets``'): where the colour is
    smooth the probe's error would then be one offset shared by every texel, and the
    texels' errors would not average out. NaN where either grid hits nothing."""
    height, width = image.shape[:2]
    samples = side * side
    row, col = np.divmod(np.asarray(pick, dtype=np.int64), width)
    gy, gx = np.mgrid[0:side, 0:side]
    cells = np.stack([gx.ravel(), gy.ravel()], axis=1).astype(np.float64)  # sample_offsets' order: x right, y down
    means = []
    for _ in range(2):
        offsets = (cells[None] + rng.random((len(pick), samples, 2))) / side
        uv = np.stack([(col[:, None] + offsets[..., 0]) / width, 1.0 - (row[:, None] + offsets[..., 1]) / height], axis=2)
        hit, values = reference_at(uv.reshape(-1, 2))
        count, sums = texel_sums(np.flatnonzero(hit) // samples, values, len(pick))
        means.append(np.where(count[:, None] > 0, sums / np.maximum(count, 1)[:, None], np.nan))
    a, b = means
    baked = image.reshape(-1, image.shape[-1])[pick].astype(np.float64)
    return np.mean((baked - 0.5 * (a + b)) ** 2, axis=1), np.mean((a - b) ** 2, axis=1) / 4.0


def chances(scores: np.ndarray, most: float) -> np.ndarray:
    """``(n,)`` chances ``min(1, c * scores)``, ``c`` such that they add up to ``most`` (all 1
    where there are no more texels of a score above 0 than that)."""
    out = np.zeros(len(scores))
    positive = np.flatnonzero(scores > 0)
    if len(positive) <= most:
        out[positive] = 1.0
        return out
    order = positive[np.argsort(-scores[positive], kind="stable")]
    s = scores[order]
    rest = np.cumsum(s[::-1])[::-1]  # rest[t]: the scores from the t-th largest on
    t = np.arange(len(s))
    c = (most - t) / rest  # the first t saturated, the others in proportion
    ok = np.flatnonzero(c * s <= 1.0)
    first = int(ok[0]) if len(ok) else len(s) - 1
    out[order] = np.minimum(1.0, c[first] * s)
    out[order[:first]] = 1.0
    return out


def _strata_of(image: np.ndarray, covered: np.ndarray, total: int, whole: bool):
    """``(strata, sizes)``: a callable that iterates the strata band by band (:func:`_strata`:
    ``(edge, inside)`` for an image probed ``whole``, else :data:`STRATA`; made once and held
    up to ``HELD`` texels), and the texels in each."""
    bands = lambda: _bands(covered, BAND, None if whole else image)
    step = max(1, total >> 20)  # the contrasts' cuts from at most about 2^20 of them
    if covered.size <= HELD:
        kept = list(bands())
        held = list(_strata(kept, None if whole else _cuts(kept, step)))
        strata = lambda: held
    else:
        cuts = None if whole else _cuts(bands(), step)
        strata = lambda: _strata(bands(), cuts)
    sizes = [0] * (2 if whole else len(STRATA))  # counted band by band
    for *_, masks in strata():
        sizes = [n + int(m.sum()) for n, m in zip(sizes, masks, strict=True)]
    return strata, sizes


def _pooled(found, sizes: list[int], total: int) -> dict:
    """The stratified means (``mse``, ``d2``, ``n2``), the MSE's standard error ``se`` and the
    texels ``probed``, from each stratum's ``(d2, n2)`` arrays so far."""
    mse = var = d2_all = n2_all = 0.0
    probed = 0
    for size, parts in zip(sizes, found, strict=True):
        if not parts:
            continue
        d2, n2 = (np.concatenate([part[i] for part in parts]) for i in (0, 1))
        ok = ~np.isnan(d2)
        e = (d2 - n2)[ok]
        if len(e) == 0:
            continue
        probed += len(e)
        weight = size / total
        mse += weight * float(e.mean())
        d2_all += weight * float(d2[ok].mean())
        n2_all += weight * float(n2[ok].mean())
        if len(e) > 1:  # no finite-population correction: each e also carries the probe's own noise
            var += weight**2 * float(e.var(ddof=1)) / len(e)
    return {"mse": mse, "se": float(np.sqrt(var)), "d2": d2_all, "n2": n2_all, "probed": probed}


def _allotted(budget: int, sizes: list[int]) -> list[int]:
    """How many of ``budget`` drawn texels each stratum (:data:`STRATA`) gets: chart edges up
    to half, the rest inside (as many as there are), and in each half a sharp texel
    ``SHARP_WEIGHT`` times as likely to be drawn as a plain one. Fixed before any texel is
    probed, so that the stratified mean stays unbiased (an allocation that follows the
    errors a first round saw read bunny.ply's filtered wood at 0.51-0.82 of its RMSE,
    twelve seeds, every one low)."""
    edge = min(sizes[0] + sizes[1], budget // 2)
    halves = [edge, min(sizes[2] + sizes[3], budget - edge)]
    halves[0] = min(sizes[0] + sizes[1], budget - halves[1])  # inside short of texels: edges take the rest
    out = []
    for (a, b), half in zip(((0, 1), (2, 3)), halves, strict=True):
        weight = SHARP_WEIGHT * sizes[a] + sizes[b]
        share = SHARP_WEIGHT * sizes[a] / weight if weight > 0 else 0.0
        take_a = min(sizes[a], int(round(share * half)))
        take_b = min(sizes[b], half - take_a)
        take_a = min(sizes[a], half - take_b)  # what b could not take
        out += [take_a, take_b]
    return out


def _shares(share: float, counts: list[int]) -> list[int]:
    """Each stratum's texels probed by the round that reaches ``share`` of its ``counts``:
    ``share`` of each, rounded so that they add up to ``share`` of them all, rounded up
    (the largest remainders rounded up first)."""
    want = np.array(counts, dtype=float) * share
    out = np.floor(want).astype(int)
    extra = int(np.ceil(share * sum(counts) - 1e-9)) - int(out.sum())
    for k in np.argsort(-(want - out), kind="stable")[:max(extra, 0)]:
        out[k] += 1
    return [min(int(o), c) for o, c in zip(out, counts, strict=True)]


def texel_sums(texel: np.ndarray, values: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """``(samples (count,), sums (count, c))``: how many of the ``(n, c)`` ``values`` fall in
    each of ``count`` texels (``texel`` ``(n,)``) and their sums."""
    n = np.bincount(texel, minlength=count)
    return n, np.stack([np.bincount(texel, weights=values[:, c], minlength=count) for c in range(values.shape[1])], axis=1)


def _probe_texels(reference_at, image: np.ndarray, pick: np.ndarray, side: int, seed: int):
    """``(d2, n2)`` ``(m,)`` per texel of ``pick`` (flat indices): the squared difference of
    the bake from a ``side x side`` point probe (NaN where the probe hit nothing) and the
    probe's own noise (see :func:`probe_estimate`)."""
    height, width = image.shape[:2]
    samples = side * side
    hit, values = reference_at(sample_uv(Tile(0, height), pick, width, height, sample_offsets(samples, seed)))
    index = np.flatnonzero(hit)
    texel, sample = index // samples, index % samples
    count, sums = texel_sums(texel, values, len(pick))
    probe = sums / np.maximum(count, 1)[:, None]
    baked = image.reshape(-1, image.shape[-1])[pick].astype(np.float64)
    d2 = np.where(count > 0, np.mean((baked - probe) ** 2, axis=1), np.nan)
    a, b, na, nb, squares = half_means(values, texel, sample, samples, len(pick))
    # the probe's noise: from its checkerboard halves, or, with samples on one half only
    # (partly covered texels), the plain s^2 / n of its samples (0 with a single sample)
    plain = np.mean(np.maximum(squares - count[:, None] * probe**2, 0.0), axis=1) / np.maximum(count * (count - 1), 1)
    n2 = np.where((na > 0) & (nb > 0), np.mean((a - b) ** 2, axis=1) / 4.0, np.where(count > 1, plain, 0.0))
    return d2, n2
