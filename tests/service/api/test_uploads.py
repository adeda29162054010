"""A mesh and the files it refers to as parts of one request (texbake.service.api.uploads),
through the app in-process: no worker runs, so jobs stay queued
(tests/integration/test_service.py bakes them). The shared capsule is an OBJ with its
MTL and image; the glTFs are written here by trimesh."""

import json

import pytest
import trimesh

from texbake.service.core.config import get_settings


def post(client, mesh, files=(), settings=None):
    """POST /v1/jobs: ``mesh`` and each of ``files`` a path or (name, bytes)."""
    def part(field, item):
        return (field, item if isinstance(item, tuple) else (item.name, item.read_bytes()))

    parts = [part("mesh", mesh)] + [part("files", f) for f in files]
    return client.post("/v1/jobs", files=parts, data={"settings": json.dumps(settings or {"size": 64})})


def sphere_gltf(embed=False) -> dict[str, bytes]:
    """An icosphere as a glTF (``model.gltf``) with its buffers in ``gltf_buffer_N.bin``
    files beside it, or as data URIs (``embed``): name -> bytes."""
    mesh = trimesh.creation.icosphere(subdivisions=2)
    return trimesh.exchange.gltf.export_gltf(mesh, embed_buffers=embed)


def with_image(parts: dict[str, bytes], uri: str) -> dict[str, bytes]:
    """The glTF of ``parts`` with an image by ``uri`` (no material uses it: the loader ignores it)."""
    doc = json.loads(parts["model.gltf"])
    doc["images"] = [{"uri": uri}]
    return {**parts, "model.gltf": json.dumps(doc).encode()}


def job_files(job) -> dict[str, bytes]:
    folder = get_settings().data_dir / "jobs" / job["id"]
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}


def uploads_left() -> list[str]:
    folder = get_settings().data_dir / "uploads"
    return sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []


def test_a_self_contained_gltf_is_queued(client):
    parts = sphere_gltf(embed=True)
    assert list(parts) == ["model.gltf"] and b"data:application/octet-stream;base64," in parts["model.gltf"]
    r = post(client, ("model.gltf", parts["model.gltf"]))
    assert r.status_code == 202, r.text
    stored = job_files(r.json())
    assert stored["model.gltf"] == parts["model.gltf"]
    assert json.loads(stored["job.json"])["files"] == [] and uploads_left() == []


def test_a_gltf_is_stored_with_its_buffers_and_each_part_is_in_the_key(client):
    parts = sphere_gltf()
    buffers = sorted(n for n in parts if n.endswith(".bin"))
    assert buffers, parts.keys()
    r = post(client, ("model.gltf", parts["model.gltf"]), [(n, parts[n]) for n in buffers])
    assert r.status_code == 202, r.text
    job = r.json()
    stored = job_files(job)
    assert {n: stored[n] for n in parts} == parts and json.loads(stored["job.json"])["files"] == buffers
    # the same parts in another order are the same upload; a buffer changed by one byte is another
    again = post(client, ("model.gltf", parts["model.gltf"]), [(n, parts[n]) for n in reversed(buffers)])
    assert again.status_code == 200 and again.json()["id"] == job["id"]
    changed = bytearray(parts[buffers[0]])
    changed[-1] ^= 1
    other = post(client, ("model.gltf", parts["model.gltf"]), [(buffers[0], bytes(changed))] + [(n, parts[n]) for n in buffers[1:]])
    assert other.status_code == 202 and other.json()["id"] != job["id"]
    assert uploads_left() == []


def test_a_buffer_not_sent_is_a_422_naming_it(client):
    parts = sphere_gltf()
    buffers = sorted(n for n in parts if n.endswith(".bin"))
    r = post(client, ("model.gltf", parts["model.gltf"]), [(n, parts[n]) for n in buffers[1:]])
    assert r.status_code == 422, r.text
    assert r.json()["detail"] == (f"mesh 'model.gltf': refers to {buffers[0]!r}, which was not sent: "
                                  "send it as a 'files' part beside the mesh")
    assert client.get("/v1/jobs").json()["total"] == 0 and uploads_left() == []


def test_a_gltf_that_cannot_be_read_is_said_so_with_its_files(client):
    """Not "does not refer to" the files sent beside it: what is wrong is the glTF."""
    parts = sphere_gltf()
    buffers = [(n, parts[n]) for n in sorted(parts) if n.endswith(".bin")]
    r = post(client, ("model.gltf", parts["model.gltf"][:-10]), buffers)
    assert r.status_code == 422 and r.json()["detail"].startswith("mesh 'model.gltf': cannot parse GLTF header: "), r.text


def test_a_gltf_image_may_be_sent_or_left_out(client):
    """The loader reads a glTF's geometry without its images (a bake draws its own texture)."""
    parts = with_image(sphere_gltf(), "wood grain.png")
    buffers = [(n, parts[n]) for n in sorted(parts) if n.endswith(".bin")]
    without = post(client, ("model.gltf", parts["model.gltf"]), buffers)
    assert without.status_code == 202, without.text
    image = ("wood grain.png", b"\x89PNG\r\n\x1a\n" + bytes(64))  # the URI percent-encoded, the name as it is
    parts = with_image(parts, "wood%20grain.png")
    sent = post(client, ("model.gltf", parts["model.gltf"]), [*buffers, image])
    assert sent.status_code == 202, sent.text
    assert job_files(sent.json())["wood grain.png"] == image[1]


def test_an_obj_with_its_mtl_and_image(client, meshes):
    capsule = [meshes / "capsule.mtl", meshes / "capsule0.jpg"]
    r = post(client, meshes / "capsule.obj", capsule)
    assert r.status_code == 202, r.text
    stored = job_files(r.json())
    assert all(stored[p.name] == p.read_bytes() for p in [meshes / "capsule.obj", *capsule])
    assert json.loads(stored["job.json"]) == {"mesh": "capsule.obj", "files": ["capsule.mtl", "capsule0.jpg"],
                                              "settings": r.json()["settings"]}
    # the MTL and its image may be left out, as the loader bakes without them: each is another upload
    ids = {r.json()["id"]}
    for files in ([meshes / "capsule.mtl"], []):
        answer = post(client, meshes / "capsule.obj", files)
        assert answer.status_code == 202 and answer.json()["id"] not in ids, answer.text
        ids.add(answer.json()["id"])


def test_every_material_library_of_an_obj_may_be_sent(client):
    obj = b"mtllib a.mtl b.mtl\n\t mtllib c.mtl\r\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
    r = post(client, ("three.obj", obj), [(name, b"newmtl x\n") for name in ("a.mtl", "b.mtl", "c.mtl")])
    assert r.status_code == 202, r.text
    assert json.loads(job_files(r.json())["job.json"])["files"] == ["a.mtl", "b.mtl", "c.mtl"]


@pytest.mark.parametrize("mesh, files, detail", [
    ("suzanne.ply", ["capsule.mtl"], "mesh 'suzanne.ply': does not refer to 'capsule.mtl', sent beside it (it refers to no other file)"),
    ("capsule.obj", ["capsule0.jpg"], "mesh 'capsule.obj': does not refer to 'capsule0.jpg', sent beside it (it refers to 'capsule.mtl')"),
    ("capsule.obj", ["capsule.mtl", "capsule0.jpg", ("other.png", b"x")],
     "mesh 'capsule.obj': does not refer to 'other.png', sent beside it (it refers to 'capsule.mtl', 'capsule0.jpg')"),
    (("commented.obj", b"# mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 # mtllib a.mtl\n"), [("a.mtl", b"newmtl a\n")],
     "mesh 'commented.obj': does not refer to 'a.mtl', sent beside it (it refers to no other file)"),
])
def test_a_file_the_mesh_does_not_refer_to_is_refused(client, meshes, mesh, files, detail):
    """An image counts as referred to only through a sent MTL that names it; an ``mtllib``
    counts only where it begins a line, as the loader reads it."""
    r = post(client, mesh if isinstance(mesh, tuple) else meshes / mesh, [f if isinstance(f, tuple) else meshes / f for f in files])
    assert r.status_code == 422 and r.json()["detail"] == detail, r.text
    assert client.get("/v1/jobs").json()["total"] == 0 and uploads_left() == []


@pytest.mark.parametrize("name, words", [
    ("../capsule.mtl", "is not a plain file name"),
    ("/etc/capsule.mtl", "is not a plain file name"),
    ("textures/capsule.mtl", "is not a plain file name"),
    ("..\\capsule.mtl", "is not a plain file name"),
    ("C:capsule.mtl", "is not a plain file name"),
    (".capsule.mtl", "is not a plain file name"),
    ("capsule.mtl.", "is not a plain file name"),
    ("a" * 300 + ".mtl", "is not a plain file name"),
    ("capsule.exe", "'capsule.exe' is not a file a mesh refers to (.mtl .bin .png"),
    ("capsule.obj", "'capsule.obj' is not a file a mesh refers to"),
])
def test_a_hostile_companion_name_is_refused(client, meshes, name, words):
    r = post(client, meshes / "capsule.obj", [(name, b"newmtl a\n")])
    assert r.status_code == 422 and r.json()["detail"].startswith("files: ") and words in r.json()["detail"], r.text
    assert client.get("/v1/jobs").json()["total"] == 0 and uploads_left() == []


def test_names_sent_twice_too_many_files_and_a_nul_are_refused(client, meshes):
    mtl = meshes / "capsule.mtl"
    r = post(client, meshes / "capsule.obj", [mtl, mtl])
    assert r.status_code == 422 and r.json()["detail"] == "files: 'capsule.mtl' is sent twice", r.text
    r = post(client, meshes / "capsule.obj", [(f"{i}.png", b"x") for i in range(65)])
    assert r.status_code == 422 and r.json()["detail"] == "files: 65 files; at most 64 are taken beside a mesh", r.text
    obj = (meshes / "capsule.obj").read_bytes()
    for control in (b"\x00", b"\x1b"):  # raw: httpx would percent-encode them
        body = (b'--b\r\nContent-Disposition: form-data; name="mesh"; filename="capsule.obj"\r\n\r\n' + obj + b"\r\n"
                b'--b\r\nContent-Disposition: form-data; name="files"; filename="cap' + control + b'sule.mtl"\r\n\r\nnewmtl a\r\n--b--\r\n')
        r = client.post("/v1/jobs", content=body, headers={"Content-Type": "multipart/form-data; boundary=b"})
        assert r.status_code == 422 and r.json()["detail"].startswith(f"files: {'cap' + control.decode() + 'sule.mtl'!r} is not a plain file name"), r.text
    r = post(client, mtl)  # a companion sent as the mesh
    assert r.status_code == 422 and r.json()["detail"] == ("mesh: 'capsule.mtl' is not a mesh: send the mesh as 'mesh' "
                                                           "and the files it refers to as 'files'"), r.text
    assert client.get("/v1/jobs").json()["total"] == 0 and uploads_left() == []


def test_names_of_four_byte_letters_fit_a_file_name_on_disk(client, meshes):
    """A file name on disk takes 255 bytes: a mesh's name is cut to fit (it only names the
    outputs), a companion's, which the mesh refers to, is refused when it does not fit."""
    letters = "\U00020000" * 70  # a CJK letter, 4 bytes in UTF-8
    r = post(client, (letters + ".ply", (meshes / "suzanne.ply").read_bytes()))
    assert r.status_code == 202 and r.json()["mesh"] == letters + ".ply", r.text
    stored = json.loads(job_files(r.json())["job.json"])["mesh"]
    assert stored == "\U00020000" * 50 + ".ply" and len(stored.encode()) == 204, stored
    r = post(client, meshes / "capsule.obj", [(letters[:63] + ".mtl", b"newmtl a\n")])  # 256 bytes
    assert r.status_code == 422 and "is not a plain file name (at most 255 bytes as UTF-8" in r.json()["detail"], r.text
    assert client.get("/v1/jobs").json()["total"] == 1 and uploads_left() == []


def test_the_upload_limit_counts_every_part(client, meshes, monkeypatch):
    from texbake.service.core import config

    limit = (meshes / "capsule.obj").stat().st_size + (meshes / "capsule.mtl").stat().st_size
    monkeypatch.setenv("BAKE_MAX_UPLOAD_BYTES", str(limit))
    config.get_settings.cache_clear()
    assert post(client, meshes / "capsule.obj", [meshes / "capsule.mtl"]).status_code == 202  # exactly at the limit
    r = post(client, meshes / "capsule.obj", [meshes / "capsule.mtl", meshes / "capsule0.jpg"])
    assert r.status_code == 413, r.text
    assert r.json()["detail"] == f"files: the mesh and its files are larger than the limit of {limit} bytes together"
    assert client.get("/v1/jobs").json()["total"] == 1 and uploads_left() == []


def test_retry_bakes_again_with_the_companions(client):
    parts = sphere_gltf()
    buffers = [(n, parts[n]) for n in sorted(parts) if n.endswith(".bin")]
    job = post(client, ("model.gltf", parts["model.gltf"]), buffers).json()
    client.delete(f"/v1/jobs/{job['id']}")
    again = client.post(f"/v1/jobs/{job['id']}/retry")
    assert again.status_code == 202 and again.json()["id"] != job["id"], again.text
    assert job_files(again.json()) == job_files(job)  # every part, and the same job.json
    assert uploads_left() == []


def test_openapi_documents_the_files_beside_the_mesh(client):
    spec = client.get("/openapi.json").json()
    body = spec["paths"]["/v1/jobs"]["post"]["requestBody"]["content"]["multipart/form-data"]["schema"]["$ref"].split("/")[-1]
    form = spec["components"]["schemas"][body]
    assert form["required"] == ["mesh"]
    files = form["properties"]["files"]
    assert files["type"] == "array" and files["items"]["contentMediaType"] == "application/octet-stream"  # a file picker each in /docs
    assert "an OBJ's MTL and its images, a glTF's .bin buffers" in files["description"]
    assert ".gltf" in form["properties"]["mesh"]["description"]
    assert "-F files=@capsule.mtl" in spec["paths"]["/v1/jobs"]["post"]["description"]
