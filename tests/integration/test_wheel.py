"""The built wheel: the package ``texbake`` and its data, nothing else, with ``py.typed``.

Built with ``python -m build --wheel`` from a copy of the working tree as a fresh clone
has it (without what .gitignore leaves out: a ``build/lib`` there would put stale
modules in the wheel). ``scripts/wheel-smoke`` installs a wheel like it and bakes with it.
"""

import shutil
import subprocess
import sys
import zipfile
from importlib import metadata

from conftest import ROOT

# what a fresh clone does not have: at the top, and anywhere (caches of Python)
NOT_AT_THE_TOP = {".git", ".venv", ".venv-blender", "build", "dist", "out", "wheelhouse", ".tools", ".pytest_cache", ".hypothesis",
                  ".mypy_cache", ".ruff_cache", ".schemathesis"}
NOWHERE = ("__pycache__", "node_modules", ".egg-info", ".pyc", ".nbi", ".nbc")


def cloned(folder, names):
    """``shutil.copytree``'s ignore: the names under ``folder`` a fresh clone lacks."""
    top = NOT_AT_THE_TOP if folder == str(ROOT) else set()
    return {n for n in names if n in top or n.endswith(NOWHERE)}


def package_files(folder):
    """Paths of the files under ``folder``/texbake, relative to ``folder``, caches left out."""
    return {p.relative_to(folder).as_posix() for p in (folder / "texbake").rglob("*")
            if p.is_file() and not any(part.endswith(NOWHERE) for part in p.parts)}


def test_the_wheel_holds_texbake_and_its_data_only(tmp_path):
    source = tmp_path / "src"
    shutil.copytree(ROOT, source, ignore=cloned, symlinks=True)
    assert (source / "tests").is_dir() and (source / "bench").is_dir()  # what must stay out is there to leave out
    built = subprocess.run([sys.executable, "-m", "build", "--wheel", "--outdir", str(tmp_path / "dist"), str(source)],
                           capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    (wheel,) = (tmp_path / "dist").glob("texbake-*.whl")
    version = metadata.version("texbake")
    assert wheel.name.startswith(f"texbake-{version}-cp3") and wheel.name.endswith("_x86_64.whl"), wheel.name  # compiled: a platform wheel
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        entry_points = z.read(f"texbake-{version}.dist-info/entry_points.txt").decode()
    assert {n.split("/")[0] for n in names} == {"texbake", f"texbake-{version}.dist-info"}  # no other top-level package
    # every module and data file of the package, and nothing else: no cache, no test
    native = {n for n in names if n.startswith("texbake/_native.") and n.endswith(".so")}
    assert len(native) == 1, names  # the compiled kernels, built from native/
    assert {n for n in names if n.startswith("texbake/")} - native == package_files(ROOT), "the wheel's texbake/ differs from the tree's"
    assert "texbake/py.typed" in names and "texbake/service/static/index.html" in names
    assert "[console_scripts]\ntexbake = texbake.cli:run\n" in entry_points
