"""``texbake serve``'s embedded worker (texbake.service.worker.supervise), as real processes: killed
with SIGKILL it is restarted and its bakes end with it; SIGTERM to serve leaves nothing."""

import os
import signal
import time

import httpx
import psutil
from conftest import free_port, start, stop, upload, wait


def session_processes(sid):
    """The processes of the session ``start`` gave serve (it leads it): pid -> (ppid, command)."""
    found = {}
    for p in psutil.process_iter(["pid", "ppid", "cmdline"]):
        try:
            if os.getsid(p.pid) == sid and p.status() != psutil.STATUS_ZOMBIE:
                found[p.pid] = (p.info["ppid"], " ".join(p.info["cmdline"] or []))
        except (ProcessLookupError, psutil.NoSuchProcess):
            pass
    return found


def until(condition, timeout, what):
    end = time.monotonic() + timeout
    while not (value := condition()):
        assert time.monotonic() < end, what()
        time.sleep(0.2)
    return value


def serve_a_long_bake(tmp_path, meshes):
    """``(serve's process, its URL, port, a job id)``: ``texbake serve`` with one worker,
    baking a marble of several seconds."""
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        job_id = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 2048, "samples": 4}).json()["id"]
        wait(url, job_id, states=("running",), timeout=60)
    except BaseException:
        stop(api)
        raise
    return api, url, port, job_id


def test_a_killed_worker_is_restarted_and_its_bakes_end_with_it(tmp_path, meshes):
    api, url, _, job_id = serve_a_long_bake(tmp_path, meshes)
    try:
        [worker] = [p for p in psutil.Process(api.pid).children() if "worker" in " ".join(p.cmdline())]
        bakes = {p.pid for p in worker.children(recursive=True)}
        assert bakes, "no bake process"
        os.kill(worker.pid, signal.SIGKILL)
        # no process of serve's is left to PID 1, and the dead worker's bake processes end
        until(lambda: not bakes & set(session_processes(api.pid)), 10,
              lambda: f"bake processes left: {session_processes(api.pid)}")
        assert all(ppid != 1 for ppid, _ in session_processes(api.pid).values()), session_processes(api.pid)
        job = wait(url, job_id, timeout=180)  # the reaper re-queues it; the new worker bakes it
        assert job["state"] == "done" and job["attempts"] == 2, job
        with open(api.log.name) as log:
            assert "restarting it in 1 s" in log.read()
        again = upload(url, meshes / "suzanne.ply", {"size": 64}).json()["id"]
        assert wait(url, again, timeout=60)["state"] == "done"
    finally:
        stop(api)


def test_sigterm_to_serve_alone_leaves_no_process(tmp_path, meshes):
    """uvicorn raised SIGTERM again after its shutdown, which ended serve before it stopped
    its worker: the pool kept running, and a restart made two."""
    api, url, port, job_id = serve_a_long_bake(tmp_path, meshes)
    try:
        assert len(session_processes(api.pid)) >= 3  # serve, its worker, a bake process
        api.send_signal(signal.SIGTERM)  # serve alone, not its group
        assert api.wait(30) == 0
        until(lambda: not session_processes(api.pid), 10, lambda: f"left: {session_processes(api.pid)}")
        api.log.close()
        api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, port=port)
        job = wait(url, job_id, timeout=180)
        assert job["state"] == "done" and job["attempts"] == 1, job  # handed back uncounted
        assert httpx.get(f"{url}/healthz", timeout=5).status_code == 200
    finally:
        stop(api)


def test_kill_9_of_serve_leaves_no_process_and_a_restart_counts_one_worker(tmp_path, meshes):
    """The worker was re-parented to PID 1 and went on baking from the queue (its bake
    processes with it): a restarted serve then counted two workers."""
    api, url, port, job_id = serve_a_long_bake(tmp_path, meshes)
    try:
        tree = session_processes(api.pid)
        assert len(tree) >= 3, tree  # serve, its worker, a bake process
        os.kill(api.pid, signal.SIGKILL)
        api.wait()
        until(lambda: not session_processes(api.pid), 5, lambda: f"left after kill -9 of serve: {session_processes(api.pid)}")
        api.log.close()
        api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, port=port)
        job = wait(url, job_id, timeout=180)  # the reaper re-queues it: baked by the new worker alone
        assert job["state"] == "done" and job["attempts"] == 2, job
        ready = httpx.get(f"{url}/readyz", timeout=10).json()
        assert (ready["workers"], ready["slots"]) == (1, 1), ready
    finally:
        stop(api)


def test_the_worker_gets_the_settings_of_serve_with_absolute_paths(tmp_path, monkeypatch):
    """serve starts its worker in the data folder: a relative path, or a setting read from
    a ``.env`` beside serve, must mean the same there."""
    from texbake.service.core.config import Settings
    from texbake.service.worker.supervise import worker_environment

    monkeypatch.chdir(tmp_path)
    (tmp_path / ".env").write_text("BAKE_JOB_SECONDS=123\n")
    monkeypatch.delenv("BAKE_JOB_SECONDS", raising=False)
    monkeypatch.setenv("BAKE_DATA_DIR", "data")
    monkeypatch.setenv("BAKE_DATABASE_URL", "sqlite:///jobs/x.db")
    monkeypatch.setenv("BAKE_API_KEYS", '["k1", "k2"]')
    here = Settings()
    env = worker_environment(here)
    assert env["BAKE_DATA_DIR"] == str(tmp_path / "data") and env["BAKE_DATABASE_URL"] == f"sqlite:///{tmp_path}/jobs/x.db"
    assert env["BAKE_JOB_SECONDS"] == "123.0" and "BAKE_REDIS_URL" not in env
    monkeypatch.chdir(tmp_path.parent)  # elsewhere, from that environment alone
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    there = Settings()
    assert there.job_seconds == 123 and there.api_keys == ["k1", "k2"]
    assert there.model_dump() == {**here.model_dump(), "data_dir": tmp_path / "data", "database_url": f"sqlite:///{tmp_path}/jobs/x.db"}
