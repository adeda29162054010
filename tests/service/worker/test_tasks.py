"""The jobs table is the truth and the queue is recovered from it (texbake.service.worker.tasks): faults
injected for real, with Redis and PostgreSQL servers the tests start, stop and flush."""

import re
import sqlite3
import threading
import time

import httpx
from conftest import free_port, start, stop, upload, wait

FAST = {"BAKE_REQUEUE_SECONDS": "2"}  # a queued job missing from the queue is enqueued again after 2 s


def done_lines(*procs):
    """job id -> how many times a log said it was done."""
    counts: dict[str, int] = {}
    for proc in procs:
        with open(proc.log.name, errors="replace") as log:
            for job_id in re.findall(r"texbake\.jobs INFO job ([0-9a-f]{32}) done", log.read()):
                counts[job_id] = counts.get(job_id, 0) + 1
    return counts


def test_a_failed_queue_write_and_a_flushed_redis_lose_no_job(tmp_path, meshes, own_redis):
    """Redis down when the row is committed (the POST answered 500, the job stayed queued
    forever), Redis back empty, then flushed with jobs queued: every job done, once."""
    env = {"BAKE_REDIS_URL": own_redis.url, **FAST}
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, env, port=port)
    url = f"http://127.0.0.1:{port}"
    worker = None
    try:
        own_redis.stop()
        first = upload(url, meshes / "suzanne.ply", {"size": 64})
        assert first.status_code == 202 and first.json()["state"] == "queued", first.text  # the table has it
        own_redis.start()  # empty, as a Redis restarted without its dump
        later = [upload(url, meshes / name, {"size": 64}) for name in ("bunny.ply", "fandisk.obj")]
        assert [r.status_code for r in later] == [202, 202]
        own_redis.flush()  # the queue loses them
        worker = start(["worker", "--workers", "2"], tmp_path, env)
        ids = [r.json()["id"] for r in [first, *later]]
        jobs = [wait(url, i, timeout=120) for i in ids]
        assert [(j["state"], j["attempts"]) for j in jobs] == [("done", 1)] * 3, jobs
        time.sleep(3)  # another reaper pass: nothing is baked again
        assert done_lines(api, worker) == dict.fromkeys(ids, 1)
    finally:
        if worker:
            stop(worker)
        stop(api)


def test_a_locked_sqlite_queue_loses_no_job(tmp_path, meshes):
    """Another process holds queue.db's write lock for 8 s (huey gives up after 5 s): the
    upload is still accepted, and baked once the lock is gone."""
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, FAST, port=port)
    url = f"http://127.0.0.1:{port}"
    worker = None
    try:
        lock = sqlite3.connect(tmp_path / "queue.db", isolation_level=None, check_same_thread=False)
        lock.execute("BEGIN EXCLUSIVE")
        release = threading.Timer(8, lambda: (lock.rollback(), lock.close()))
        release.start()
        r = upload(url, meshes / "suzanne.ply", {"size": 64})
        assert r.status_code == 202 and r.json()["state"] == "queued", r.text
        release.join()
        worker = start(["worker", "--workers", "1"], tmp_path, FAST)
        job = wait(url, r.json()["id"], timeout=120)
        assert job["state"] == "done" and job["attempts"] == 1, job
        with open(api.log.name) as log:
            text = log.read()
        assert "the queue write failed" in text
        assert re.search(r"texbake\.access INFO 127\.0\.0\.1 POST /v1/jobs 202 [0-9.]+", text)  # the access log
    finally:
        if worker:
            stop(worker)
        stop(api)


def test_postgresql_down_40_s_mid_load_every_job_done_once(tmp_path, meshes, own_postgres, own_redis):
    """Workers dequeued jobs they could not claim, and huey dropped them. Now a claim that
    cannot reach the table is tried again, a running bake keeps baking through the outage,
    its lease fences its publishing, and the API answers 503 meanwhile."""
    env = {"BAKE_REDIS_URL": own_redis.url, "BAKE_DATABASE_URL": own_postgres.url, **FAST}
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "2"], tmp_path, env, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        names = ("bunny.ply", "suzanne.ply", "fandisk.obj", "ico4uv.obj")
        ids = [upload(url, meshes / name, {"size": size, "texture": "marble"}).json()["id"] for size in (512, 320) for name in names]
        wait(url, ids[0], states=("running",), timeout=60)
        own_postgres.stop()
        began = time.monotonic()
        r = upload(url, meshes / "suzanne.ply", {"size": 96})
        assert r.status_code == 503 and r.headers["Retry-After"] and "database is unavailable" in r.json()["detail"], r.text
        assert httpx.get(f"{url}/v1/jobs/{ids[0]}", timeout=10).status_code == 503
        assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200
        time.sleep(max(0.0, 40 - (time.monotonic() - began)))
        own_postgres.start()
        jobs = [wait(url, i, timeout=300) for i in ids]
        assert [j["state"] for j in jobs] == ["done"] * len(ids), [(j["state"], j["error"]) for j in jobs]
        assert done_lines(api) == dict.fromkeys(ids, 1)
        # no bake's folder left behind: a bake that lost its lease in the outage may still be
        # waiting (backing off up to 5 s) to learn so, and then removes its own
        deadline = time.monotonic() + 30
        while list(tmp_path.glob("jobs/*/out.tmp.*")) and time.monotonic() < deadline:
            time.sleep(0.5)
        assert not list(tmp_path.glob("jobs/*/out.tmp.*"))
    finally:
        stop(api)


def test_outputs_are_checked_in_the_store_before_the_job_reads_done(tmp_path):
    """What the bake wrote must be in the store, each file at its size, after publishing;
    a store that drops one (here: loses it right away) fails the job, naming it."""
    from texbake.service.storage import LocalStorage
    from texbake.service.worker.tasks import _publish

    class Losing(LocalStorage):
        def publish(self, job_id, lease, outputs):
            super().publish(job_id, lease, outputs)
            (self.jobs / job_id / "out" / "albedo.png").unlink()

    for storage, reason in [(LocalStorage(tmp_path), None),
                            (Losing(tmp_path), "its outputs could not be stored: the store does not hold albedo.png as written")]:
        baked = tmp_path / "jobs" / "a" / "out.tmp.1"
        baked.mkdir(parents=True)
        (baked / "albedo.png").write_bytes(b"\x89PNG")
        (baked / "report.json").write_text("{}")
        assert _publish(storage, "a", 1, baked) == reason
        assert set(storage.outputs("a", 1)) == ({"albedo.png", "report.json"} if reason is None else {"report.json"})
