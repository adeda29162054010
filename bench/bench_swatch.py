"""Swatch latency: ``GET /v1/swatch`` of a 256² swatch from a real ``texbake serve``, as the
page asks for it while a person drags a slider.

    scripts/run python bench/bench_swatch.py [--requests 20] [--size 256] [--view sphere]

``texbake serve --workers 0`` on a temporary data folder; after one warm-up request per
texture (the kernels loaded), REQUESTS requests per texture of the catalogue, each with
its own spec (the texture moved by a little: ``transform.translate``), so that none is
answered from the cache; then the same spec again (answered from the cache). Times are
the client's, request to last byte, over HTTP on 127.0.0.1. Target: median < 0.3 s.

Then the material editor's refresh after an edit: every channel a built-in material gives,
as 128² swatches (``POST /v1/swatch`` with the material and the channel), asked for at once
as the page does, each edit a material of its own (``height_scale`` moved by a little: no
answer from the cache); the time is the whole set's, the first request sent to the last byte
of the last. The texture swatch's target (0.3 s) is its reference.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import numpy as np
from _rows import emit
from bench_service import free_port

ROOT = Path(__file__).resolve().parents[1]
TARGET = 0.3


def timed(client: httpx.Client, params: dict) -> float:
    t0 = time.perf_counter()
    r = client.get("/v1/swatch", params=params)
    seconds = time.perf_counter() - t0
    if r.status_code != 200 or r.content[:4] != b"\x89PNG":
        raise SystemExit(f"/v1/swatch {params}: {r.status_code} {r.text[:200]}")
    return seconds


def material_refresh(client: httpx.Client, material: dict, pool: ThreadPoolExecutor) -> float:
    """Seconds to get every channel ``material`` gives as a 128² swatch, all asked for at once."""
    channels = [c for c in ("base_color", "roughness", "metallic", "normal", "height", "occlusion", "emissive", "opacity") if c in material]
    t0 = time.perf_counter()
    answers = list(pool.map(lambda c: client.post("/v1/swatch", json={"material": material, "channel": c, "size": 128}), channels))
    seconds = time.perf_counter() - t0
    bad = [r for r in answers if r.status_code != 200]
    if bad:
        raise SystemExit(f"/v1/swatch {material.get('name')}: {bad[0].status_code} {bad[0].text[:200]}")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--requests", type=int, default=20, help="uncached requests per texture")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--view", default="sphere", choices=("sphere", "slice"))
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="texbake-bench-swatch-"))
    port = free_port()
    log = open(work / "serve.log", "wb")
    proc = subprocess.Popen([sys.executable, "-m", "texbake.cli", "serve", "--port", str(port), "--workers", "0"], cwd=ROOT,
                            env={**os.environ, "BAKE_DATA_DIR": str(work / "data")}, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    per_texture: dict[str, list[float]] = {}
    cached: list[float] = []
    refresh: dict[str, list[float]] = {}
    try:
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=60) as client:
            for _ in range(300):
                try:
                    client.get("/healthz", timeout=1)
                    break
                except httpx.HTTPError:
                    time.sleep(0.1)
            names = [t["name"] for t in client.get("/v1/textures").json()["textures"]]
            query = lambda name, i: {"texture": json.dumps({"name": name, "transform": {"translate": [0.001 * i, 0, 0]}}),
                                     "size": args.size, "view": args.view}
            for name in names:  # warm-up: the kernels loaded (or compiled) in the API process
                timed(client, query(name, -1))
            for name in names:
                per_texture[name] = [timed(client, query(name, i)) for i in range(args.requests)]
                cached += [timed(client, query(name, 0)) for _ in range(5)]
            with ThreadPoolExecutor(8) as pool:
                for material in client.get("/v1/materials").json()["materials"]:
                    edits = [{**material, "height_scale": material.get("height_scale", 0.01) * (1 + 0.01 * i)} for i in range(-1, args.requests // 2)]
                    material_refresh(client, edits[0], pool)  # warm-up
                    refresh[material["name"]] = [material_refresh(client, m, pool) for m in edits[1:]]
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(30)
        log.close()
        shutil.rmtree(work, ignore_errors=True)
    every = [t for times in per_texture.values() for t in times]
    median, p90 = statistics.median(every), float(np.percentile(every, 90))
    slowest = max(per_texture, key=lambda n: statistics.median(per_texture[n]))
    rows = [
        (f"swatch {args.size}² ({args.view}), uncached, median over {len(per_texture)} textures x {args.requests} requests",
         f"{1e3 * median:.0f} ms (p90 {1e3 * p90:.0f} ms)", f"target < {1e3 * TARGET:.0f} ms median: {'met' if median < TARGET else 'NOT met'}"),
        (f"swatch {args.size}², slowest texture's median ({slowest})", f"{1e3 * statistics.median(per_texture[slowest]):.0f} ms", f"target < {1e3 * TARGET:.0f} ms"),
        (f"swatch {args.size}², cached (same spec again), median", f"{1e3 * statistics.median(cached):.1f} ms", ""),
    ]
    if refresh:
        sets = [t for times in refresh.values() for t in times]
        heaviest = max(refresh, key=lambda n: statistics.median(refresh[n]))
        rows += [
            (f"material editor's refresh: every channel of a built-in as 128² swatches at once, median over {len(refresh)} "
             f"materials x {len(sets) // len(refresh)} edits", f"{1e3 * statistics.median(sets):.0f} ms (p90 {1e3 * float(np.percentile(sets, 90)):.0f} ms)",
             f"reference: the texture swatch's {1e3 * TARGET:.0f} ms"),
            (f"material editor's refresh, slowest material's median ({heaviest})", f"{1e3 * statistics.median(refresh[heaviest]):.0f} ms", ""),
        ]
    if not args.markdown:
        for name, times in per_texture.items():
            print(f"  {name:<11} median {1e3 * statistics.median(times):6.1f} ms   max {1e3 * max(times):6.1f} ms")
        for name, times in refresh.items():
            print(f"  {name:<22} every channel, median {1e3 * statistics.median(times):6.1f} ms   max {1e3 * max(times):6.1f} ms")
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
