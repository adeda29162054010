"""Start-up: what a default bake imports, and what that costs, measured in fresh processes.

A child bakes a small mesh with its own UVs at the default settings (every stage runs:
load, the UV checks, normals, lookup, texture, margin) and records, for each module it
imports, the CPU time of the import less that of the imports inside it (what ``python -X
importtime`` calls "self", there in wall-clock time), and which imports it ran inside.
Those times are added up, leaving out numba and llvmlite with everything imported
beneath them or from their code while it runs (their import and JIT set-up are leaving
the runtime for compiled kernels); each module's smallest time over ``RUNS`` children
counts. CPU time rather than ``-X importtime``'s wall clock: on this 2-core machine
shared with other work the wall clock read 0.95 s for imports of 0.5 CPU-s. Bytecode
is written and read, as an installed package has it (the first child writes it).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

# CPU seconds: the imports of a default bake, numba and llvmlite left out. Issue 25's
# target is 0.25, and the figure moves with the machine more than with the code: 0.22
# (2026-12-03, no load, three runs alike), 0.27-0.29 on the machine before, and on
# 2026-12-06's 0.25-0.27 for the code of 2026-12-03 (dc243c2) and for today's alike, five
# runs each. So the guard is 0.30, what a regression passes: a module such as SciPy,
# trimesh or OpenImageIO imported before it is needed costs 0.1 s or more. Of today's
# 0.25-0.29: texbake 68 ms (texbake.settings' pydantic models 23 ms, the texture specs 10),
# numpy 65, pydantic and pydantic_core 67; the settings' models are the next cut.
BUDGET_S = 0.30
RUNS = 5
LEFT_OUT = ("numba", "llvmlite")  # with all they import
# Never imported by a bake of a mesh file with its own UVs: the GLB's and the images'
# writers, the service, the command line, the unwrap, plots, and Embree (the lookup
# locates texels through its own grid; rays are a transfer's).
NEVER = {"OpenImageIO", "trimesh", "xatlas", "matplotlib", "fastapi", "sqlalchemy", "huey", "typer", "rich", "psutil", "embreex"}
# Imported only by numba (SciPy's LAPACK bindings, its YAML config): once numba has left,
# not at all.
ONLY_WITH_NUMBA = {"scipy", "yaml"}

# The child: importlib's _find_and_load (what every import statement and import_module
# call run for a module not yet loaded) timed; an import made outside any other from
# numba's or llvmlite's code while it runs is put under "numba".
CHILD = """
import importlib._bootstrap as bootstrap, json, sys, time
plain, open_, rows = bootstrap._find_and_load, [], []

def importers():
    if open_:  # inside another import: its importers, then it
        return open_[-1][2] + [open_[-1][0]]
    frame = sys._getframe(2)
    while frame is not None:
        if any(f"/{p}/" in frame.f_code.co_filename for p in ("numba", "llvmlite")):
            return ["numba"]
        frame = frame.f_back
    return []

def timed(name, import_):
    if name in sys.modules:
        return plain(name, import_)
    outer = importers()
    open_.append([name, 0.0, outer])
    start = time.thread_time()
    try:
        return plain(name, import_)
    finally:
        spent = time.thread_time() - start
        inner = open_.pop()[1]
        if open_:
            open_[-1][1] += spent
        rows.append((name, spent - inner, outer))

bootstrap._find_and_load = timed
import texbake
texbake.bake_mesh(sys.argv[1], size=64)
bootstrap._find_and_load = plain
print(json.dumps({"rows": rows, "modules": sorted({name.partition(".")[0] for name in sys.modules})}))
"""


def counted(rows: list) -> dict[str, float]:
    """CPU seconds by module of ``(module, seconds, importers)`` rows not beneath ``LEFT_OUT``."""
    times: dict[str, float] = {}
    for name, seconds, importers in rows:
        if not any(n.partition(".")[0] in LEFT_OUT for n in [name, *importers]):
            times[name] = times.get(name, 0.0) + seconds
    return times


def test_counted_leaves_out_numba_and_what_it_imports():
    rows = [("llvmlite", 0.1, ["texbake", "numba"]), ("numba", 0.5, ["texbake"]), ("texbake.errors", 0.03, ["texbake"]),
            ("texbake", 0.02, []), ("json", 0.007, []), ("numpy.ma", 0.01, ["numba"])]
    assert counted(rows) == {"texbake.errors": 0.03, "texbake": 0.02, "json": 0.007}


def test_a_default_bake_imports_within_the_budget(meshes):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "PYTHONPROFILEIMPORTTIME")}
    best: dict[str, float] = {}
    for _ in range(RUNS):
        done = subprocess.run([sys.executable, "-c", CHILD, str(meshes / "ico4uv.obj")], capture_output=True, text=True,
                              env=env, timeout=300)
        assert done.returncode == 0, done.stderr[-3000:]
        child = json.loads(done.stdout.splitlines()[-1])
        for name, seconds in counted(child["rows"]).items():
            best[name] = min(best.get(name, seconds), seconds)
        imported = set(child["modules"])
        assert not imported & NEVER, f"a bake imported {sorted(imported & NEVER)}"
        if "numba" not in imported:
            assert not imported & ONLY_WITH_NUMBA, f"a bake imported {sorted(imported & ONLY_WITH_NUMBA)}"
    total = sum(best.values())
    heaviest = ", ".join(f"{name} {seconds * 1e3:.0f} ms" for name, seconds in sorted(best.items(), key=lambda kv: -kv[1])[:8])
    assert total <= BUDGET_S, f"a default bake's imports took {total:.3f} CPU-s (budget {BUDGET_S}); heaviest: {heaviest}"
    assert "texbake.pipeline" in best and "numpy" in best  # what a bake imports was seen


@pytest.mark.parametrize("name", sorted(NEVER))
def test_the_list_of_modules_never_imported_names_real_modules(name):
    import importlib.util

    assert importlib.util.find_spec(name) is not None  # a misspelt name would pass the check above unseen
