"""What an operator sees, through real processes: JSON logs (``BAKE_LOG_FORMAT=json``),
and a full disk under the data folder (a small tmpfs) answered with 503, the server up."""

import contextlib
import json
import os
import subprocess
import time
from pathlib import Path

import httpx
import pytest
from conftest import free_port, need, start, stop, upload, wait


def test_json_logs_one_object_a_line(tmp_path, meshes):
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, {"BAKE_LOG_FORMAT": "json"}, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        began = time.perf_counter()
        posted = upload(url, meshes / "suzanne.ply", {"size": 64})
        took = time.perf_counter() - began  # the client's wait: the server's own time is within it
        job = wait(url, posted.json()["id"], timeout=120)
        assert job["state"] == "done", job["error"]
        assert httpx.get(f"{url}/v1/jobs/nope", timeout=10).status_code == 404
    finally:
        stop(api)
    lines = Path(api.log.name).read_text().splitlines()
    logged = [json.loads(line) for line in lines if line.startswith("{")]
    # every line of a logger is JSON, the API's, its worker's, huey's and uvicorn's alike
    # (what is not is a child's own output, such as the first bake's kernel compilation notice)
    assert not [line for line in lines if not line.startswith("{") and any(f" {name}" in line for name in ("texbake.", "huey", "uvicorn"))], lines
    assert all({"time", "level", "logger", "message"} <= set(entry) for entry in logged)
    access = [e for e in logged if e["logger"] == "texbake.access"]
    post = [e for e in access if e["method"] == "POST" and e["path"] == "/v1/jobs"]
    assert len(post) == 1 and post[0]["status"] == 202 and post[0]["client"] == "127.0.0.1", post
    assert 0 < post[0]["seconds"] <= took + 0.001, (post, took)  # logged to the millisecond
    assert any(e["path"] == "/v1/jobs/nope" and e["status"] == 404 for e in access)
    states = [(e["state"], e["detail"]) for e in logged if e["logger"] == "texbake.jobs" and e["job"] == job["id"]]
    assert [state for state, _ in states] == ["queued", "running", "done"], states
    assert states[0][1] == "suzanne.ply, client 127.0.0.1" and states[1][1] == "attempt 1, lease 1"


@pytest.fixture
def small_disk(tmp_path):
    """A 2 MB tmpfs, mounted for the test (needs root, or CAP_SYS_ADMIN) and unmounted after."""
    folder = tmp_path / "disk"
    folder.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(folder)], capture_output=True, text=True)
    if mounted.returncode != 0:
        need(f"mounting a tmpfs needed (as root): {mounted.stderr.strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=True)


def test_a_full_disk_is_a_503_and_the_server_stays_up(tmp_path, small_disk, meshes):
    port = free_port()
    # its log outside the small disk (start() writes it into the folder it is given)
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, {"BAKE_DATA_DIR": str(small_disk)}, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        assert httpx.get(f"{url}/v1/jobs", timeout=10).json()["total"] == 0  # the jobs table exists
        with open(small_disk / "filler", "wb") as f, contextlib.suppress(OSError):
            while True:  # until the disk is full
                f.write(bytes(64 << 10))
                f.flush()
                os.fsync(f.fileno())
        assert os.statvfs(small_disk).f_bavail == 0
        for _ in range(2):
            r = upload(url, meshes / "suzanne.ply", {"size": 64})
            assert r.status_code == 503 and r.headers["Retry-After"] == "10", (r.status_code, r.text)
            assert r.json()["detail"] == "the server's disk (full) is unavailable: try again in 10 s", r.text
        assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200
        ready = httpx.get(f"{url}/readyz", timeout=10)
        assert ready.status_code == 503 and ready.json()["disk_free_mb"] == 0, ready.text
        (small_disk / "filler").unlink()  # room again: uploads are taken again
        assert upload(url, meshes / "suzanne.ply", {"size": 64}).status_code == 202
        assert api.poll() is None
    finally:
        stop(api)
