"""A glTF's node tree and buffers (texbake.mesh.load): hostile files refused before trimesh
parses them, with the file and the limit named; deep trees placed as trimesh places them,
in time linear in their depth."""

import base64
import json
import struct
import time

import numpy as np
import pytest
import trimesh

from texbake.errors import MeshError
from texbake.mesh.load import MAX_GLTF_DEPTH, MAX_GLTF_NODES, _world_transform, load_mesh

TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes() + np.array([0, 1, 2, 0], np.uint16).tobytes()


def gltf_doc(nodes, roots=(0,)):
    """A glTF of one triangle (mesh 0, its 44 bytes in buffer 0) and these nodes."""
    return {"asset": {"version": "2.0"}, "buffers": [{"byteLength": len(TRIANGLE)}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                          {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
            "nodes": nodes, "scenes": [{"nodes": list(roots)}], "scene": 0}


def glb(doc, binary=TRIANGLE) -> bytes:
    j = json.dumps(doc, separators=(",", ":")).encode()
    j += b" " * (-len(j) % 4)
    body = struct.pack("<I4s", len(j), b"JSON") + j + struct.pack("<I4s", len(binary), b"BIN\x00") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def chain(depth, leaves=1, turn=True):
    """``depth - 1`` nested nodes, each moved and (``turn``) rotated, and ``leaves`` mesh
    nodes under the deepest: every leaf ``depth`` deep."""
    move = {"translation": [0.01, 0.002, 0], **({"rotation": [0, 0.0998334, 0, 0.9950042]} if turn else {})}
    nodes = [{"children": [i + 1], **move} for i in range(depth - 2)]
    nodes.append({"children": list(range(depth - 1, depth - 1 + leaves)), **move})
    return nodes + [{"mesh": 0, "translation": [0, 0.001 * i, 0], "scale": [1, 1 + i / 7, 1]} for i in range(leaves)]


def refused(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data)
    began = time.monotonic()
    with pytest.raises(MeshError) as info:
        load_mesh(path)
    assert time.monotonic() - began < 10  # refused before any slow work
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)
    return str(info.value).removeprefix(f"{path}: ")


def test_a_tree_past_the_limits_or_not_a_tree_is_refused(tmp_path):
    nested = [{"children": [i + 1]} for i in range(99_999)] + [{"mesh": 0}]  # 2.3 MB
    assert refused(tmp_path, "deep.glb", glb(gltf_doc(nested))) == f"glTF nodes nest 100,000 deep: the limit is {MAX_GLTF_DEPTH}"
    assert refused(tmp_path, "deep65.glb", glb(gltf_doc(chain(MAX_GLTF_DEPTH + 1)))) == f"glTF nodes nest 65 deep: the limit is {MAX_GLTF_DEPTH}"
    flat = [{"mesh": 0}] * (MAX_GLTF_NODES + 1)
    assert refused(tmp_path, "wide.glb", glb(gltf_doc(flat))) == f"glTF has 100,001 nodes: the limit is {MAX_GLTF_NODES:,}"
    assert refused(tmp_path, "cycle.glb", glb(gltf_doc([{"mesh": 0}, {"children": [2]}, {"children": [1], "mesh": 0}]))) == \
        "glTF nodes form a cycle (a node is its own ancestor): the nodes must form trees"
    assert refused(tmp_path, "self.glb", glb(gltf_doc([{"mesh": 0}, {"children": [1]}]))).endswith("the nodes must form trees")
    assert refused(tmp_path, "shared.glb", glb(gltf_doc([{"children": [2]}, {"children": [2]}, {"mesh": 0}], roots=(0, 1)))) == \
        "glTF node 2 has two parents (nodes 0 and 1): the nodes must form trees"
    assert refused(tmp_path, "twice.glb", glb(gltf_doc([{"children": [1, 1]}, {"mesh": 0}]))) == "glTF node 0 lists its child 1 twice"
    for children in (["1"], [7], 1, [-1]):
        assert refused(tmp_path, "bad.glb", glb(gltf_doc([{"children": children}, {"mesh": 0}]))) == "glTF node 0 has malformed children"


def test_buffers_and_views_must_hold_what_they_claim(tmp_path):
    doc = gltf_doc([{"mesh": 0}])
    doc["buffers"][0]["byteLength"] = 2**40  # trimesh: a bare AssertionError
    assert refused(tmp_path, "claims.glb", glb(doc)) == "glTF buffer 0 claims 1,099,511,627,776 bytes but the file holds 44"
    doc = gltf_doc([{"mesh": 0}])
    doc["bufferViews"][1]["byteOffset"] = 40
    assert refused(tmp_path, "view.glb", glb(doc)) == "glTF buffer view 1 (bytes 40 to 46) lies outside its buffer of 44 bytes"
    doc["bufferViews"][1]["buffer"] = 3
    assert refused(tmp_path, "nobuffer.glb", glb(doc)) == "glTF buffer view 1 is malformed"
    doc = gltf_doc([{"mesh": 0}])
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(TRIANGLE[:40]).decode()
    assert refused(tmp_path, "short.gltf", json.dumps(doc).encode()) == "glTF buffer 0 claims 44 bytes but the file holds 40"
    doc["buffers"][0]["uri"] = "triangle.bin"
    assert refused(tmp_path, "missing.gltf", json.dumps(doc).encode()) == "glTF buffer file 'triangle.bin' is missing"
    (tmp_path / "triangle.bin").write_bytes(TRIANGLE)
    (tmp_path / "beside.gltf").write_text(json.dumps(doc))
    assert len(load_mesh(tmp_path / "beside.gltf").faces) == 1  # the same claims, held


def test_node_transforms_are_trimeshs_to_the_bit(meshes, tmp_path):
    """The transforms of every mesh node equal trimesh's own (``graph[node]``), bit for bit:
    leaves at depths 1 to 12, turned or not (trimesh leaves out near-identity matrices),
    and the shared glTF meshes."""
    files = [meshes / "Duck.glb", meshes / "BoxTextured.glb"]
    for depth in (1, 2, 3, 4, 5, 12):
        for turn in (True, False):
            files.append(tmp_path / f"chain{depth}{turn}.glb")
            nodes = chain(depth, leaves=3, turn=turn) if depth > 1 else [{"mesh": 0, "translation": [1, 2, 3]}]
            files[-1].write_bytes(glb(gltf_doc(nodes)))
    for path in files:
        scene = trimesh.load(path, process=False)
        for node in scene.graph.nodes_geometry:
            ours = _world_transform(scene.graph, node)
            theirs = trimesh.load(path, process=False).graph[node][0]  # a graph of its own: its cache holds what it computed
            assert np.array_equal(ours, theirs), (path.name, node, ours - theirs)
        assert not np.array_equal(_world_transform(scene.graph, scene.graph.nodes_geometry[0]), np.eye(4))


def test_a_deep_tree_loads_in_time_linear_in_its_depth(tmp_path):
    """500 meshes 64 deep: trimesh's own transforms search for the order of each path's
    matrix products, in time cubic in its length."""
    path = tmp_path / "deep.glb"
    path.write_bytes(glb(gltf_doc(chain(MAX_GLTF_DEPTH, leaves=500))))
    began = time.monotonic()
    mesh = load_mesh(path)
    assert time.monotonic() - began < 20
    assert len(mesh.faces) == 500


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_a_scene_keeps_the_uvs_of_the_parts_that_have_them(tmp_path, suffix):
    """A crate with UVs beside a ball without: the crate's faces keep their UVs (to float32),
    the ball's are marked as having none, named, and not welded to the crate's."""
    from conftest import mixed_uv_scene

    crate = mixed_uv_scene(tmp_path / f"scene{suffix}")
    m = load_mesh(tmp_path / f"scene{suffix}")
    assert m.has_uv is not None and m.has_uv.sum() == 12 and (~m.has_uv).sum() == 320
    assert m.without_uv == ["ball"] and m.warnings == []
    kept = m.faces[m.has_uv]
    assert np.array_equal(m.vertices[kept], crate["positions"])
    assert np.allclose(m.uv[kept], crate["uv"], atol=1e-7, rtol=0)
    assert np.isnan(m.uv[np.unique(m.faces[~m.has_uv])]).all()
    assert np.isfinite(m.uv[np.unique(kept)]).all()
    assert len(m.vertices) == 36 + 162  # the crate's corners split by UV; the ball's welded among themselves


def test_a_scene_whose_parts_all_have_uvs_or_none_has_no_mask(tmp_path):
    both = trimesh.Scene()
    both.add_geometry(trimesh.creation.icosphere(1), node_name="a")
    both.add_geometry(trimesh.creation.box(), node_name="b")
    both.export(tmp_path / "none.glb")
    m = load_mesh(tmp_path / "none.glb")
    assert m.uv is None and m.has_uv is None and m.without_uv == []
