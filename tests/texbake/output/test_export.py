"""GLB and OBJ export: round trips, the V-flip convention, and the Khronos validator.

The validator is the npm package ``gltf-validator`` (pinned in tools/package.json),
run through ``node tools/validate-gltf.mjs FILE``; set up with ``npm ci`` in tools/
(``scripts/run`` does it). Without it these checks fail under CI=true and are skipped,
with the reason, elsewhere.
"""

import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import ROOT

import texbake
from texbake.errors import OutputError, ParameterError
from texbake.materials import BUILTINS
from texbake.output.export import write_glb, write_obj
from texbake.output.images import encode_png_bytes, read_image, write_image

TOOLS = ROOT / "tools"


def glb_parts(path):
    """The JSON document and the BIN chunk of a GLB, checking its framing on the way."""
    data = Path(path).read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert (magic, version, length) == (b"glTF", 2, len(data))
    n, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON" and n % 4 == 0
    text = data[20 : 20 + n]
    assert text == text.rstrip(b" ") + b" " * (len(text) - len(text.rstrip(b" ")))  # space padding
    doc = json.loads(text)
    m, kind = struct.unpack_from("<I4s", data, 20 + n)
    assert kind == b"BIN\0" and m % 4 == 0 and 28 + n + m == len(data)
    binary = data[28 + n :]
    assert doc["buffers"] == [{"byteLength": m}]
    return doc, binary


def view_bytes(doc, binary, index):
    view = doc["bufferViews"][index]
    start = view.get("byteOffset", 0)
    return binary[start : start + view["byteLength"]]


def accessor_array(doc, binary, index):
    acc = doc["accessors"][index]
    dtype = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}[acc["componentType"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[acc["type"]]
    return np.frombuffer(view_bytes(doc, binary, acc["bufferView"]), dtype, acc["count"] * width).reshape(acc["count"], width)


def glb_texture(path, tmp_path):
    """The base-colour image embedded in a GLB, decoded with OpenImageIO (to linear)."""
    doc, binary = glb_parts(path)
    texture = doc["textures"][doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"]]
    image = doc["images"][texture["source"]]
    assert image["mimeType"] == "image/png"
    png = tmp_path / "embedded.png"
    png.write_bytes(view_bytes(doc, binary, image["bufferView"]))
    return read_image(png)


def validate(path):
    """The Khronos glTF validator's report for a file."""
    script = TOOLS / "validate-gltf.mjs"
    if shutil.which("node") is None or not (TOOLS / "node_modules" / "gltf-validator").is_dir():
        message = (
            "the Khronos glTF validator is not set up: run `npm ci` in tools/ (scripts/run does it; "
            "needs node and npm)"
        )
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(message)
        pytest.skip(message)
    out = subprocess.run(["node", str(script), str(path)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, f"validator failed: {out.stderr}"
    return json.loads(out.stdout)


def assert_valid(path):
    report = validate(path)
    issues = report["issues"]
    listing = "\n".join(f"{m['severity']} {m['code']} {m.get('pointer', '')}: {m['message']}" for m in issues["messages"])
    assert issues["numErrors"] == 0, f"{issues['numErrors']} errors, {issues['numWarnings']} warnings:\n{listing}"
    return report


def unwelded_cube():
    """A unit cube, three vertices per triangle (nothing shared), random UVs."""
    box = trimesh.creation.box()
    v = box.vertices[box.faces].reshape(-1, 3)
    f = np.arange(len(v)).reshape(-1, 3)
    rng = np.random.default_rng(0)
    uv = rng.random((len(v), 2)) * 0.9 + 0.05
    normals = np.repeat(box.face_normals, 3, axis=0)
    return v, f, uv, normals


def test_glb_round_trip_and_validator(tmp_path):
    v, f, uv, _ = unwelded_cube()
    png = tmp_path / "t.png"
    write_image(png, np.full((8, 8, 3), 0.5, np.float32))
    info = write_glb(tmp_path / "c.glb", v, f, uv, png)
    assert info == {"path": str(tmp_path / "c.glb"), "bytes": (tmp_path / "c.glb").stat().st_size, "vertices": 36, "faces": 12}
    loaded = trimesh.load(tmp_path / "c.glb", force="mesh", process=False)
    assert np.allclose(loaded.vertices, v) and np.array_equal(loaded.faces, f)
    # trimesh flips V back on load; float32 in the file: half an ulp below 1 is 6e-8 (measured 3.6e-8)
    assert np.allclose(loaded.visual.uv, uv, rtol=0, atol=2e-7)
    report = assert_valid(tmp_path / "c.glb")
    assert report["info"]["hasTextures"] and report["info"]["totalVertexCount"] == 36


def test_glb_layout(tmp_path):
    v, f, uv, normals = unwelded_cube()
    write_glb(tmp_path / "c.glb", v, f, uv, encode_png_bytes(np.zeros((4, 4, 3), np.float32)), normals=normals * 3, name="cube")
    doc, binary = glb_parts(tmp_path / "c.glb")
    assert doc["asset"] == {"version": "2.0", "generator": "texbake"}
    assert doc["scenes"][doc["scene"]]["nodes"] == [0] and doc["nodes"][0] == {"mesh": 0, "name": "cube"}
    (prim,) = doc["meshes"][0]["primitives"]
    assert prim["mode"] == 4 and set(prim["attributes"]) == {"POSITION", "NORMAL", "TEXCOORD_0"}
    for view in doc["bufferViews"]:
        assert view["byteOffset"] % 4 == 0
        padding = binary[view["byteOffset"] + view["byteLength"] : view["byteOffset"] + view["byteLength"] + (-view["byteLength"] % 4)]
        assert padding == b"\0" * len(padding)
    position = doc["accessors"][prim["attributes"]["POSITION"]]
    assert position["min"] == [-0.5] * 3 and position["max"] == [0.5] * 3
    assert np.allclose(accessor_array(doc, binary, prim["attributes"]["POSITION"]), v)
    assert np.allclose(np.linalg.norm(accessor_array(doc, binary, prim["attributes"]["NORMAL"]), axis=1), 1, atol=1e-6)
    st = accessor_array(doc, binary, prim["attributes"]["TEXCOORD_0"])
    assert np.allclose(st, np.column_stack([uv[:, 0], 1 - uv[:, 1]]), atol=1e-7)  # glTF: t = 1 - v
    assert doc["accessors"][prim["indices"]]["componentType"] == 5123  # uint16: few vertices
    assert np.array_equal(accessor_array(doc, binary, prim["indices"]).reshape(-1, 3), f)
    material = doc["materials"][prim["material"]]["pbrMetallicRoughness"]
    assert material == {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0}
    assert doc["samplers"] == [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}]
    assert "target" not in doc["bufferViews"][doc["images"][0]["bufferView"]]
    loaded = trimesh.load(tmp_path / "c.glb", force="mesh", process=False)
    assert np.allclose(loaded.vertex_normals, normals, atol=1e-6)
    assert_valid(tmp_path / "c.glb")


def test_glb_with_uint32_indices(tmp_path):
    rng = np.random.default_rng(1)
    k = 3 * 22000  # 66000 unwelded vertices: above the uint16 range
    v = rng.random((k, 3))
    f = np.arange(k).reshape(-1, 3)
    uv = rng.random((k, 2))
    write_glb(tmp_path / "big.glb", v, f, uv, encode_png_bytes(np.ones((2, 2, 3), np.float32)))
    doc, binary = glb_parts(tmp_path / "big.glb")
    prim = doc["meshes"][0]["primitives"][0]
    assert doc["accessors"][prim["indices"]]["componentType"] == 5125
    assert np.array_equal(accessor_array(doc, binary, prim["indices"]).reshape(-1, 3), f)
    loaded = trimesh.load(tmp_path / "big.glb", force="mesh", process=False)
    assert np.array_equal(loaded.faces, f) and np.allclose(loaded.visual.uv, uv, rtol=0, atol=2e-7)  # float32: measured 4.5e-8
    assert_valid(tmp_path / "big.glb")


def test_glb_texture_orientation(tmp_path):
    # Paint each texel with a function of its own (u, v) (v up, row 0 at the top of the
    # image); after the GLB round trip, the texel at row (1 - v) * h, column u * w of the
    # embedded image must hold that function of each vertex's uv (as trimesh loads it).
    n = 64
    rows, cols = np.mgrid[0:n, 0:n]
    u_texel, v_texel = (cols + 0.5) / n, 1 - (rows + 0.5) / n
    img = np.zeros((n, n, 3), np.float32)
    img[..., 0] = u_texel
    img[..., 1] = v_texel
    img[..., 2] = 0.5 * u_texel * v_texel  # asymmetric: no flip or swap maps it to itself
    v, f, uv, _ = unwelded_cube()
    write_image(tmp_path / "uv.png", img, bits=16)
    write_glb(tmp_path / "c.glb", v, f, uv, tmp_path / "uv.png")
    tex = glb_texture(tmp_path / "c.glb", tmp_path)
    assert tex.shape == (n, n, 3)
    loaded = trimesh.load(tmp_path / "c.glb", force="mesh", process=False)
    got_uv = loaded.visual.uv
    r = np.clip(((1 - got_uv[:, 1]) * n).astype(int), 0, n - 1)
    c = np.clip((got_uv[:, 0] * n).astype(int), 0, n - 1)
    sampled = tex[r, c]
    expect = np.column_stack([uv[:, 0], uv[:, 1], 0.5 * uv[:, 0] * uv[:, 1]])
    assert np.abs(sampled - expect).max() < 1 / n  # within one texel
    assert np.abs(tex[0, :, 1] - (1 - 0.5 / n)).max() < 1e-4  # top row: v close to 1


def test_baked_glb_shows_the_texture_at_known_points(meshes, tmp_path):
    result = texbake.bake_mesh(meshes / "suzanne.ply", "position", size=256, texture_space="object")
    result.save(tmp_path)
    glb = tmp_path / "suzanne.glb"
    assert_valid(glb)
    loaded = trimesh.load(glb, force="mesh", process=False)
    tex = glb_texture(glb, tmp_path)
    # vertices' centroids per face: sample at their UVs, compare with the texture there
    uv = loaded.visual.uv[loaded.faces].mean(axis=1)
    p = loaded.vertices[loaded.faces].mean(axis=1)
    h, w = tex.shape[:2]
    got = tex[np.clip(((1 - uv[:, 1]) * h).astype(int), 0, h - 1), np.clip((uv[:, 0] * w).astype(int), 0, w - 1)]
    expect = texbake.textures.evaluate("position", p, bounds=result.report["mesh"]["bounds"])
    err = np.abs(got - expect).max(axis=1)
    # 8-bit sRGB quantisation (<= 0.02 in linear near 1) plus one texel of position
    assert np.median(err) < 0.02 and np.quantile(err, 0.95) < 0.05


def test_glb_bad_input_and_failures(tmp_path):
    v, f, uv, normals = unwelded_cube()
    png = encode_png_bytes(np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ParameterError, match="faces"):
        write_glb(tmp_path / "a.glb", v, f + 100, uv, png)
    with pytest.raises(ParameterError, match="uv"):
        write_glb(tmp_path / "a.glb", v, f, uv[:-1], png)
    with pytest.raises(ParameterError, match="vertices"):
        write_glb(tmp_path / "a.glb", np.full_like(v, np.nan), f, uv, png)
    with pytest.raises(ParameterError, match="normals"):
        write_glb(tmp_path / "a.glb", v, f, uv, png, normals=np.zeros_like(v))
    write_image(tmp_path / "t.exr", np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ParameterError, match="PNG"):
        write_glb(tmp_path / "a.glb", v, f, uv, tmp_path / "t.exr")
    with pytest.raises(OutputError, match="missing.png"):
        write_glb(tmp_path / "a.glb", v, f, uv, tmp_path / "missing.png")
    with pytest.raises(OutputError, match="nope"):
        write_glb(tmp_path / "nope" / "a.glb", v, f, uv, png)
    (tmp_path / "taken.glb").mkdir()
    with pytest.raises(OutputError, match="taken.glb"):
        write_glb(tmp_path / "taken.glb", v, f, uv, png)
    assert sorted(os.listdir(tmp_path)) == ["t.exr", "taken.glb"]  # no temporary file left


def test_obj_export(tmp_path):
    v, f, uv, _ = unwelded_cube()
    write_image(tmp_path / "albedo.png", np.zeros((4, 4, 3), np.float32))
    info = write_obj(tmp_path / "c.obj", v, f, uv, "albedo.png")
    assert info["mtl"] == "c.mtl" and info["vertices"] == 36 and info["faces"] == 12
    mtl = (tmp_path / "c.mtl").read_text()
    assert "map_Kd albedo.png\n" in mtl
    assert "mtllib c.mtl" in (tmp_path / "c.obj").read_text()
    loaded = trimesh.load(tmp_path / "c.obj", process=False)
    assert np.allclose(loaded.visual.uv[loaded.faces], uv[f], atol=1e-8)  # OBJ keeps v up
    assert np.allclose(loaded.vertices[loaded.faces], v[f], atol=1e-8)
    assert sorted(os.listdir(tmp_path)) == ["albedo.png", "c.mtl", "c.obj"]


def test_obj_with_normals_and_an_absolute_image_path(tmp_path):
    v, f, uv, normals = unwelded_cube()
    (tmp_path / "maps").mkdir()
    write_image(tmp_path / "maps" / "albedo.png", np.zeros((4, 4, 3), np.float32))
    write_obj(tmp_path / "c.obj", v, f, uv, tmp_path / "maps" / "albedo.png", normals=normals)
    assert "map_Kd maps/albedo.png\n" in (tmp_path / "c.mtl").read_text()  # relative to the OBJ
    loaded = trimesh.load(tmp_path / "c.obj", process=False)
    assert np.allclose(loaded.vertex_normals[loaded.faces], normals[f], atol=1e-6)
    assert np.allclose(loaded.visual.uv[loaded.faces], uv[f], atol=1e-8)


def test_missing_validator_fails_under_ci_and_skips_elsewhere(monkeypatch, tmp_path):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="npm ci"):
        validate(tmp_path / "x.glb")
    monkeypatch.delenv("CI")
    with pytest.raises(pytest.skip.Exception, match="npm ci"):
        validate(tmp_path / "x.glb")


def test_a_baked_glb_has_shading_normals_and_validates(meshes, tmp_path):
    """Every output GLB carries normals (split at hard edges), unit length; 0 validator issues."""
    import texbake

    result = texbake.bake_mesh(meshes / "fandisk.obj", "checker", size=64, margin=2)  # a CAD part with hard edges
    result.save(tmp_path)
    doc, binary = glb_parts(tmp_path / "fandisk.glb")
    attributes = doc["meshes"][0]["primitives"][0]["attributes"]
    assert "NORMAL" in attributes
    m = result.mesh
    assert m.normals is not None and m.normals.shape == m.vertices.shape
    assert np.abs(np.linalg.norm(m.normals, axis=1) - 1).max() < 1e-12
    report = assert_valid(tmp_path / "fandisk.glb")
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]


def test_glb_texture_slots_and_tangents(tmp_path):
    """Normal and emissive slots next to the base colour; one image per distinct PNG."""
    v, f, uv, normals = unwelded_cube()
    colour = encode_png_bytes(np.full((4, 4, 3), 0.25, np.float32))
    normal_map = encode_png_bytes(np.full((4, 4, 3), 0.5, np.float32), colorspace="data")
    tangents = np.column_stack([np.cross(normals, [0.6, 0.0, 0.8]), np.ones(len(v))])
    tangents[:, :3] /= np.linalg.norm(tangents[:, :3], axis=1, keepdims=True)
    write_glb(tmp_path / "c.glb", v, f, uv, {"baseColor": colour, "normal": normal_map, "emissive": colour},
              normals=normals, tangents=tangents)
    doc, binary = glb_parts(tmp_path / "c.glb")
    (material,) = doc["materials"]
    assert material["pbrMetallicRoughness"]["baseColorTexture"] == {"index": 0} == material["emissiveTexture"]
    assert material["normalTexture"] == {"index": 1} and material["emissiveFactor"] == [1.0, 1.0, 1.0]
    assert [t["source"] for t in doc["textures"]] == [0, 1] and len(doc["images"]) == 2
    assert view_bytes(doc, binary, doc["images"][1]["bufferView"]) == normal_map
    prim = doc["meshes"][0]["primitives"][0]
    acc = doc["accessors"][prim["attributes"]["TANGENT"]]
    assert acc["type"] == "VEC4" and acc["count"] == len(v)
    got = np.frombuffer(view_bytes(doc, binary, acc["bufferView"]), np.float32).reshape(-1, 4)
    assert np.allclose(got, tangents, rtol=0, atol=1e-7)  # float32
    report = assert_valid(tmp_path / "c.glb")
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]


def test_a_glb_of_a_normal_map_alone_has_a_plain_base_colour(tmp_path):
    """A bake of mesh maps only (texture none) has no colour map: its material is white with the normal texture."""
    v, f, uv, normals = unwelded_cube()
    normal_map = encode_png_bytes(np.full((4, 4, 3), 0.5, np.float32), colorspace="data")
    tangents = np.column_stack([np.cross(normals, [0.6, 0.0, 0.8]), np.ones(len(v))])
    tangents[:, :3] /= np.linalg.norm(tangents[:, :3], axis=1, keepdims=True)
    write_glb(tmp_path / "n.glb", v, f, uv, {"normal": normal_map}, normals=normals, tangents=tangents)
    doc, _ = glb_parts(tmp_path / "n.glb")
    (material,) = doc["materials"]
    assert "baseColorTexture" not in material["pbrMetallicRoughness"] and "baseColorFactor" not in material["pbrMetallicRoughness"]
    assert material["normalTexture"] == {"index": 0} and len(doc["images"]) == 1
    report = assert_valid(tmp_path / "n.glb")
    assert report["issues"]["numErrors"] == 0 and report["issues"]["numWarnings"] == 0, report["issues"]["messages"]


def test_glb_bad_slots_and_tangents(tmp_path):
    v, f, uv, normals = unwelded_cube()
    png = encode_png_bytes(np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ParameterError, match="clearcoat"):
        write_glb(tmp_path / "a.glb", v, f, uv, {"baseColor": png, "clearcoat": png})
    with pytest.raises(ParameterError, match="normal: expected a PNG"):
        write_glb(tmp_path / "a.glb", v, f, uv, {"baseColor": png, "normal": b"not a png"})
    tangents = np.tile([1.0, 0.0, 0.0, 1.0], (len(v), 1))
    with pytest.raises(ParameterError, match="tangents"):
        write_glb(tmp_path / "a.glb", v, f, uv, png, tangents=tangents)  # no normals
    with pytest.raises(ParameterError, match="tangents"):
        write_glb(tmp_path / "a.glb", v, f, uv, png, normals=normals, tangents=tangents * 2)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize(("settings", "maps"), [
    ({"texture": "marble", "bump": "turbulence"}, {"baseColor": "albedo.png", "normal": "normal.png"}),
    ({"texture": "flame", "frames": [0, 0.5], "shading": "full"}, {"baseColor": "albedo_0000.png", "emissive": "albedo_0000.png"}),
    ({"texture": "marble", "bump": "noise", "format": "exr"}, {"baseColor": "albedo_gltf.png", "normal": "normal_gltf.png"}),
    ({"texture": "flame", "format": "tif", "bits": 32}, {"baseColor": "albedo_gltf.png", "emissive": "albedo_gltf.png"}),
], ids=["bump", "flame-frames", "exr-bump", "tif-flame"])
def test_every_baked_glb_variant_binds_its_maps_and_validates(meshes, tmp_path, settings, maps):
    """The normal map as normalTexture (with the tangents it was baked in), the flame as
    emissive, PNG copies for other formats; each embedded image is the map's PNG, the
    normal map's tagged linear; Khronos validator 0 errors, 0 warnings."""
    result = texbake.bake_mesh(meshes / "suzanne.ply", size=32, margin=2, **settings)
    result.save(tmp_path)
    doc, binary = glb_parts(tmp_path / "suzanne.glb")
    (material,) = doc["materials"]
    slots = {"baseColor": material["pbrMetallicRoughness"]["baseColorTexture"], **{
        slot: material[f"{slot}Texture"] for slot in ("normal", "emissive") if f"{slot}Texture" in material}}
    assert set(slots) == set(maps)
    for slot, ref in slots.items():
        image = doc["images"][doc["textures"][ref["index"]]["source"]]
        assert view_bytes(doc, binary, image["bufferView"]) == (tmp_path / maps[slot]).read_bytes()
    assert material.get("emissiveFactor") == ([1.0, 1.0, 1.0] if "emissive" in maps else None)
    # the flame is light, not paint: no diffuse colour on top of its emission
    assert material["pbrMetallicRoughness"].get("baseColorFactor") == ([0.0, 0.0, 0.0, 1.0] if "emissive" in maps else None)
    attributes = doc["meshes"][0]["primitives"][0]["attributes"]
    assert ("TANGENT" in attributes) == ("normal" in maps) and "NORMAL" in attributes
    if "normal" in maps:
        assert png_chunks(tmp_path / maps["normal"]).get(b"gAMA") == struct.pack(">I", 100000)  # gamma 1.0: linear
        assert b"sRGB" not in png_chunks(tmp_path / maps["normal"])
    assert b"sRGB" in png_chunks(tmp_path / maps["baseColor"])
    report = assert_valid(tmp_path / "suzanne.glb")
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]


def png_chunks(path):
    """``{chunk type: data}`` of a PNG's chunks (the last of each type)."""
    data, p, chunks = Path(path).read_bytes(), 8, {}
    while p < len(data):
        n, kind = struct.unpack_from(">I4s", data, p)
        chunks[kind] = data[p + 8 : p + 8 + n]
        p += 12 + n
    return chunks


MATERIAL_SLOTS = {"baseColor": ("pbrMetallicRoughness", "baseColorTexture"),
                  "metallicRoughness": ("pbrMetallicRoughness", "metallicRoughnessTexture"),
                  "occlusion": ("occlusionTexture",), "normal": ("normalTexture",), "emissive": ("emissiveTexture",)}


def material_slots(material):
    """``{slot: texture index}`` of a glTF material's textures."""
    found = {}
    for slot, path in MATERIAL_SLOTS.items():
        node = material
        for key in path:
            node = node.get(key, {})
        if "index" in node:
            found[slot] = node["index"]
    return found


@pytest.mark.parametrize("name", sorted(BUILTINS))
def test_each_built_in_materials_glb_is_whole_and_validator_clean(meshes, tmp_path, name):
    """Every map the material has bound to its slot, each the map's own PNG (the ORM map as
    metallic-roughness and occlusion); Khronos validator 0 errors, 0 warnings."""
    result = texbake.bake_mesh(meshes / "suzanne.ply", material=name, size=64, margin=2)
    result.save(tmp_path)
    doc, binary = glb_parts(tmp_path / "suzanne.glb")
    (material,) = doc["materials"]
    slots = material_slots(material)
    maps = result.images
    expected = {"baseColor": "base_color.png", "metallicRoughness": "orm.png", **({"occlusion": "orm.png"} if "occlusion" in maps else {}),
                **({"normal": "normal.png"} if "normal" in maps else {}), **({"emissive": "emissive.png"} if "emissive" in maps else {})}
    assert set(slots) == set(expected)
    for slot, index in slots.items():
        image = doc["images"][doc["textures"][index]["source"]]
        assert view_bytes(doc, binary, image["bufferView"]) == (tmp_path / expected[slot]).read_bytes(), slot
    pbr = material["pbrMetallicRoughness"]
    assert (pbr["metallicFactor"], pbr["roughnessFactor"]) == (1.0, 1.0)  # the ORM map's values as they are
    assert material.get("emissiveFactor") == ([1.0, 1.0, 1.0] if "emissive" in maps else None)
    assert "alphaMode" not in material  # no opacity channel
    assert ("TANGENT" in doc["meshes"][0]["primitives"][0]["attributes"]) == ("normal" in maps)
    for data_map in ("orm", "normal", "roughness"):
        if (tmp_path / f"{data_map}.png").exists():
            assert b"sRGB" not in png_chunks(tmp_path / f"{data_map}.png")  # data: linear
    report = assert_valid(tmp_path / "suzanne.glb")
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]


def test_an_opacity_channel_is_the_base_colours_alpha_and_the_alpha_mode(meshes, tmp_path):
    material = {"base_color": [0.8, 0.2, 0.1], "opacity": {"op": "texture", "texture": "checker", "output": "value"},
                "alpha_mode": "mask", "alpha_cutoff": 0.4}
    result = texbake.bake_mesh(meshes / "suzanne.ply", material=material, size=32, margin=2, normal_convention="directx")
    result.save(tmp_path)
    doc, binary = glb_parts(tmp_path / "suzanne.glb")
    (glb_material,) = doc["materials"]
    assert (glb_material["alphaMode"], glb_material["alphaCutoff"]) == ("MASK", 0.4)
    rgba = glb_texture(tmp_path / "suzanne.glb", tmp_path)
    assert rgba.shape[2] == 4
    np.testing.assert_allclose(rgba[..., 3], result.images["opacity"][..., 0], rtol=0, atol=0.5 / 255)  # alpha: 8-bit, linear
    assert "metallicRoughness" not in material_slots(glb_material)  # no roughness, metallic or occlusion map: the factors
    assert (glb_material["pbrMetallicRoughness"]["metallicFactor"], glb_material["pbrMetallicRoughness"]["roughnessFactor"]) == (0.0, 1.0)
    report = assert_valid(tmp_path / "suzanne.glb")
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]
def test_a_glb_keeps_every_material_by_name_one_primitive_each(tmp_path):
    """Per material (the default) and with one texture set for the mesh: one primitive per
    material, each material by its name; validator-clean."""
    from conftest import two_material_scene

    import texbake

    scene = tmp_path / "cart.glb"
    two_material_scene(scene)
    per = texbake.bake_mesh(scene, "checker", size=32)
    per.save(tmp_path / "per")
    doc = _gltf(tmp_path / "per" / "cart.glb")
    assert sorted(m["name"] for m in doc["materials"]) == ["body", "wheels"] and len(doc["images"]) == 2
    assert assert_valid(tmp_path / "per" / "cart.glb")["issues"]["numWarnings"] == 0
    result = texbake.bake_mesh(scene, "checker", size=32, texture_set="single")
    assert len(result.sets) == 1 and result.images["albedo"].shape == (32, 32, 3)
    result.save(tmp_path / "one")
    assert sorted(p.name for p in (tmp_path / "one").iterdir()) == ["albedo.png", "cart.glb", "coverage.png", "report.json"]
    report = assert_valid(tmp_path / "one" / "cart.glb")
    doc = _gltf(tmp_path / "one" / "cart.glb")
    assert sorted(m["name"] for m in doc["materials"]) == ["body", "wheels"] and len(doc["images"]) == 1
    assert len(doc["meshes"][0]["primitives"]) == 2 and report["issues"]["numWarnings"] == 0


def _gltf(path):
    data = path.read_bytes()
    (length,) = struct.unpack_from("<I", data, 12)
    return json.loads(data[20 : 20 + length])


def test_each_texture_set_may_have_its_own_material(tmp_path):
    # a mesh of two materials: the body baked as rusted iron, the wheels as the texture; the
    # GLB a primitive each, the body's material whole, the wheels' the albedo alone
    from conftest import two_material_scene

    scene = tmp_path / "cart.glb"
    two_material_scene(scene)
    result = texbake.bake_mesh(scene, texture="marble", size=64, materials={"body": {"material": "rusted_iron"}})
    body, wheels = sorted(result.sets, key=lambda s: s.name)
    assert body.settings.material.nodes == BUILTINS["rusted_iron"]["nodes"] and wheels.settings.material is None
    assert {"base_color", "metallic", "orm", "normal"} <= set(body.images) and "albedo" in wheels.images
    (entry,) = [s for s in result.report["sets"] if s["name"] == "body"]
    assert entry["material"]["name"] == "rusted_iron" and "material" not in result.report  # several sets: each its own
    result.save(tmp_path / "out")
    doc, _ = glb_parts(tmp_path / "out" / "cart.glb")
    by_name = {m["name"]: m for m in doc["materials"]}
    assert "metallicRoughnessTexture" in by_name["body"]["pbrMetallicRoughness"] and "normalTexture" in by_name["body"]
    assert "metallicRoughnessTexture" not in by_name["wheels"]["pbrMetallicRoughness"]
    assert assert_valid(tmp_path / "out" / "cart.glb")["issues"]["numWarnings"] == 0
    assert json.loads((tmp_path / "out" / "report.json").read_text())["sets"][0]["outputs"]
