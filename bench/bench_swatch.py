"""Swatch latency: ``GET /v1/swatch`` of a 256² swatch from a real ``texbake serve``, as the
page asks for it while a person drags a slider.

    scripts/run python bench/bench_swatch.py [--requests 20] [--size 256] [--view sphere]

``texbake serve --workers 0`` on a temporary data folder; after one warm-up request per
texture (the kernels loaded), REQUESTS requests per texture of the catalogue, each with
its own spec (the texture moved by a little: ``transform.translate``), so that none is
answered from the cache; then the same spec again (answered from the cache). Times are
the client's, request to last byte, over HTTP on 127.0.0.1. Target: median < 0.3 s.
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
    if not args.markdown:
        for name, times in per_texture.items():
            print(f"  {name:<11} median {1e3 * statistics.median(times):6.1f} ms   max {1e3 * max(times):6.1f} ms")
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
