"""The jobs database under a real ``texbake serve`` (SQLite and PostgreSQL): bursts of 200
concurrent uploads answered without a 5xx, each within 10 s, the per-client limit exact;
a database made before migrations, with jobs in it, upgraded by an API and a worker that
start together, losing none."""

import json
import threading
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import pytest
from conftest import free_port, make_old_database, old_jobs, start, stop

BURST = 200
LIMIT = 50
MESH = "soup.stl"  # a small upload: the burst measures the service, not the parsing of a big body


@pytest.fixture(params=["sqlite", "postgresql"])
def database(request, tmp_path):
    """The environment that points the service at a fresh jobs database of each kind."""
    return {} if request.param == "sqlite" else {"BAKE_DATABASE_URL": request.getfixturevalue("postgres_url")}


@pytest.fixture
def api(database, tmp_path):
    """``texbake serve`` with no worker (nothing is baked: every job stays unfinished)."""
    port = free_port()
    proc = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, {**database, "BAKE_JOBS_PER_CLIENT": str(LIMIT)}, port=port)
    yield f"http://127.0.0.1:{port}"
    stop(proc)


def burst(url, mesh: bytes, settings_of) -> list[tuple[int, float, httpx.Response]]:
    """``BURST`` uploads at once (released together), each with ``settings_of(i)``:
    (status, seconds, response) of each."""
    go = threading.Barrier(BURST)

    with httpx.Client(timeout=60, limits=httpx.Limits(max_connections=BURST)) as client:
        def one(i):
            go.wait()
            began = time.monotonic()
            r = client.post(f"{url}/v1/jobs", files={"mesh": (MESH, mesh)}, data={"settings": json.dumps(settings_of(i))})
            return r.status_code, time.monotonic() - began, r

        with ThreadPoolExecutor(BURST) as pool:
            return list(pool.map(one, range(BURST)))


def test_a_burst_of_identical_uploads_makes_one_job_and_answers_every_request(api, meshes):
    """One job, and every request answered in time: a request that held its pooled
    connection until its answer was sent, while the answer waited for a thread that
    requests waiting for the pool held, ran the pool dry (500s, answers after minutes)."""
    answers = burst(api, (meshes / MESH).read_bytes(), lambda i: {"size": 64, "texture": "wood"})
    codes = Counter(code for code, _, _ in answers)
    assert codes == {200: BURST - 1, 202: 1}, (codes, [r.text[:200] for c, _, r in answers if c >= 300][:5])
    assert len({r.json()["id"] for _, _, r in answers}) == 1
    slowest = max(seconds for _, seconds, _ in answers)
    assert slowest < 10, sorted(seconds for _, seconds, _ in answers)[-10:]
    assert httpx.get(f"{api}/v1/jobs", timeout=10).json()["total"] == 1


def test_a_burst_of_distinct_uploads_stops_exactly_at_the_limit(api, meshes):
    """200 distinct uploads of one client with 50 unfinished jobs allowed: counted in the
    transaction that inserts (a count before it lets concurrent uploads through), exactly
    50 are taken, and the other 150 get 429 with Retry-After."""
    answers = burst(api, (meshes / MESH).read_bytes(), lambda i: {"size": 64 + i, "texture": "wood"})
    codes = Counter(code for code, _, _ in answers)
    assert codes == {202: LIMIT, 429: BURST - LIMIT}, (codes, [r.text[:200] for c, _, r in answers if c >= 500][:5])
    refused = [r for code, _, r in answers if code == 429]
    assert all(r.headers.get("Retry-After") == "30" for r in refused), refused[0].headers
    assert {r.json()["detail"] for r in refused} == {f"{LIMIT} unfinished jobs: the limit per client is {LIMIT}"}
    slowest = max(seconds for _, seconds, _ in answers)
    assert slowest < 10, sorted(seconds for _, seconds, _ in answers)[-10:]
    page = httpx.get(f"{api}/v1/jobs", params={"limit": 200}, timeout=10).json()
    assert page["total"] == LIMIT and len({j["settings"]["size"] for j in page["jobs"]}) == LIMIT


def test_an_old_database_is_upgraded_by_an_api_and_a_worker_starting_together(database, tmp_path):
    """A jobs database as the code before migrations made it, with 30 jobs in every state:
    `texbake serve` and `texbake worker` start at once on it (one migrates, the other
    waits for its lock), and every job is there, read over HTTP as it was written."""
    url = database.get("BAKE_DATABASE_URL", f"sqlite:///{tmp_path / 'jobs.db'}")
    jobs = list(old_jobs())
    make_old_database(url, jobs)
    for job in jobs:  # a done job's outputs, where its bake left them (without them it reads failed: outputs lost)
        if job["state"] == "done":
            out = tmp_path / "jobs" / job["id"] / "out"
            out.mkdir(parents=True)
            (out / "albedo.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    port = free_port()
    worker = start(["worker", "--workers", "1"], tmp_path, database)
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, database, port=port)
    try:
        page = httpx.get(f"http://127.0.0.1:{port}/v1/jobs", params={"limit": 200}, timeout=10).json()
        assert page["total"] == len(jobs) and {j["id"] for j in page["jobs"]} == {j["id"] for j in jobs}
        for job in jobs:
            read = httpx.get(f"http://127.0.0.1:{port}/v1/jobs/{job['id']}", timeout=10).json()
            assert (read["mesh"], read["settings"]) == (job["mesh_name"], json.loads(job["settings"])), read
            if job["state"] in ("done", "failed", "cancelled"):  # the worker leaves finished jobs alone
                assert (read["state"], read["error"], read["report"]) == (
                    job["state"], job["error"], json.loads(job["report"]) if job["report"] else None), read
        assert worker.poll() is None and api.poll() is None
    finally:
        stop(api)
        stop(worker)
    logs = "".join(Path(p.log.name).read_text(errors="replace") for p in (api, worker))
    assert "cannot migrate" not in logs and "Traceback" not in logs, logs[-3000:]
    assert logs.count("migrated from no revision to 0001") == 1, logs[-3000:]  # once, by one of the two


def test_db_upgrade_and_current_say_what_they_did(tmp_path):
    import os
    import subprocess
    import sys

    def texbake(*args, **env):
        return subprocess.run([sys.executable, "-m", "texbake.cli", *args], capture_output=True, text=True, timeout=120,
                              env={**os.environ, "BAKE_DATA_DIR": str(tmp_path), **env})

    shown = f"sqlite:///{tmp_path / 'jobs.db'}"
    steps = [texbake("db", "current"), texbake("db", "upgrade"), texbake("db", "upgrade"), texbake("db", "current")]
    assert [(r.returncode, r.stdout) for r in steps] == [
        (0, f"{shown}: at no revision (empty, or made before migrations)\n"), (0, f"{shown}: upgraded from no revision to 0001\n"),
        (0, f"{shown}: at 0001 already\n"), (0, f"{shown}: at 0001\n")], [r.stderr[-2000:] for r in steps]
    # a database out of reach: serve and worker do not start, in one line that hides the password
    url = f"postgresql+psycopg://postgres:secret@127.0.0.1:{free_port()}/none?connect_timeout=2"
    for command in (["serve", "--port", str(free_port()), "--workers", "0"], ["worker"]):
        r = texbake(*command, BAKE_DATABASE_URL=url)
        line = (f"texbake {command[0]}: error: cannot migrate the jobs database {url.replace(':secret@', ':***@')}: "
                f"OperationalError: connection failed: connection to server at \"127.0.0.1\"")
        assert r.returncode == 1 and r.stderr.splitlines()[-1].startswith(line), r.stderr[-2000:]
