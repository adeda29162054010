"""Numerical stability cases: the textures and the bake at the edges of their inputs.

A registry of small cases, each measuring one property as one figure against a stated
limit: texture evaluation far from the origin (against the float64 reference in
``texbake.checks.reference``), at lattice points, cell boundaries, signed zeros and
subnormals; the checkerboard on integer planes, wood at its axis, the flame above its
height; antialiasing at 10, 100 and 1000 times the texel rate; 30 octaves; footprints
of zero and of the whole object; tiny, huge and far meshes, slivers and degenerate
faces; a mesh that hangs xatlas and one that crashes it; images of 1 x 1 and (slow)
16384 x 16384 texels.

``run_cases(quick=False, select=None)`` runs them and returns one :class:`Result` each.
A case that raises is a failed result holding the exception text; numpy's floating
point warnings (overflow, invalid value) are errors inside a case. ``texbake
stability`` prints the results as a table; ``tests/texbake/checks/test_stability.py`` runs the same
cases under pytest.

A case is a function of no arguments returning a :class:`Figure` (the measured number,
its limit, optional detail), registered with :func:`case` under a name and the property
it checks; the runner turns it into a :class:`Result`.
"""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

# -- records and registry --------------------------------------------------------------


@dataclass(frozen=True)
class Figure:
    """What a case measured: ``figure`` judged against ``limit`` by ``comparison``.

    ``passed`` defaults to ``figure <= limit`` (``">="``: ``figure >= limit``); a case
    may set it to False when something beside the figure failed (said in ``detail``).
    """

    figure: float
    limit: float
    detail: str = ""
    comparison: str = "<="
    passed: bool | None = None


@dataclass(frozen=True)
class Result:
    """One row of the stability table."""

    case: str
    property: str
    figure: float  # NaN when not measured (raised, skipped)
    limit: float
    passed: bool
    slow: bool = False
    detail: str = ""
    comparison: str = "<="
    skipped: bool = False  # a slow case left out by ``quick``
    seconds: float = 0.0


@dataclass(frozen=True)
class Case:
    name: str
    property: str
    run: Callable[[], Figure]
    slow: bool = False


CASES: dict[str, Case] = {}


def case(name: str, property: str, *, slow: bool = False):
    """Register ``fn() -> Figure`` as the case ``name`` checking ``property``."""

    def register(fn: Callable[[], Figure]) -> Callable[[], Figure]:
        if name in CASES:
            raise ValueError(f"stability case {name!r} registered twice")
        CASES[name] = Case(name, property, fn, slow)
        return fn

    return register


def run_case(c: Case) -> Result:
    """Run one case; an exception becomes a failed result with its text."""
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            f = c.run()
    except Exception as exc:  # a case must never take the table down
        where = traceback.extract_tb(exc.__traceback__)[-1]
        return Result(c.name, c.property, math.nan, math.nan, False, c.slow,
                      f"raised {type(exc).__name__}: {exc} ({Path(where.filename).name}:{where.lineno})",
                      seconds=time.perf_counter() - start)
    if f.passed is not None:
        passed = bool(f.passed)
    elif f.comparison == ">=":
        passed = bool(f.figure >= f.limit)
    else:
        passed = bool(f.figure <= f.limit)  # NaN fails
    return Result(c.name, c.property, float(f.figure), float(f.limit), passed, c.slow, f.detail, f.comparison,
                  seconds=time.perf_counter() - start)


def selected(select: str | Iterable[str] | None = None) -> list[Case]:
    """Cases whose name contains ``select`` (or any of several substrings), in order."""
    if select is None:
        return list(CASES.values())
    words = [select] if isinstance(select, str) else list(select)
    return [c for c in CASES.values() if any(w in c.name for w in words)]


def run_cases(quick: bool = False, select: str | Iterable[str] | None = None) -> list[Result]:
    """Run the registered cases (those matching ``select``); ``quick`` skips slow ones.

    Skipped cases are returned as results with ``skipped=True`` and ``passed=True``.
    """
    out = []
    for c in selected(select):
        if quick and c.slow:
            out.append(Result(c.name, c.property, math.nan, math.nan, True, True, "slow: skipped by --quick",
                              skipped=True))
        else:
            out.append(run_case(c))
    return out


# -- helpers ---------------------------------------------------------------------------

# The colour map that is the identity on [0, 1]: Catmull-Rom through collinear knots
# (the two-knot default map eases in and out), so colours are the scalar itself.
IDENTITY = {"knots": [-1.0, 0.0, 1.0, 2.0], "colours": [[-1.0] * 3, [0.0] * 3, [1.0] * 3, [2.0] * 3]}
SCALARS = ("noise", "turbulence", "fbm", "marble", "wood")
ALL = ("position", "checker", "noise", "turbulence", "fbm", "marble", "wood", "flame")


def _spec(name: str, **params) -> dict:
    """A spec of ``name``; scalar textures get the identity colour map."""
    spec = {"name": name, **params}
    if name in SCALARS:
        spec.setdefault("colormap", IDENTITY)
    return spec


def _evaluate(spec, points, footprint=None) -> np.ndarray:
    from ..textures import evaluate

    return evaluate(spec, np.asarray(points, dtype=np.float64), footprint)


def _max(x) -> float:
    """Largest value, inf if any is not finite (a NaN must not pass a ``<=`` check)."""
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return 0.0
    return float(np.max(x)) if np.isfinite(x).all() else math.inf


def _worst(figures: Mapping[str, float]) -> tuple[float, str]:
    """The largest figure and a detail naming it and the others."""
    name = max(figures, key=lambda k: (not np.isfinite(figures[k]), figures[k]))
    parts = ", ".join(f"{k} {v:.3g}" for k, v in figures.items())
    return figures[name], f"worst: {name} ({parts})"


# -- texture evaluation against the float64 reference ---------------------------------

def _against_reference(points: np.ndarray) -> tuple[float, str]:
    """Max |evaluate(noise) - reference| over linear and cubic value noise, and a detail."""
    from . import reference

    errors = {}
    for interpolation in ("linear", "cubic"):
        ours = _evaluate(_spec("noise", scale=1.0, interpolation=interpolation), points)[:, 0]
        errors[interpolation] = _max(np.abs(ours - reference.value_noise(points, interpolation)))
    # the lecture's sample code: its field is ours moved by +10000 (the offset it adds)
    lecture = _max(np.abs(reference.lecture_sample_code(points) - reference.value_noise(points + 10000.0)))
    figure, detail = _worst(errors)
    return figure, f"{detail}; the lecture's float32 +10000/(int) code is off by {lecture:.3g} here"


# Both split x exactly into floor(x) and x - floor(x) (exact in float64), so only the
# rounding of the seven lerps can differ (the kernel may fuse multiply-adds): a few ulps
# of values in [0, 1]. A wrong cell or a lost fraction gives errors of 1e-3 to 1.
REFERENCE_LIMIT = 1e-12


def _offset_case(offset: float, label: str):
    @case(f"noise-offset-{label}", f"noise at {offset:+.0e} + [0, 10)^3 equals the float64 reference")
    def _() -> Figure:
        p = np.random.default_rng(1).random((4000, 3)) * 10 + offset
        figure, detail = _against_reference(p)
        return Figure(figure, REFERENCE_LIMIT, detail)


for _offset, _label in [(1e3, "plus-1e3"), (-1e3, "minus-1e3"), (1e6, "plus-1e6"), (-1e6, "minus-1e6"),
                        (1e9, "plus-1e9"), (-1e9, "minus-1e9")]:
    _offset_case(_offset, _label)


@case("noise-below-minus-10000", "noise at coordinates in [-10010, -10005) equals the float64 reference")
def _() -> Figure:
    p = np.random.default_rng(2).random((4000, 3)) * 5 - 10010
    figure, detail = _against_reference(p)
    return Figure(figure, REFERENCE_LIMIT, detail)


@case("noise-lattice-points", "noise at integer points is exactly noiseTable[INDEX(i, j, k)]")
def _() -> Figure:
    from ..textures import noise
    from . import reference

    rng = np.random.default_rng(3)
    cells = np.concatenate([rng.integers(-3, 4, (500, 3)), rng.integers(-2**40, 2**40, (500, 3)),
                            rng.integers(-10**9 - 5, -10**9 + 5, (200, 3)), rng.integers(10**9 - 5, 10**9 + 5, (200, 3))])
    errors = {}
    for interpolation in ("linear", "cubic", "catmull-rom"):
        # the kernel itself: a colour map's lookup table would round by an ulp
        ours = noise.noise(cells.astype(np.float64), interpolation=interpolation)
        errors[interpolation] = _max(np.abs(ours - reference.lattice(cells)))
    figure, detail = _worst(errors)
    # fraction 0: each lerp a + 0 * (b - a) returns a exactly, so does Catmull-Rom's b
    return Figure(figure, 0.0, detail)


@case("noise-cell-boundaries", "noise is continuous across cell boundaries (max jump over 2e-6)")
def _() -> Figure:
    eps = 1e-6  # above the float64 spacing at 1e9 (1.2e-7)
    base = np.random.default_rng(4).random((300, 3)) * 3
    jumps = {}
    for basis, interpolation in [("value", "linear"), ("value", "cubic"), ("value", "catmull-rom"), ("perlin", "linear")]:
        spec = _spec("noise", scale=1.0, basis=basis, interpolation=interpolation)
        worst = 0.0
        for boundary in (-1e9, -10001.0, -1.0, 0.0, 1.0, 255.0, 256.0, 1e6, 1e9):
            for axis in range(3):
                a, b = base.copy(), base.copy()
                a[:, axis], b[:, axis] = boundary - eps, boundary + eps
                worst = max(worst, _max(np.abs(_evaluate(spec, a) - _evaluate(spec, b))))
        jumps[f"{basis}/{interpolation}"] = worst
    figure, detail = _worst(jumps)
    # every basis has a slope below 10 per unit, so 2 eps moves it < 2e-5; a jump
    # between cells (a wrong cell or table wrap) would be ~0.1
    return Figure(figure, 2 * eps * 10, detail)


# -- special values --------------------------------------------------------------------

@case("signed-zero", "every texture gives the same value at -0.0 and 0.0 (point and filtered)")
def _() -> Figure:
    signs = np.array([[sx, sy, sz] for sx in (1, -1) for sy in (1, -1) for sz in (1, -1)], dtype=np.float64)
    bases = [np.array(b) for b in ([0.0, 0.0, 0.0], [0.0, 0.3, 0.7], [0.45, 0.0, 0.0])]
    diffs = {}
    for name in ALL:
        worst = 0.0
        for b in bases:
            p = np.where(b == 0, np.copysign(0.0, signs), b)  # its zeros with both signs
            for fp in (None, np.full((len(p), 2, 3), 1e-3)):
                v = _evaluate(_spec(name), p, fp)
                worst = max(worst, _max(np.abs(v - v[:1])))
        diffs[name] = worst
    figure, detail = _worst(diffs)
    return Figure(figure, 0.0, detail)  # the same point: bit for bit the same value


@case("subnormals", "continuous textures at subnormal coordinates equal their value at 0")
def _() -> Figure:
    tiny = np.array([5e-324, -5e-324, 1e-310, -1e-310, 2.2e-308, -2.2e-308])
    p = np.array([[a, b, c] for a in tiny[:3] for b in tiny[2:5] for c in tiny[3:]])
    diffs = {}
    for name in ("position", "checker", "noise", "turbulence", "fbm", "marble"):
        v = _evaluate(_spec(name), p)
        zero = _evaluate(_spec(name), np.zeros((1, 3)))
        diffs[name] = _max(np.abs(v - zero))
    figure, detail = _worst(diffs)
    # -5e-324 lies in cell -1 at fraction 1.0: a + 1 * (b - a) may round an ulp from b.
    # (Wood's wobble makes r = 0 singular, where every ring meets, and the flame's
    # weight steps to 0 below its base: both are checked for finiteness instead.)
    return Figure(figure, 1e-12, detail)


@case("extreme-coordinates", "every texture is finite and in [0, 1] up to float32's largest coordinate")
def _() -> Figure:
    big = 3.4028234e38  # the loader's limit (float32 range)
    values = np.array([0.0, -0.0, 5e-324, -5e-324, 1.0, -1.0, 1e9, -1e9, 1e20, -1e20, big, -big])
    rng = np.random.default_rng(5)
    p = values[rng.integers(0, len(values), (400, 3))]
    bad: dict[str, int] = {}
    for name in ALL:
        for fp in (None, np.full((len(p), 2, 3), 1e-3), np.full((len(p), 2, 3), 1e30)):
            v = _evaluate(_spec(name), p, fp)
            lo, hi = (-1e-9, math.inf if name == "flame" else 1 + 1e-9)  # flame: HDR, its red curve overshoots 1
            out = ~np.isfinite(v) | (v < lo) | (v > hi)
            bad[name] = bad.get(name, 0) + int(out.any(axis=1).sum())
    figure, detail = _worst(bad)
    return Figure(figure, 0, f"points not finite or outside [0, 1]; {detail}")  # none may be


# -- textures at their own edges -------------------------------------------------------

@case("checker-integer-planes", "the checkerboard on z = 0 and x = +-1 (with last-bit noise) is one colour")
def _() -> Figure:
    rng = np.random.default_rng(6)
    xy = rng.random((2000, 2)) * 0.9 + 0.05
    minority = {}
    for axis, level in [(2, 0.0), (0, 1.0), (0, -1.0), (1, 3.0)]:
        p = np.zeros((2000, 3))
        p[:, [a for a in range(3) if a != axis]] = xy
        p[:, axis] = level + rng.choice([-1, 0, 1], 2000) * np.spacing(max(abs(level), 1e-300))
        fp = np.zeros((2000, 2, 3))
        fp[:, 0, [a for a in range(3) if a != axis][0]] = 1e-3  # a footprint in the plane
        fp[:, 1, [a for a in range(3) if a != axis][1]] = 1e-3
        for label, f in (("point", None), ("filtered", fp)):
            v = _evaluate({"name": "checker", "box": [1, 1, 1]}, p, f)[:, 0]
            counts = np.unique(v.round(12), return_counts=True)[1]
            minority[f"{'xyz'[axis]}={level:g} {label}"] = float(len(v) - counts.max())
    figure, detail = _worst(minority)
    # the nudge before floor puts a plane's points on one side, whatever their last bit
    return Figure(figure, 0, f"points on the other side of the plane; {detail}")


@case("wood-axis", "wood at r = 0 is finite and one colour for every signed zero and z")
def _() -> Figure:
    z = np.linspace(-2, 2, 41)
    worst = 0.0
    for spec in (_spec("wood"), _spec("wood", wobble=0.0), _spec("wood", tilt=[0, 90, 0])):
        axis = np.array([0.0, 0.0, 1.0])
        if spec.get("tilt"):
            axis = np.array([1.0, 0.0, 0.0])  # the ring axis turned by the tilt
        for fp in (None, np.full((4, 2, 3), 1e-3)):
            for zi in z:
                p = np.array([[sx * 0.0, sy * 0.0, 0.0] for sx in (1, -1) for sy in (1, -1)])
                p = np.where(axis > 0, zi, p)
                v = _evaluate(spec, p, fp)
                worst = max(worst, _max(np.abs(v - v[:1])))
    # theta is 0 at r = 0 (not atan2's +-pi for -0.0): the same rings, bit for bit
    return Figure(worst, 0.0, "spread of the colours at the four signed zeros of (x, y)")


@case("wood-negative-axis", "wood has no seam across the negative y axis (theta = +-pi)")
def _() -> Figure:
    eps = 1e-9
    y = -np.linspace(0.05, 2, 500) - 0.0123
    z = np.random.default_rng(7).random(500)
    left = np.column_stack([np.full(500, -eps), y, z])
    right = np.column_stack([np.full(500, eps), y, z])
    jumps = {}
    for label, spec in (("default", _spec("wood")), ("wobbly", _spec("wood", wobble=0.5, wobbles=3, twist=0.0))):
        for fl, fp in (("point", None), ("filtered", np.full((500, 2, 3), 1e-3))):
            a, b = _evaluate(spec, left, fp), _evaluate(spec, right, fp)
            jump = np.abs(a - b).max(axis=1)
            if fp is None:  # point-sampled rings step 0 to 1: count steps, not slopes
                jump = jump[jump > 0.5]
                jumps[f"{label} {fl} steps"] = float(len(jump))
            else:
                jumps[f"{label} {fl}"] = _max(jump)
    figure, detail = _worst(jumps)
    # 2e-9 apart: the filtered rings move by (ds/dx) 2e-9 / footprint < 1e-4; a seam
    # (the lecture's theta / N) would be a jump of ~0.5
    return Figure(figure, 1e-4, detail)


@case("flame-above-height", "the flame is black above its height h, at y = h and below its base")
def _() -> Figure:
    rng = np.random.default_rng(8)
    worst = 0.0
    for height, time_ in ((1.0, 0.0), (0.25, 3.5), (1e3, -2.0)):
        spec = {"name": "flame", "height": height, "time": time_}
        x = (rng.random(2000) - 0.5) * 4
        y = np.concatenate([height * (1 + rng.random(1000) * 100), np.full(500, height), -rng.random(500) * height])
        p = np.column_stack([x, y, rng.random(2000)])
        for fp in (None, np.full((2000, 2, 3), 1e-2)):
            worst = max(worst, _max(np.abs(_evaluate(spec, p, fp))))
    return Figure(worst, 0.0, "largest colour component there")  # weight 1 - y/h clamped: exactly 0


# -- antialiasing -----------------------------------------------------------------------

def _aliasing(ratio: float) -> dict[str, tuple[float, float]]:
    """Per texture ``(mean error, aliasing ratio)`` with its pattern at ``ratio`` x the texel rate.

    A 48 x 48 grid of texels (width w) on the plane z = 0.37; the texture's frequency
    (the base octave, the rings, the checks; the marble's sine sqrt(2) times that) is
    ``ratio / w``. The reference is the box-filtered texture: 16 x 16 jittered point
    samples per texel.
    ``mean error``: |mean of filtered texels - mean of the reference|; ``aliasing``:
    RMS(filtered - reference) / RMS(point-sampled - reference) (1: as bad as point
    sampling).
    """
    n, s = 48, 16
    w = 1.0 / n
    f = ratio / w
    rng = np.random.default_rng(9)
    ij = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 2)
    centres = np.column_stack([(ij + 0.5) * w + [0.1234567, 0.2345678], np.full(len(ij), 0.37)])
    fp = np.zeros((len(centres), 2, 3))
    fp[:, 0, 0] = fp[:, 1, 1] = w
    grid = np.stack(np.meshgrid(np.arange(s), np.arange(s), indexing="ij"), -1).reshape(-1, 2)
    sub = ((grid + rng.random((len(centres), s * s, 2))) / s - 0.5) * w  # jittered anew in each texel
    xy = (centres[:, None, :2] + sub).reshape(-1, 2)
    dense = np.column_stack([xy, np.full(len(xy), 0.37)])
    specs = {
        "noise": _spec("noise", scale=f),
        "turbulence": _spec("turbulence", scale=f),
        "fbm": _spec("fbm", scale=f),
        # the sine off the lattice's frequency: locked to it, sin(f x + turbulence) has a
        # mean of its own that no per-octave filter can know
        "marble": _spec("marble", frequency=2 * np.pi * np.sqrt(2) * f, turbulence={"scale": f}),
        "wood": _spec("wood", ring_width=0.5 / f),  # rings alternate: period 2 M
        "checker": {"name": "checker", "box": [0.5 / f] * 3},
    }
    out = {}
    for name, spec in specs.items():
        filtered = _evaluate(spec, centres, fp)[:, 0]
        point = _evaluate(spec, centres)[:, 0]
        ref = _evaluate(spec, dense)[:, 0].reshape(len(centres), -1).mean(axis=1)
        rms_point = np.sqrt(np.mean((point - ref) ** 2))
        out[name] = (abs(filtered.mean() - ref.mean()), float(np.sqrt(np.mean((filtered - ref) ** 2)) / rms_point))
    return out


_ALIASING_CACHE: dict[float, dict] = {}


def _aliasing_cached(ratio: float) -> dict[str, tuple[float, float]]:
    if ratio not in _ALIASING_CACHE:
        _ALIASING_CACHE[ratio] = _aliasing(ratio)
    return _ALIASING_CACHE[ratio]


def _antialias_cases(ratio: int):
    @case(f"antialias-{ratio}x-mean", f"at {ratio}x the texel rate the filtered mean is the box-filtered mean")
    def _() -> Figure:
        figure, detail = _worst({k: v[0] for k, v in _aliasing_cached(ratio).items()})
        # 0.01 is 2.5 levels of an 8-bit map; the reference mean's own error is < 1e-3
        return Figure(figure, 0.01, detail)

    @case(f"antialias-{ratio}x-aliasing", f"at {ratio}x the texel rate filtering removes the aliasing of point sampling")
    def _() -> Figure:
        figure, detail = _worst({k: v[1] for k, v in _aliasing_cached(ratio).items()})
        # RMS error against the box filter as a fraction of point sampling's (1): the
        # reference's own sampling error (16 x 16 samples) is about 1/16 of it, and a
        # quarter leaves at most a faint moire
        return Figure(figure, 0.25, detail)


for _ratio in (10, 100, 1000):
    _antialias_cases(_ratio)


@case("octaves-30", "30-octave turbulence equals the float64 reference sum (and stays in [0, 1])")
def _() -> Figure:
    from . import reference

    rng = np.random.default_rng(10)
    errors = {}
    for offset in (0.0, -1e3, 1e6):
        p = rng.random((1000, 3)) * 10 + offset
        ours = _evaluate(_spec("turbulence", scale=1.0, octaves=30), p)[:, 0]
        errors[f"offset {offset:g}"] = _max(np.abs(ours - reference.turbulence(p, 30)))
    filtered = _evaluate(_spec("turbulence", scale=1.0, octaves=30), p, np.full((1000, 2, 3), 1e-4))
    in_range = bool(np.isfinite(filtered).all() and filtered.min() >= 0 and filtered.max() <= 1)
    figure, detail = _worst(errors)
    # 30 terms of a few ulps each
    return Figure(figure, 1e-12, f"{detail}; filtered in [0, 1]: {in_range}", passed=figure <= 1e-12 and in_range)


@case("footprint-zero", "a zero footprint gives exactly the point-sampled value")
def _() -> Figure:
    p = np.random.default_rng(11).random((2000, 3)) * 4 - 2
    diffs = {name: _max(np.abs(_evaluate(_spec(name), p, np.zeros((2000, 2, 3))) - _evaluate(_spec(name), p)))
             for name in ALL}
    figure, detail = _worst(diffs)
    # width 0 keeps every octave, damps no sine and takes the point branch of the box
    # filters: the same arithmetic as point sampling
    return Figure(figure, 0.0, detail)


@case("footprint-whole-object", "footprints 10 and 1e6 times the whole object give a flat, finite texture")
def _() -> Figure:
    p = np.random.default_rng(12).random((2000, 3))  # the unit cube: texture space "unit"
    spreads = {}
    for name in ALL:
        if name in ("position", "flame"):
            continue  # not filtered: the position is the point; the flame's shape is not a pattern
        for size in (10.0, 1e6):  # at 1x a box filter still keeps a few % of the coarsest octaves
            fp = np.zeros((2000, 2, 3))
            fp[:, 0, 0] = fp[:, 1, 1] = size
            v = _evaluate(_spec(name), p, fp)
            spreads[f"{name} x{size:g}"] = _max(v.max(axis=0) - v.min(axis=0)) if np.isfinite(v).all() else math.inf
    figure, detail = _worst(spreads)
    # filtered to their means: any spread beyond rounding would be a pattern leaking through
    return Figure(figure, 1e-3, f"spread of values; {detail}")


# -- meshes ----------------------------------------------------------------------------

def _loaded(vertices, faces, uv=None, name="case"):
    from ..mesh import LoadedMesh

    return LoadedMesh(np.asarray(vertices, np.float64), np.asarray(faces, np.int64),
                      None if uv is None else np.asarray(uv, np.float64), name, f"<{name}>", 0, "")


def _sphere(subdivisions: int = 2):
    import trimesh  # pip install trimesh

    s = trimesh.creation.icosphere(subdivisions)
    return np.asarray(s.vertices, np.float64), np.asarray(s.faces, np.int64)


def _bake(mesh, texture="marble", **kw):
    from ..pipeline import bake_mesh

    kw = {"size": 64, "margin": 0, "workers": 1, **kw}
    return bake_mesh(mesh, texture, **kw)


def _scale_case(name: str, scale: float, offset: float, what: str):
    @case(name, f"a mesh {what} unwraps with xatlas and bakes as the unit mesh does")
    def _() -> Figure:
        from ..atlas import make_atlas

        v, f = _sphere(2)
        moved = v * scale + offset
        atlas = make_atlas(moved, f, mode="unwrap", size=64, workers=1)
        a = _bake(_loaded(moved[atlas.vmapping], atlas.faces, atlas.uv), uv="keep")
        b = _bake(_loaded(v[atlas.vmapping], atlas.faces, atlas.uv), uv="keep")
        same_cover = np.array_equal(a.coverage, b.coverage)
        diff = _max(np.abs(a.images["albedo"] - b.images["albedo"])[b.coverage])
        ok = atlas.method == "xatlas" and same_cover and bool(b.coverage.any())
        detail = f"atlas {atlas.method}; coverage equal: {same_cover} ({int(b.coverage.sum())} texels)"
        # unit texture space removes scale and offset; the far mesh's points carry
        # 1e-8 relative error into a pattern of slope ~100: < 1e-5, and float32 images
        return Figure(diff, 1e-4, detail, passed=ok and diff <= 1e-4)


_scale_case("mesh-1e-6-across", 0.5e-6, 0.0, "1e-6 units across")
_scale_case("mesh-1e6-across", 0.5e6, 0.0, "1e6 units across")
_scale_case("mesh-far-from-origin", 1.0, 1e8, "2 units across, 1e8 from the origin,")


@case("sliver-triangles", "sliver triangles (aspect ratio 1e6) bake to finite texels with finite footprints")
def _() -> Figure:
    from ..sampling import SurfaceMap

    v, f = _sphere(2)
    # a strip of 20 slivers 1 long and 1e-6 wide beside the sphere
    x = np.linspace(0, 1, 11)
    strip = np.concatenate([np.column_stack([x, np.zeros(11), np.full(11, 2.0)]),
                            np.column_stack([x, np.full(11, 1e-6), np.full(11, 2.0)])])
    k = np.arange(10)
    sf = np.concatenate([np.column_stack([k, k + 1, k + 12]), np.column_stack([k, k + 12, k + 11])]) + len(v)
    vertices, faces = np.concatenate([v, strip]), np.concatenate([f, sf])
    r = _bake(_loaded(vertices, faces), uv="unwrap", samples=4)
    bad = int((~np.isfinite(r.images["albedo"])).any(axis=2).sum())
    # footprints of sliver UV triangles (UV area ~1e-12 and exactly 0) stay finite
    uv = np.array([[0, 0], [1, 0], [0.5, 1e-12], [0.5, 0.0]])
    sm = SurfaceMap(strip[[0, 10, 11]], np.array([[0, 1, 2], [0, 1, 2]]), uv, np.array([[0, 1, 2], [0, 1, 3]]), 64, 64)
    s = sm.samples(np.array([0, 1]), np.full((2, 3), 1 / 3))
    assert s.dpdx is not None and s.dpdy is not None
    fp = np.stack([s.dpdx, s.dpdy], axis=1)
    bad += int((~np.isfinite(fp)).sum())
    for name in ALL:
        bad += int((~np.isfinite(_evaluate(_spec(name), s.points, fp))).sum())
    detail = f"atlas {r.report['atlas']['method']}, {r.report['texels']['covered']} texels covered"
    # footprints are clamped to 1e30 and zero for collapsed UV triangles: nothing may be NaN
    return Figure(bad, 0, f"non-finite texels, footprints and values; {detail}",
                  passed=bad == 0 and r.report["atlas"]["method"] != "fallback-grid")


@case("sliver-fan", "a cylinder of 100k segments (caps of 100k slivers round one vertex) bakes whole; its UV grid lists at most 64 entries a face")
def _() -> Figure:
    import trimesh  # pip install trimesh

    from ..sampling import UVLookup

    # A cap's slivers span half its disc's box each: listed by their boxes the UV grid held
    # 8.8e9 entries at 200k segments (a MemoryError), and the outline's walk took minutes
    c = trimesh.creation.cylinder(radius=1.0, height=0.5, sections=100_000)
    r = _bake(_loaded(c.vertices, c.faces), texture="checker", size=256, workers=2)
    uv = np.asarray(r.mesh.uv, np.float64)
    _chart, _box, _nx, _ny, _start, listed = UVLookup(uv, np.asarray(r.mesh.faces, np.int64))._cells()
    per_face = len(listed) / len(r.mesh.faces)
    bad = int((~np.isfinite(r.images["albedo"])).any(axis=2).sum())
    covered = r.report["texels"]["covered"]
    detail = f"atlas {r.report['atlas']['method']} in {r.report['atlas']['seconds']:.1f} s, {covered} texels covered, {bad} not finite"
    return Figure(per_face, 64.0, detail,
                  passed=per_face <= 64 and bad == 0 and covered > 0.3 * 256 * 256 and r.report["atlas"]["method"] == "planar")


@case("degenerate-faces", "a mesh with coincident, collinear and repeated-index faces bakes without NaN")
def _() -> Figure:
    import trimesh

    v, f = _sphere(2)
    v = v.copy()
    a0, b0, c0 = f[0]
    v[b0] = v[a0]  # coincident corners
    a1, b1, c1 = f[100]
    v[c1] = 0.5 * (v[a1] + v[b1])  # collinear
    f = np.concatenate([f, [[5, 5, 6], [7, 8, 7]]])  # repeated indices
    r = _bake(trimesh.Trimesh(v, f, process=False), uv="unwrap")
    bad = int((~np.isfinite(r.images["albedo"])).any(axis=2).sum())
    detail = (f"{r.report['mesh']['degenerate_faces_removed']} faces removed by the loader; "
              f"atlas {r.report['atlas']['method']}; {r.report['texels']['covered']} texels covered")
    ok = bad == 0 and r.report["atlas"]["method"] == "xatlas" and r.report["texels"]["covered"] > 0
    # the loader drops zero-area faces, the atlas keeps float32-degenerate ones from xatlas
    return Figure(bad, 0, f"non-finite texels; {detail}", passed=ok)


HANG_DEADLINE = 2.0


@case("xatlas-hang", "xatlas hanging on an infinite vertex is stopped at the deadline")
def _() -> Figure:
    from ..atlas import run_xatlas_in_child

    v, f = _sphere(2)
    v = v.astype(np.float32)
    v[0] = np.inf  # xatlas loops forever on it
    start = time.monotonic()
    ok, why = run_xatlas_in_child(v, f, deadline=HANG_DEADLINE)
    seconds = time.monotonic() - start
    stopped = not ok and "timed out" in str(why)
    # the deadline is the worker's CPU time: on a busy machine more wall time, up to the
    # pool's wall-clock backstop; then the kill: 2 s of slack
    from ..workers import Pool

    limit = Pool.WALL_FACTOR * HANG_DEADLINE + 2.0
    return Figure(seconds, limit, f"{why}", passed=stopped and seconds <= limit)


@case("xatlas-crash", "xatlas crashing (icosphere(6) in one piece) is survived and reported")
def _() -> Figure:
    from ..atlas import run_xatlas_in_child

    v, f = _sphere(6)
    start = time.monotonic()
    ok, why = run_xatlas_in_child(v.astype(np.float32), f, deadline=60.0)
    seconds = time.monotonic() - start
    crashed = not ok and "crashed" in str(why)
    # it dies after charting for some seconds; the 60 s deadline must not be what ends it
    return Figure(seconds, 60.0, f"{why}", passed=crashed and seconds < 60.0)


@case("xatlas-crash-fallback", "make_atlas with charting='xatlas' on the mesh that crashes xatlas in one piece unwraps it in patches")
def _() -> Figure:
    from ..atlas import make_atlas

    v, f = _sphere(6)
    # xatlas' charts asked for (the default takes planar charts for a mesh this large) and
    # in one piece first: that crashes, and the retry in patches must give the atlas
    a = make_atlas(v, f, mode="unwrap", size=1024, charting="xatlas", _patch_faces=None)
    crashed = a.reason.endswith(")") and "(after: xatlas crashed (exit code" in a.reason
    ok = a.method == "xatlas-patches" and crashed and a.stats["patches"] > 1 and a.stats["overlap"] < 1e-3
    # stretch 1 is an isometry; patches of one texel density keep it near 1 on a sphere
    return Figure(a.stats["stretch"], 1.05, f"{a.method}, {a.stats.get('patches')} patches: {a.reason}",
                  passed=ok and a.stats["stretch"] <= 1.05)


# -- images ----------------------------------------------------------------------------

@case("image-1x1", "a 1 x 1 bake gives a finite texel (the whole object under it) and writes its files")
def _() -> Figure:
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0.5]], dtype=np.float64)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)  # the quad fills the texel
    r = _bake(_loaded(v, [[0, 1, 2], [0, 2, 3]], uv), size=1, samples=4, margin=1, uv="keep")
    bad = int((~np.isfinite(r.images["albedo"])).sum())
    with tempfile.TemporaryDirectory() as d:
        r.save(d)
        written = sorted(p.name for p in Path(d).iterdir())
    # one texel whose footprint is the whole quad: finite like any other
    ok = bad == 0 and r.images["albedo"].shape == (1, 1, 3) and bool(r.coverage.all()) and "albedo.png" in written
    return Figure(bad, 0, f"shape {r.images['albedo'].shape}, covered {bool(r.coverage.any())}; wrote {', '.join(written)}",
                  passed=ok)


BIG = 16384
# Peak RSS limit of the 16384^2 bake and save, in its own process. The maps are held as
# float16 at this size (6 bytes a texel), the hit counts and masks take a few more, and
# the tiles, the margin and the PNG writer work in bands: about 11 bytes a texel in all
# (bench/bench_bake.py measures it). 13 bytes a texel bounds that with some room; a float32
# map (12 bytes a texel more) or a stage that held whole-image per-sample arrays would
# break it.
BIG_LIMIT_GB = 13 * BIG * BIG / 1e9


def _big_bake_child(size: int) -> None:  # pragma: no cover  (runs in a child process)
    """Bake and save a ``size`` x ``size`` checker map; prints the peak RSS in bytes."""
    import resource

    v, f = _sphere(3)
    r = _bake(_loaded(v, f), "checker", size=size, uv="unwrap", margin=16, workers=2)
    covered = int(r.coverage.sum())
    with tempfile.TemporaryDirectory() as d:
        r.save(d)
    peak = max(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
    print(f"{peak * 1024} {covered}")


@case(f"image-{BIG}", f"a {BIG} x {BIG} bake and save stays under a peak RSS of {BIG_LIMIT_GB:.1f} GB", slow=True)
def _() -> Figure:
    code = f"from texbake.checks.stability import _big_bake_child; _big_bake_child({BIG})"
    root = str(Path(__file__).resolve().parents[2])
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=1800, cwd=root)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        return Figure(math.inf, BIG_LIMIT_GB, f"child exited {proc.returncode}: {tail}", passed=False)
    peak, covered = (int(x) for x in proc.stdout.split()[-2:])
    return Figure(peak / 1e9, BIG_LIMIT_GB, f"{covered} texels covered; peak RSS {peak / (BIG * BIG):.1f} bytes a texel")
