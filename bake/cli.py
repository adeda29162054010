"""The ``texbake`` command line: ``bake`` one mesh, ``batch`` many, ``report`` error against
time, ``stability`` checks.

User errors (bad file, bad parameter) print one line and exit with code 2.
"""

from __future__ import annotations

import glob
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from pathlib import Path

import numpy as np
import typer

from .errors import BakeError, TextureError

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Bake procedural solid textures into maps and textured meshes.")


def _version(value: bool):
    if value:
        from . import __version__

        typer.echo(f"texbake {__version__}")
        raise typer.Exit()


@app.callback()
def _options(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="print the version and exit")):
    """Bake procedural solid textures into maps and textured meshes."""


def _plugin_commands() -> None:
    """Commands other packages register under the ``texbake.commands`` entry points
    (the service's ``serve`` and ``worker``): the core never imports them itself."""
    from importlib.metadata import entry_points

    known = {command.name for command in app.registered_commands}
    for point in entry_points(group="texbake.commands"):
        if point.name not in known:
            app.command(name=point.name)(point.load())


def _fail(message: str, code: int = 2):
    typer.echo(f"texbake: error: {message}", err=True)
    raise typer.Exit(code)


SPEC_SUFFIXES = (".json", ".yaml", ".yml")


def read_spec(value):
    """A texture argument as the command line takes it: a name, JSON, or a spec file.

    Only the command line reads files; the library and the service take names and JSON.
    """
    if not isinstance(value, str) or value.lstrip().startswith("{") or Path(value).suffix.lower() not in SPEC_SUFFIXES:
        return value
    path = Path(value)
    try:
        text = path.read_text()
    except OSError as exc:
        raise TextureError(f"{path}: cannot read texture spec: {exc.strerror}") from None
    try:
        import yaml  # a superset of JSON

        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise TextureError(f"{path}: not a valid spec file: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise TextureError(f"{path}: a spec file holds one mapping with a 'name', got {type(data).__name__}")
    return data


def _bake_one(mesh: str, out: str, settings: dict) -> dict:
    """Bake and save one mesh; returns the report (runs in batch worker processes too)."""
    from .pipeline import bake_mesh
    from .textures.spec import with_overrides

    save = {k: settings.pop(k) for k in ("fmt", "bits", "obj") if k in settings}
    texture = with_overrides(read_spec(settings.pop("texture")), settings.pop("set", None) or [])
    if settings.get("bump") is not None:
        settings["bump"] = read_spec(settings["bump"])
    result = bake_mesh(mesh, texture, **settings)
    result.save(out, **save)
    return result.report


def _floats(text: str | None, name: str, count: int | None = None) -> list[float] | None:
    """``"a,b,c"`` as floats, or ``"start:stop:n"`` as n evenly spaced values."""
    if text is None:
        return None
    try:
        if ":" in text:
            start, stop, n = text.split(":")
            values = [float(x) for x in np.linspace(float(start), float(stop), int(n))]
        else:
            values = [float(x) for x in text.split(",")]
    except ValueError:
        _fail(f"parameter {name!r}: expected numbers like 'a,b,c' or 'start:stop:count', got {text!r}")
    if count is not None and len(values) != count:
        _fail(f"parameter {name!r}: expected {count} numbers, got {len(values)}")
    return values


def _settings(texture, sets, size, samples, margin, uv, source, cage, texture_space, max_faces, deadline, fmt, bits, obj,
              workers=2, shading="decal", light=None, bump=None, bump_strength=1.0, frames=None, quality=None):
    extra = {"shading": shading, "bump": bump, "bump_strength": bump_strength, "frames": _floats(frames, "frames")}
    if quality is not None:
        extra["quality"] = quality
    if samples is not None:  # else the quality preset's
        extra["samples"] = samples
    if light is not None:
        extra["light"] = tuple(_floats(light, "light", 3))
    return {
        **extra, "texture": texture, "set": list(sets or []), "size": size, "margin": margin, "uv": uv,
        "source": source, "cage": cage, "texture_space": texture_space, "max_faces": max_faces,
        "unwrap_deadline": deadline, "fmt": fmt, "bits": bits, "obj": obj, "workers": workers,
    }


_TEXTURE = typer.Option("checker", "--texture", "-t", help="texture name, JSON spec, or a .json/.yaml spec file (see `texbake textures`)")
_SET = typer.Option(None, "--set", help="override a texture parameter: key.sub=value (repeatable)")
_SIZE = typer.Option(1024, "--size", "-s", help="image size in texels (square)")
_SAMPLES = typer.Option(None, "--samples", help="samples per texel (stratified; default: the quality preset's, 1)")
_QUALITY = typer.Option(None, "--quality", "-q", help="draft | default | final: samples, filtering, precision, octave cap")
_MARGIN = typer.Option(16, "--margin", help="texels of margin filled around charts")
_UV = typer.Option("auto", "--uv", help="auto | unwrap | keep")
_SOURCE = typer.Option(None, "--source", help="mesh to transfer the texture from (high poly)")
_CAGE = typer.Option(None, "--cage", help="max transfer ray distance (default 5% of the bbox diagonal)")
_SPACE = typer.Option("unit", "--texture-space", help="unit (bbox scaled to 1) | object")
_FACES = typer.Option(5_000_000, "--max-faces", help="reject meshes with more faces")
_DEADLINE = typer.Option(120.0, "--unwrap-deadline", help="seconds xatlas may run before a fallback atlas is used")
_FMT = typer.Option("png", "--format", "-f", help="png | exr | tif")
_BITS = typer.Option(None, "--bits", help="png/tif 8 or 16; exr 16 (half) or 32; tif 32 (float)")
_OBJ = typer.Option(False, "--obj", help="also write OBJ + MTL")
_SHADING = typer.Option("decal", "--shading", help="decal (albedo only) | ambient-diffuse | full: also bake a lit map")
_LIGHT = typer.Option(None, "--light", help="light direction x,y,z for lit maps")
_BUMP = typer.Option(None, "--bump", help="texture whose luminance is bumped into a tangent-space normal map")
_BUMP_STRENGTH = typer.Option(1.0, "--bump-strength", help="scale of the bump")
_FRAMES = typer.Option(None, "--frames", help="times to bake an animated texture (flame): 't0,t1,...' or 'start:stop:count'")


@app.command()
def bake(
    mesh: str = typer.Argument(..., help="mesh file: OBJ, PLY, STL, OFF, glTF, GLB"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder"),
    texture: str = _TEXTURE, set_: list[str] | None = _SET, size: int = _SIZE, samples: int | None = _SAMPLES, margin: int = _MARGIN,
    uv: str = _UV, source: str | None = _SOURCE, cage: float | None = _CAGE,
    texture_space: str = _SPACE, max_faces: int = _FACES, unwrap_deadline: float = _DEADLINE,
    fmt: str = _FMT, bits: int | None = _BITS, obj: bool = _OBJ, shading: str = _SHADING,
    light: str | None = _LIGHT, bump: str | None = _BUMP, bump_strength: float = _BUMP_STRENGTH,
    frames: str | None = _FRAMES, quality: str | None = _QUALITY,
):
    """Bake one mesh: writes DIR/albedo.<format>, DIR/<mesh>.glb and DIR/report.json."""
    settings = _settings(texture, set_, size, samples, margin, uv, source, cage, texture_space, max_faces, unwrap_deadline,
                         fmt, bits, obj, shading=shading, light=light, bump=bump, bump_strength=bump_strength, frames=frames,
                         quality=quality)
    start = time.perf_counter()
    try:
        report = _bake_one(mesh, str(out), settings)
    except BakeError as exc:
        _fail(str(exc))
    t = report["texels"]
    typer.echo(
        f"{mesh}: {t['covered']} texels covered, {t['margin']} margin; "
        f"atlas {report['atlas']['method']}; {time.perf_counter() - start:.2f} s -> {out}"
    )


def _expand(inputs: list[str]) -> list[tuple[str, dict]]:
    """Mesh paths and per-item settings from files, globs and ``.jsonl`` manifests."""
    items = []
    for arg in inputs:
        if arg.endswith(".jsonl"):
            try:
                lines = Path(arg).read_text().splitlines()
            except OSError as exc:
                _fail(f"{arg}: cannot read manifest: {exc.strerror}")
            for number, line in enumerate(lines, 1):
                if not line.strip() or line.lstrip().startswith("#"):
                    continue
                try:
                    entry = json.loads(line)
                    mesh = entry.pop("mesh")
                except (json.JSONDecodeError, KeyError, AttributeError, TypeError):
                    _fail(f"{arg}:{number}: expected a JSON object with a 'mesh' key")
                if not Path(mesh).is_absolute():
                    mesh = str(Path(arg).parent / mesh)
                items.append((mesh, entry))
        elif any(c in arg for c in "*?["):
            matches = sorted(glob.glob(arg, recursive=True))
            if not matches:
                _fail(f"{arg}: no file matches")
            items.extend((m, {}) for m in matches)
        else:
            items.append((arg, {}))
    return items


def _unique_folder(out: Path, stem: str, used: set[str]) -> Path:
    name, k = stem, 1
    while name in used:
        k += 1
        name = f"{stem}-{k}"
    used.add(name)
    return out / name


@app.command()
def batch(
    inputs: list[str] = typer.Argument(..., help="mesh files, globs, or .jsonl manifests (one JSON object a line: mesh and settings)"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder; one sub-folder per mesh"),
    jobs: int = typer.Option(2, "--jobs", "-j", min=1, help="parallel processes"),
    texture: str = _TEXTURE, set_: list[str] | None = _SET, size: int = _SIZE, samples: int | None = _SAMPLES, margin: int = _MARGIN,
    uv: str = _UV, texture_space: str = _SPACE, max_faces: int = _FACES, unwrap_deadline: float = _DEADLINE,
    fmt: str = _FMT, bits: int | None = _BITS, obj: bool = _OBJ, quality: str | None = _QUALITY,
):
    """Bake many meshes in parallel; keeps going past failures, exits 1 if any failed."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn
    from rich.table import Table

    base = _settings(texture, set_, size, samples, margin, uv, None, None, texture_space, max_faces, unwrap_deadline, fmt, bits, obj,
                     workers=1, quality=quality)
    items = _expand(inputs)
    if not items:
        _fail("no input meshes")
    used: set[str] = set()
    jobs_list = [(mesh, str(_unique_folder(out, Path(mesh).stem, used)), {**base, **extra}) for mesh, extra in items]
    rows = []
    console = Console(stderr=True)
    with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool, Progress(
        "[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), console=console
    ) as progress:
        task = progress.add_task("baking", total=len(jobs_list))
        started = {pool.submit(_bake_one, mesh, folder, settings): (mesh, folder, time.perf_counter()) for mesh, folder, settings in jobs_list}
        for future in as_completed(started):
            mesh, folder, t0 = started[future]
            try:
                report = future.result()
                rows.append((mesh, "done", time.perf_counter() - t0, f"{report['texels']['covered']} texels -> {folder}"))
            except BakeError as exc:
                rows.append((mesh, "failed", time.perf_counter() - t0, str(exc)))
            except Exception as exc:  # a crash in one item must not stop the batch
                rows.append((mesh, "failed", time.perf_counter() - t0, f"{type(exc).__name__}: {exc}"))
            progress.advance(task)
    table = Table(title=f"texbake batch: {len(rows)} meshes")
    for col in ("mesh", "status", "seconds", "result"):
        table.add_column(col)
    for mesh, status, seconds, detail in sorted(rows):
        table.add_row(mesh, "[green]done" if status == "done" else "[red]failed", f"{seconds:.2f}", detail)
    Console().print(table)
    failed = sum(r[1] == "failed" for r in rows)
    if failed:
        typer.echo(f"texbake: {failed} of {len(rows)} failed", err=True)
        raise typer.Exit(1)


@app.command()
def report(
    mesh: str = typer.Argument(..., help="mesh file: OBJ, PLY, STL, OFF, glTF, GLB"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder for error_vs_time.csv, .png and .md"),
    texture: str = _TEXTURE, set_: list[str] | None = _SET,
    size: int = typer.Option(512, "--size", "-s", help="image size of the sweep (a few settings also at half of it)"),
    repeats: int = typer.Option(3, "--repeats", help="timed runs per setting (the median is reported)"),
    reference_samples: int = typer.Option(256, "--reference-samples", help="samples a texel of the converged reference"),
    uv: str = _UV,
):
    """Error against run time: bake under a sweep of quality settings, measure each against a converged reference."""
    from .sweep import markdown, run_sweep, write_all
    from .textures.spec import with_overrides

    if not 8 <= size <= 8192:
        _fail(f"parameter 'size': expected a whole number from 8 to 8192, got {size}")
    try:
        spec = with_overrides(read_spec(texture), list(set_ or []))
        rows, info = run_sweep(mesh, spec, size=size, repeats=repeats, reference_samples=reference_samples, uv=uv,
                               progress=lambda line: typer.echo(line, err=True))
        paths = write_all(rows, out, info)
    except BakeError as exc:
        _fail(str(exc))
    typer.echo(markdown(rows, info), nl=False)
    typer.echo(f"wrote {', '.join(str(p) for p in paths.values())}")


@app.command()
def textures(as_json: bool = typer.Option(False, "--json", help="print the JSON Schema of a texture spec")):
    """List every texture with its parameters, defaults and ranges."""
    from rich.console import Console
    from rich.table import Table

    from .textures.spec import catalogue, json_schema

    if as_json:
        typer.echo(json.dumps(json_schema(), indent=2))
        return
    console = Console()
    for texture in catalogue():
        table = Table(title=f"{texture['name']}: {texture['description']}", title_justify="left")
        for col in ("parameter", "default", "limits", "description"):
            table.add_column(col)
        for p in texture["parameters"]:
            limits = ", ".join(f"{k} {v}" for k, v in p["limits"].items())
            table.add_row(p["name"], json.dumps(p["default"]), limits, p["description"])
        console.print(table)


def _number(x: float) -> str:
    return "-" if x != x else f"{x:.3g}"


@app.command()
def stability(
    quick: bool = typer.Option(False, "--quick", help="skip the slow cases (listed as skipped)"),
    as_json: bool = typer.Option(False, "--json", help="print the results as JSON"),
    select: list[str] | None = typer.Option(None, "--case", help="run only cases whose name contains this (repeatable)"),
):
    """Run the numerical stability cases; prints a table, exits 1 if any case fails."""
    from dataclasses import asdict

    from rich.console import Console
    from rich.table import Table

    from .stability import run_cases, selected

    if select and not selected(select):
        _fail(f"parameter '--case': no stability case matches {', '.join(map(repr, select))}")
    start = time.perf_counter()
    results = run_cases(quick=quick, select=select or None)
    seconds = time.perf_counter() - start
    failed = [r for r in results if not r.passed]
    if as_json:
        # JSON has no NaN or infinity: figures not measured (or not finite) are null
        rows = [{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(r).items()}
                for r in results]
        typer.echo(json.dumps(rows, indent=2))
    else:
        ran = sum(not r.skipped for r in results)
        table = Table(title=f"texbake stability: {ran} cases run, {len(results) - ran} skipped, {len(failed)} failed, {seconds:.1f} s",
                      title_justify="left")
        for col in ("case", "property", "figure", "limit", "result", "s", "detail"):
            table.add_column(col, justify="right" if col in ("figure", "limit", "s") else "left")
        for r in results:
            result = "[yellow]skipped" if r.skipped else "[green]pass" if r.passed else "[red]fail"
            limit = "-" if r.skipped else f"{r.comparison} {_number(r.limit)}"
            table.add_row(r.case, r.property, _number(r.figure), limit, result, f"{r.seconds:.2f}", r.detail)
        Console().print(table)
    if failed:
        typer.echo(f"texbake: {len(failed)} of {len(results)} stability cases failed: {', '.join(r.case for r in failed)}", err=True)
        raise typer.Exit(1)


def main(argv: list[str] | None = None) -> int:
    """Entry point: usage errors print one line and exit 2, like bake errors."""
    argv = sys.argv[1:] if argv is None else argv
    _plugin_commands()
    command = typer.main.get_command(app)
    if not argv:
        argv = ["--help"]
    try:
        code = command.main(args=argv, prog_name="texbake", standalone_mode=False)
    except typer.TyperException as exc:  # usage errors: one line, exit 2
        typer.echo(f"texbake: error: {exc.format_message()}", err=True)
        return exc.exit_code
    except typer.Exit as exc:
        return exc.exit_code
    except typer.Abort:
        typer.echo("texbake: aborted", err=True)
        return 130
    return code if isinstance(code, int) else 0


if __name__ == "__main__":
    sys.exit(main())
