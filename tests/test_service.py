"""The bake service, through a real uvicorn process with its real worker processes
(SQLite queue and jobs table in a temporary data folder)."""

import io
import json
import os
import signal
import socket
import subprocess
import sys
import time
import zipfile

import httpx
import numpy as np
import pytest

from bake.imageio import read_image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    data = tmp_path_factory.mktemp("data")
    port = free_port()
    env = {**os.environ, "BAKE_DATA_DIR": str(data), "BAKE_MAX_UPLOAD_BYTES": "2000000", "BAKE_HEARTBEAT_SECONDS": "0.5"}
    log = open(data / "server.log", "wb")
    proc = subprocess.Popen(
        [sys.executable, "-m", "bake.cli", "serve", "--port", str(port), "--workers", "2"],
        cwd=ROOT, env=env, start_new_session=True, stdout=log, stderr=subprocess.STDOUT,
    )
    url = f"http://127.0.0.1:{port}"
    for _ in range(100):
        try:
            if httpx.get(f"{url}/healthz", timeout=1).status_code == 200:
                break
        except httpx.HTTPError:
            time.sleep(0.2)
    else:
        os.killpg(proc.pid, signal.SIGKILL)
        log.close()
        pytest.fail(f"server did not start: {(data / 'server.log').read_text()[-2000:]}")
    yield url, data
    os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(20)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    log.close()


def upload(url, path, settings, name=None):
    with open(path, "rb") as f:
        return httpx.post(f"{url}/v1/jobs", files={"mesh": (name or path.name, f)}, data={"settings": json.dumps(settings)}, timeout=30)


def wait(url, job_id, states=("done", "failed", "cancelled"), timeout=120):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        job = httpx.get(f"{url}/v1/jobs/{job_id}", timeout=10).json()
        if job["state"] in states:
            return job
        time.sleep(0.3)
    pytest.fail(f"job {job_id} still {job['state']} after {timeout} s")


def test_upload_bake_download(server, meshes, tmp_path):
    url, _ = server
    r = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 256})
    assert r.status_code == 202, r.text
    job = wait(url, r.json()["id"])
    assert job["state"] == "done", job["error"]
    assert {"albedo.png", "bunny.glb", "report.json", "coverage.png"} <= set(job["files"])
    png = httpx.get(f"{url}/v1/jobs/{job['id']}/files/albedo.png", timeout=30)
    (tmp_path / "a.png").write_bytes(png.content)
    image = read_image(tmp_path / "a.png")
    assert image.shape == (256, 256, 3) and image.max() > 0.3
    glb = httpx.get(f"{url}/v1/jobs/{job['id']}/files/bunny.glb", timeout=30).content
    assert glb[:4] == b"glTF"
    z = zipfile.ZipFile(io.BytesIO(httpx.get(f"{url}/v1/jobs/{job['id']}/result.zip", timeout=30).content))
    assert set(job["files"]) == set(z.namelist())
    assert job["report"]["texels"]["covered"] > 1000
    # the same upload with the same settings is the same job
    again = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 256})
    assert again.status_code == 200 and again.json()["id"] == job["id"]


def test_bad_input_gets_4xx_with_a_reason(server, meshes, tmp_path):
    url, _ = server
    r = upload(url, meshes / "bunny.ply", {"texture": {"name": "marble", "frequncy": 3}})
    assert r.status_code == 422 and "frequncy" in r.json()["detail"]
    r = upload(url, meshes / "bunny.ply", {"size": 100000})
    assert r.status_code == 422 and "size" in r.json()["detail"]
    r = upload(url, meshes / "bunny.ply", {"colour": "red"})
    assert r.status_code == 422 and "colour" in r.json()["detail"]
    (tmp_path / "x.txt").write_text("hello")
    r = upload(url, tmp_path / "x.txt", {})
    assert r.status_code == 422 and "x.txt" in r.json()["detail"]
    big = tmp_path / "big.obj"
    big.write_bytes(b"v 0 0 0\n" * 400_000)  # 3.2 MB, over this server's 2 MB limit
    r = upload(url, big, {})
    assert r.status_code == 413
    assert httpx.get(f"{url}/v1/jobs/nope", timeout=10).status_code == 404
    assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200


def test_broken_mesh_fails_its_job_with_the_reason(server, tmp_path):
    url, _ = server
    bad = tmp_path / "nan.obj"
    bad.write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    r = upload(url, bad, {})
    assert r.status_code == 202
    job = wait(url, r.json()["id"])
    assert job["state"] == "failed" and "non-finite" in job["error"]


def test_cancel_a_running_bake(server, meshes):
    url, _ = server
    r = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 8192, "samples": 16})
    job_id = r.json()["id"]
    wait(url, job_id, states=("running",), timeout=60)
    assert httpx.delete(f"{url}/v1/jobs/{job_id}", timeout=10).json()["state"] == "cancelled"
    time.sleep(2)
    assert httpx.get(f"{url}/v1/jobs/{job_id}", timeout=10).json()["state"] == "cancelled"
    assert httpx.delete(f"{url}/v1/jobs/{job_id}", timeout=10).status_code == 409


def test_catalogue_and_docs(server):
    url, _ = server
    cat = httpx.get(f"{url}/v1/textures", timeout=10).json()
    assert {t["name"] for t in cat["textures"]} >= {"checker", "marble", "wood", "flame"}
    assert httpx.get(f"{url}/openapi.json", timeout=10).status_code == 200
    assert httpx.get(f"{url}/readyz", timeout=10).json()["ok"]


def start(args, data, extra_env=None, port=None):
    env = {**os.environ, "BAKE_DATA_DIR": str(data), "BAKE_HEARTBEAT_SECONDS": "0.5", "BAKE_STALE_SECONDS": "3", **(extra_env or {})}
    log = open(data / f"{args[0]}-{time.monotonic_ns()}.log", "wb")
    proc = subprocess.Popen([sys.executable, "-m", "bake.cli", *args], cwd=ROOT, env=env, start_new_session=True, stdout=log, stderr=subprocess.STDOUT)
    proc.log = log
    if port:
        for _ in range(100):
            try:
                httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1)
                break
            except httpx.HTTPError:
                time.sleep(0.2)
    return proc


def stop(proc, sig=signal.SIGTERM):
    try:
        os.killpg(proc.pid, sig)
        proc.wait(20)
    except (ProcessLookupError, subprocess.TimeoutExpired):
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    proc.log.close()


def test_killed_worker_job_is_requeued_and_done_once(tmp_path, meshes):
    data = tmp_path
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], data, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        # serve's embedded pool is one worker process; find and kill it mid-bake with SIGKILL
        job_id = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 2048, "samples": 16}).json()["id"]
        wait(url, job_id, states=("running",), timeout=60)
        pool = [p for p in psutil_children(api.pid) if "worker" in " ".join(p["cmd"])]
        assert pool, "no worker process"
        os.kill(pool[0]["pid"], signal.SIGKILL)
        time.sleep(0.5)
        replacement = start(["worker", "--workers", "1"], data)  # another worker takes over
        try:
            job = wait(url, job_id, timeout=180)
        finally:
            stop(replacement)
        assert job["state"] == "done" and job["attempts"] == 2, job
    finally:
        stop(api)


def test_restart_loses_no_queued_job(tmp_path, meshes):
    data = tmp_path
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], data, port=port)
    url = f"http://127.0.0.1:{port}"
    ids = [upload(url, meshes / name, {"size": 128}).json()["id"] for name in ("suzanne.ply", "fandisk.obj", "ico4uv.obj")]
    stop(api)  # with jobs still queued (or running)
    api = start(["serve", "--port", str(port), "--workers", "2"], data, port=port)
    try:
        assert [wait(url, i, timeout=120)["state"] for i in ids] == ["done"] * 3
    finally:
        stop(api)


def psutil_children(pid):
    import psutil

    return [{"pid": c.pid, "cmd": c.cmdline()} for c in psutil.Process(pid).children(recursive=True)]


def shared_servers():
    """Redis and PostgreSQL on localhost, or the reason they cannot be used."""
    try:
        import psycopg
        import redis

        redis.Redis(host="127.0.0.1", port=6379, socket_connect_timeout=2).ping()
        with psycopg.connect("host=127.0.0.1 port=5432 user=postgres dbname=postgres", connect_timeout=3, autocommit=True) as conn:
            name = f"texbake_test_{os.getpid()}_{time.monotonic_ns() % 10**6}"
            conn.execute(f'CREATE DATABASE "{name}"')
        return name, None
    except Exception as exc:  # any reason at all: report it
        return None, f"Redis 127.0.0.1:6379 and PostgreSQL 127.0.0.1:5432 needed: {type(exc).__name__}: {exc}"


def test_with_redis_and_postgresql(tmp_path, meshes):
    database, why = shared_servers()
    if why:
        if os.environ.get("TEXBAKE_REQUIRE_SERVICES"):
            pytest.fail(why)
        pytest.skip(why)
    env = {
        "BAKE_REDIS_URL": "redis://127.0.0.1:6379/15",
        "BAKE_DATABASE_URL": f"postgresql+psycopg://postgres@127.0.0.1:5432/{database}",
    }
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, env, port=port)
    extra = start(["worker", "--workers", "1"], tmp_path, env)  # a second machine, as it were
    url = f"http://127.0.0.1:{port}"
    try:
        ids = [upload(url, meshes / name, {"size": 256, "texture": "wood"}).json()["id"] for name in ("bunny.ply", "suzanne.ply")]
        jobs = [wait(url, i, timeout=120) for i in ids]
        assert [j["state"] for j in jobs] == ["done", "done"], jobs
        assert httpx.get(f"{url}/readyz", timeout=10).json()["ok"]
    finally:
        stop(extra)
        stop(api)
        import psycopg

        with psycopg.connect("host=127.0.0.1 port=5432 user=postgres dbname=postgres", autocommit=True) as conn:
            conn.execute(f'DROP DATABASE IF EXISTS "{database}" WITH (FORCE)')
