"""Error against run time: one mesh and texture baked under a sweep of quality settings.

Each setting (samples per texel, footprint filtering, precision, octave cap, size) is
baked once for its error, then ``repeats`` times in turn with the others; its time is
the median wall time of the whole ``bake_mesh``
call with an atlas made beforehand (the mesh is loaded and unwrapped once for the whole
sweep; each timed bake still builds its Embree scene and surface map, evaluates, and
makes its error estimate; no margin, nothing written). ``tiles_seconds`` is the median
wall time of the tile loop alone (texel lookup, surface, texture, accumulate).

Its error is measured against a converged reference at the same size: about
``reference_samples`` (default 256; at a size half the largest of the sweep, four times
as many, at most 1024) stratified samples a texel, point-sampled (no
footprint filtering: a footprint-filtered sample is blurred by a whole texel, so many
of them do not converge to the texel mean), float64, every octave. RMSE and maximum
absolute error are taken over the three channels, in linear colour, and over the same
texels for every setting of one size: those covered by the reference and by every
setting's bake at that size (``info[size]["texels"]``). A bake with more samples covers
more of the partly covered texels on chart edges, the hardest ones; scoring each setting
on its own coverage would flatter the settings that cover fewer.

The reference is not exact, and at large sizes its own error nears that of one filtered
sample (at 4096², 256 samples a texel of the checker on a box on a floor are off by
about as much as one filtered sample). So it is the mean of two bakes of half its
samples with different jitter (``REFERENCE_SEEDS``), and their difference measures its
own error: two independent bakes of equal error e differ by RMSE sqrt(2) e, and their
mean is off by e / sqrt(2), half their difference (``info[size]["own_rmse"]``). A
setting's error and the reference's are independent, so their squares add: a row's
``rmse`` is sqrt(measured^2 - own^2) (``measured_rmse`` is the RMSE against the
reference itself), and where the reference's own error is the larger the row's error is
below what the reference resolves (``Row.resolved``).

A whole image's reference of 1024 samples a texel still errs by as much as one filtered
sample of the checker or the wood at 2048² (its edges' texels converge slowly: a jittered
k x k grid's error on an edge falls as k^-1.5). With ``reference_texels`` the reference is
made on about that many of the scored texels only (``pipeline.texel_means``: the probe's
own reference, point samples in float64, every octave), up to 16384 samples each. The
texels are drawn with chances in proportion to how much the settings' bakes disagree
there, plus their mean (so that every texel has a chance, and half of them go evenly:
``maps.estimate.chances``), and each counts 1 / its chance in the RMSE (Horvitz-Thompson,
as a ratio: the weighted mean square over the weights' sum), so the figure is the whole
image's without favouring the texels it looked at. Its own error is taken out as above.

``estimate`` is the error estimate from the bake's own report (``texbake.maps.estimate``);
``ratio`` is estimate / RMSE (the reference's own error taken out).
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import importlib.util
import io
import math
import statistics
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..mesh import LoadedMesh
from ..output import write_bytes
from ..textures import parse_spec

COLUMNS = ("setting", "seconds", "rmse", "max_abs", "estimate", "ratio", "method", "samples", "filtering", "precision",
           "max_octaves", "size", "tiles_seconds", "pareto", "measured_rmse", "reference_rmse")
REFERENCE_SEEDS = (1, 2)  # the jitter of the reference's two halves: neither the settings' (seed 0) nor each other's
REFERENCE_DRAW = 3  # the seed of the draw of a texel reference's texels
Baked = tuple[np.ndarray, np.ndarray]  # (image, coverage) of a bake
Images = dict[int, Baked]  # size -> a reference bake


@dataclass(frozen=True)
class Setting:
    """One point of the sweep: the ``bake_mesh`` settings it varies (those a quality
    preset fixes, and the size)."""

    samples: int = 1
    filtering: bool = True
    precision: str = "float64"
    max_octaves: int | None = None
    size: int = 512
    adaptive: float = 0.0

    @property
    def name(self) -> str:
        """Short label, e.g. ``16spp point f64 512`` or ``1spp filter f32 oct5 256``."""
        parts = [f"{self.samples}spp", "filter" if self.filtering else "point", "f32" if self.precision == "float32" else "f64"]
        if self.max_octaves is not None:
            parts.append(f"oct{self.max_octaves}")
        if self.adaptive:
            parts.append(f"adaptive{self.adaptive:g}")
        return " ".join(parts + [str(self.size)])

    def kwargs(self) -> dict:
        """The setting, as ``bake_mesh`` keywords."""
        return dataclasses.asdict(self)


@dataclass
class Row:
    """What a setting measured. Errors are linear-colour, over the texels every bake of its size covers."""

    setting: Setting
    seconds: float  # median whole-bake wall time, pre-made atlas
    tiles_seconds: float  # median wall time of the tile loop
    rmse: float
    max_abs: float
    estimate: float  # the bake's own error estimate (report.json "error_estimate")
    method: str  # how it was estimated ("probe")
    pareto: bool = False  # no other setting is both faster and more accurate
    mean_samples: float = 0.0  # samples looked up (and evaluated) a covered texel
    measured_rmse: float | None = None  # against the reference as it is (None: rmse, a reference taken as exact)
    reference_rmse: float = 0.0  # the reference's own error at this size (the module's note)

    @property
    def ratio(self) -> float:
        return self.estimate / self.rmse if self.rmse > 0 else math.inf

    @property
    def resolved(self) -> bool:
        """Whether the reference resolves this row's error: its own error is no larger."""
        return self.reference_rmse <= self.rmse

    def record(self) -> dict:
        s = self.setting
        return {
            "setting": s.name, "seconds": self.seconds, "rmse": self.rmse, "max_abs": self.max_abs, "estimate": self.estimate,
            "ratio": self.ratio, "method": self.method, "samples": s.samples, "filtering": s.filtering,
            "precision": s.precision, "max_octaves": "" if s.max_octaves is None else s.max_octaves, "size": s.size,
            "tiles_seconds": self.tiles_seconds, "pareto": self.pareto,
            "measured_rmse": self.rmse if self.measured_rmse is None else self.measured_rmse,
            "reference_rmse": self.reference_rmse,
        }


def default_settings(size: int = 512) -> list[Setting]:
    """Samples 1, 4, 16, 64 with filtering on and off; float32; octave caps; half the size."""
    grid = [Setting(n, f, size=size) for n in (1, 4, 16, 64) for f in (True, False)]
    return grid + [
        Setting(1, True, "float32", size=size),
        Setting(16, False, "float32", size=size),
        Setting(1, True, max_octaves=4, size=size),
        Setting(1, True, max_octaves=5, size=size),
        Setting(4, False, max_octaves=5, size=size),
        Setting(1, True, size=max(1, size // 2)),
        Setting(16, False, size=max(1, size // 2)),
    ]


def prepare_mesh(mesh_or_path, *, size: int = 1024, uv: str = "auto", workers: int = 2) -> LoadedMesh:
    """The mesh with its atlas as its own UVs (loaded and unwrapped once), for ``uv="keep"`` bakes."""
    from ..atlas import make_atlas
    from ..pipeline import as_mesh

    mesh = as_mesh(mesh_or_path, 5_000_000, "mesh")
    atlas = make_atlas(mesh.vertices, mesh.faces, mesh.uv, mode=uv, size=size, workers=workers, has_uv=mesh.has_uv,
                       part=mesh.part, part_names=mesh.part_names)
    if atlas.method == "kept":
        return mesh
    return dataclasses.replace(mesh, vertices=mesh.vertices[atlas.vmapping], faces=atlas.faces, uv=atlas.uv)


def compare(image: np.ndarray, covered: np.ndarray, reference: np.ndarray, ref_covered: np.ndarray,
            texels: np.ndarray | None = None) -> tuple[float, float]:
    """``(rmse, max_abs)`` of ``(h, w, c)`` images over texels covered in both (and in
    ``texels``, ``(h, w)`` bool, when given: the texels a sweep scores every setting on)."""
    both = covered & ref_covered if texels is None else covered & ref_covered & texels
    if not both.any():
        return 0.0, 0.0
    d = image[both].astype(np.float64) - reference[both].astype(np.float64)
    return float(np.sqrt(np.mean(d**2))), float(np.abs(d).max())


def pareto_front(rows: list[Row], tolerance: float = 0.01) -> None:
    """Mark the rows that no other row of the same size beats in both time and RMSE
    (errors at different sizes are against different references). RMSEs within
    ``tolerance`` (relative) count as equal: float32 changes the error by far less."""
    def beats(o: Row, r: Row) -> bool:
        as_good = o.seconds <= r.seconds and o.rmse <= r.rmse * (1 + tolerance)
        return as_good and (o.seconds < r.seconds or o.rmse * (1 + tolerance) < r.rmse)

    for r in rows:
        r.pareto = not any(o is not r and o.setting.size == r.setting.size and beats(o, r) for o in rows)


def run_sweep(mesh, spec, *, size: int = 512, settings: list[Setting] | None = None, repeats: int = 3,
              reference_samples: int = 256, reference_texels: int | None = None, uv: str = "auto", workers: int = 2,
              progress=None) -> tuple[list[Row], dict]:
    """Bake ``spec`` on ``mesh`` under each setting; returns the rows and the references' info.

    ``mesh``: a path, a trimesh mesh or a ``LoadedMesh`` (made into one with its atlas
    once, ``uv`` as in ``bake_mesh``); ``settings``: default :func:`default_settings`
    (``size``); ``reference_texels``: None, a reference bake of every texel; a count, a
    reference of ``reference_samples`` (16 to 16384) samples on about that many of the
    scored texels only, drawn with chances (see the module); ``progress``: optional
    callable taking a line.
    The second value maps each size to ``{"samples", "own_rmse", "seconds", "texels"}``:
    ``samples`` the reference's a texel (its two halves'), ``own_rmse`` its own error (see
    the module), ``texels`` how many texels every setting of that size is scored on
    (covered by the reference and by every setting's bake), and with ``reference_texels``
    ``drawn``: how many of them the reference was made on.
    """
    if not isinstance(repeats, int) or not 1 <= repeats <= 100:
        raise ParameterError("repeats", f"expected a whole number from 1 to 100, got {repeats!r}")
    most = 1024 if reference_texels is None else 16384  # samples a texel: a whole image's reference takes 1024 at most
    if not isinstance(reference_samples, int) or not 16 <= reference_samples <= most:
        raise ParameterError("reference_samples", f"expected a whole number from 16 to {most}, got {reference_samples!r}")
    if reference_texels is not None and (not isinstance(reference_texels, int) or reference_texels < 64):
        raise ParameterError("reference_texels", f"expected None or a whole number of at least 64, got {reference_texels!r}")
    spec = parse_spec(spec)
    settings = default_settings(size) if settings is None else list(dict.fromkeys(settings))
    if not settings:
        raise ParameterError("settings", "expected at least one setting")
    say = progress or (lambda line: None)
    base = prepare_mesh(mesh, size=max(s.size for s in settings), uv=uv, workers=workers)
    bake = functools.partial(_bake, base, spec, workers)

    sizes = sorted({s.size for s in settings})
    info: dict[int, dict] = {}
    if reference_texels is None:
        references, halves, info = _references(bake, sizes, reference_samples, say)
    # The first bake of each setting (untimed: it also pays the imports and first-use costs) gives the errors.
    baked = {}
    for setting in settings:
        result = bake(**setting.kwargs())
        figures = result.report["sets"][0]
        spent = (figures["rays"]["cast"] + figures["rays"]["crease_parts"]) / max(1, figures["texels"]["covered"])
        baked[setting] = (result.images[next(iter(result.images))], result.coverage, result.report["error_estimate"], spent)
    results = {}
    if reference_texels is None:
        # every setting of a size is scored on the same texels: those all its bakes cover
        scored = {sz: np.logical_and.reduce([ref_cov, *(baked[s][1] for s in settings if s.size == sz)])
                  for sz, (_, ref_cov) in references.items()}
        for sz, mask in scored.items():
            info[sz]["texels"] = int(mask.sum())
            info[sz]["own_rmse"] = 0.5 * compare(*halves[sz][0], *halves[sz][1], mask)[0]
        for setting in settings:
            image, coverage, est, spent = baked.pop(setting)
            rmse, max_abs = compare(image, coverage, *references[setting.size], scored[setting.size])
            results[setting] = (rmse, max_abs, est, spent)
    else:
        for sz in sizes:
            ours = [s for s in settings if s.size == sz]
            info[sz], errors = _texel_reference(base, spec, sz, [baked[s][:2] for s in ours], reference_texels, reference_samples,
                                                workers)
            for setting, (rmse, max_abs) in zip(ours, errors, strict=True):
                results[setting] = (rmse, max_abs, *baked.pop(setting)[2:])
    for sz in sizes:
        say(f"reference {sz}: {info[sz]['samples']} samples, its own error {info[sz]['own_rmse']:.2e}")
    times, tile_times = _timed(bake, settings, repeats)
    rows = []
    for setting in settings:
        measured, max_abs, est, spent = results[setting]
        own = info[setting.size]["own_rmse"]
        rmse = math.sqrt(max(measured**2 - own**2, 0.0))  # the reference's own error taken out (the module's note)
        rows.append(Row(setting, statistics.median(times[setting]), statistics.median(tile_times[setting]), rmse, max_abs,
                        est["rmse"], est["method"], mean_samples=spent, measured_rmse=measured, reference_rmse=own))
        say(f"{setting.name}: {rows[-1].seconds:.3f} s, RMSE {rmse:.2e} ({measured:.2e} against the reference), "
            f"estimate {est['rmse']:.2e} ({est['method']})")
    pareto_front(rows)
    return rows, info


def _bake(mesh: LoadedMesh, spec, workers: int, **settings):
    """One bake of the sweep: ``mesh``'s own atlas, no margin."""
    from ..pipeline import bake_mesh

    return bake_mesh(mesh, spec, uv="keep", margin=0, workers=workers, **settings)


def _references(bake, sizes: list[int], reference_samples: int,
                say) -> tuple[Images, dict[int, tuple[Baked, Baked]], dict[int, dict]]:
    """``(references, halves, info)`` per size: the converged reference's ``(image,
    coverage)`` (the mean of its two halves, over the texels both cover), the halves'
    ``(image, coverage)`` pair, and what they took."""
    references: Images = {}
    halves: dict[int, tuple[Baked, Baked]] = {}
    info: dict[int, dict] = {}
    for sz in sizes:
        # smaller sizes get more samples a texel (same total, at most 1024): their texels
        # on chart edges cover more of the surface and converge more slowly
        n = min(1024, reference_samples * max(1, (sizes[-1] // sz) ** 2))
        k = max(2, round(math.sqrt(n / 2)))  # each half a jittered k x k grid (sample_offsets), k^2 about n / 2
        start = time.perf_counter()
        pair: list[Baked] = []
        for seed in REFERENCE_SEEDS:
            half = bake(size=sz, samples=k * k, filtering=False, seed=seed)
            pair.append((half.images[next(iter(half.images))], half.coverage))
            del half
        seconds = time.perf_counter() - start
        (a, a_covered), (b, b_covered) = pair
        references[sz] = (0.5 * (a.astype(np.float64) + b.astype(np.float64)), a_covered & b_covered)
        halves[sz] = (pair[0], pair[1])
        info[sz] = {"samples": 2 * k * k, "seconds": seconds}
    return references, halves, info


def _texel_reference(mesh: LoadedMesh, spec, size: int, images: list[Baked], count: int, samples: int,
                     workers: int) -> tuple[dict, list[tuple[float, float]]]:
    """``(info, [(rmse, max_abs) of each of images])``: the settings' bakes of one size
    scored against a reference on about ``count`` of the texels they all cover (the
    module's note), ``samples`` a texel in two halves."""
    from ..maps.estimate import chances
    from ..pipeline import texel_means

    covered = np.logical_and.reduce([c for _, c in images])
    where = np.flatnonzero(covered.ravel())
    flat = [im.reshape(-1, im.shape[-1]) for im, _ in images]
    mean = sum(f[where].astype(np.float64) for f in flat) / len(flat)
    # where the settings disagree, their errors are: drawn in proportion to that, and half
    # evenly (chances floored at the mean's), so that no texel's chance is 0
    spread = sum(((f[where] - mean) ** 2).mean(axis=1) for f in flat)
    chance = chances(spread + max(float(np.mean(spread)), 1e-30), count)
    drawn = np.random.default_rng(REFERENCE_DRAW).random(len(where)) < chance
    texels, chance = where[drawn], chance[drawn]
    values = [f[texels].astype(np.float64) for f in flat]
    k = max(2, round(math.sqrt(samples / 2)))  # each half a jittered k x k grid
    start = time.perf_counter()
    settings = {"texture": spec, "size": size, "uv": "keep", "filtering": False}
    (a, a_hits), (b, b_hits) = (texel_means(mesh, settings, texels, k * k, seed=seed, workers=workers) for seed in REFERENCE_SEEDS)
    seconds = time.perf_counter() - start
    both = (a_hits > 0) & (b_hits > 0)
    weight = 1.0 / chance[both]  # Horvitz-Thompson: each drawn texel stands for 1 / chance of them

    def rmse(d: np.ndarray) -> float:
        return math.sqrt(float(weight @ (d**2).mean(axis=1)) / float(weight.sum())) if len(d) else 0.0

    reference = 0.5 * (a[both] + b[both])
    errors = [(rmse(v[both] - reference), float(np.abs(v[both] - reference).max(initial=0.0))) for v in values]
    info = {"samples": 2 * k * k, "seconds": seconds, "texels": int(covered.sum()), "drawn": int(both.sum()),
            "own_rmse": 0.5 * rmse(a[both] - b[both])}
    return info, errors


def _timed(bake, settings: list[Setting], repeats: int) -> tuple[dict, dict]:
    """``(whole-bake seconds, tile-loop seconds)`` of each setting, ``repeats`` of each.
    The runs go round the settings, so that a change in the load of a shared machine
    spreads over all of them instead of falling on one."""
    times: dict[Setting, list[float]] = {s: [] for s in settings}
    tile_times: dict[Setting, list[float]] = {s: [] for s in settings}
    for _ in range(repeats):
        for setting in settings:
            start = time.perf_counter()
            result = bake(**setting.kwargs())
            times[setting].append(time.perf_counter() - start)
            tile_times[setting].append(result.report["seconds"]["tiles (wall)"])
    return times, tile_times


def write_csv(rows: list[Row], path) -> Path:
    """``path``: one row per setting, columns :data:`COLUMNS`."""
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        rec = r.record()
        writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in rec.items()})
    write_bytes(Path(path), buf.getvalue().encode())
    return Path(path)


def markdown(rows: list[Row], info: dict | None = None) -> str:
    """The rows as a markdown table, fastest first, with the references as a note."""
    lines = [
        "| setting | seconds | tiles s | RMSE | max abs | estimate | est/RMSE | method | Pareto |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | :---: |",
    ]
    for r in sorted(rows, key=lambda r: (r.setting.size, r.seconds)):
        lines.append(
            f"| {r.setting.name} | {r.seconds:.3f} | {r.tiles_seconds:.3f} | {r.rmse:.2e}{'' if r.resolved else ' (unresolved)'} | "
            f"{r.max_abs:.2e} | "
            f"{r.estimate:.2e} | {r.ratio:.2f} | {r.method} | {'*' if r.pareto else ''} |"
        )
    lines += [
        "",
        "Seconds: median wall time of the whole `bake_mesh` call with an atlas made beforehand (no margin, nothing "
        "written; the runs go round the settings); tiles s: the tile loop alone (lookup, surface, texture, accumulate). "
        "RMSE and max abs: linear colour, three channels, the same texels for every setting of a size: those "
        "covered by the reference and by every setting's bake at that size; the RMSE with the reference's own error "
        "taken out (sqrt(measured^2 - own^2)), unresolved where the reference's own error is the larger. "
        "Estimate: the bake's own `report.json` `error_estimate` (a point-sampled probe of up to 4096 covered "
        "texels, stratified into chart edges and inside, less its own noise; see `texbake/maps/estimate.py`).",
    ]
    for sz, ref in sorted((info or {}).items()):
        lines.append("")
        lines.append(
            f"Reference {sz}: {ref['samples']} stratified point samples a texel (two halves of different jitter), "
            f"float64, every octave ({ref['seconds']:.1f} s); its own error (half its halves' difference) RMSE "
            f"{ref['own_rmse']:.2e}, taken out of every row's RMSE; "
            f"every setting at {sz} scored on the {ref.get('texels', 0)} texels they all cover."
        )
    return "\n".join(lines) + "\n"


def write_markdown(rows: list[Row], path, info: dict | None = None) -> Path:
    write_bytes(Path(path), markdown(rows, info).encode())
    return Path(path)


def plot(rows: list[Row], path) -> Path:
    """Log-log RMSE against seconds, one point per setting, the Pareto front as a line.

    Needs matplotlib (``pip install matplotlib``).
    """
    import matplotlib  # pip install matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 5.5), dpi=110)
    ax = fig.add_subplot()
    for r in rows:
        s = r.setting
        marker = "o" if s.filtering else "s"
        colour = "tab:blue" if s.precision == "float64" else "tab:orange"
        if s.max_octaves is not None:
            colour = "tab:green"
        ax.scatter(r.seconds, max(r.rmse, 1e-12), marker=marker, color=colour, edgecolors="black" if r.pareto else "none",
                   s=45, zorder=3)
        ax.annotate(s.name, (r.seconds, max(r.rmse, 1e-12)), fontsize=6.5, xytext=(4, 3), textcoords="offset points")
    sizes = sorted({r.setting.size for r in rows}, reverse=True)
    for style, size in zip(("k--", "k:", "k-."), sizes, strict=False):
        front = sorted((r for r in rows if r.pareto and r.setting.size == size), key=lambda r: r.seconds)
        ax.plot([r.seconds for r in front], [max(r.rmse, 1e-12) for r in front], style, lw=1, zorder=2,
                label=f"Pareto front, {size}x{size}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("seconds (median whole bake, pre-made atlas)")
    ax.set_ylabel("RMSE against the converged reference (linear colour)")
    ax.set_title("error against run time (circles: footprint filtering, squares: point; orange float32, green octave cap)",
                 fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    write_bytes(path, buf.getvalue())
    return path


def write_all(rows: list[Row], folder, info: dict | None = None) -> dict[str, Path]:
    """``error_vs_time.csv``, ``.md`` and, where matplotlib is installed (the ``report``
    extra), ``.png`` in ``folder`` (made if missing)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = {"csv": write_csv(rows, folder / "error_vs_time.csv"), "md": write_markdown(rows, folder / "error_vs_time.md", info)}
    if importlib.util.find_spec("matplotlib") is not None:
        paths["png"] = plot(rows, folder / "error_vs_time.png")
    return paths
