"""The bake service, through a real uvicorn process with its real worker processes
(SQLite queue and jobs table in a temporary data folder)."""

import bz2
import io
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import zipfile

import httpx
import numpy as np
import pytest
from conftest import free_port, glb_with_accessor, glb_with_image_uri, need, start, stop, upload, wait

import texbake
from texbake.output.images import read_image


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    data = tmp_path_factory.mktemp("data")
    port = free_port()
    proc = start(["serve", "--port", str(port), "--workers", "2"], data, {"BAKE_MAX_UPLOAD_BYTES": "2000000"}, port=port)
    yield f"http://127.0.0.1:{port}", data, proc.pid
    stop(proc)


def test_upload_bake_download(server, meshes, tmp_path):
    url, *_ = server
    r = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 256})
    assert r.status_code == 202, r.text
    job = wait(url, r.json()["id"])
    assert job["state"] == "done", job["error"]
    assert {"albedo.png", "bunny.glb", "report.json", "coverage.png"} <= set(job["files"])
    png = httpx.get(f"{url}/v1/jobs/{job['id']}/files/albedo.png", timeout=30)
    (tmp_path / "a.png").write_bytes(png.content)
    assert read_image(tmp_path / "a.png").shape == (256, 256, 3)
    # the bake is the library's: the same settings give the same bytes in this process
    texbake.bake_mesh(meshes / "bunny.ply", "marble", size=256).save(tmp_path / "here")
    assert png.content == (tmp_path / "here" / "albedo.png").read_bytes()
    glb = httpx.get(f"{url}/v1/jobs/{job['id']}/files/bunny.glb", timeout=30).content
    assert glb[:4] == b"glTF"
    z = zipfile.ZipFile(io.BytesIO(httpx.get(f"{url}/v1/jobs/{job['id']}/result.zip", timeout=30).content))
    assert set(job["files"]) == set(z.namelist())
    assert job["report"]["texels"]["covered"] > 1000
    # the same upload with the same settings is the same job
    again = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 256})
    assert again.status_code == 200 and again.json()["id"] == job["id"]
    # the same mesh with another texture is another job, on the atlas the first one made
    wood = wait(url, upload(url, meshes / "bunny.ply", {"texture": "wood", "size": 256}).json()["id"])
    assert wood["state"] == "done" and wood["id"] != job["id"], wood["error"]
    assert job["report"]["atlas"]["cached"] is False and wood["report"]["atlas"]["cached"] is True
    assert any(s["stage"] == "unwrap" and "cache" in s["why"] for s in wood["report"]["skipped"])


def test_a_normal_map_and_a_flame_sequence_over_http(server, meshes):
    url, *_ = server
    settings = {"texture": "flame", "frames": [0, 0.5], "bump": "noise", "shading": "full", "light": [0, 1, 0], "size": 64}
    r = upload(url, meshes / "suzanne.ply", settings)
    assert r.status_code == 202, r.text
    job = wait(url, r.json()["id"])
    assert job["state"] == "done", job["error"]
    assert {"albedo_0000.png", "albedo_0001.png", "flipbook.png", "lit.png", "normal.png", "suzanne.glb"} <= set(job["files"])
    assert job["report"]["settings"] == job["settings"]  # the worker baked what the job holds
    assert job["settings"]["frames"] == [0, 0.5] and job["settings"]["light"] == [0, 1, 0]
    assert job["warnings"] == []
    duck = wait(url, upload(url, meshes / "Duck.glb", {"uv": "keep", "size": 64}).json()["id"])
    assert duck["state"] == "done" and len(duck["warnings"]) == 1 and "overlap" in duck["warnings"][0], duck


def test_a_scene_with_uvs_on_some_parts_keeps_them_and_the_job_says_so(server, tmp_path):
    from conftest import mixed_uv_scene

    url, *_ = server
    mixed_uv_scene(tmp_path / "scene.glb", 0.5)
    job = wait(url, upload(url, tmp_path / "scene.glb", {"uv": "keep", "size": 64, "texture_set": "single"}).json()["id"])
    assert job["state"] == "done", job["error"]
    assert job["report"]["atlas"]["method"].startswith("kept+") and job["report"]["atlas"]["kept_scale"] == 1.0
    assert job["warnings"] == job["report"]["warnings"]
    assert job["warnings"][0].startswith("unwrapped: part 'ball' (320 faces) has no UVs"), job["warnings"]


def test_bad_input_gets_4xx_with_a_reason(server, meshes, tmp_path):
    url, *_ = server
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
    big.write_bytes(b"v 0 0 0\n" * 300_000)  # 2.4 MB, over this server's 2 MB limit
    r = upload(url, big, {})
    assert r.status_code == 413 and "2000000 bytes" in r.json()["detail"]
    big.write_bytes(b"v 0 0 0\n" * 1_000_000)  # 8 MB: refused by its Content-Length before it is read
    r = upload(url, big, {})
    assert r.status_code == 413 and r.json()["detail"].startswith("request body: larger than the limit of "), r.text
    assert httpx.get(f"{url}/v1/jobs/nope", timeout=10).status_code == 404
    assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200


def test_broken_mesh_fails_its_job_with_the_reason(server, tmp_path):
    url, *_ = server
    bad = tmp_path / "nan.obj"
    bad.write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    r = upload(url, bad, {})
    assert r.status_code == 202
    job = wait(url, r.json()["id"])
    assert job["state"] == "failed" and "non-finite" in job["error"]


def test_cancel_a_running_bake(server, meshes):
    url, *_ = server
    r = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 8192, "samples": 16})
    job_id = r.json()["id"]
    wait(url, job_id, states=("running",), timeout=60)
    end = time.monotonic() + 60
    while (progress := httpx.get(f"{url}/v1/jobs/{job_id}", timeout=10).json()["progress"]) < 0.3 and time.monotonic() < end:
        time.sleep(0.3)  # the atlas is made: tiles are being baked
    assert 0.3 <= progress < 0.95, progress
    assert httpx.delete(f"{url}/v1/jobs/{job_id}", timeout=10).json()["state"] == "cancelled"
    time.sleep(2)
    assert httpx.get(f"{url}/v1/jobs/{job_id}", timeout=10).json()["state"] == "cancelled"
    assert httpx.delete(f"{url}/v1/jobs/{job_id}", timeout=10).status_code == 409


def zip_bomb() -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("mesh.obj", bytes(200_000_000))  # 200 MB of zeros in about 200 kB
    return buf.getvalue()


@pytest.mark.parametrize("name, data, reason", [
    ("lying.stl", bytes(80) + (2**32 - 1).to_bytes(4, "little") + bytes(150), "header says 4,294,967,295 triangles"),
    ("huge.glb", glb_with_accessor(1_900_000_000), "(22,800,000,000 bytes)"),
    ("escape.glb", glb_with_image_uri("../../../etc/passwd"), "leaves"),
    ("bomb.obj", zip_bomb(), "zip archive"),
    ("bomb.ply", bz2.compress(bytes(200_000_000)), "bzip2 archive"),
    ("bomb.zip", zip_bomb(), "not a mesh file this server takes"),
    ("empty.off", b"", "empty"),
])
def test_hostile_uploads_get_422_with_the_reason(server, tmp_path, name, data, reason):
    url, data_dir, _ = server
    (tmp_path / name).write_bytes(data)
    r = upload(url, tmp_path / name, {})
    assert r.status_code == 422 and reason in r.json()["detail"] and name in r.json()["detail"], r.text
    assert not list((data_dir / "uploads").iterdir())  # nothing left behind
    assert httpx.get(f"{url}/healthz", timeout=5).status_code == 200


def test_broken_geometry_fails_its_job_and_uploaded_names_stay_inside(server, tmp_path):
    url, data_dir, _ = server
    bad = tmp_path / "range.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    # up to the root and down into this test's own folder: there only if the name escaped
    # (a fixed /tmp path may be another process's)
    escaped = tmp_path / "escaped"
    r = upload(url, bad, {}, name="../" * 16 + str(escaped).lstrip("/") + "/range.obj")
    assert r.status_code == 202
    job = wait(url, r.json()["id"])
    assert job["state"] == "failed" and job["error"] == "range.obj: line 4: vertex index 9 out of range (3 defined)", job["error"]
    assert (data_dir / "jobs" / job["id"] / "range.obj").is_file() and not escaped.exists()


def capsule_gltf(meshes, embed=False) -> dict[str, bytes]:
    """The shared capsule (OBJ) as a glTF written by trimesh: ``model.gltf`` with its
    buffers (geometry and image) as data URIs, or in ``.bin`` files beside it: name -> bytes."""
    import trimesh

    return trimesh.exchange.gltf.export_gltf(trimesh.load(meshes / "capsule.obj", force="mesh"), embed_buffers=embed)


def upload_parts(url, mesh, files, settings):
    """POST /v1/jobs with ``mesh`` and ``files`` as (name, bytes) parts."""
    parts = [("mesh", mesh)] + [("files", f) for f in files]
    return httpx.post(f"{url}/v1/jobs", files=parts, data={"settings": json.dumps(settings)}, timeout=60)


def test_a_gltf_and_meshes_with_their_files_bake(server, meshes):
    """A self-contained .gltf, an OBJ with its MTL and image, and a glTF with its .bin
    buffers each bake through the worker, to the same geometry as the OBJ alone."""
    url, data_dir, _ = server
    settings = {"size": 64, "texture": "checker"}
    embedded, separate = capsule_gltf(meshes, embed=True), capsule_gltf(meshes)
    buffers = sorted((name, part) for name, part in separate.items() if name.endswith(".bin"))
    answers = {
        "gltf": upload_parts(url, ("capsule.gltf", embedded["model.gltf"]), [], settings),
        "obj+mtl": upload_parts(url, ("capsule.obj", (meshes / "capsule.obj").read_bytes()),
                                [(p.name, p.read_bytes()) for p in (meshes / "capsule.mtl", meshes / "capsule0.jpg")], settings),
        "gltf+bin": upload_parts(url, ("scene.gltf", separate["model.gltf"]), buffers, settings),
    }
    assert {k: r.status_code for k, r in answers.items()} == dict.fromkeys(answers, 202), {k: r.text for k, r in answers.items()}
    jobs = {k: wait(url, r.json()["id"]) for k, r in answers.items()}
    assert {k: j["state"] for k, j in jobs.items()} == dict.fromkeys(jobs, "done"), {k: j["error"] for k, j in jobs.items()}
    assert "capsule.glb" in jobs["gltf"]["files"] and "scene.glb" in jobs["gltf+bin"]["files"]
    faces = {k: j["report"]["mesh"]["faces"] for k, j in jobs.items()}
    assert len(set(faces.values())) == 1 and faces["obj+mtl"] > 9000, faces  # the geometry came through whole
    stored = data_dir / "jobs" / jobs["gltf+bin"]["id"]
    assert all((stored / name).read_bytes() == part for name, part in buffers)


def two_material_obj(folder):
    """``pair.obj`` + ``pair.mtl``: two unit boxes side by side, the first under ``usemtl
    paint``, the second under ``usemtl rubber`` (no UVs): name -> bytes."""
    import trimesh

    lines, base = ["mtllib pair.mtl"], 0
    for k, material in enumerate(("paint", "rubber")):
        box = trimesh.creation.box(extents=(1, 1, 1)).apply_translation((1.5 * k, 0, 0))
        lines += ["v {:.9g} {:.9g} {:.9g}".format(*v) for v in box.vertices] + [f"usemtl {material}"]
        lines += ["f " + " ".join(str(base + 1 + i) for i in face) for face in box.faces]
        base += len(box.vertices)
    return {"pair.obj": ("\n".join(lines) + "\n").encode(), "pair.mtl": b"newmtl paint\nKd 1 0 0\nnewmtl rubber\nKd 0 0 0\n"}


def glb_materials(glb: bytes) -> list[str]:
    """The material names of a GLB's JSON chunk."""
    length = int.from_bytes(glb[12:16], "little")
    return [m["name"] for m in json.loads(glb[20:20 + length])["materials"]]


def test_a_multi_material_upload_bakes_a_texture_set_per_material(server, tmp_path):
    """An OBJ with its MTL, two materials given two textures and sizes: the worker bakes a
    set each, the job lists the sets with their files, the zip holds every set's files and
    the GLB both materials by name; a glTF scene of two materials the same."""
    from conftest import two_material_scene

    url, *_ = server
    parts = two_material_obj(tmp_path)
    info = httpx.post(f"{url}/v1/inspect", files=[("mesh", ("pair.obj", parts["pair.obj"])), ("files", ("pair.mtl", parts["pair.mtl"]))],
                      timeout=60).json()
    assert [(m["name"], m["faces"], m["uv"]) for m in info["materials"]] == [("paint", 12, "none"), ("rubber", 12, "none")], info
    settings = {"size": 64, "texture": "checker", "materials": {"paint": {"texture": "marble"}, "rubber": {"texture": "wood", "size": 32}}}
    r = upload_parts(url, ("pair.obj", parts["pair.obj"]), [("pair.mtl", parts["pair.mtl"])], settings)
    assert r.status_code == 202, r.text
    job = wait(url, r.json()["id"])
    assert job["state"] == "done", job["error"]
    assert job["sets"] == [
        {"name": "paint", "materials": ["paint"], "size": [64, 64], "texture": "marble", "tiles": [], "files": ["paint_albedo.png", "paint_coverage.png"]},
        {"name": "rubber", "materials": ["rubber"], "size": [32, 32], "texture": "wood", "tiles": [], "files": ["rubber_albedo.png", "rubber_coverage.png"]},
    ], job["sets"]
    assert set(job["files"]) == {"paint_albedo.png", "paint_coverage.png", "rubber_albedo.png", "rubber_coverage.png", "pair.glb", "report.json"}
    z = zipfile.ZipFile(io.BytesIO(httpx.get(f"{url}/v1/jobs/{job['id']}/result.zip", timeout=30).content))
    assert sorted(z.namelist()) == sorted(job["files"])
    (tmp_path / "rubber.png").write_bytes(z.read("rubber_albedo.png"))
    assert read_image(tmp_path / "rubber.png").shape == (32, 32, 3)
    assert sorted(glb_materials(z.read("pair.glb"))) == ["paint", "rubber"]
    # a GLB scene: its materials' sets, by the names /v1/inspect gave
    two_material_scene(tmp_path / "scene.glb")
    with open(tmp_path / "scene.glb", "rb") as f:
        names = [m["name"] for m in httpx.post(f"{url}/v1/inspect", files={"mesh": ("scene.glb", f)}, timeout=60).json()["materials"]]
    job = wait(url, upload(url, tmp_path / "scene.glb", {"size": 32, "materials": {"body": {"texture": "marble"}}}).json()["id"])
    assert job["state"] == "done", job["error"]
    assert [s["name"] for s in job["sets"]] == names and sorted(names) == ["body", "wheels"]
    assert {s["name"]: s["texture"] for s in job["sets"]} == {"body": "marble", "wheels": "checker"}
    assert sorted(glb_materials(httpx.get(f"{url}/v1/jobs/{job['id']}/files/scene.glb", timeout=30).content)) == ["body", "wheels"]


def test_a_udim_upload_lists_its_tiles_and_their_files(server, tmp_path):
    """Four boxes in UDIM tiles 1001-1004: one set of four tiles, an image of each per map,
    and the USD naming them with <UDIM>, all in the job's files and its zip."""
    from conftest import udim_boxes

    url, *_ = server
    udim_boxes(tmp_path / "boxes.obj")
    job = wait(url, upload(url, tmp_path / "boxes.obj", {"size": 32}).json()["id"])
    assert job["state"] == "done", job["error"]
    tiles = [1001, 1002, 1003, 1004]
    [one] = job["sets"]
    assert (one["name"], one["tiles"]) == ("default", tiles), one
    assert one["files"] == sorted(f"{m}.{t}.png" for m in ("albedo", "coverage") for t in tiles)
    assert set(job["files"]) == {*one["files"], "boxes.glb", "boxes.usda", "report.json"}
    z = zipfile.ZipFile(io.BytesIO(httpx.get(f"{url}/v1/jobs/{job['id']}/result.zip", timeout=30).content))
    assert sorted(z.namelist()) == sorted(job["files"])
    assert b"@./albedo.<UDIM>.png@" in z.read("boxes.usda")


def test_a_bake_whose_tiles_pass_the_memory_limit_fails_before_its_atlas(tmp_path_factory, tmp_path):
    """One 8192² image fits this server's 1500 MB a bake, so the upload is taken; the
    worker's bake process reads the mesh, counts its four UDIM tiles and fails the job
    naming the size, before any atlas is made."""
    from conftest import udim_boxes

    from texbake.memory import gigabytes, sets_bytes
    from texbake.settings import BakeSettings

    data, port = tmp_path_factory.mktemp("data"), free_port()
    proc = start(["serve", "--port", str(port), "--workers", "1"], data, {"BAKE_JOB_MEMORY_MB": "1500"}, port=port)
    try:
        url = f"http://127.0.0.1:{port}"
        udim_boxes(tmp_path / "boxes.obj")
        r = upload(url, tmp_path / "boxes.obj", {"size": 8192})
        assert r.status_code == 202, r.text
        job = wait(url, r.json()["id"])
    finally:
        stop(proc)
    need = sets_bytes([(BakeSettings.build(size=8192), 4)], 48, workers=1)
    assert job["state"] == "failed" and job["error"] == (f"size: a bake of 4 images (texture sets and tiles) needs about {gigabytes(need)}; "
                                                         f"this server's limit is {gigabytes(1500 << 20)} a bake"), job["error"]


def test_a_missing_buffer_and_a_hostile_companion_name_get_422(server, meshes):
    url, data_dir, _ = server
    separate = capsule_gltf(meshes)
    buffers = sorted((name, part) for name, part in separate.items() if name.endswith(".bin"))
    r = upload_parts(url, ("scene.gltf", separate["model.gltf"]), buffers[1:], {})
    assert r.status_code == 422 and r.json()["detail"] == (f"mesh 'scene.gltf': refers to {buffers[0][0]!r}, which was not sent: "
                                                           "send it as a 'files' part beside the mesh"), r.text
    mtl = (meshes / "capsule.mtl").read_bytes()
    for name in ("../capsule.mtl", "/tmp/capsule.mtl"):
        r = upload_parts(url, ("capsule.obj", (meshes / "capsule.obj").read_bytes()), [(name, mtl)], {})
        assert r.status_code == 422 and r.json()["detail"].startswith(f"files: {name!r} is not a plain file name"), r.text
    assert not list((data_dir / "uploads").iterdir())  # nothing left behind


def test_upload_limit_stops_a_streamed_body(server):
    url, *_ = server
    part = b'--b\r\nContent-Disposition: form-data; name="mesh"; filename="big.obj"\r\n\r\n' + b"v 0 0 0\n" * (1 << 17)
    with socket.create_connection(("127.0.0.1", int(url.rsplit(":", 1)[1]))) as sock:
        sock.sendall(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: multipart/form-data; boundary=b\r\n"
                     b"Transfer-Encoding: chunked\r\n\r\n")  # chunked: no Content-Length to refuse it by
        for _ in range(4):  # 4 MB against this server's 2 MB (+1 MB for the form) limit, never finished
            sock.sendall(b"%x\r\n%s\r\n" % (len(part), part))
        sock.settimeout(20)
        reply = b""
        while not reply.endswith(b"}") and (more := sock.recv(65536)):
            reply += more
    assert reply.startswith(b"HTTP/1.1 413") and b"larger than the limit of 3048576 bytes" in reply, reply[:300]
    assert httpx.get(f"{url}/healthz", timeout=5).status_code == 200


def test_catalogue_and_docs(server):
    url, *_ = server
    cat = httpx.get(f"{url}/v1/textures", timeout=10).json()
    assert {t["name"] for t in cat["textures"]} >= {"checker", "marble", "wood", "flame"}
    assert httpx.get(f"{url}/openapi.json", timeout=10).json()["paths"].keys() >= {"/v1/jobs", "/v1/jobs/{job_id}", "/v1/textures"}
    docs = httpx.get(f"{url}/docs", timeout=10)
    assert docs.status_code == 200 and "swagger-ui" in docs.text
    scripts = re.findall(r'(?:src|href)="([^"]+)"', docs.text)
    assert scripts and all(s.startswith("/") for s in scripts), scripts  # no CDN: served here
    assert all(httpx.get(f"{url}{s}", timeout=10).status_code == 200 for s in scripts)
    redoc = httpx.get(f"{url}/redoc", timeout=10).text
    assert all(s.startswith("/") for s in re.findall(r'src="([^"]+)"', redoc))
    assert httpx.get(f"{url}/readyz", timeout=10).json()["ok"]


def test_twenty_concurrent_uploads(server, meshes):
    """Every job ends done; the API's memory stays bounded and /healthz stays fast meanwhile."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    import psutil

    url, _, pid = server
    api = psutil.Process(pid)
    base_rss, peak_rss, health = api.memory_info().rss, 0, []
    done = threading.Event()

    def watch():
        nonlocal peak_rss
        while not done.is_set():
            t0 = time.perf_counter()
            assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200
            health.append(time.perf_counter() - t0)
            peak_rss = max(peak_rss, api.memory_info().rss)
            time.sleep(0.05)

    watcher = threading.Thread(target=watch)
    watcher.start()
    try:
        with ThreadPoolExecutor(20) as pool:  # distinct sizes: 20 distinct jobs
            answers = list(pool.map(lambda i: upload(url, meshes / "bunny.ply", {"size": 64 + 8 * i, "texture": "checker"}), range(20)))
        assert [a.status_code for a in answers] == [202] * 20, [a.text for a in answers if a.status_code != 202]
        jobs = [wait(url, a.json()["id"], timeout=300) for a in answers]
    finally:
        done.set()
        watcher.join()
    assert [j["state"] for j in jobs] == ["done"] * 20, [j["error"] for j in jobs]
    # uploads are streamed to disk (20 x 2.9 MB would show)
    assert peak_rss - base_rss < 50e6, (base_rss, peak_rss)
    # /healthz is answered on the event loop, never behind the uploads or the bakes. Seconds
    # (median, 90th percentile, max): idle 0.03, 0.05, 0.27; with three other processes
    # busy on the 2 cores 0.17, 0.33, 0.49 (and a max of 1.7 seen once). Bounds with margin
    # for a loaded machine; a /healthz that waited for uploads or bakes would take seconds.
    median, p90, worst = np.percentile(health, [50, 90, 100])
    assert median < 0.5 and p90 < 1.5 and worst < 5.0, (median, p90, worst, len(health))


def identical_uploads(url, meshes, n=20):
    """``n`` identical uploads at once: their status codes and job ids."""
    from concurrent.futures import ThreadPoolExecutor

    start = threading.Barrier(n)

    def one(_):
        start.wait()
        return upload(url, meshes / "suzanne.ply", {"size": 72, "texture": "wood"})

    with ThreadPoolExecutor(n) as pool:
        answers = list(pool.map(one, range(n)))
    return sorted(a.status_code for a in answers), {a.json()["id"] for a in answers}


def test_twenty_identical_concurrent_uploads_make_one_job(server, meshes):
    url, data, _ = server
    codes, ids = identical_uploads(url, meshes)
    assert codes == [200] * 19 + [202] and len(ids) == 1, (codes, ids)
    [job_id] = ids
    assert wait(url, job_id)["state"] == "done"
    assert sorted(p.name for p in (data / "jobs").iterdir() if p.name == job_id) == [job_id]  # no folders of the 19 left


def test_result_zip_streams_from_disk(server, meshes, tmp_path):
    """A 100 MB result.zip downloads about as fast as the same file from /files/, and the
    API's memory does not grow with it (it was built in memory and sent line by line:
    112 MB took 53 s, six at once took the API from 183 to 826 MB). It is written as it is
    sent, nothing kept on the server."""
    import psutil

    url, data, pid = server
    job = wait(url, upload(url, meshes / "bunny.ply", {"size": 64, "texture": "checker", "samples": 2}).json()["id"])
    assert job["state"] == "done", job["error"]
    big = data / "jobs" / job["id"] / "out" / "big.exr"  # as large as a 4096 x 4096 float32 RGBA EXR, and as incompressible
    with open(big, "wb") as f:
        for _ in range(100):
            f.write(os.urandom(1 << 20))
    api = psutil.Process(pid)
    before = api.memory_info().rss

    def timed(path):
        t0 = time.perf_counter()
        with httpx.stream("GET", f"{url}/v1/jobs/{job['id']}/{path}", timeout=120) as r, open(tmp_path / "got", "wb") as f:
            assert r.status_code == 200
            for chunk in r.iter_bytes(1 << 20):
                f.write(chunk)
        return time.perf_counter() - t0, (tmp_path / "got").stat().st_size

    plain, plain_size = timed("files/big.exr")
    zipped, zip_size = timed("result.zip")
    grown = api.memory_info().rss - before
    assert zip_size > plain_size == 100 << 20 and grown < 50e6, (zip_size, plain_size, grown)
    # measured on this machine: /files/ 0.3 s, result.zip 0.6 s
    assert zipped < 3 * plain + 2, (plain, zipped)
    with zipfile.ZipFile(tmp_path / "got") as z:
        assert set(z.namelist()) == set(job["files"]) | {"big.exr"}
        assert z.getinfo("big.exr").compress_type == zipfile.ZIP_STORED
        assert z.testzip() is None  # every member's CRC right
        assert z.read("report.json") == (data / "jobs" / job["id"] / "out" / "report.json").read_bytes()
    assert not [p.name for p in (data / "jobs" / job["id"]).iterdir() if "zip" in p.name]  # nothing written on the server


def test_a_bake_over_its_memory_limit_or_deadline_fails_alone(tmp_path, meshes):
    port = free_port()
    limits = {"BAKE_JOB_MEMORY_MB": "1500", "BAKE_JOB_SECONDS": "10", "BAKE_MAX_SIZE": "16384"}
    api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, limits, port=port)
    url = f"http://127.0.0.1:{port}"
    try:
        # Over the memory limit: refused at upload with the figure, before anything is queued
        # (the estimate is texbake.memory's; a bake that passes it and still runs out is
        # killed by its process's limit, tests/service/worker/test_tasks.py)
        big = upload(url, meshes / "Duck.glb", {"size": 16384, "uv": "keep"})
        assert big.status_code == 422, big.text
        assert re.fullmatch(r"settings\.size: a 16384x16384 bake needs about [0-9.]+ GB; this server's limit is 1\.6 GB a bake",
                            big.json()["detail"]), big.json()
        # Over the deadline: 64 samples of 2048 x 2048 take 76 s on an idle machine (and stay
        # under 1500 MB), the deadline is 10 s.
        slow = wait(url, upload(url, meshes / "bunny.ply", {"size": 2048, "samples": 64}).json()["id"], timeout=120)
        assert slow["state"] == "failed" and slow["error"] == "the bake took longer than 10 s", slow["error"]
        small = wait(url, upload(url, meshes / "bunny.ply", {"size": 64}).json()["id"], timeout=120)
        assert small["state"] == "done", small["error"]  # the worker and its next bake are fine
    finally:
        stop(api)


def test_api_keys(tmp_path, meshes):
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], tmp_path, {"BAKE_API_KEYS": '["alpha-key", "beta-key"]'}, port=port)
    url = f"http://127.0.0.1:{port}"
    alpha, beta = ({"Authorization": f"Bearer {k}-key"} for k in ("alpha", "beta"))
    try:
        for headers in (None, {"Authorization": "Bearer nope"}):
            r = upload(url, meshes / "suzanne.ply", {"size": 64}, headers=headers)
            assert r.status_code == 401 and "API key" in r.json()["detail"] and r.headers["WWW-Authenticate"] == "Bearer"
        job = upload(url, meshes / "suzanne.ply", {"size": 64}, headers=alpha).json()
        assert httpx.get(job["url"], headers=alpha, timeout=10).status_code == 200
        assert httpx.get(job["url"], headers=beta, timeout=10).status_code == 404  # other keys do not see it
        assert httpx.delete(job["url"], headers=beta, timeout=10).status_code == 404
        assert httpx.get(f"{url}/v1/jobs", headers=beta, timeout=10).json()["total"] == 0
        assert httpx.get(f"{url}/v1/jobs", headers=alpha, timeout=10).json()["total"] == 1
        theirs = upload(url, meshes / "suzanne.ply", {"size": 64}, headers=beta)
        assert theirs.status_code == 202 and theirs.json()["id"] != job["id"]
        assert httpx.get(f"{url}/healthz", timeout=10).status_code == 200  # health needs no key
    finally:
        stop(api)


def finish_on_another_worker(url, data, job_id):
    """Start a worker of its own on the data folder, wait for the job to end, stop the worker."""
    replacement = start(["worker", "--workers", "1"], data)
    try:
        return wait(url, job_id, timeout=180)
    finally:
        stop(replacement)


def test_stopped_worker_hands_its_bake_back(tmp_path, meshes):
    """SIGTERM (what docker stop sends): no new job, BAKE_STOP_SECONDS for the running bake,
    then it goes back to the queue uncounted, and another worker bakes it."""
    data = tmp_path
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "0"], data, port=port)
    url = f"http://127.0.0.1:{port}"
    worker = start(["worker", "--workers", "1"], data, {"BAKE_STOP_SECONDS": "1"})
    try:
        job_id = upload(url, meshes / "bunny.ply", {"texture": "marble", "size": 2048, "samples": 16}).json()["id"]
        wait(url, job_id, states=("running",), timeout=60)
        began = time.monotonic()
        worker.send_signal(signal.SIGTERM)  # the worker alone, as docker stop does
        assert worker.wait(30) == 0
        assert time.monotonic() - began < 20
        job = httpx.get(f"{url}/v1/jobs/{job_id}", timeout=10).json()
        assert job["state"] == "queued" and job["attempts"] == 0, job
        with open(worker.log.name) as log:
            assert "handed 1 running jobs back" in log.read()
        job = finish_on_another_worker(url, data, job_id)
        assert job["state"] == "done" and job["attempts"] == 1, job
    finally:
        stop(worker)
        stop(api)


def test_restart_loses_no_queued_job(tmp_path, meshes):
    """SIGTERM to the whole process group (systemd's stop, Ctrl-C's kind) while a bake
    runs: the bake is handed back, not killed with the group, and queued jobs wait."""
    data = tmp_path
    port = free_port()
    api = start(["serve", "--port", str(port), "--workers", "1"], data, port=port)
    url = f"http://127.0.0.1:{port}"
    ids = [upload(url, meshes / "bunny.ply", {"size": 2048, "samples": 4})] + [
        upload(url, meshes / name, {"size": 128}) for name in ("suzanne.ply", "fandisk.obj", "ico4uv.obj")]
    ids = [r.json()["id"] for r in ids]
    wait(url, ids[0], states=("running",), timeout=60)
    stop(api)  # the group: API, worker and bake process
    api = start(["serve", "--port", str(port), "--workers", "2"], data, port=port)
    try:
        jobs = [wait(url, i, timeout=240) for i in ids]
        assert [j["state"] for j in jobs] == ["done"] * 4, [j["error"] for j in jobs]
        assert jobs[0]["attempts"] == 1, jobs[0]  # handed back uncounted
    finally:
        stop(api)


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
        need(why)
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
        codes, same = identical_uploads(url, meshes)  # 14 jobs of 20 before the unique key
        assert codes == [200] * 19 + [202] and len(same) == 1, (codes, same)
    finally:
        stop(extra)
        stop(api)
        import psycopg

        with psycopg.connect("host=127.0.0.1 port=5432 user=postgres dbname=postgres", autocommit=True) as conn:
            conn.execute(f'DROP DATABASE IF EXISTS "{database}" WITH (FORCE)')


def schemathesis(url, folder):
    cli = os.path.join(os.path.dirname(sys.executable), "schemathesis")
    return subprocess.run(
        [cli, "run", f"{url}/openapi.json", "--checks", "not_a_server_error", "--max-examples", "30", "--seed", "1",
         "--request-timeout", "30", "--no-color"],
        capture_output=True, text=True, timeout=600, cwd=folder,  # its cache folder goes there
    )


def test_schemathesis_finds_no_server_error(server, tmp_path):
    """Property-based requests from the OpenAPI schema: never a 5xx (runs last: it leaves jobs queued)."""
    url, *_ = server
    r = schemathesis(url, tmp_path)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]


def test_schemathesis_finds_no_server_error_on_postgresql(tmp_path, postgres_url):
    """The same against PostgreSQL, which refuses what SQLite takes (a NUL in a string, a
    name longer than its column). A worker runs (else /readyz is rightly a 503), with small
    limits: what is accepted bakes in a moment."""
    port = free_port()
    limits = {"BAKE_DATABASE_URL": postgres_url, "BAKE_MAX_SIZE": "128", "BAKE_MAX_SAMPLES": "2", "BAKE_MAX_FRAMES": "2"}
    api = start(["serve", "--port", str(port), "--workers", "1"], tmp_path, limits, port=port)
    try:
        r = schemathesis(f"http://127.0.0.1:{port}", tmp_path)
        assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    finally:
        stop(api)


def test_a_done_job_whose_outputs_are_gone_says_so_and_is_baked_again(server, meshes):
    """Its outputs deleted from the data folder: the job reads failed with the reason (not
    done with files that answer 409); a retry and the same upload bake it again."""
    import shutil

    url, data, _ = server
    settings = {"size": 64, "texture": "checker", "bits": 16}
    job = wait(url, upload(url, meshes / "suzanne.ply", settings).json()["id"])
    assert job["state"] == "done" and job["files"], job
    shutil.rmtree(data / "jobs" / job["id"] / "out")
    lost = httpx.get(f"{url}/v1/jobs/{job['id']}", timeout=10).json()
    assert lost["state"] == "failed" and lost["error"] == "its outputs are gone from the store: retry the job to bake them again" and lost["files"] == []
    r = httpx.get(f"{url}/v1/jobs/{job['id']}/result.zip", timeout=10)
    assert r.status_code == 409 and r.json()["detail"] == f"job {job['id']} is failed: {lost['error']}", r.text
    retried = httpx.post(f"{url}/v1/jobs/{job['id']}/retry", timeout=30)
    assert retried.status_code == 202 and retried.json()["id"] != job["id"], retried.text
    assert wait(url, retried.json()["id"])["state"] == "done"
    again = upload(url, meshes / "suzanne.ply", settings)  # the same upload: the retry's job, done
    assert again.status_code == 200 and again.json()["id"] == retried.json()["id"] and again.json()["files"]
    assert httpx.get(f"{url}/v1/jobs/{retried.json()['id']}/result.zip", timeout=30).status_code == 200
