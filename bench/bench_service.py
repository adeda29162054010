"""Service benchmark: throughput of N small bakes through the service against `texbake batch`,
and enqueue latency under 20 concurrent uploads.

    scripts/run python bench/bench_service.py [--jobs 50] [--size 512] [--uploads 20]

Both sides bake the same N jobs: ``../shared/meshes/bunny.ply`` with marble at SIZE x SIZE,
each with its own marble frequency (so the service cannot answer one from another).

1. ``texbake batch`` with ``--jobs 2`` (one process per core) on a ``.jsonl`` manifest:
   wall time from start to exit.
2. ``texbake serve --workers 2`` on the SQLite defaults in a temporary data folder: the N
   jobs uploaded one after another, wall time from the first upload to the last job done.
   Target: the service reaches at least 80% of batch's throughput.
3. On the same server, UPLOADS concurrent uploads from as many client processes (each its
   own settings): the latency of each ``POST /v1/jobs`` until its 202, p50 and p99
   (workers busy meanwhile).
4. Reuse: then, the workers idle, bunny.ply at 1024² (a size not baked before, so its
   atlas is not in the server's cache) with marble, and again with another marble (its
   frequency changed: a texture of the same cost): each job's time from upload to done.
   Target: the second <= 0.5x the first, its report saying the unwrap was skipped.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import httpx
import numpy as np
from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "bunny.ply"
TEXBAKE = [sys.executable, "-m", "texbake.cli"]


def settings(i: int, size: int) -> dict:
    return {"texture": {"name": "marble", "frequency": 10.0 + 0.01 * i}, "size": size}


def run_batch(jobs: int, size: int, work: Path) -> float:
    manifest = work / "jobs.jsonl"
    manifest.write_text("".join(json.dumps({"mesh": str(MESH), **settings(i, size)}) + "\n" for i in range(jobs)))
    start = time.perf_counter()
    subprocess.run([*TEXBAKE, "batch", str(manifest), "--out", str(work / "batch"), "--jobs", "2"],
                   cwd=ROOT, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def upload(url: str, s: dict) -> tuple[float, str]:
    t0 = time.perf_counter()
    with open(MESH, "rb") as f:
        r = httpx.post(f"{url}/v1/jobs", files={"mesh": (MESH.name, f)}, data={"settings": json.dumps(s)}, timeout=120)
    r.raise_for_status()
    return time.perf_counter() - t0, r.json()["id"]


def wait_all(url: str, ids: list[str]) -> None:
    """Poll the job list (one request every 0.5 s, as a considerate client would) until all are done."""
    pending = set(ids)
    while pending:
        time.sleep(0.5)
        for job in httpx.get(f"{url}/v1/jobs", params={"limit": 200}, timeout=30).json()["jobs"]:
            if job["id"] in pending and job["state"] in ("done", "failed", "cancelled"):
                if job["state"] != "done":
                    raise SystemExit(f"job {job['id']} {job['state']}: {job['error']}")
                pending.discard(job["id"])


def one_job(url: str, s: dict) -> tuple[float, dict]:
    """Upload, then poll the job every 50 ms until done: ``(seconds, job)``."""
    t0 = time.perf_counter()
    _, job_id = upload(url, s)
    while True:
        job = httpx.get(f"{url}/v1/jobs/{job_id}", timeout=30).json()
        if job["state"] in ("done", "failed", "cancelled"):
            if job["state"] != "done":
                raise SystemExit(f"job {job_id} {job['state']}: {job['error']}")
            return time.perf_counter() - t0, job
        time.sleep(0.05)


def run_service(jobs: int, size: int, uploads: int, work: Path) -> tuple[float, list[float], list[tuple[float, dict]]]:
    data = work / "service"
    port = free_port()
    env = {**os.environ, "BAKE_DATA_DIR": str(data), "BAKE_JOBS_PER_CLIENT": str(jobs + uploads)}
    log = open(work / "serve.log", "wb")
    proc = subprocess.Popen([*TEXBAKE, "serve", "--port", str(port), "--workers", "2"], cwd=ROOT, env=env,
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    try:
        for _ in range(300):
            try:
                httpx.get(f"{url}/healthz", timeout=1)
                break
            except httpx.HTTPError:
                time.sleep(0.1)
        start = time.perf_counter()
        ids = [upload(url, settings(i, size))[1] for i in range(jobs)]
        wait_all(url, ids)
        seconds = time.perf_counter() - start
        # one client process per upload (threads in one Python process would measure its GIL)
        with ProcessPoolExecutor(uploads) as pool:
            list(pool.map(time.sleep, [0.5] * uploads))  # every client process started and idle
            sent = list(pool.map(upload, [url] * uploads, [settings(jobs + i, size) for i in range(uploads)]))
        latencies = [t for t, _ in sent]
        wait_all(url, [job_id for _, job_id in sent])
        reuse = [one_job(url, {"texture": {"name": "marble", "frequency": f}, "size": 1024}) for f in (7.0, 9.0)]
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(60)
        log.close()
    return seconds, latencies, reuse


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=50)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--uploads", type=int, default=20)
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="texbake-bench-service-"))
    try:
        batch = run_batch(args.jobs, args.size, work)
        service, latencies, reuse = run_service(args.jobs, args.size, args.uploads, work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    ratio = batch / service
    p50, p99 = np.percentile(latencies, [50, 99])
    rows = [
        (f"service throughput, {args.jobs} bakes of bunny.ply at {args.size}² (serve --workers 2)",
         f"{60 * args.jobs / service:.1f} jobs/min ({ratio:.0%} of batch)",
         f"target >= 80% of `texbake batch --jobs 2` on the same jobs: {60 * args.jobs / batch:.1f} jobs/min"),
        (f"enqueue latency, {args.uploads} concurrent uploads of bunny.ply ({MESH.stat().st_size / 1e6:.1f} MB), workers busy",
         f"p50 {1e3 * p50:.0f} ms, p99 {1e3 * p99:.0f} ms", ""),
        ("second bake of bunny.ply at 1024² with another texture (another marble), upload to done",
         f"{reuse[1][0]:.2f} s = {reuse[1][0] / reuse[0][0]:.2f}x the first ({reuse[0][0]:.2f} s); "
         f"unwrap skipped: {any(s['stage'] == 'unwrap' for s in reuse[1][1]['report']['skipped'])}",
         "target <= 0.5x, the unwrap skipped"),
    ]
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
