"""Where an unwrap's time goes: the stages of ``make_atlas(mode="unwrap")``, mesh by mesh.

    .venv/bin/python bench/bench_unwrap_stages.py [--only NAME[,NAME...]] [--runs N] [--size S]

The meshes are bench_unwrap's (:func:`bench_unwrap.all_meshes`); ``--only`` keeps those
whose name contains one of the comma-separated words. Each is unwrapped ``--runs`` times
in a warm process (the packing workers started by a first unwrap, as in a service's bake
process); printed per mesh, the medians of: the wall time, this process's CPU time, the
workers' CPU time (read from /proc, so Linux only), and the wall time of each stage
(planar charting with its projections and the merge of cut pieces, the packing proxies,
the wait on the workers' packing, the refit of the proxies, the checks and the stats).
Stages nest (``_project`` and ``_merge_cuts`` are inside ``planar_charts``). Times on a
loaded machine vary: read CPU times, and compare versions in one run.
"""

from __future__ import annotations

import argparse
import collections
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_unwrap import all_meshes, building  # noqa: E402
from meshes import cache_dir  # noqa: E402

from texbake.atlas import charts, decide, make_atlas, pack  # noqa: E402
from texbake.workers import Pool, cpu_seconds  # noqa: E402

# (module or class, function, label): the stages timed, in the order they run
STAGES = [
    (pack, "planar_charts", "planar charts"),
    (charts, "_project", "  projections"),
    (charts, "_merge_cuts", "  merge of cut pieces"),
    (pack, "_proxy", "packing proxies"),
    (Pool, "run", "workers (wait)"),
    (pack, "_place", "refit to the packing"),
    (decide, "coverage", "overlap raster"),
    (decide, "_stats", "stats"),
    (decide, "packing_estimate", "promise estimate"),
]


def timed(spent: dict[str, float]) -> None:
    """Wrap each of ``STAGES`` so that its wall time is added to ``spent[label]``."""
    for owner, name, label in STAGES:
        inner = getattr(owner, name)

        def wrapper(*args, _inner=inner, _label=label, **kwargs):
            start = time.perf_counter()
            try:
                return _inner(*args, **kwargs)
            finally:
                spent[_label] += time.perf_counter() - start

        setattr(owner, name, wrapper)


def worker_cpu() -> float:
    warm = pack._warm
    return sum(cpu_seconds(w.pid) or 0.0 for w in warm.all) if warm is not None else 0.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated words: only meshes whose name contains one")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--cache", help="the folder of bench/meshes.py's meshes")
    args = ap.parse_args()
    words = args.only.split(",") if args.only else [""]
    meshes = {k: v for k, v in all_meshes(None, cache_dir(args.cache), 150_000).items() if any(w in k for w in words)}
    spent: dict[str, float] = collections.defaultdict(float)
    timed(spent)
    make_atlas(*building(), mode="unwrap", size=args.size, workers=2)  # warm workers
    for name, (v, f) in meshes.items():
        rows: dict[str, list[float]] = collections.defaultdict(list)
        for _ in range(args.runs):
            spent.clear()
            wall, cpu, workers = time.perf_counter(), time.process_time(), worker_cpu()
            atlas = make_atlas(v, f, mode="unwrap", size=args.size, workers=2)
            rows["wall"].append(time.perf_counter() - wall)
            rows["CPU, this process"].append(time.process_time() - cpu)
            rows["CPU, workers"].append(worker_cpu() - workers)
            for _, _, label in STAGES:
                rows[label].append(spent.get(label, 0.0))
        print(f"{name} ({len(f)} faces, {atlas.method}, {atlas.stats['charts']} charts, "
              f"utilisation {atlas.stats['utilisation']:.4f}), median of {args.runs}:")
        for label, values in rows.items():
            print(f"  {label:<24} {statistics.median(values):.3f} s")


if __name__ == "__main__":
    main()
