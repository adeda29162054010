"""Loading and validating meshes: the real meshes, and every rejection."""

import bz2
import gzip
import io
import json
import struct
import zipfile

import numpy as np
import pytest
import trimesh

from bake.errors import MeshError
from bake.load import load_mesh, mesh_from_trimesh

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
    assert len(m.faces) + m.removed_degenerate == faces
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
    assert np.allclose([m.vertices.min(axis=0), m.vertices.max(axis=0)], scene.bounds, atol=1e-5)


def test_negative_indices_shared_file(meshes):
    m = load_mesh(meshes / "negative_indices.obj")
    # the file's faces written with absolute indices: quads of the unit cube
    text = (meshes / "negative_indices.obj").read_text().splitlines()
    v = np.array([list(map(float, l.split()[1:4])) for l in text if l.startswith("v ")])
    quads = [[len(v) + int(t.split("/")[0]) for t in l.split()[1:]] for l in text if l.startswith("f ")]
    expect = {frozenset(map(tuple, v[q])) for q in quads}
    # every loaded triangle lies within one of the expected quads
    for tri in m.vertices[m.faces]:
        assert any(set(map(tuple, tri)) <= quad for quad in expect)
    assert np.allclose(np.abs(m.vertices), 1)


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


def glb_with_image_uri(uri):
    doc = json.dumps({"asset": {"version": "2.0"}, "images": [{"uri": uri}]}).encode()
    doc += b" " * (-len(doc) % 4)
    return struct.pack("<4sII", b"glTF", 2, 20 + len(doc)) + struct.pack("<I4s", len(doc), b"JSON") + doc


@pytest.mark.parametrize(
    "name, data, words",
    [
        ("empty.obj", "", "empty"),
        ("nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no faces"),
        ("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "non-finite"),
        ("inf.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 inf\n0 1 0\n3 0 1 2\n", "non-finite"),
        ("huge.obj", "v 0 0 1e39\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "float32"),
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


def test_mtl_texture_outside_the_folder(tmp_path):
    write(tmp_path, "m.mtl", "newmtl a\nmap_Kd -s 1 1 1 ../../etc/passwd\n")
    path = write(tmp_path, "m.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match="m.obj.*leaves"):
        load_mesh(path)


def test_missing_file_and_face_limit(meshes, tmp_path):
    with pytest.raises(MeshError, match="nothing.obj: no such file"):
        load_mesh(tmp_path / "nothing.obj")
    with pytest.raises(MeshError, match="16301 faces is more than the limit of 1000"):
        load_mesh(meshes / "bunny.ply", max_faces=1000)
