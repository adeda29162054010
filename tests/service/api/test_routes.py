"""The API in-process through FastAPI's TestClient (SQLite queue and jobs table in a
temporary data folder; no worker runs, so jobs stay queued).

Each test gets its own app on its own empty data folder, so no test sees another's jobs
and every test passes alone and in any order."""

import json

import numpy as np
import pytest
from fastapi.testclient import TestClient

from texbake.service.core.config import get_settings
from texbake.settings import BakeSettings


def post(client, path, settings, name=None):
    with open(path, "rb") as f:
        return client.post("/v1/jobs", files={"mesh": (name or path.name, f)}, data={"settings": json.dumps(settings)})


def test_upload_is_queued_once(client, meshes):
    r = post(client, meshes / "suzanne.ply", {"texture": "wood", "size": 256})
    assert r.status_code == 202 and r.headers["Location"] == r.json()["url"]
    job = r.json()
    assert job["state"] == "queued" and job["mesh"] == "suzanne.ply" and job["settings"]["texture"]["name"] == "wood"
    assert post(client, meshes / "suzanne.ply", {"texture": "wood", "size": 256}).json()["id"] == job["id"]
    assert post(client, meshes / "suzanne.ply", {"texture": "wood", "size": 128}).json()["id"] != job["id"]
    final = post(client, meshes / "suzanne.ply", {"texture": "wood", "size": 128, "quality": "final"}).json()
    assert (final["settings"]["quality"], final["settings"]["samples"], final["settings"]["filtering"]) == ("final", 16, False)
    limit = get_settings().max_faces  # a face limit the client does not set is this server's
    assert final["settings"] == BakeSettings(texture="wood", size=128, quality="final", max_faces=limit).model_dump(mode="json")
    # the same bake however it is written: the preset's values spelt out are the same job
    spelt = {"texture": "wood", "size": 128, "samples": 16, "filtering": False, "quality": "final"}
    assert post(client, meshes / "suzanne.ply", spelt).json()["id"] == final["id"]
    page = client.get("/v1/jobs", params={"limit": 1}).json()
    assert page["total"] == 3 and len(page["jobs"]) == 1
    assert client.get(f"/v1/jobs/{job['id']}/files/albedo.png").status_code == 409  # not baked yet
    assert client.delete(f"/v1/jobs/{job['id']}").json()["state"] == "cancelled"
    assert client.delete(f"/v1/jobs/{job['id']}").status_code == 409


@pytest.mark.parametrize("settings, field", [
    ({"texture": {"name": "wood", "rings": "many"}}, "rings"),
    ({"texture": "plaid"}, "plaid"),
    ({"size": 4096}, "size: 4096 is over this server's limit of 2048"),
    ({"size": 0}, "size"),
    ({"uv": "sideways"}, "uv"),
    ({"sampels": 4}, "sampels"),
    ({"quality": "best"}, "quality"),
    ({"bits": 7}, "settings.bits"),
    ({"format": "exr", "bits": 8}, "exr takes 16 or 32 bits"),
    ({"margin": -1}, "settings.margin"),
    ({"texture": "none", "maps": ["ao", "source_normal"]}, "settings.maps: source_normal bake a source mesh onto the uploaded one"),
])
def test_bad_settings_name_the_field(client, meshes, settings, field):
    r = post(client, meshes / "suzanne.ply", settings)
    assert r.status_code == 422 and field in r.json()["detail"], r.text


@pytest.mark.parametrize("settings, detail", [
    ({"size": "abc"}, "settings.size: expected a whole number from 1 to 65536 (or width,height), got 'abc'"),
    ({"texture": "marbel"}, "settings.texture: unknown texture 'marbel' (did you mean 'marble'? known: checker, fbm, flame, marble, "
                            "noise, position, turbulence, wood)"),
    ({"texture": {"name": "marble", "octaves": 6}}, "settings.texture: marble has no parameter 'octaves' (did you mean "
     "'turbulence.octaves'? it has: axis, frequency, amplitude, turbulence, colormap, transform, space, model)"),
    ({"texture": '{"name": "marble", x}'}, "settings.texture: not valid JSON at line 1 column 20: expecting property name enclosed in "
                                           "double quotes"),
])
def test_bad_settings_get_the_libraries_words(client, meshes, settings, detail):
    """The same messages as the library's and the command line's, under ``settings.``."""
    r = post(client, meshes / "suzanne.ply", settings)
    assert r.status_code == 422 and r.json()["detail"] == detail, r.text
    assert r.json()["errors"] == [{"loc": detail.partition(":")[0].split("."), "msg": detail.partition(": ")[2]}]


def test_a_bake_over_the_job_memory_limit_is_refused_at_upload(client, meshes, monkeypatch):
    from texbake.memory import bake_bytes
    from texbake.service.core import config

    monkeypatch.setenv("BAKE_JOB_MEMORY_MB", "180")  # between what a 512² (152 MB) and a 2048² (204 MB) bake need
    config.get_settings.cache_clear()
    need = bake_bytes(BakeSettings.build(size=2048), 0, workers=1)
    r = post(client, meshes / "suzanne.ply", {"size": 2048})
    assert r.status_code == 422 and r.json()["detail"] == (f"settings.size: a 2048x2048 bake needs about {need / 1e9:.2g} GB; "
                                                           f"this server's limit is {180 * 2**20 / 1e9:.2g} GB a bake"), r.text
    assert post(client, meshes / "suzanne.ply", {"size": 512}).status_code == 202
    assert client.get("/v1/jobs").json()["total"] == 1


def test_not_json_settings_and_unknown_routes(client, meshes):
    with open(meshes / "suzanne.ply", "rb") as f:
        r = client.post("/v1/jobs", files={"mesh": ("suzanne.ply", f)}, data={"settings": "{size: 3"})
    assert r.status_code == 422 and r.json()["detail"].startswith("settings")
    assert client.get("/v1/jobs/0123/result.zip").json()["detail"] == "no job '0123'"
    assert client.get("/v2/anything").status_code == 404


def test_readiness_checks_queue_database_workers_and_disk(client, meshes, monkeypatch):
    import shutil

    from texbake.service.core import config, crud, db
    from texbake.service.core.config import get_settings

    r = client.get("/readyz")  # a new data folder, no worker
    assert r.status_code == 503 and r.json()["detail"] == "not ready: no worker is alive", r.json()
    assert r.json()["database"] == r.json()["queue"] == "ok" and r.json()["queued"] == 0
    with db.sessions(get_settings().database)() as session:
        crud.worker_seen(session, "host:1", 2)
    assert post(client, meshes / "suzanne.ply", {"texture": "wood"}).status_code == 202
    answer = client.get("/readyz").json()
    assert answer["ok"] and answer["queued"] == 1 and (answer["workers"], answer["slots"]) == (1, 2), answer
    free = shutil.disk_usage(get_settings().data_dir).free >> 20  # MiB, as /readyz counts them
    assert abs(answer["disk_free_mb"] - free) <= 64, (answer["disk_free_mb"], free)  # other writers on this disk
    # asked to keep more free than there is, the service is not ready and says why
    monkeypatch.setenv("BAKE_MIN_FREE_MB", str(free + (1 << 20)))
    config.get_settings.cache_clear()
    r = client.get("/readyz")
    assert r.status_code == 503 and r.json()["ok"] is False, r.json()
    assert r.json()["detail"] == f"not ready: {r.json()['disk_free_mb']} MB free on the data folder's disk"


def test_a_texture_naming_a_server_path_is_an_unknown_name(client, meshes, tmp_path):
    """The service never opens a path a client names: an existing spec file on the server,
    a missing one and a made-up name get the same 422, before anything is queued."""
    spec = tmp_path / "secret.yaml"
    spec.write_text("name: wood\n")
    queued = post(client, meshes / "suzanne.ply", {"texture": "wood"}).json()["id"]  # one job, queued
    details = set()
    for text in (str(spec), str(tmp_path / "missing.yaml"), "/etc/hostname", "plaid"):
        r = post(client, meshes / "suzanne.ply", {"texture": text})
        assert r.status_code == 422, r.text
        details.add(r.json()["detail"].replace(repr(text), "TEXT"))
    assert len(details) == 1 and next(iter(details)).startswith("settings.texture: unknown texture TEXT"), details
    assert [j["id"] for j in client.get("/v1/jobs").json()["jobs"]] == [queued]  # nothing more queued


def test_openapi_documents_the_settings_and_the_bearer_scheme(client):
    """The form field is BakeSettings: its schema in the OpenAPI document is the model's own
    JSON Schema (FastAPI leaves out ``"default": null``, nothing else)."""
    from texbake.settings import BakeSettings

    spec = client.get("/openapi.json").json()
    body = spec["paths"]["/v1/jobs"]["post"]["requestBody"]["content"]["multipart/form-data"]["schema"]["$ref"].split("/")[-1]
    field = spec["components"]["schemas"][body]["properties"]["settings"]["anyOf"][0]
    assert field["contentMediaType"] == "application/json" and field["contentSchema"]["$ref"].endswith("/BakeSettings")
    model = BakeSettings.model_json_schema(ref_template="#/components/schemas/{model}")
    for schema in [model, *model["$defs"].values()]:
        for prop in schema.get("properties", {}).values():
            if prop.get("default", 0) is None:
                del prop["default"]
    for name, definition in model.pop("$defs").items():
        assert spec["components"]["schemas"][name] == definition, name
    assert spec["components"]["schemas"]["BakeSettings"] == model
    assert spec["components"]["securitySchemes"]["HTTPBearer"]["scheme"] == "bearer"
    assert {"HTTPBearer": []} in spec["paths"]["/v1/jobs"]["post"]["security"]
    assert spec["paths"]["/v1/jobs"]["post"]["responses"]["4XX"]["content"]["application/json"]["schema"]["$ref"].endswith("/Problem")


def test_every_library_feature_can_be_asked_for(client, meshes):
    """A normal map, lit shading with a light, a flame sequence and a quality preset are
    settings like any other: queued as given, preset resolved."""
    settings = {"texture": {"name": "flame", "half_width": 0.4}, "frames": [0, 0.25, 0.5], "bump": "noise", "bump_strength": 2,
                "shading": "full", "light": [0, 1, 0], "quality": "final", "size": [256, 128], "format": "exr", "bits": 32}
    r = post(client, meshes / "suzanne.ply", settings)
    assert r.status_code == 202, r.text
    job = r.json()["settings"]
    assert job["frames"] == [0, 0.25, 0.5] and job["bump"]["name"] == "noise" and job["light"] == [0, 1, 0]
    assert job["texture"]["half_width"] == 0.4 and job["size"] == [256, 128] and (job["samples"], job["filtering"]) == (16, False)
    r = post(client, meshes / "suzanne.ply", {"texture": "marble", "frames": [0, 1]})
    assert r.status_code == 422 and "has no time to animate" in r.json()["detail"]
    r = post(client, meshes / "suzanne.ply", {"frames": list(range(100)), "texture": "flame"})
    assert r.status_code == 422 and "settings.frames: 100 is over this server's limit" in r.json()["detail"]


def test_what_a_client_sends_gets_a_4xx_never_a_500(client, meshes):
    """Nesting bounded before parsing, lengths and NULs checked before the database sees them."""
    deep = '{"name": "marble", "x": ' + '{"a":' * 100_000 + "1" + "}" * 100_000 + "}"  # json.loads: RecursionError
    for settings in ({"texture": deep}, "[" * 100_000 + "]" * 100_000):
        with open(meshes / "suzanne.ply", "rb") as f:
            r = client.post("/v1/jobs", files={"mesh": ("suzanne.ply", f)}, data={"settings": settings if isinstance(settings, str) else json.dumps(settings)})
        assert r.status_code == 422 and r.json()["detail"].startswith("settings"), r.text[:300]
    mesh = (meshes / "suzanne.ply").read_bytes()
    for name in (b"a" * 300 + b".ply", b"nul\x00.ply"):  # a raw NUL: httpx would percent-encode it
        body = b'--b\r\nContent-Disposition: form-data; name="mesh"; filename="' + name + b'"\r\n\r\n' + mesh + b"\r\n--b--\r\n"
        r = client.post("/v1/jobs", content=body, headers={"Content-Type": "multipart/form-data; boundary=b"})
        assert r.status_code == 422 and "at most 255 characters, without NUL" in r.json()["detail"], r.text[:300]
    for job_id in ("%00", "x" * 5000, "0123"):
        r = client.get(f"/v1/jobs/{job_id}")
        assert r.status_code == 404 and r.json()["detail"].startswith("no job"), r.text[:300]


def test_database_down_is_a_503_with_retry_after(tmp_path, monkeypatch, meshes):
    """PostgreSQL that refuses connections (nothing listens on the port): every route that
    needs the jobs table answers 503 in JSON with Retry-After; /healthz still answers."""
    from conftest import free_port

    from texbake.service.core import config as settings
    from texbake.service.main import create_app
    from texbake.service.worker import tasks

    monkeypatch.setenv("BAKE_DATA_DIR", str(tmp_path))
    monkeypatch.setenv("BAKE_DATABASE_URL", f"postgresql+psycopg://postgres@127.0.0.1:{free_port()}/none?connect_timeout=2")
    settings.get_settings.cache_clear()
    tasks.queue.cache_clear()
    try:
        with TestClient(create_app()) as c:
            for r in (c.get("/v1/jobs"), c.get(f"/v1/jobs/{'0' * 32}"), post(c, meshes / "suzanne.ply", {})):
                assert r.status_code == 503 and r.headers["Retry-After"] == "10", r.text
                assert r.json()["detail"] == "the jobs database is unavailable: try again in 10 s"
            assert c.get("/healthz").status_code == 200
    finally:
        settings.get_settings.cache_clear()
        tasks.queue.cache_clear()


def test_a_client_at_its_limit_gets_429_with_retry_after(client, meshes, monkeypatch):
    from texbake.service.core import config as settings

    monkeypatch.setenv("BAKE_JOBS_PER_CLIENT", "2")
    settings.get_settings.cache_clear()
    answers = [post(client, meshes / "suzanne.ply", {"texture": "wood", "size": 64 + i}) for i in range(3)]
    assert [r.status_code for r in answers] == [202, 202, 429], [r.text for r in answers]
    assert answers[2].headers["Retry-After"] == "30" and answers[2].json()["detail"] == "2 unfinished jobs: the limit per client is 2"
    client.delete(f"/v1/jobs/{answers[0].json()['id']}")  # one finished: one more taken
    assert post(client, meshes / "suzanne.ply", {"texture": "wood", "size": 99}).status_code == 202
    retried = client.post(f"/v1/jobs/{answers[0].json()['id']}/retry")  # a retry counts too
    assert retried.status_code == 429 and retried.headers["Retry-After"] == "30", retried.text


def test_no_free_database_connection_is_a_503_within_the_wait(client, meshes, monkeypatch):
    """Every pooled connection taken (as a burst takes them): a request gives up after
    BAKE_DATABASE_WAIT_SECONDS with 503 and Retry-After, not 500 after 30 s."""
    import time

    from texbake.service.core import config as settings
    from texbake.service.core import db

    monkeypatch.setenv("BAKE_DATABASE_WAIT_SECONDS", "0.5")
    settings.get_settings.cache_clear()
    db.sessions.cache_clear()  # an engine made with the new wait
    engine = db.sessions(settings.get_settings().database).kw["bind"]
    held = [engine.connect() for _ in range(engine.pool.size() + engine.pool._max_overflow)]
    try:
        for call in (lambda: client.get(f"/v1/jobs/{'0' * 32}"), lambda: client.get("/v1/jobs"),
                     lambda: post(client, meshes / "suzanne.ply", {"texture": "wood"})):
            began = time.monotonic()
            r = call()
            assert r.status_code == 503 and r.headers["Retry-After"] == "10", r.text
            assert r.json()["detail"] == "the jobs database is busy: try again in 10 s" and time.monotonic() - began < 3
    finally:
        for conn in held:
            conn.close()
    assert client.get("/v1/jobs").status_code == 200
    engine.dispose()
    db.sessions.cache_clear()


def test_job_urls_use_the_configured_base_url_not_the_host_header(client, meshes, monkeypatch):
    from texbake.service.core import config as settings

    monkeypatch.setenv("BAKE_BASE_URL", "https://bake.example.org/")
    settings.get_settings.cache_clear()
    with open(meshes / "suzanne.ply", "rb") as f:
        r = client.post("/v1/jobs", files={"mesh": ("suzanne.ply", f)}, headers={"Host": "evil.example.com"})
    job = r.json()
    assert r.status_code == 202 and job["url"] == f"https://bake.example.org/v1/jobs/{job['id']}" == r.headers["Location"]


# --- the web page's endpoints -------------------------------------------------------------

def test_the_swatch_is_a_png_cached_by_its_spec(client):
    from texbake.output.images import read_image

    r = client.get("/v1/swatch", params={"texture": "marble"})
    assert r.status_code == 200 and r.headers["content-type"] == "image/png" and r.content[:8] == b"\x89PNG\r\n\x1a\n"
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "s.png").write_bytes(r.content)
        image = read_image(Path(folder) / "s.png")
    assert image.shape == (256, 256, 4) and image[0, 0, 3] == 0 and image[128, 128, 3] == 1
    etag = r.headers["ETag"]
    assert client.get("/v1/swatch", params={"texture": "marble"}, headers={"If-None-Match": etag}).status_code == 304
    # the same spec written otherwise is the same swatch; POST answers the same
    same = client.get("/v1/swatch", params={"texture": json.dumps({"name": "marble", "frequency": 12.0})})
    posted = client.post("/v1/swatch", json={"texture": {"name": "marble"}})
    assert same.headers["ETag"] == posted.headers["ETag"] == etag and posted.content == r.content
    other = client.get("/v1/swatch", params={"texture": json.dumps({"name": "marble", "frequency": 30}), "size": 64, "view": "slice"})
    assert other.status_code == 200 and other.headers["ETag"] != etag


@pytest.mark.parametrize("method, request_args, words", [
    ("get", {"params": {"texture": json.dumps({"name": "marble", "frequency": -1})}},
     "texture: frequency: expected a number above 0 and at most 1000000, got -1"),
    ("get", {"params": {"texture": "plaid"}}, "texture: unknown texture 'plaid' (known: checker, fbm, flame, marble, noise, position, turbulence, wood)"),
    ("get", {"params": {"texture": "/etc/passwd"}}, "texture: unknown texture '/etc/passwd' (known: "),
    ("get", {"params": {"texture": "marble", "size": 4096}}, "size: expected at most 512, got 4096"),
    ("get", {"params": {"texture": "marble", "view": "cube"}}, "view: expected 'sphere' or 'slice', got 'cube'"),
    ("get", {"params": {"texture": "x" * 9000}}, "texture: expected at most 8192 characters, got 9000 characters"),
    ("get", {"params": {"texture": '{"name": "marble", "x": ' + '{"a":' * 800 + "1" + "}" * 800 + "}"}},
     "texture: JSON spec nested deeper than 32 levels"),  # refused unparsed
    ("get", {}, "texture: required"),
    ("post", {"json": {"texture": {"name": "wood", "rings": 3}}}, "texture: wood has no parameter 'rings' (it has: ring_width, wobble,"),
    ("post", {"json": {"texture": "marble", "colour": "red"}}, "colour: not a known field"),
    ("post", {"json": {"texture": {"name": {}}}}, "texture: unknown texture {} (known: "),  # was a 500: a dict as the name
])
def test_a_bad_swatch_is_a_422_naming_the_parameter(client, method, request_args, words):
    r = getattr(client, method)("/v1/swatch", **request_args)
    assert r.status_code == 422 and words in r.json()["detail"], r.text[:300]


def _png_image(content: bytes, *, stored: bool = False):
    """The PNG's pixels: read as texbake reads them (sRGB decoded to linear), or ``stored``:
    its 8-bit values as they are in the file, over 255."""
    import tempfile
    from pathlib import Path

    import OpenImageIO as oiio

    from texbake.output.images import read_image

    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / "s.png").write_bytes(content)
        if stored:
            return oiio.ImageBuf(str(Path(folder) / "s.png")).get_pixels(oiio.UINT8) / 255.0
        return read_image(Path(folder) / "s.png")


TWO_LAYERS = {"nodes": {"mask": {"op": "texture", "output": "value", "texture": {"name": "checker", "box": [0.25, 0.25, 0.25]}}},
              "base_color": {"op": "mix", "a": [0.8, 0.1, 0.05], "b": [0.05, 0.1, 0.8], "mask": "mask"},
              "roughness": {"op": "mix", "a": 0.2, "b": 0.9, "mask": "mask"}, "metallic": 0.75}


def test_a_material_swatch_is_its_channel_on_the_sphere(client):
    """Each channel of a material on the texture swatch's sphere, unlit: the checker mask's
    two values where the material says, data channels stored as they are (not sRGB)."""
    from texbake.swatch import material_swatch

    shots = {}
    for channel in ("base_color", "roughness", "metallic", "occlusion"):
        r = client.post("/v1/swatch", json={"material": TWO_LAYERS, "channel": channel, "size": 64})
        assert r.status_code == 200 and r.headers["content-type"] == "image/png", r.text[:300]
        shots[channel] = _png_image(r.content)
        assert shots[channel].shape == (64, 64, 4) and shots[channel][0, 0, 3] == 0 and shots[channel][32, 32, 3] == 1
    on = shots["roughness"][..., 3] == 1
    rough = shots["roughness"][on][:, 0]
    # the two layers: 0.2 and 0.9 in 8 bits (8-bit rounding 0.5/255; filtered checker edges between)
    assert abs(np.quantile(rough, 0.02) - 0.2) < 0.01 and abs(np.quantile(rough, 0.98) - 0.9) < 0.01, np.quantile(rough, [0.02, 0.98])
    metallic = _png_image(client.post("/v1/swatch", json={"material": TWO_LAYERS, "channel": "metallic", "size": 64}).content,
                          stored=True)
    assert np.abs(metallic[on][:, :3] - 191 / 255).max() < 1e-6  # data: 0.75 stored as 191/255, not sRGB's 225
    base = _png_image(client.post("/v1/swatch", json={"material": TWO_LAYERS, "size": 64}).content, stored=True)
    assert np.abs(base[on][:, 0].max() - 231 / 255) < 1e-6  # colour: linear 0.8 stored as sRGB's 231
    assert np.abs(shots["occlusion"][on][:, :3] - 1.0).max() < 0.003  # not given: the default
    red = shots["base_color"][on]
    assert (red[:, 0] > 0.7).mean() > 0.3 and (red[:, 2] > 0.7).mean() > 0.3  # both layers' colours show (read back as linear)
    # red where the roughness is low: the same mask in both channels
    assert np.corrcoef(red[:, 0], rough)[0, 1] < -0.95
    # the route's image is the library's, and GET with the material's JSON answers the same
    expected = material_swatch(TWO_LAYERS, "roughness", 64)
    assert np.abs(shots["roughness"][..., 0] - expected[..., 0]).max() < 0.003
    got = client.get("/v1/swatch", params={"material": json.dumps(TWO_LAYERS), "channel": "roughness", "size": 64})
    assert got.status_code == 200 and got.content == client.post("/v1/swatch", json={
        "material": TWO_LAYERS, "channel": "roughness", "size": 64}).content
    built_in = client.get("/v1/swatch", params={"material": "rusted_iron", "channel": "metallic"})
    assert built_in.status_code == 200 and built_in.headers["ETag"] != got.headers["ETag"]


def test_the_built_in_materials_are_listed_as_the_bake_takes_them(client):
    from texbake.materials import parse_material

    r = client.get("/v1/materials").json()
    names = [m["name"] for m in r["materials"]]
    assert names == ["polished_marble", "oak_planks", "lava", "rusted_iron", "glazed_ceramic_checker"]
    assert r["channels"]["base_color"] == "colour" and r["channels"]["roughness"] == "scalar" and r["defaults"]["roughness"] == 1.0
    for listed in r["materials"]:  # each object is the built-in itself
        assert parse_material(listed).model_dump() == parse_material(listed["name"]).model_dump()


@pytest.mark.parametrize("body, words", [
    ({"material": {**TWO_LAYERS, "roughness": {"op": "mix", "a": 0.2, "b": 0.9, "mask": {"op": "texture", "output": "value",
                                                 "texture": {"name": "marble", "frequency": -1}}}}, "channel": "roughness"},
     "material: node 'roughness.mask': texture: frequency: expected a number above 0"),
    ({"material": {"base_color": "nowhere"}}, "material: node 'base_color': unknown node 'nowhere'"),
    ({"material": {"base_color": 0.5, "roughness": [0.1, 0.2, 0.3]}}, "material: node 'roughness': the roughness channel takes a scalar"),
    ({"material": "rusted_iron", "channel": "shine"}, "channel: "),
    ({"material": {"base_color": 0.5, "roughness": json.loads(
        '{"op": "invert", "input": ' * 200 + "0.5" + "}" * 200)}}, "request body: JSON nested 202 deep: the limit is 32"),  # refused unparsed
    ({"material": 7}, "material: expected a material's name or a material"),
    ({"material": "rusted_iron", "texture": "marble"}, "texture: give a texture or a material, not both"),
])
def test_a_bad_material_swatch_is_a_422_naming_the_node(client, body, words):
    r = client.post("/v1/swatch", json=body)
    assert r.status_code == 422 and words in r.json()["detail"], r.text[:300]


def test_with_api_keys_a_swatch_needs_a_key(client, monkeypatch):
    from texbake.service.core import config as settings

    monkeypatch.setenv("BAKE_API_KEYS", '["sesame"]')
    settings.get_settings.cache_clear()
    assert client.get("/v1/swatch", params={"texture": "wood"}).status_code == 401
    assert client.get("/v1/swatch", params={"texture": "wood"}, headers={"Authorization": "Bearer sesame"}).status_code == 200
    assert client.get("/v1/config").json()["auth"] is True  # the page asks for the key


def test_the_config_gives_the_limits_the_formats_and_the_settings_schema(client):
    config = client.get("/v1/config").json()
    assert config["auth"] is False
    assert config["limits"]["max_size"] == 2048 and config["limits"]["max_upload_bytes"] == 256 * 1024 * 1024
    assert config["formats"] == [".obj", ".ply", ".stl", ".off", ".gltf", ".glb"]
    assert {".mtl", ".bin", ".png", ".jpg"} <= set(config["companions"]) and config["max_companions"] == 64
    assert config["settings_schema"]["properties"]["size"]["default"] == 1024


def test_the_page_and_everything_it_loads_are_served_here(client):
    import re

    r = client.get("/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    csp = r.headers["Content-Security-Policy"]
    assert "default-src 'self'" in csp and "script-src 'self' 'sha256-" in csp  # nothing from elsewhere, the import map by its hash
    local = re.findall(r'(?:src|href)="([^"]+)"', r.text)
    importmap = json.loads(re.search(r'<script type="importmap">(.*?)</script>', r.text, re.S).group(1))["imports"]
    assert all(u.startswith("/") or u == "data:," for u in [*local, *importmap.values()]), local
    for path in [u for u in local if u.startswith("/static/")] + [importmap["three"]]:
        assert client.get(path).status_code == 200, path
    app = client.get("/static/app.js").text
    for module in re.findall(r'from "three/addons/([^"]+)"', app):  # each addon the page imports, and what it imports
        assert client.get(importmap["three/addons/"] + module).status_code == 200, module
    assert client.get("/static/../service/main.py").status_code == 404
    assert "/" not in client.get("/openapi.json").json()["paths"]  # the page is no API


def test_retry_bakes_a_failed_or_cancelled_job_again(client, meshes):
    job = post(client, meshes / "suzanne.ply", {"texture": "wood", "size": 64}).json()
    r = client.post(f"/v1/jobs/{job['id']}/retry")
    assert r.status_code == 409 and "queued: only a failed or cancelled job is retried" in r.json()["detail"]
    client.delete(f"/v1/jobs/{job['id']}")
    again = client.post(f"/v1/jobs/{job['id']}/retry")
    assert again.status_code == 202 and again.json()["id"] != job["id"] and again.json()["state"] == "queued"
    assert again.json()["settings"] == job["settings"] and again.json()["mesh"] == "suzanne.ply"
    assert again.headers["Location"] == again.json()["url"]
    # the same upload and settings are live again: a second retry gives that job
    same = client.post(f"/v1/jobs/{job['id']}/retry")
    assert same.status_code == 200 and same.json()["id"] == again.json()["id"]
    assert client.post(f"/v1/jobs/{'0' * 32}/retry").status_code == 404


def test_a_material_is_a_setting_resolved_before_queueing(client, meshes):
    """A built-in's name is queued as the whole material it names (the same job as that
    material written out), with the ORM packing it brings."""
    from texbake.materials import BUILTINS

    r = post(client, meshes / "suzanne.ply", {"material": "rusted_iron", "size": 256, "normal_convention": "directx"})
    assert r.status_code == 202, r.text
    job = r.json()
    material = job["settings"]["material"]
    assert material["name"] == "rusted_iron" and material["nodes"] == BUILTINS["rusted_iron"]["nodes"]
    assert job["settings"]["packing"] == [{"name": "orm", "channels": ["occlusion", "roughness", "metallic"]}]
    again = post(client, meshes / "suzanne.ply", {"material": BUILTINS["rusted_iron"], "size": 256, "normal_convention": "directx"})
    assert again.status_code == 200 and again.json()["id"] == job["id"]


@pytest.mark.parametrize("material, detail", [
    ({"nodes": {"a": {"op": "invert", "input": "b"}, "b": {"op": "add", "a": "a", "b": 1}}, "base_color": "a"},
     "settings.material: node 'a': a cycle: a -> b -> a"),
    ({"base_color": {"op": "blur", "input": 1}}, "settings.material: node 'base_color': unknown op 'blur' (the ops are: texture, "
     "constant, position, normal, channel, combine, mix, add, subtract, multiply, divide, power, invert, clamp, threshold, smoothstep, "
     "remap, blend, warp, mtlx, mesh_map)"),
    ({"base_color": {"op": "mix", "a": 0, "b": 1, "mask": [1, 0, 0]}},
     "settings.material: node 'base_color': input 'mask' takes a scalar, got a colour"),
])
def test_a_graph_error_is_a_422_naming_the_node(client, meshes, material, detail):
    r = post(client, meshes / "suzanne.ply", {"material": material})
    assert r.status_code == 422 and r.json()["detail"] == detail, r.text
    assert "\n" not in r.json()["detail"] and client.get("/v1/jobs").json()["total"] == 0


def test_a_materialx_document_is_a_material(client, meshes):
    """A MaterialX document's XML text as the material (texbake.mtlx); a node it cannot bake is a 422 naming it."""
    from conftest import ROOT

    text = (ROOT / "tests" / "data" / "mtlx" / "standard_surface_marble_solid.mtlx").read_text()
    r = post(client, meshes / "suzanne.ply", {"material": text, "size": 64})
    assert r.status_code == 202, r.text
    material = r.json()["settings"]["material"]
    assert material["name"] == "Marble_3D" and material["base_color"]["op"] == "mtlx"
    bad = text.replace('<position name="obj_pos" type="vector3" />', '<viewdirection name="obj_pos" type="vector3" />')
    r = post(client, meshes / "suzanne.ply", {"material": bad})
    assert r.status_code == 422 and r.json()["detail"].startswith("settings.material: <mtlx>: node 'NG_marble1/obj_pos': "
                                                                  "viewdirection: a shading node"), r.text


def test_a_material_naming_a_server_path_is_an_unknown_name(client, meshes, tmp_path):
    (tmp_path / "secret.json").write_text('{"base_color": 0.5}')
    r = post(client, meshes / "suzanne.ply", {"material": str(tmp_path / "secret.json")})
    assert r.status_code == 422 and r.json()["detail"].startswith("settings.material: unknown material '/"), r.text
def test_inspect_names_a_meshs_materials_as_a_bake_takes_them(client, meshes, tmp_path):
    """``POST /v1/inspect`` reads the mesh with the bake's own loader (in its child
    process): the materials in the order of their texture sets, their faces, UVs and
    UDIM tiles; a file it cannot read is a 422 naming it; nothing is kept."""
    from conftest import two_material_scene, udim_boxes

    from texbake.service.core.config import get_settings

    two_material_scene(tmp_path / "pair.glb")
    udim_boxes(tmp_path / "boxes.obj")
    answers = {}
    for path in (tmp_path / "pair.glb", tmp_path / "boxes.obj", meshes / "bunny.ply"):
        with open(path, "rb") as f:
            r = client.post("/v1/inspect", files={"mesh": (path.name, f)})
        assert r.status_code == 200, r.text
        answers[path.name] = r.json()
    pair = answers["pair.glb"]
    assert (pair["mesh"], pair["faces"]) == ("pair.glb", 12 + 2 * 320), pair
    from texbake.mesh import load_mesh

    order = load_mesh(tmp_path / "pair.glb").material_names  # the sets' order is the loader's
    materials = {"body": {"name": "body", "faces": 12, "uv": "all", "tiles": []},
                 "wheels": {"name": "wheels", "faces": 640, "uv": "none", "tiles": []}}
    assert sorted(order) == ["body", "wheels"] and pair["materials"] == [materials[name] for name in order], pair
    assert answers["boxes.obj"]["materials"] == [{"name": "default", "faces": 48, "uv": "all", "tiles": [1001, 1002, 1003, 1004]}]
    assert answers["bunny.ply"]["materials"] == [{"name": "default", "faces": 16295, "uv": "none", "tiles": []}]
    bad = tmp_path / "nan.obj"
    bad.write_text("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")  # only parsing tells
    with open(bad, "rb") as f:
        r = client.post("/v1/inspect", files={"mesh": ("nan.obj", f)})
    assert r.status_code == 422 and r.json()["detail"].startswith("mesh 'nan.obj': ") and "non-finite" in r.json()["detail"], r.text
    assert "/" not in r.json()["detail"].partition(": ")[2]  # no server folder in the reason
    assert not list((get_settings().data_dir / "uploads").iterdir())
    assert client.get("/v1/jobs").json()["total"] == 0


@pytest.mark.parametrize("settings, detail", [
    ({"materials": {"body": {"texture": "plaid"}}}, "settings.materials.body.texture: unknown texture 'plaid'"),
    ({"materials": {"body": {"size": 0}}}, "settings.materials.body.size"),
    ({"materials": {"body": {"colour": "red"}}}, "settings.materials.body.colour"),
    ({"materials": {"body": {"texture": "wood"}}, "texture_set": "single"}, "settings.materials: texture_set='single' bakes one"),
    ({"texture_set": "each"}, "settings.texture_set"),
    ({"names": "{set}_{mapp}.{ext}"}, "settings.names: unknown field {mapp}"),
    ({"names": "{set}.{ext}"}, "settings.names: a template needs {map} and {ext}"),
    ({"materials": {"bodee": {"texture": "wood"}}}, "settings.materials: 'pair.glb' has no material 'bodee'; its materials: "),
])
def test_texture_sets_settings_name_the_field(client, tmp_path, settings, detail):
    """texture_set, materials and names are BakeSettings: a bad one is a 422 naming it
    before anything is queued; a material the mesh has not, once the mesh is read."""
    from conftest import two_material_scene

    two_material_scene(tmp_path / "pair.glb")
    r = post(client, tmp_path / "pair.glb", settings)
    assert r.status_code == 422 and detail in r.json()["detail"], r.text
    assert client.get("/v1/jobs").json()["total"] == 0


def test_the_memory_check_counts_every_texture_set_and_tile(client, tmp_path, monkeypatch):
    """Each material's set at its own size, each UDIM tile an image: counted before
    anything is queued, with the mesh's faces once it is read (``materials`` given)."""
    from conftest import two_material_scene, udim_boxes

    from texbake.memory import bake_bytes, sets_bytes
    from texbake.service.core import config

    two_material_scene(tmp_path / "pair.glb")
    udim_boxes(tmp_path / "boxes.obj")
    one = BakeSettings.build(size=1024)
    monkeypatch.setenv("BAKE_JOB_MEMORY_MB", str(bake_bytes(one, 652, workers=1) // 2**20 + 1))  # one 1024² image fits, two do not
    config.get_settings.cache_clear()
    assert post(client, tmp_path / "pair.glb", {"size": 1024, "texture_set": "single"}).status_code == 202
    two = {"size": 1024, "materials": {"body": {"texture": "wood"}}}  # the wheels' set at the bake's size too
    need = sets_bytes([(one, 1), (one, 1)], 652, workers=1)
    r = post(client, tmp_path / "pair.glb", two)
    assert r.status_code == 422 and r.json()["detail"].startswith(
        f"settings.size: a bake of 2 images (texture sets and tiles) needs about {need / 1e9:.2g} GB"), r.text
    small = {"size": 1024, "materials": {"body": {"size": 256}, "wheels": {"size": 256}}}
    assert post(client, tmp_path / "pair.glb", small).status_code == 202
    # before the mesh is read: the sets materials names, each at its own size
    r = post(client, tmp_path / "boxes.obj", {"materials": {"a": {"size": 1024}, "b": {"size": 1024}}})
    assert r.status_code == 422 and r.json()["detail"].startswith("settings.size: a bake of 2 images"), r.text
    assert client.get("/v1/jobs").json()["total"] == 2
