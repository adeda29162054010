"""What `pip install texbake` puts on disk, and the first bake after it, in fresh venvs.

Run: scripts/run python bench/bench_install.py [--wheel WHEEL] [--runs 3]

Builds the wheel (``pip wheel . --no-deps``; or takes ``--wheel``), installs it with its
runtime dependencies into an empty venv outside the tree (pinned by constraints.txt) and
measures the venv's size on disk. Then installs what the runtime held before issue 25
(numba and llvmlite, the JIT it replaced with compiled kernels; SciPy and psutil, which no
bake imports) into a second venv made alike, and measures that: the target is a runtime
smaller by at least the size of numba and llvmlite. In the first venv it then bakes
``../shared/meshes/suzanne_blender_uv.obj`` (marble, 1024²) ``--runs`` times, each a
fresh process, and compares the first bake after the install with the later ones (target:
within 10 %: nothing is compiled on first use).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"
BEFORE = ["numba", "llvmlite", "scipy", "psutil"]  # in the runtime before issue 25
JIT = ["numba", "llvmlite"]


def size_mb(path: Path) -> float:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file() and not f.is_symlink()) / 1e6


def venv(where: Path, *packages: str) -> Path:
    subprocess.run([sys.executable, "-m", "venv", str(where)], check=True)
    pip = [str(where / "bin" / "python"), "-m", "pip", "install", "-q", "--disable-pip-version-check", "-c",
           str(ROOT / "constraints.txt")]
    subprocess.run([*pip, *packages], check=True, stderr=subprocess.DEVNULL)
    return where


def site(where: Path) -> Path:
    return next((where / "lib").glob("python*/site-packages"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wheel", type=Path)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        wheel = args.wheel
        if wheel is None:
            subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", tmp, str(ROOT)], check=True,
                           stderr=subprocess.DEVNULL)
            wheel = next(Path(tmp).glob("texbake-*.whl"))
        now = venv(Path(tmp) / "now", str(wheel))
        before = venv(Path(tmp) / "before", str(wheel), *BEFORE)
        jit = sum(size_mb(p) for name in JIT for p in site(before).glob(f"{name}*"))
        s_now, s_before = size_mb(site(now)), size_mb(site(before))
        times = []
        for run in range(max(2, args.runs)):
            start = time.perf_counter()
            subprocess.run([str(now / "bin" / "texbake"), "bake", str(MESH), "--texture", "marble", "--size", "1024", "--out",
                            f"{tmp}/out{run}"], check=True, capture_output=True)
            times.append(time.perf_counter() - start)
    later = statistics.median(times[1:])
    rows = [("installed runtime (`pip install texbake`, an empty venv's site-packages)",
             f"{s_now:.0f} MB; {s_before - s_now:.0f} MB smaller",
             f"with numba, llvmlite, SciPy and psutil as before issue 25: {s_before:.0f} MB; target: smaller by at least "
             f"numba + llvmlite, {jit:.0f} MB"),
            ("first bake after the install (marble 1024², suzanne_blender_uv.obj, whole process)",
             f"{times[0]:.2f} s = {times[0] / later:.2f}x the later ones", f"later: median {later:.2f} s (target <= 1.10x)")]
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
