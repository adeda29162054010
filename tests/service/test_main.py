"""The app's middleware (texbake.service.main), in-process through FastAPI's TestClient: JSON
bodies bounded in nesting and size before FastAPI parses them, and the security headers
on every answer."""

import json

import pytest
from fastapi.testclient import TestClient


def nested(depth: int) -> str:
    """A swatch body whose JSON nests ``depth`` deep (its outer object counted)."""
    return '{"texture": {"name": "checker", "scale": ' + "[" * (depth - 2) + "1" + "]" * (depth - 2) + "}}"


@pytest.mark.parametrize("content_type", ["application/json", "Application/merge-patch+json; charset=utf-8"])
def test_a_json_body_nested_past_32_is_a_422_naming_the_limit(client, content_type):
    headers = {"Content-Type": content_type}
    r = client.post("/v1/swatch", content=nested(32), headers=headers)
    assert r.status_code == 422 and "scale" in r.json()["detail"], r.text[:300]  # parsed: the spec itself is wrong
    for depth in (33, 100_000):  # 100,000: json.loads would end in a RecursionError, FastAPI's bare 400
        r = client.post("/v1/swatch", content=nested(depth), headers=headers)
        assert r.status_code == 422 and r.json() == {"detail": f"request body: JSON nested {depth:,} deep: the limit is 32"}, r.text[:300]
    assert client.post("/v1/swatch", content='{"texture": "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[wood"}', headers=headers).status_code == 422
    assert client.post("/v1/swatch", content='{"texture": "wood", "size": 16}', headers=headers).status_code == 200


def test_a_json_body_over_a_megabyte_is_a_413(client):
    body = json.dumps({"texture": "wood", "pad": "x" * (1 << 20)})
    r = client.post("/v1/swatch", content=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 413 and r.json() == {"detail": "request body: JSON larger than the limit of 1048576 bytes"}


def test_the_settings_field_nested_past_32_is_a_422_naming_the_limit(client, meshes):
    for depth, words in [(32, "settings.size"), (33, "settings: JSON nested 33 deep: the limit is 32")]:
        settings = '{"size": ' + "[" * (depth - 1) + "1" + "]" * (depth - 1) + "}"
        with open(meshes / "suzanne.ply", "rb") as f:
            r = client.post("/v1/jobs", files={"mesh": ("suzanne.ply", f)}, data={"settings": settings})
        assert r.status_code == 422 and r.json()["detail"].startswith(words), r.text[:300]


SECURITY = {"x-content-type-options": "nosniff", "x-frame-options": "DENY", "referrer-policy": "no-referrer"}


def test_every_answer_has_the_security_headers(client, meshes):
    from texbake.service.core.config import get_settings

    answers = {
        "page": client.get("/"), "script": client.get("/static/app.js"), "docs": client.get("/docs"),
        "json": client.get("/v1/config"), "png": client.get("/v1/swatch", params={"texture": "wood", "size": 16}),
        "404": client.get("/v1/jobs/" + "0" * 32), "422": client.post("/v1/swatch", json={}),
        "413": client.post("/v1/jobs", content=b"x", headers={"Content-Length": str(get_settings().max_upload_bytes * 2)}),
    }
    client.app.add_api_route("/boom", lambda: 1 / 0)
    answers["500"] = TestClient(client.app, raise_server_exceptions=False).get("/boom")
    for what, r in answers.items():
        assert {k: r.headers.get(k) for k in SECURITY} == SECURITY, (what, r.status_code, dict(r.headers))
    assert [answers[s].status_code for s in ("404", "422", "413", "500")] == [404, 422, 413, 500]
    assert answers["script"].headers["content-type"].startswith(("text/javascript", "application/javascript"))  # nosniff: must be right
    assert "frame-ancestors 'none'" in answers["page"].headers["content-security-policy"]


def test_a_hostile_gltf_is_refused_at_upload(client, tmp_path):
    """Refused by the API's check of the upload (no bake slot is taken): 100,000 nested
    nodes, and a buffer that claims 2^40 bytes."""
    import struct

    def glb(doc):
        j = json.dumps(doc).encode()
        j += b" " * (-len(j) % 4)
        return struct.pack("<4sII", b"glTF", 2, 20 + len(j)) + struct.pack("<I4s", len(j), b"JSON") + j

    nodes = [{"children": [i + 1]} for i in range(99_999)] + [{}]
    for name, doc, words in [("deep.glb", {"asset": {"version": "2.0"}, "nodes": nodes}, "glTF nodes nest 100,000 deep: the limit is 64"),
                             ("claims.glb", {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 2**40}]},
                              "glTF buffer 0 claims 1,099,511,627,776 bytes but the file holds 0")]:
        (tmp_path / name).write_bytes(glb(doc))
        with open(tmp_path / name, "rb") as f:
            r = client.post("/v1/jobs", files={"mesh": (name, f)})
        assert r.status_code == 422 and r.json()["detail"] == f"mesh '{name}': {words}", r.text[:300]
