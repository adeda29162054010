"""The public meshes of the unwrap benchmark, gathered into a cache folder outside the repo.

    .venv/bin/python bench/meshes.py [--cache DIR]

Copies into ``DIR`` (default ``$TEXBAKE_BENCH_MESHES``, else ``~/.cache/texbake-bench/meshes``)
the meshes named in ``SOURCES`` from git repositories that are already on this machine:
``--repo owner/name=GIT_DIR`` (a bare clone, e.g. ``git clone --bare --filter=blob:none
https://github.com/mikedh/trimesh``, or a mirror; by default the mirrors under
``/work/.mirror``), read with ``git show HEAD:path``, so nothing is downloaded here. The
shared meshes (``../shared/meshes``) and the generated CAD parts
(:mod:`texbake.checks.cad`) are not copied: :func:`gathered` lists the cache's files and
the benchmark adds the others. Files already in the cache are left as they are.
"""

from __future__ import annotations

import argparse
import os
import subprocess
from pathlib import Path

# (repository, path in it): CAD parts, scans, game and test assets, double-sided and boxy ones
SOURCES = {
    "mikedh/trimesh": [
        "models/chair_model.obj", "models/counter.unitsmm.STL", "models/1002_tray_bottom.STL",
        "models/ADIS16480.STL", "models/angle_block.STL", "models/cycloidal.ply", "models/fixed_top.ply",
        "models/octagonal_pocket.stl", "models/plate_holes.STL", "models/idler_riser.STL", "models/round.stl",
        "models/torus.STL", "models/teapot.stl", "models/quadknot.obj", "models/rabbit.obj", "models/fuze.ply",
        "models/ballA.off", "models/CesiumMilkTruck.glb", "models/boolean.glb", "models/tube.obj",
        "models/20mm-xyz-cube.stl", "models/multibody.stl",
    ],
    "alecjacobson/common-3d-test-models": [
        "data/alligator.obj", "data/beetle.obj", "data/cheburashka.obj", "data/cow.obj", "data/homer.obj",
        "data/rocker-arm.obj", "data/spot.obj", "data/teapot.obj", "data/woody.obj", "data/beetle-alt.obj",
        "data/ogre.obj",
    ],
}
MIRRORS = Path("/work/.mirror")


def cache_dir(given: str | None = None) -> Path:
    """The cache folder: ``given``, else ``$TEXBAKE_BENCH_MESHES``, else ``~/.cache/texbake-bench/meshes``."""
    return Path(given or os.environ.get("TEXBAKE_BENCH_MESHES") or Path.home() / ".cache" / "texbake-bench" / "meshes")


def gather(cache: Path, repos: dict[str, Path]) -> list[Path]:
    """Copy ``SOURCES`` into ``cache`` from the git directories ``repos`` (owner/name ->
    git dir) as ``<name>__<file>``; the files there afterwards."""
    cache.mkdir(parents=True, exist_ok=True)
    for repo, paths in SOURCES.items():
        git = repos.get(repo)
        if git is None or not git.exists():
            print(f"meshes: {repo} is not on this machine (give --repo {repo}=GIT_DIR); its meshes are left out")
            continue
        for path in paths:
            target = cache / f"{repo.split('/')[1]}__{Path(path).name}"
            if target.exists():
                continue
            data = subprocess.run(["git", f"--git-dir={git}", "show", f"HEAD:{path}"], capture_output=True, check=False)
            if data.returncode or data.stdout.startswith(b"version https://git-lfs"):
                print(f"meshes: {repo}:{path} could not be read; left out")
                continue
            target.write_bytes(data.stdout)
    return gathered(cache)


def gathered(cache: Path) -> list[Path]:
    """The mesh files in ``cache``, sorted."""
    return sorted(p for p in cache.glob("*__*") if p.is_file()) if cache.is_dir() else []


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", help="the cache folder")
    ap.add_argument("--repo", action="append", default=[], help="owner/name=GIT_DIR")
    args = ap.parse_args()
    repos = {r: MIRRORS / r.replace("/", "+") / "repo" for r in SOURCES}
    repos.update({k: Path(v) for k, v in (r.split("=", 1) for r in args.repo)})
    files = gather(cache_dir(args.cache), repos)
    print(f"{len(files)} meshes in {cache_dir(args.cache)}")


if __name__ == "__main__":
    main()
