"""Loading and validating meshes: the real meshes, and every rejection."""

import bz2
import gzip
import hashlib
import io
import json
import lzma
import os
import struct
import tarfile
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import MESHES, glb_with_accessor, glb_with_image_uri
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from texbake.errors import MeshError, ParameterError
from texbake.mesh.load import load_mesh, mesh_from_trimesh

# faces, has UVs (from ../shared/meshes/SOURCES.md)
REAL = {
    "bunny.ply": (16301, False),
    "fandisk.obj": (5750, False),
    "featuretype.STL": (3476, False),
    "Duck.glb": (4212, True),
    "BoxTextured.glb": (12, True),
    "suzanne.ply": (968, True),
    "capsule.obj": (10200, True),
    "ico4uv.obj": (1280, True),
    "negative_indices.obj": (12, True),
    "soup.stl": (100, False),
    "busted.STL": (3878, False),
}


@pytest.mark.parametrize("name", sorted(REAL))
def test_real_meshes_load(meshes, name):
    faces, has_uv = REAL[name]
    m = load_mesh(meshes / name)
    assert len(m.faces) + m.removed_degenerate + m.removed_duplicate == faces
    assert (m.uv is not None) == has_uv
    assert m.vertices.dtype == np.float64 and m.faces.dtype == np.int64
    assert m.faces.max() < len(m.vertices) and np.isfinite(m.vertices).all()
    assert m.name == name.rsplit(".", 1)[0] and len(m.sha256) == 64


def test_capsule_degenerate_faces_are_removed_and_counted(meshes):
    m = load_mesh(meshes / "capsule.obj")
    assert m.removed_degenerate == 200
    t = m.vertices[m.faces]
    assert (np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1) > 0).all()


def test_scene_node_transforms_are_applied(meshes):
    scene = trimesh.load(meshes / "Duck.glb")
    m = load_mesh(meshes / "Duck.glb")
    # the same node transforms in float64: measured 0
    assert np.allclose([m.vertices.min(axis=0), m.vertices.max(axis=0)], scene.bounds, rtol=0, atol=1e-12)


def test_negative_indices_shared_file(meshes):
    m = load_mesh(meshes / "negative_indices.obj")
    # Resolved by hand: every v and vt line comes before the faces, so index -k is
    # element count - k; each quad is split as a fan (0, 1, 2), (0, 2, 3).
    text = (meshes / "negative_indices.obj").read_text().splitlines()
    v = np.array([line.split()[1:4] for line in text if line.startswith("v ")], float)
    vt = np.array([line.split()[1:3] for line in text if line.startswith("vt ")], float)
    corners = [[t.split("/") for t in line.split()[1:]] for line in text if line.startswith("f ")]
    pos = [[v[len(v) + int(c[0])] for c in q] for q in corners]
    tex = [[vt[len(vt) + int(c[1])] for c in q] for q in corners]
    fan = lambda q: [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    expect_pos = np.array([t for q in pos for t in fan(q)])
    expect_uv = np.array([t for q in tex for t in fan(q)])
    assert m.removed_degenerate == 0 and len(m.faces) == 12
    assert np.array_equal(m.vertices[m.faces], expect_pos)
    assert np.array_equal(m.uv[m.faces], expect_uv)


def test_negative_indices_interleaved(tmp_path):
    # v/f lines interleaved: -3 -2 -1 means the last three vertices *so far*
    obj = tmp_path / "inter.obj"
    obj.write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n"
        "v 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n"
    )
    m = load_mesh(obj)
    tris = sorted(tuple(map(tuple, m.vertices[f])) for f in m.faces)
    assert tris == [((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((5, 5, 5), (6, 5, 5), (5, 6, 5))]


def test_negative_texcoord_indices_interleaved(tmp_path):
    obj = tmp_path / "inter_vt.obj"
    obj.write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n"
        "v 5 5 5\nv 6 5 5\nv 5 6 5\nvt .5 .5\nvt .6 .5\nvt .5 .6\nf -3/-3 -2/-2 -1/-1\n"
        "f 1/4 2/5 3/6\n"  # positive indices mix old positions with new coordinates
    )
    m = load_mesh(obj)
    assert np.array_equal(m.vertices[m.faces], [[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[5, 5, 5], [6, 5, 5], [5, 6, 5]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    assert np.allclose(m.uv[m.faces], [[[0, 0], [1, 0], [0, 1]], [[.5, .5], [.6, .5], [.5, .6]], [[.5, .5], [.6, .5], [.5, .6]]])
    assert len(m.vertices) == 9  # same positions with other UVs stay separate (a seam)


def test_duck_has_uvs_and_file_hash(meshes):
    m = load_mesh(meshes / "Duck.glb")
    assert m.uv.shape == (len(m.vertices), 2) and m.uv.dtype == np.float64
    assert m.sha256 == hashlib.sha256((meshes / "Duck.glb").read_bytes()).hexdigest()
    assert m.path == str(meshes / "Duck.glb")


def test_mirroring_node_keeps_faces_outward():
    box = trimesh.creation.box()
    scene = trimesh.Scene()
    scene.add_geometry(box, transform=np.diag([-1.0, 1.0, 1.0, 1.0]))
    m = mesh_from_trimesh(scene)
    t = m.vertices[m.faces]
    normals = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    outward = (normals * (t.mean(axis=1) - m.vertices.mean(axis=0))).sum(axis=1)
    assert (outward > 0).all()


def test_scene_parts_are_joined_and_each_keeps_its_uvs():
    a = trimesh.creation.box()
    a.visual = trimesh.visual.TextureVisuals(uv=np.zeros((len(a.vertices), 2)))
    b = trimesh.creation.box()
    cloud = trimesh.PointCloud(np.random.default_rng(0).random((5, 3)))
    m = mesh_from_trimesh(trimesh.Scene([b, b.copy(), cloud]))
    assert len(m.faces) == 12 and m.removed_duplicate == 12 and m.uv is None  # the copy lies exactly on b
    # b lies on a, but a has UVs and b none: both stay (as a copy with other UVs does)
    m = mesh_from_trimesh(trimesh.Scene([a, b.copy(), cloud]))
    assert len(m.faces) == 24 and m.removed_duplicate == 0 and m.has_uv.tolist() == [True] * 12 + [False] * 12
    assert len(m.without_uv) == 1 and (m.uv[np.unique(m.faces[:12])] == 0).all() and np.isnan(m.uv[np.unique(m.faces[12:])]).all()
    b.visual = trimesh.visual.TextureVisuals(uv=np.ones((len(b.vertices), 2)))
    m = mesh_from_trimesh(trimesh.Scene([a, b]))
    assert m.uv is not None and len(m.uv) == len(m.vertices) and m.has_uv is None and m.without_uv == []
    with pytest.raises(MeshError, match="<mesh>: no faces"):
        mesh_from_trimesh(trimesh.Scene([cloud]))


def test_gltf_with_sibling_buffers_and_with_data_uris(meshes, tmp_path):
    scene = trimesh.load(meshes / "BoxTextured.glb")
    ref = load_mesh(meshes / "BoxTextured.glb")
    for folder, embed in [("files", False), ("embedded", True)]:
        (tmp_path / folder).mkdir()
        for name, data in trimesh.exchange.gltf.export_gltf(scene, embed_buffers=embed).items():
            (tmp_path / folder / name).write_bytes(data)
        m = load_mesh(tmp_path / folder / "model.gltf")
        assert len(m.faces) == 12 and m.uv is not None
        # the same triangles and texture coordinates as the GLB they were written from
        assert np.array_equal(m.vertices[m.faces], ref.vertices[ref.faces]) and np.array_equal(m.uv[m.faces], ref.uv[ref.faces])


def test_degenerate_faces_removed_and_counted(tmp_path):
    obj = tmp_path / "some_flat.obj"
    obj.write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\n"
        "f 1 2 3\nf 1 2 4\nf 1 1 3\nf 3 2 1\n"  # collinear, repeated corner
    )
    m = load_mesh(obj)
    assert m.removed_degenerate == 2 and len(m.faces) == 2
    assert np.array_equal(m.vertices[m.faces[:, 0]], [[0, 0, 0], [0, 1, 0]])


def test_ascii_and_binary_stl_and_off(tmp_path):
    box = trimesh.creation.box()
    for name, data in [("a.stl", trimesh.exchange.stl.export_stl_ascii(box)), ("b.stl", trimesh.exchange.stl.export_stl(box))]:
        (tmp_path / name).write_bytes(data.encode() if isinstance(data, str) else data)
        m = load_mesh(tmp_path / name)
        assert len(m.faces) == 12 and len(m.vertices) == 8  # welded
    (tmp_path / "c.off").write_text("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n")
    assert len(load_mesh(tmp_path / "c.off").faces) == 2


def test_in_memory_mesh():
    m = mesh_from_trimesh(trimesh.creation.icosphere(2), name="ball")
    assert m.path == "<mesh>" and len(m.faces) == 320 and m.name == "ball"


PLY = (
    "ply\nformat ascii 1.0\nelement vertex 3\nproperty {t} x\nproperty {t} y\nproperty {t} z\n"
    "element face 1\nproperty list uchar int vertex_indices\nend_header\n{v}\n{f}\n"
)


def tarred():
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w") as t:
        info = tarfile.TarInfo("a.obj")
        info.size = 8
        t.addfile(info, io.BytesIO(b"v 0 0 0\n"))
    return buf.getvalue()


def write(tmp_path, name, data):
    p = tmp_path / name
    p.write_bytes(data if isinstance(data, bytes) else data.encode())
    return p


def zipped():
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("a.obj", "v 0 0 0\n")
    return buf.getvalue()


def gltf_with(uri_buffer=None, uri_image=None):
    doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 36, "uri": uri_buffer or "data:application/octet-stream;base64," + "A" * 48}]}
    if uri_image:
        doc["images"] = [{"uri": uri_image}]
    return json.dumps(doc)


@pytest.mark.parametrize(
    "name, data, words",
    [
        ("empty.obj", "", "empty"),
        ("nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no faces"),
        ("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "non-finite"),
        ("inf.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n", "non-finite"),
        ("huge.obj", "v 0 0 1e39\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "float32"),
        ("huge_double.ply", PLY.format(t="double", v="0 0 0\n1 0 1e39\n0 1 0", f="3 0 1 2"), "float32"),
        ("huge_float.ply", PLY.format(t="float", v="0 0 0\n1 0 -1e39\n0 1 0", f="3 0 1 2"), "float32"),
        ("nan.ply", PLY.format(t="float", v="0 0 0\n1 nan 0\n0 1 0", f="3 0 1 2"), "non-finite"),
        ("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "out of range"),
        ("behind.obj", "v 0 0 0\nv 1 0 0\nf -3 -2 -1\nv 0 1 0\n", "out of range"),
        ("negative.ply", PLY.format(t="float", v="0 0 0\n1 0 0\n0 1 0", f="3 0 1 -1"), "out of range"),
        ("range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "range"),
        ("gzipped.obj", gzip.compress(b"v 0 0 0\n"), "archive"),
        ("xz.ply", lzma.compress(b"ply\n"), "archive"),
        ("seven.stl", b"7z\xbc\xaf\x27\x1c" + bytes(40), "archive"),
        ("rar.off", b"Rar!\x1a\x07\x01\x00" + bytes(40), "archive"),
        ("tarred.obj", tarred(), "archive"),
        ("archive.zip", zipped(), "archive"),
        ("url.obj", "mtllib http://example.com/m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "URL"),
        ("list.gltf", "[]", "not an object"),
        ("notjson.gltf", "{ nope", "gltf header"),
        ("badglb.glb", b"glTF" + bytes(30), "glb"),
        ("nomesh.gltf", json.dumps({"asset": {"version": "2.0"}}), "no faces"),
        ("corner.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 /3\n", "obj"),
        ("bigindex.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n", "obj"),
        ("binary.stl", b"\x00" * 80 + struct.pack("<I", 5) + bytes(20), "stl"),
        ("lying.stl", b"\x00" * 80 + struct.pack("<I", 2**32 - 1) + bytes(150), "header says 4,294,967,295 triangles"),
        ("huge.glb", glb_with_accessor(1_900_000_000), "asks for 1900000000 items (22,800,000,000 bytes)"),
        ("badaccessor.glb", glb_with_accessor("many"), "accessor 0 is malformed"),
        ("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "out of range"),
        ("range.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "out of range"),
        ("zipped.obj", zipped(), "archive"),
        ("packed.glb", gzip.compress(b"glTF...."), "archive"),
        ("packed.stl", bz2.compress(b"solid x"), "archive"),
        ("outside.obj", "mtllib ../outside.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "leaves"),
        ("absolute.obj", "mtllib /etc/passwd\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "leaves"),
        ("buffer.gltf", gltf_with(uri_buffer="../x.bin"), "leaves"),
        ("image.gltf", gltf_with(uri_image="file:///etc/passwd"), "URL"),
        ("remote.glb", glb_with_image_uri("http://example.com/a.png"), "URL"),
        ("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n", "degenerate"),
        ("garbage.ply", "ply\nthis is not a ply file\n", "ply"),
        ("mesh.xyz", "0 0 0\n", "unknown mesh format"),
    ],
)
def test_rejections_name_the_file_and_the_problem(tmp_path, name, data, words):
    path = write(tmp_path, name, data)
    with pytest.raises(MeshError) as info:
        load_mesh(path)
    message = str(info.value)
    assert name in message and words.lower() in message.lower(), message
    assert "\n" not in message


@pytest.mark.parametrize(
    "line",
    ["map_Kd /etc/passwd", "map_Kd -s 1 1 1 ../../etc/passwd", "bump sub/../../x.png", "norm C:\\x.png",
     "disp file:///etc/passwd", "map_Bump http://example.com/x.png"],
)
def test_mtl_texture_outside_the_folder(tmp_path, line):
    write(tmp_path, "m.mtl", f"newmtl a\n{line}\n")
    path = write(tmp_path, "m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match=r"m\.obj: .*(leaves|URL)"):
        load_mesh(path)


def test_references_inside_the_folder_are_fine(tmp_path):
    (tmp_path / "tex").mkdir()
    write(tmp_path, "m.mtl", "newmtl a\nmap_Kd -o 0 0 tex/a.png\nbump tex/./b.png\n")
    path = write(tmp_path, "m.obj", "mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert len(load_mesh(path).faces) == 1


@pytest.mark.skipif(not hasattr(os, "symlink"), reason="needs symbolic links")
def test_symbolic_link_out_of_the_folder(tmp_path):
    (tmp_path / "mesh").mkdir()
    write(tmp_path, "outside.mtl", "newmtl a\n")
    os.symlink(tmp_path / "outside.mtl", tmp_path / "mesh" / "m.mtl")
    path = write(tmp_path / "mesh", "m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match=r"m\.obj: mtllib 'm\.mtl' leaves .*link"):
        load_mesh(path)


def test_gltf_uri_escapes_and_percent_encoding(tmp_path):
    for uri, words in [("..%2Fx.bin", "leaves"), ("/abs/x.bin", "leaves"), ("file:x.bin", "URL")]:
        path = write(tmp_path, "b.gltf", gltf_with(uri_buffer=uri))
        with pytest.raises(MeshError, match=rf"b\.gltf: .*{words}"):
            load_mesh(path)


def test_not_a_file_and_bad_limit(tmp_path):
    (tmp_path / "dir.obj").mkdir()
    with pytest.raises(MeshError, match="dir.obj: not a file"):
        load_mesh(tmp_path / "dir.obj")
    for bad in (0, -5, 2.5, "10", True):
        with pytest.raises(ParameterError, match="max_faces"):
            load_mesh(tmp_path / "dir.obj", max_faces=bad)


def test_in_memory_limit_and_hash():
    ball = trimesh.creation.icosphere(1)
    a, b = mesh_from_trimesh(ball), mesh_from_trimesh(ball.copy())
    assert a.sha256 == b.sha256 and a.name == "mesh"
    with pytest.raises(MeshError, match="<mesh>: 80 faces is more than the limit of 79"):
        mesh_from_trimesh(ball, max_faces=79)
    ball.vertices[0] = np.nan
    with pytest.raises(MeshError, match="<mesh>: 1 vertices have non-finite"):
        mesh_from_trimesh(ball)


_SEEDS = {name: MESHES / name for name in ("negative_indices.obj", "BoxTextured.glb", "soup.stl", "suzanne.ply")}


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(sorted(_SEEDS)),
    cut=st.floats(0, 1),
    edits=st.lists(st.tuples(st.floats(0, 1), st.binary(min_size=1, max_size=6)), max_size=6),
)
def test_corrupt_files_raise_only_mesh_errors(name, cut, edits):
    data = bytearray(_SEEDS[name].read_bytes())
    for where, junk in edits:
        i = int(where * len(data))
        data[i : i + len(junk)] = junk
    data = bytes(data[: max(1, int(cut * len(data))) if cut < 0.5 else len(data)])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / name
        path.write_bytes(data)
        try:
            m = load_mesh(path)
        except MeshError as exc:
            assert str(exc).startswith(str(path) + ": ") and "\n" not in str(exc)
        else:
            assert np.isfinite(m.vertices).all() and m.faces.min() >= 0 and m.faces.max() < len(m.vertices)


def test_missing_file_and_face_limit(meshes, tmp_path):
    with pytest.raises(MeshError, match="nothing.obj: no such file"):
        load_mesh(tmp_path / "nothing.obj")
    with pytest.raises(MeshError, match="16301 faces is more than the limit of 1000"):
        load_mesh(meshes / "bunny.ply", max_faces=1000)


def test_duplicate_faces_removed_and_counted(tmp_path):
    """Every face doubled (the copy's corners rotated): one of each stays, the rest are
    counted; a flipped copy is a back face and stays."""
    s = trimesh.creation.icosphere(2)
    faces = np.concatenate([s.faces, np.roll(s.faces, 1, axis=1), s.faces[:8, ::-1]])
    path = tmp_path / "doubled.ply"
    trimesh.Trimesh(s.vertices, faces, process=False).export(path)
    mesh = load_mesh(path)
    assert len(mesh.faces) == len(s.faces) + 8 and mesh.removed_duplicate == len(s.faces)
    assert np.array_equal(mesh.faces[: len(s.faces)], s.faces) and np.array_equal(mesh.faces[len(s.faces):], s.faces[:8, ::-1])
    trimesh.Trimesh(s.vertices, s.faces, process=False).export(tmp_path / "single.ply")
    assert load_mesh(tmp_path / "single.ply").removed_duplicate == 0


def test_obj_groups_materials_and_a_missing_material_library(tmp_path):
    obj = tmp_path / "two.obj"
    body = ("mtllib two.mtl\nmtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
            "g top\nusemtl paint\nf 1/1 2/2 3/3 4/4\ng leg\nusemtl metal\nf 1 2 5\nusemtl ghost\nf 2 3 5\n")
    obj.write_text(body)
    (tmp_path / "two.mtl").write_text("newmtl paint\nKd 1 0 0\nnewmtl metal\nKd 0.5 0.5 0.5\n")
    m = load_mesh(obj)
    assert m.part_names == ["top", "leg"] and m.part.tolist() == [0, 0, 1, 1]
    assert m.material_names == ["paint", "metal", "ghost"] and m.material.tolist() == [0, 0, 1, 2]
    assert m.has_uv.tolist() == [True, True, False, False] and m.without_uv == ["leg"]
    assert len(m.warnings) == 2 and "'gone.mtl' (mtllib) is missing" in m.warnings[0] and "'ghost'" in m.warnings[1]


def test_gltf_materials_and_a_mesh_of_one_material():
    # a scene of three parts: two share the material "red", one has "blue"; a PLY is one material
    parts = [trimesh.creation.box(), trimesh.creation.box().apply_translation((3, 0, 0)), trimesh.creation.icosphere(1)]
    for p, name in zip(parts, ["red", "red", "blue"], strict=True):
        p.visual = trimesh.visual.TextureVisuals(uv=np.zeros((len(p.vertices), 2)), material=trimesh.visual.material.PBRMaterial(name=name))
    scene = trimesh.Scene(parts)
    m = mesh_from_trimesh(trimesh.load(trimesh.util.wrap_as_stream(scene.export(file_type="glb")), file_type="glb"))
    assert sorted(m.material_names) == ["blue", "red"]
    assert dict(zip(m.material_names, np.bincount(m.material).tolist(), strict=True)) == {"red": 24, "blue": 80}
    assert len(m.part_names) == 3 and m.part is not None
    ply = load_mesh(MESHES / "suzanne.ply")
    assert ply.material is None and ply.material_names == ["default"] and ply.part is None
