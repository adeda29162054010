"""Uploads and outputs through an object store (texbake.service.storage), against moto's real S3
server on 127.0.0.1: the two storages through one interface, then the API and a worker
as separate processes with separate data folders (no shared folder), and a store that is
missing or down (503 with Retry-After, never a 500)."""

import contextlib
import io
import json
import os
import socket
import threading
import time
import zipfile
from pathlib import Path

import httpx
import psutil
import pytest
from conftest import free_port, start, stop, upload, wait

from texbake.output.images import read_image
from texbake.service.storage import LocalStorage, S3Storage, StorageMissing, StorageUnavailable, zip_stream

BUCKET = "texbake"


@pytest.fixture(params=["local", "s3"])
def storage(request, tmp_path, monkeypatch):
    if request.param == "local":
        return LocalStorage(tmp_path)
    s3 = request.getfixturevalue("own_s3")
    s3.client().create_bucket(Bucket=BUCKET)
    for key, value in s3.KEYS.items():
        monkeypatch.setenv(key, value)
    return S3Storage(f"s3://{BUCKET}/run", tmp_path, s3.endpoint)


def test_both_storages_keep_publish_serve_and_sweep_a_job(storage, tmp_path):
    mesh, mtl, image = tmp_path / "upload.obj", tmp_path / "upload.mtl", tmp_path / "upload.png"
    mesh.write_bytes(b"mtllib m.mtl\n" + b"v 0 0 0\n" * 1000)
    mtl.write_bytes(b"newmtl a\nmap_Kd m.png\n")
    image.write_bytes(b"\x89PNG" + bytes(100))
    job = {"mesh": "m.obj", "files": ["m.mtl", "m.png"], "settings": {"size": 8}}
    storage.save_input("a" * 32, {"m.obj": mesh, "m.mtl": mtl, "m.png": image}, job)
    folder = storage.fetch_input("a" * 32, 3)  # what a worker bakes in: the mesh beside the files it refers to
    assert (folder / "m.obj").read_bytes() == b"mtllib m.mtl\n" + b"v 0 0 0\n" * 1000
    assert (folder / "m.mtl").read_bytes() == b"newmtl a\nmap_Kd m.png\n" and (folder / "m.png").read_bytes() == b"\x89PNG" + bytes(100)
    assert json.loads((folder / "job.json").read_text()) == job
    baked = folder / "out.tmp.3"
    baked.mkdir()
    (baked / "albedo.png").write_bytes(b"\x89PNG" + bytes(3 << 20))  # more than one chunk
    (baked / "report.json").write_text("{}")
    storage.publish("a" * 32, 3, baked)
    storage.done_with(folder)
    assert storage.outputs("a" * 32, 3) == {"albedo.png": 4 + (3 << 20), "report.json": 2}
    assert b"".join(storage.read("a" * 32, 3, "albedo.png")) == b"\x89PNG" + bytes(3 << 20)
    members = [(n, s, lambda n=n: storage.read("a" * 32, 3, n)) for n, s in sorted(storage.outputs("a" * 32, 3).items())]
    with zipfile.ZipFile(io.BytesIO(b"".join(zip_stream(members)))) as z:
        assert z.testzip() is None and z.read("report.json") == b"{}"
        assert z.getinfo("albedo.png").compress_type == zipfile.ZIP_STORED and z.getinfo("report.json").compress_type == zipfile.ZIP_DEFLATED
    # left-overs: an orphan's files, and (of a finished job) what it did not publish
    mesh.write_bytes(b"v 0 0 0\n")  # (save_input may have moved it)
    storage.save_input("b" * 32, {"m.obj": mesh}, {"mesh": "m.obj", "settings": {}})
    unpublished = storage.fetch_input("a" * 32, 2) / "out.tmp.2"
    unpublished.mkdir()
    (unpublished / "albedo.png").write_bytes(b"half")
    if isinstance(storage, S3Storage):  # a store's out.2/: a bake that lost its lease after publishing
        storage.publish("a" * 32, 2, unpublished)
    assert storage.sweep({"a" * 32: 3}, older_than=time.time() - 3600) == []  # all recent: kept
    removed = storage.sweep({"a" * 32: 3}, older_than=time.time() + 60)
    assert f"jobs/{'b' * 32}" in removed or f"jobs/{'b' * 32}/m.obj" in removed, removed
    assert storage.outputs("a" * 32, 3) == {"albedo.png": 4 + (3 << 20), "report.json": 2}
    if isinstance(storage, S3Storage):
        assert storage.outputs("a" * 32, 2) == {} and not list((tmp_path / "work").iterdir())
    else:
        assert not (tmp_path / "jobs" / ("a" * 32) / "out.tmp.2").exists()
    storage.delete("a" * 32)
    assert storage.outputs("a" * 32, 3) == {}


def test_a_store_that_is_missing_or_down_raises_typed_errors(own_s3, tmp_path, monkeypatch):
    for key, value in own_s3.KEYS.items():
        monkeypatch.setenv(key, value)
    missing = S3Storage("s3://no-such-bucket/x", tmp_path, own_s3.endpoint)
    (tmp_path / "m.obj").write_bytes(b"v 0 0 0\n")
    with pytest.raises(StorageUnavailable, match="does not exist"):
        missing.save_input("a" * 32, {"m.obj": tmp_path / "m.obj"}, {})
    own_s3.client().create_bucket(Bucket=BUCKET)
    store = S3Storage(f"s3://{BUCKET}/x", tmp_path, own_s3.endpoint)
    with pytest.raises(StorageMissing):
        store.fetch_input("a" * 32, 1)
    own_s3.stop()
    began = time.monotonic()
    with pytest.raises(StorageUnavailable):
        store.check()
    assert time.monotonic() - began < 15  # retried briefly, not for object_store's default 3 minutes


def files_under(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file() and not p.name.endswith(".log"))


def test_api_and_worker_on_separate_machines_share_only_the_store(own_s3, own_redis, postgres_url, tmp_path, meshes):
    """The API and a worker with a data folder each, the jobs table (PostgreSQL), the queue
    (Redis) and an S3 bucket between them, as on two machines without a shared disk."""
    own_s3.client().create_bucket(Bucket=BUCKET)
    env = {**own_s3.env, "BAKE_STORAGE_URL": f"s3://{BUCKET}/bakes", "BAKE_REDIS_URL": own_redis.url, "BAKE_DATABASE_URL": postgres_url}
    api_data, worker_data = tmp_path / "api", tmp_path / "worker"
    api_data.mkdir()
    worker_data.mkdir()
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], api_data, env, port=port)
    worker = start(["worker", "--workers", "1"], worker_data, env)
    url = f"http://127.0.0.1:{port}"
    try:
        r = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 128})
        assert r.status_code == 202, r.text
        job = wait(url, r.json()["id"], timeout=180)
        assert job["state"] == "done", job["error"]
        job_id = job["id"]
        stored = own_s3.keys(BUCKET, f"bakes/jobs/{job_id}/")
        lease = f"bakes/jobs/{job_id}/out.1/"
        assert sorted(stored) == sorted([f"bakes/jobs/{job_id}/bunny.ply", f"bakes/jobs/{job_id}/job.json"] + [lease + n for n in job["files"]])
        assert stored[f"bakes/jobs/{job_id}/bunny.ply"] == (meshes / "bunny.ply").read_bytes()

        # what the API serves is what the worker baked and stored
        png = httpx.get(f"{url}/v1/jobs/{job_id}/files/albedo.png", timeout=30)
        assert png.status_code == 200 and png.headers["content-type"] == "image/png"
        assert png.content == stored[lease + "albedo.png"]
        (tmp_path / "albedo.png").write_bytes(png.content)
        assert read_image(tmp_path / "albedo.png").shape == (128, 128, 3)
        got = httpx.get(f"{url}/v1/jobs/{job_id}/result.zip", timeout=30)
        assert got.status_code == 200 and got.headers["content-type"] == "application/zip"
        with zipfile.ZipFile(io.BytesIO(got.content)) as z:
            assert sorted(z.namelist()) == job["files"] and z.testzip() is None
            assert all(z.read(name) == stored[lease + name] for name in job["files"])
        assert json.loads(stored[lease + "report.json"]) == job["report"]

        # streamed from the store: a 100 MB output goes through the API in constant memory
        # (measured on this machine: /files/ 0.6-1.5 s, result.zip 0.9 s, the API +10 MB)
        own_s3.client().put_object(Bucket=BUCKET, Key=lease + "big.exr", Body=os.urandom(100 << 20))
        rss = psutil.Process(api.pid).memory_info().rss
        for path, least in (("files/big.exr", 100 << 20), ("result.zip", 100 << 20)):
            with httpx.stream("GET", f"{url}/v1/jobs/{job_id}/{path}", timeout=120) as r:
                assert r.status_code == 200 and sum(len(c) for c in r.iter_bytes(1 << 20)) >= least
        assert psutil.Process(api.pid).memory_info().rss - rss < 50e6

        # no shared folder: the outputs never reached the API's data folder, and the worker
        # kept neither the upload nor the outputs once the bake was over
        assert files_under(api_data) == []  # its uploads/ empty: the upload went to the store
        assert not any(name in f for f in files_under(worker_data) for name in ["bunny.ply", *job["files"]]), files_under(worker_data)
        assert not list((worker_data / "work").iterdir())

        # retention cleans the store: the expired job's objects go with its row
        gc = start(["gc"], api_data, {**env, "BAKE_KEEP_HOURS": "0"})
        assert gc.wait(60) == 0
        gc.log.close()
        assert "expired 1 jobs" in Path(gc.log.name).read_text()
        assert own_s3.keys(BUCKET, f"bakes/jobs/{job_id}/") == {}
        assert httpx.get(f"{url}/v1/jobs/{job_id}", timeout=10).status_code == 404

        # a store that is down: 503 with Retry-After (JSON) for what needs it, the API stays up
        second = wait(url, upload(url, meshes / "suzanne.ply", {"size": 64}).json()["id"], timeout=120)
        assert second["state"] == "done", second["error"]
        stop(worker)
        third = upload(url, meshes / "fandisk.obj", {"size": 64}).json()["id"]  # stored, waiting for a worker
        kept = own_s3.keys(BUCKET)
        own_s3.stop()
        for answer in (httpx.get(f"{url}/v1/jobs/{second['id']}/files/albedo.png", timeout=60),
                       httpx.get(f"{url}/v1/jobs/{second['id']}/result.zip", timeout=60),
                       httpx.get(f"{url}/v1/jobs/{second['id']}", timeout=60),
                       upload(url, meshes / "suzanne.ply", {"size": 72})):
            assert answer.status_code == 503 and answer.headers["Retry-After"] == "10", (answer.status_code, answer.text)
            assert answer.json()["detail"].startswith("the object store is unavailable"), answer.text
        ready = httpx.get(f"{url}/readyz", timeout=60)
        assert ready.status_code == 503 and ready.json()["storage"] == "unavailable", ready.text
        assert "the object store is unavailable" in ready.json()["detail"]
        assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200

        # a worker that cannot fetch its job's upload hands it back and tries again: the job
        # is baked once the store is back (moto's, started again, given its objects back)
        worker = start(["worker", "--workers", "1"], worker_data, env)
        end = time.monotonic() + 60
        while "cannot fetch its upload" not in Path(worker.log.name).read_text():
            assert time.monotonic() < end, Path(worker.log.name).read_text()[-3000:]
            time.sleep(0.3)
        job = httpx.get(f"{url}/v1/jobs/{third}", timeout=10).json()
        assert job["state"] in ("queued", "running") and job["attempts"] <= 1, job
        own_s3.start()
        own_s3.client().create_bucket(Bucket=BUCKET)
        for key, data in kept.items():
            own_s3.client().put_object(Bucket=BUCKET, Key=key, Body=data)
        job = wait(url, third, timeout=120)
        assert job["state"] == "done" and job["attempts"] == 1, job  # handed back uncounted
        assert httpx.get(f"{url}/v1/jobs/{third}/files/fandisk.glb", timeout=30).content[:4] == b"glTF"
    finally:
        stop(worker)
        stop(api)


def test_a_missing_bucket_is_a_503_not_a_500(own_s3, tmp_path, meshes):
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, {**own_s3.env, "BAKE_STORAGE_URL": "s3://no-such-bucket/x"}, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        r = upload(url, meshes / "suzanne.ply", {"size": 64})
        assert r.status_code == 503 and r.headers["Retry-After"] == "10" and r.json()["detail"].startswith("the object store is unavailable"), r.text
        assert httpx.get(f"{url}/v1/jobs", timeout=10).json()["total"] == 0  # no job without its upload
        assert not list((tmp_path / "uploads").iterdir())
        assert httpx.get(f"{url}/readyz", timeout=10).json()["storage"] == "unavailable"
    finally:
        stop(api)


class SlowUploads:
    """A TCP proxy on 127.0.0.1 to ``port`` that passes what its clients send at ``rate``
    bytes a second (what they receive at full speed): a slow link to the store."""

    def __init__(self, port: int, rate: float):
        self.target, self.rate = port, rate
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.sockets: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                client, _ = self.server.accept()
            except OSError:  # closed
                return
            upstream = socket.create_connection(("127.0.0.1", self.target))
            self.sockets += [client, upstream]
            threading.Thread(target=self._pipe, args=(client, upstream, self.rate), daemon=True).start()
            threading.Thread(target=self._pipe, args=(upstream, client, None), daemon=True).start()

    @staticmethod
    def _pipe(source, to, rate):
        with contextlib.suppress(OSError):
            while data := source.recv(8192):
                to.sendall(data)
                if rate:
                    time.sleep(len(data) / rate)
        for end in (source, to):
            with contextlib.suppress(OSError):
                end.shutdown(socket.SHUT_RDWR)

    def close(self):
        for sock in [self.server, *self.sockets]:
            sock.close()


def test_a_slow_publish_keeps_its_lease(own_s3, tmp_path, meshes):
    """The outputs take longer to upload than a heartbeat may go stale (5 s here): the
    heartbeat goes on meanwhile, so the reaper leaves the job to its bake (baked once)."""
    own_s3.client().create_bucket(Bucket=BUCKET)
    slow = SlowUploads(own_s3.port, rate=50_000)  # bunny's 0.5 MB of outputs at 256²: about 10 s
    env = {**own_s3.env, "BAKE_STORAGE_URL": f"s3://{BUCKET}/slow"}
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, env, port=port)
    worker = start(["worker", "--workers", "1"], tmp_path, {**env, "BAKE_S3_ENDPOINT": f"http://127.0.0.1:{slow.port}"})
    url = f"http://127.0.0.1:{port}"
    try:
        job_id = upload(url, meshes / "bunny.ply", {"size": 256}).json()["id"]
        wait(url, job_id, states=("running",), timeout=60)
        began = time.monotonic()
        job = wait(url, job_id, timeout=120)
        assert job["state"] == "done" and job["attempts"] == 1, job
        assert time.monotonic() - began > 8  # the upload was slow indeed
        assert "stopped answering" not in Path(api.log.name).read_text() + Path(worker.log.name).read_text()
    finally:
        stop(worker)
        stop(api)
        slow.close()


def test_retry_takes_the_upload_from_the_store(own_s3, tmp_path, meshes):
    """POST /v1/jobs/ID/retry of a cancelled job: a new job whose upload is copied in the store."""
    own_s3.client().create_bucket(Bucket=BUCKET)
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, {**own_s3.env, "BAKE_STORAGE_URL": f"s3://{BUCKET}/retry"}, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        job = upload(url, meshes / "suzanne.ply", {"size": 64}).json()
        assert httpx.delete(f"{url}/v1/jobs/{job['id']}", timeout=10).json()["state"] == "cancelled"
        r = httpx.post(f"{url}/v1/jobs/{job['id']}/retry", timeout=30)
        assert r.status_code == 202 and r.json()["state"] == "queued", r.text
        keys = {o["Key"] for o in own_s3.client().list_objects_v2(Bucket=BUCKET, Prefix=f"retry/jobs/{r.json()['id']}/")["Contents"]}
        assert keys == {f"retry/jobs/{r.json()['id']}/suzanne.ply", f"retry/jobs/{r.json()['id']}/job.json"}, keys
        assert not list((tmp_path / "uploads").iterdir()) and not list((tmp_path / "work").glob("*"))  # no copy left behind
    finally:
        stop(api)


def test_a_gltf_with_its_buffers_bakes_from_the_store(own_s3, tmp_path):
    """A glTF whose geometry is in .bin files beside it: every part is stored in the
    bucket, and a worker that bakes from its own copy (work/) fetches them all."""
    import trimesh

    own_s3.client().create_bucket(Bucket=BUCKET)
    parts = trimesh.exchange.gltf.export_gltf(trimesh.creation.icosphere(subdivisions=3))
    buffers = sorted((name, part) for name, part in parts.items() if name.endswith(".bin"))
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, {**own_s3.env, "BAKE_STORAGE_URL": f"s3://{BUCKET}/parts"}, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        r = httpx.post(f"{url}/v1/jobs", files=[("mesh", ("sphere.gltf", parts["model.gltf"]))] + [("files", b) for b in buffers],
                       data={"settings": json.dumps({"size": 64})}, timeout=60)
        assert r.status_code == 202, r.text
        job = wait(url, r.json()["id"], timeout=120)
        assert job["state"] == "done" and job["report"]["mesh"]["faces"] == 1280, job
        stored = own_s3.keys(BUCKET, f"parts/jobs/{job['id']}/")
        assert {name: stored[f"parts/jobs/{job['id']}/{name}"] for name, _ in buffers} == dict(buffers)
        assert json.loads(stored[f"parts/jobs/{job['id']}/job.json"])["files"] == [name for name, _ in buffers]
        assert not list((tmp_path / "uploads").iterdir()) and not list((tmp_path / "work").glob("*"))  # no copy left behind
    finally:
        stop(api)


def test_a_store_that_lost_its_objects_fails_its_done_jobs_with_the_reason(own_s3, tmp_path, meshes):
    """The S3 server restarted empty: a done job reads failed with the reason, its
    result.zip says why; its upload is gone too, so retry asks for the mesh again, and
    the same upload makes a new job (the lost one let go of its key) that bakes."""
    own_s3.client().create_bucket(Bucket=BUCKET)
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, {**own_s3.env, "BAKE_STORAGE_URL": f"s3://{BUCKET}/lost"}, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        first = wait(url, upload(url, meshes / "suzanne.ply", {"size": 64}).json()["id"], timeout=120)
        assert first["state"] == "done" and first["files"], first
        own_s3.stop()
        own_s3.start()  # on the same port, empty
        own_s3.client().create_bucket(Bucket=BUCKET)
        lost = httpx.get(f"{url}/v1/jobs/{first['id']}", timeout=30).json()
        assert lost["state"] == "failed" and lost["error"].startswith("its outputs are gone from the store") and lost["files"] == [], lost
        r = httpx.get(f"{url}/v1/jobs/{first['id']}/result.zip", timeout=30)
        assert r.status_code == 409 and "its outputs are gone from the store" in r.json()["detail"], r.text
        r = httpx.post(f"{url}/v1/jobs/{first['id']}/retry", timeout=30)
        assert r.status_code == 409 and r.json()["detail"].endswith("its upload is no longer kept; upload the mesh again"), r.text
        again = upload(url, meshes / "suzanne.ply", {"size": 64})
        assert again.status_code == 202 and again.json()["id"] != first["id"], again.text
        assert wait(url, again.json()["id"], timeout=120)["state"] == "done"
        assert httpx.get(f"{url}/v1/jobs/{again.json()['id']}/result.zip", timeout=30).status_code == 200
    finally:
        stop(api)
