"""The ``texbake`` command line: ``bake`` one mesh, ``batch`` many, ``report`` error against
time, ``stability`` checks.

User errors (bad file, bad parameter) print one line and exit with code 2.
"""

from __future__ import annotations

import atexit
import glob
import inspect
import json
import math
import os
import sys
import threading
import time
import types
import typing
from contextlib import contextmanager
from pathlib import Path

_ENDED: dict[str, int] = {}  # the exit code run() returned with, for _end
atexit.register(lambda: _end())  # before the libraries' imports register theirs: run last (handlers run last in, first out)

import numpy as np  # noqa: E402
import typer  # noqa: E402

from .errors import BakeError, TextureError  # noqa: E402

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Bake procedural solid textures into maps and textured meshes.")


def _version(value: bool):
    if value:
        from .version import __version__

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


def read_material(value):
    """A material argument as the command line takes it: a built-in's name, JSON, a
    ``.json``/``.yaml`` material file or a MaterialX ``.mtlx`` (only the command line reads files)."""
    from .errors import ParameterError

    if isinstance(value, str) and Path(value).suffix.lower() == ".mtlx" and not value.lstrip().startswith(("{", "<")):
        from .mtlx.material import material_from_mtlx

        return material_from_mtlx(Path(value))
    if not isinstance(value, str) or value.lstrip().startswith("{") or Path(value).suffix.lower() not in SPEC_SUFFIXES:
        return value
    try:
        text = Path(value).read_text()
    except OSError as exc:
        raise ParameterError("material", f"{value}: cannot read material file: {exc.strerror}") from None
    try:
        import yaml  # a superset of JSON

        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ParameterError("material", f"{value}: not a valid material file: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise ParameterError("material", f"{value}: a material file holds one mapping of channels, got {type(data).__name__}")
    return data


def read_packing(value):
    """``packing`` as the command line takes it: names and templates, comma-separated
    (``orm,hdrp-mask``), JSON, or a ``.json``/``.yaml`` file of a template or a list of them."""
    if not isinstance(value, str) or value.lstrip().startswith(("{", "[")):
        return value
    items = []
    for item in (part.strip() for part in value.split(",")):
        if Path(item).suffix.lower() in SPEC_SUFFIXES:
            import yaml

            from .errors import ParameterError

            try:
                data = yaml.safe_load(Path(item).read_text())
            except (OSError, yaml.YAMLError) as exc:
                raise ParameterError("packing", f"{item}: cannot read the template: {getattr(exc, 'strerror', None) or exc}") from None
            items.extend(data if isinstance(data, list) else [data])
        else:
            items.append(item)
    return items


def read_materials(value):
    """The ``materials`` setting as the command line takes it: JSON text, or a ``.json`` or
    ``.yaml`` file of it (a mapping of material names to their settings); each one's
    ``texture`` and ``bump`` may be spec files too (:func:`read_spec`)."""
    from .errors import ParameterError

    if isinstance(value, str):
        text = value
        if not value.lstrip().startswith("{"):
            try:
                text = Path(value).read_text()
            except OSError as exc:
                raise ParameterError("materials", f"{value}: cannot read: {exc.strerror} (expected JSON or a .json/.yaml file)") from None
        try:
            import yaml  # a superset of JSON

            value = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise ParameterError("materials", f"not valid JSON or YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(value, dict):
        return value  # the settings' own check names what it is
    return {name: {k: read_spec(v) if k in ("texture", "bump") else v for k, v in own.items()} if isinstance(own, dict) else own
            for name, own in value.items()}


def _bake_one(mesh: str, out: str, given: dict, source: str | None = None, workers: int = 2, cache: str | None = None,
              progress=None, cage_mesh: str | None = None) -> dict:
    """Bake and save one mesh with the settings ``given`` (as the command line or a manifest
    line has them), atlases kept in ``cache``, ``progress`` called with the fraction done;
    returns the report (runs in batch worker processes too)."""
    from .pipeline import bake_mesh
    from .settings import BakeSettings

    given = dict(given)
    overrides = given.pop("set", None) or []
    if given.get("texture") == "none" and not overrides:
        pass  # no texture: a bake of the mesh maps only (texbake.settings), which imports no texture
    elif "texture" in given or overrides:
        from .textures.spec import with_overrides

        given["texture"] = with_overrides(read_spec(given.get("texture", "checker")), overrides)
    if isinstance(given.get("bump"), str):
        given["bump"] = read_spec(given["bump"])
    if isinstance(given.get("material"), str):
        given["material"] = read_material(given["material"])
    if isinstance(given.get("packing"), str):
        given["packing"] = read_packing(given["packing"])
    if given.get("materials") is not None:
        given["materials"] = read_materials(given["materials"])
    result = bake_mesh(mesh, BakeSettings.build(given), source=source, workers=workers, cache=cache, progress=progress,
                       cage_mesh=cage_mesh)
    result.save(out)
    return result.report


def _batch_process(parent: int) -> None:
    """A batch's bake process ends with the batch (killed, it left them baking and their
    warm packing workers waiting): the workers' own mechanism, with the batch as parent."""
    from multiprocessing.util import Finalize

    from .atlas.pack import close_warm
    from .workers import PARENT_ENV, die_with_parent

    os.environ[PARENT_ENV] = str(parent)
    die_with_parent()
    Finalize(None, close_warm, exitpriority=0)  # a forked process's exit runs these, not atexit's


def _batch_item(mesh: str, out: str, given: dict, cache: str | None) -> tuple[str, float, dict | str]:
    """One batch item in its worker process: ``(status, seconds of the bake and its save,
    report or the error)``; a user error is a failed item, not an exception."""
    start = time.perf_counter()
    try:
        report = _bake_one(mesh, out, given, None, 1, cache)
    except BakeError as exc:
        return "failed", time.perf_counter() - start, str(exc)
    return "done", time.perf_counter() - start, report


def _floats(text: str, name: str) -> list[float]:
    """``"a,b,c"`` as floats, or ``"start:stop:n"`` as n evenly spaced values."""
    try:
        if ":" in text:
            start, stop, n = text.split(":")
            return [float(x) for x in np.linspace(float(start), float(stop), int(n))]
        return [float(x) for x in text.split(",")]
    except ValueError:
        _fail(f"{name}: expected numbers like 'a,b,c' or 'start:stop:count', got {text!r}")
        raise  # not reached: _fail exits


_SET = typer.Option(None, "--set", help="override a texture parameter: key.sub=value (repeatable)")
_TEXTURE = typer.Option("checker", "--texture", "-t", help="texture name, JSON spec, or a .json/.yaml spec file (see `texbake textures`); "
                        "none: bake the --maps only")
_UV = typer.Option("auto", "--uv", help="auto | unwrap | keep")
_CACHE = typer.Option(None, "--cache", help="folder of atlases kept for later bakes of the same mesh "
                      "(default: $TEXBAKE_CACHE, else $XDG_CACHE_HOME/texbake or ~/.cache/texbake)")
_NO_CACHE = typer.Option(False, "--no-cache", help="neither reuse nor keep atlases")


def _cache_folder(cache: Path | None, no_cache: bool) -> str | None:
    """The atlas cache's folder for a command (None: no cache)."""
    if no_cache:
        return None
    if cache is not None:
        return str(cache)
    if os.environ.get("TEXBAKE_CACHE"):
        return os.environ["TEXBAKE_CACHE"]
    return str(Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "texbake")

# One option per BakeSettings field: the command line maps onto the settings one to one.
_SHORT = {"texture": "-t", "size": "-s", "quality": "-q", "format": "-f"}
_LISTS = {"size": "N, or W,H", "light": "X,Y,Z", "frames": "T0,T1,... or START:STOP:COUNT",
          "texture": "a name, JSON, or a .json/.yaml spec file", "bump": "a name, JSON, or a .json/.yaml spec file",
          "material": "a built-in's name, JSON, a .json/.yaml material file or a MaterialX .mtlx",
          "packing": "names or templates, comma-separated: orm,hdrp-mask; JSON; or a .json/.yaml file",
          "maps": "comma-separated: ao,curvature,..."}


def _option_type(annotation) -> tuple[type, list[str]]:
    """The command-line type of a settings field and, for a choice, its values."""
    union = typing.get_origin(annotation) in (typing.Union, types.UnionType)
    args = [a for a in typing.get_args(annotation) if a is not type(None)] if union else [annotation]
    kind = typing.get_args(args[0])[0] if typing.get_origin(args[0]) is typing.Annotated else args[0]
    if typing.get_origin(kind) is typing.Literal:
        values = typing.get_args(kind)
        return (int if all(isinstance(v, int) for v in values) else str), [str(v) for v in values]
    if len(args) == 1 and kind in (bool, int, float):
        return kind, []
    return str, []


def _settings_parameters() -> list[inspect.Parameter]:
    from .settings import BakeSettings

    params = []
    for name, info in BakeSettings.model_fields.items():
        kind, choices = _option_type(info.annotation)
        flag = "--" + name.replace("_", "-")
        decls = [f"{flag}/--no-{flag[2:]}"] if kind is bool else [flag, *([_SHORT[name]] if name in _SHORT else [])]
        default = info.default
        shown = ",".join(map(str, default)) if isinstance(default, (tuple, list)) else default
        notes = [" | ".join(choices) if choices else _LISTS.get(name, "")]
        if "default" not in (info.description or "") and shown is not None:
            notes.append(f"default: {shown}")
        help_ = (info.description or "") + "".join(f" ({note})" for note in notes if note)
        params.append(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, annotation=kind | None,
                                        default=typer.Option(None, *decls, help=help_, show_default=False)))
    return params


def settings_options(command):
    """Give ``command`` (which takes ``**given``) one option per ``BakeSettings`` field."""
    signature = inspect.signature(command)
    own = [p for p in signature.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    command.__signature__ = signature.replace(parameters=own + _settings_parameters())
    return command


def _given(options: dict) -> dict:
    """The settings given on the command line (options left out take the defaults)."""
    given = {k: v for k, v in options.items() if v is not None}
    if "size" in given:  # N, W,H or WxH; anything else goes to the settings as typed, to be named in the error
        parts = given["size"].replace("x", ",").split(",")
        if all(part.strip().isdigit() for part in parts):
            given["size"] = int(parts[0]) if len(parts) == 1 else [int(part) for part in parts]
    for name in ("light", "frames"):
        if name in given:
            given[name] = _floats(given[name], name)
    if "maps" in given:  # a list, comma-separated; each name is checked by the settings
        given["maps"] = [m.strip() for m in given["maps"].split(",") if m.strip()]
    return given


PROGRESS_SECONDS = 10.0  # between progress lines when stderr is not a terminal ($TEXBAKE_PROGRESS_SECONDS)


@contextmanager
def _progress(label: str, quiet: bool):
    """A ``progress(fraction)`` callable for one bake, shown on stderr: a bar on a terminal
    (gone when the bake ends); elsewhere (a CI log, a pipe) a plain line at most every
    ``$TEXBAKE_PROGRESS_SECONDS`` (10) seconds, so a bake shorter than that writes none and
    a long one shows it is alive; None with ``quiet``."""
    if quiet:
        yield None
    elif sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TaskProgressColumn, TimeElapsedColumn, TimeRemainingColumn

        with Progress("[progress.description]{task.description}", BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                      TimeRemainingColumn(), console=Console(stderr=True), transient=True) as bar:
            task = bar.add_task(label, total=1.0)
            yield lambda fraction: bar.update(task, completed=fraction)
    else:
        try:
            every = float(os.environ.get("TEXBAKE_PROGRESS_SECONDS", PROGRESS_SECONDS))
        except ValueError:
            every = PROGRESS_SECONDS
        start = time.monotonic()
        due = [start + every]
        lock = threading.Lock()  # called from the bake's tile threads too

        def line(fraction: float) -> None:
            now = time.monotonic()
            with lock:
                if now < due[0] or fraction >= 1.0:  # done: the summary line says so
                    return
                due[0] = now + every
                typer.echo(f"texbake: {label}: {fraction:.0%} after {now - start:.0f} s", err=True)

        yield line


@app.command()
@settings_options
def bake(
    mesh: str = typer.Argument(..., help="mesh file: OBJ, PLY, STL, OFF, glTF, GLB"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder"),
    set_: list[str] | None = _SET,
    source: str | None = typer.Option(None, "--source", help="mesh to transfer the texture from (high poly), and the "
                                      "source_* mesh maps' (normal, height, misses)"),
    cage_mesh: str | None = typer.Option(None, "--cage-mesh", help="the cage of the source_* maps: the mesh's topology, "
                                         "moved out (default: rays from --front-distance along the normal)"),
    cache: Path | None = _CACHE,
    no_cache: bool = _NO_CACHE,
    quiet: bool = typer.Option(False, "--quiet", help="no progress and no summary line (warnings and errors still on stderr); "
                               "progress is a bar on a terminal, else a line every 10 s ($TEXBAKE_PROGRESS_SECONDS)"),
    **options,
):
    """Bake one mesh: writes its maps (DIR/albedo.<format>; one set per material: DIR/<material>_albedo.<format>...), DIR/<mesh>.glb and DIR/report.json."""
    start = time.perf_counter()
    try:
        with _progress(Path(mesh).name, quiet) as progress:
            report = _bake_one(mesh, str(out), {**_given(options), "set": set_ or []}, source=source,
                               cache=_cache_folder(cache, no_cache), progress=progress, cage_mesh=cage_mesh)
    except BakeError as exc:
        _fail(str(exc))
    t = report["texels"]
    if not quiet:
        typer.echo(f"{mesh}: {t['covered']} texels covered, {t['margin']} margin; "
                   f"atlas {report['atlas']['method']}; {time.perf_counter() - start:.2f} s -> {out}")
    for warning in report.get("warnings", []):
        typer.echo(f"texbake: warning: {mesh}: {warning}", err=True)


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
        elif any(c in arg for c in "*?["):  # only the mesh files a glob matches (not an OBJ's .mtl or .jpg)
            matches = sorted(m for m in glob.glob(arg, recursive=True) if _is_mesh(m))
            if not matches:
                _fail(f"{arg}: no mesh file matches")
            items.extend((m, {}) for m in matches)
        elif Path(arg).is_dir():  # every mesh file in it, not in its sub-folders
            from .mesh.load import FORMATS

            found = sorted(str(p) for p in Path(arg).iterdir() if _is_mesh(p) and p.is_file())
            if not found:
                _fail(f"{arg}: no mesh file in this folder (looked for {' '.join(FORMATS)})")
            items.extend((m, {}) for m in found)
        else:
            items.append((arg, {}))
    return items


def _largest_first(job: tuple) -> int:
    """Sort key of a batch job ``(mesh, ...)``: the largest files first, so that the last
    bakes, while the other processes have nothing left, are the shortest."""
    try:
        return -os.path.getsize(job[0])
    except OSError:
        return 0


def _is_mesh(path) -> bool:
    """A mesh file by its extension (not an OBJ's .mtl or textures, nor a hidden file)."""
    from .mesh.load import FORMATS

    return Path(path).suffix.lower() in FORMATS and not Path(path).name.startswith(".")


def _unique_folder(out: Path, stem: str, used: set[str]) -> Path:
    name, k = stem, 1
    while name in used:
        k += 1
        name = f"{stem}-{k}"
    used.add(name)
    return out / name


@app.command()
@settings_options
def batch(
    inputs: list[str] = typer.Argument(..., help="mesh files, folders (their mesh files), globs, or .jsonl manifests "
                                       "(one JSON object a line: mesh and settings)"),
    out: Path = typer.Option(..., "--out", "-o", help="output folder; one sub-folder per mesh"),
    jobs: int = typer.Option(2, "--jobs", "-j", min=1, help="parallel processes"),
    as_json: bool = typer.Option(False, "--json", help="print the summary as JSON (one object per mesh) instead of a table"),
    set_: list[str] | None = _SET,
    cache: Path | None = _CACHE,
    no_cache: bool = _NO_CACHE,
    **options,
):
    """Bake many meshes in parallel; keeps going past failures, exits 1 if any failed."""
    from concurrent.futures import ProcessPoolExecutor, as_completed  # here: a single bake starts 17 ms sooner without them
    from multiprocessing import get_context

    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn
    from rich.table import Table

    base = {**_given(options), "set": set_ or []}
    items = _expand(inputs)
    if not items:
        _fail("no input meshes")
    used: set[str] = set()
    jobs_list = [(mesh, str(_unique_folder(out, Path(mesh).stem, used)), {**base, **extra}) for mesh, extra in items]
    rows = []
    # The bake processes are forked from this one with the pipeline imported here once, not
    # in each of them (0.3 CPU-s a process). The pool forks them all at its first submit,
    # before its own thread and the progress bar's start; the only other thread here is
    # OpenBLAS', which is fork-safe. Elsewhere than Linux they are spawned.
    context = get_context("fork" if sys.platform == "linux" else "spawn")
    if context.get_start_method() == "fork":
        from . import pipeline  # noqa: F401
    folder_of_cache = _cache_folder(cache, no_cache)
    with ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=_batch_process,
                             initargs=(os.getpid(),)) as pool:
        started = {pool.submit(_batch_item, mesh, folder, settings, folder_of_cache): (mesh, folder)
                   for mesh, folder, settings in sorted(jobs_list, key=_largest_first)}
        with Progress("[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      console=Console(stderr=True)) as progress:
            task = progress.add_task("baking", total=len(jobs_list))
            for future in as_completed(started):
                mesh, folder = started[future]
                try:
                    status, seconds, outcome = future.result()
                except Exception as exc:  # a crash in one item must not stop the batch
                    status, seconds, outcome = "failed", math.nan, f"{type(exc).__name__}: {exc}"
                report = outcome if isinstance(outcome, dict) else {}
                rows.append({"mesh": mesh, "status": status, "seconds": seconds, "out": folder if report else None,
                             "atlas": report.get("atlas", {}).get("method"), "warnings": report.get("warnings", []),
                             "covered": report.get("texels", {}).get("covered"), "error": None if report else outcome})
                progress.advance(task)
    rows.sort(key=lambda r: r["mesh"])
    if as_json:
        typer.echo(json.dumps([{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
                               for r in rows], indent=2))
    else:
        table = Table(title=f"texbake batch: {len(rows)} meshes")
        for col in ("mesh", "status", "seconds", "atlas", "result", "warnings"):
            table.add_column(col, overflow="fold")
        for r in rows:
            result = f"{r['covered']} texels -> {r['out']}" if r["status"] == "done" else r["error"]
            table.add_row(r["mesh"], "[green]done" if r["status"] == "done" else "[red]failed", _number(r["seconds"]),
                          r["atlas"] or "-", result, "\n".join(r["warnings"]) or "-")
        # paths whole when the output goes to a file or a pipe, not cut to a terminal's width
        Console(width=None if sys.stdout.isatty() else 100_000).print(table)
    failed = sum(r["status"] == "failed" for r in rows)
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
    from .checks.sweep import markdown, run_sweep, write_all
    from .textures.spec import with_overrides

    if not 8 <= size <= 8192:
        _fail(f"size: expected a whole number from 8 to 8192, got {size}")
    try:
        spec = with_overrides(read_spec(texture), list(set_ or []))
        rows, info = run_sweep(mesh, spec, size=size, repeats=repeats, reference_samples=reference_samples, uv=uv,
                               progress=lambda line: typer.echo(line, err=True))
        paths = write_all(rows, out, info)
    except BakeError as exc:
        _fail(str(exc))
    typer.echo(markdown(rows, info), nl=False)
    typer.echo(f"wrote {', '.join(str(p) for p in paths.values())}")
    if "png" not in paths:
        typer.echo("texbake: the plot error_vs_time.png needs matplotlib: pip install 'texbake[report]'", err=True)


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


@app.command()
def materials(name: str | None = typer.Argument(None, help="a built-in material: print it as JSON"),
              as_json: bool = typer.Option(False, "--json", help="print the JSON Schema of a material")):
    """List the built-in materials, the ops of a material's node graph, or print one material as JSON."""
    from .materials import BUILTINS, OPS, Material

    if as_json:
        typer.echo(json.dumps(Material.model_json_schema(), indent=2))
        return
    if name is not None:
        if name not in BUILTINS:
            _fail(f"material: unknown material {name!r} (built in: {', '.join(sorted(BUILTINS))})")
        typer.echo(json.dumps(BUILTINS[name], indent=2))
        return
    typer.echo("built-in materials (texbake materials NAME prints one):")
    for builtin in BUILTINS.values():
        typer.echo(f"  {builtin['name']}: {builtin['description']}")
    typer.echo("ops of a material's nodes (inputs; each input a number, three numbers, a node's name or a node):")
    for op, o in OPS.items():
        typer.echo(f"  {op} ({', '.join(o.inputs) or 'a leaf'}): {o.summary}")


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

    from .checks.stability import run_cases, selected

    if select and not selected(select):
        _fail(f"case: no stability case matches {', '.join(map(repr, select))}")
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
    own = {c.name or typer.main.get_command_name(c.callback.__name__) for c in app.registered_commands if c.callback}
    if not argv or argv[0] not in own:  # one of texbake's own commands needs no look through the installed packages
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


def run() -> None:
    """The ``texbake`` program: :func:`main`, and then, once every exit handler has run, the
    process ends without tearing down its modules. That teardown (pydantic's, numpy's and
    the rest, freed one object at a time) took 40-50 ms of a 0.5 s bake, after the last file
    was written, synced and closed. An exception out of :func:`main` leaves Python to end
    the process its own way."""
    _ENDED["code"] = main()
    sys.exit(_ENDED["code"])


def _end() -> None:
    """The last exit handler (:func:`run`): end the process now, where :func:`run` returned."""
    ended = _ENDED
    if "code" not in ended:
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:  # None: started with that descriptor closed
                stream.flush()
        except (OSError, ValueError):  # a closed pipe: what was written there is gone either way
            pass
    os._exit(ended["code"])


if __name__ == "__main__":
    run()
