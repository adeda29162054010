"""The PLY reader: triangle strips, polygons of mixed sizes, ASCII and binary, UVs."""

from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh

from texbake.errors import MeshError
from texbake.mesh.load import load_mesh
from texbake.mesh.plyfile import read_ply

# a strip of squares up the y axis, in the z = 0 plane: vertex 2k at (0, k), 2k+1 at (1, k)
GRID = np.array([(x, y, 0.0) for y in range(4) for x in range(2)])
STRIP = [0, 1, 2, 3, 4, 5, 6, 7]  # six triangles, all facing +z when read with alternating winding


def ply(fmt: str, elements: list[tuple[str, list[list[int]], list[int] | None]], uv: bool = False) -> bytes:
    """A PLY of ``GRID`` (with u, v = x, y when ``uv``) and ``elements``: (name, index lists,
    a uchar flag per row or None), ``fmt`` "ascii", "<" or ">" (binary endianness)."""
    head = ["ply", f"format {'ascii' if fmt == 'ascii' else 'binary_little_endian' if fmt == '<' else 'binary_big_endian'} 1.0",
            "comment made by the test", f"element vertex {len(GRID)}", "property float x", "property float y", "property double z"]
    head += ["property float u", "property float v"] if uv else []
    for name, lists, flags in elements:
        head += [f"element {name} {len(lists)}", "property list uchar int vertex_indices"]
        head += ["property uchar flag"] if flags is not None else []
    data = ("\n".join(head) + "\nend_header\n").encode()
    rows = [(*p, *p[:2]) if uv else tuple(p) for p in GRID]
    if fmt == "ascii":
        data += "".join(" ".join(f"{x:g}" for x in r) + "\n" for r in rows).encode()
        for _, lists, flags in elements:
            data += "".join(" ".join(map(str, [len(x), *x, *([flags[i]] if flags else [])])) + "\n" for i, x in enumerate(lists)).encode()
        return data
    vertex = np.dtype([("x", fmt + "f4"), ("y", fmt + "f4"), ("z", fmt + "f8")] + ([("u", fmt + "f4"), ("v", fmt + "f4")] if uv else []))
    data += np.array(rows, dtype=vertex).tobytes()
    for _, lists, flags in elements:
        for i, x in enumerate(lists):
            data += np.uint8(len(x)).tobytes() + np.array(x, dtype=fmt + "i4").tobytes() + (np.uint8(flags[i]).tobytes() if flags else b"")
    return data


def facing(v, f):
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])[:, 2]


@pytest.mark.parametrize("fmt", ["ascii", "<", ">"])
def test_triangle_strips_with_restarts_and_stitches(fmt):
    # two strips split by -1, then a strip with a stitch (a repeated corner) in one list
    strips = [[*STRIP[:4], -1, *STRIP[2:]], [0, 1, 1, 2, 3]]
    v, f, uv = read_ply(ply(fmt, [("tristrips", strips, None)]))
    assert np.array_equal(v, GRID) and uv is None
    assert len(f) == 2 + 4 + 1  # the stitches (two corners the same) left out
    assert (facing(v, f[:6]) > 0).all()  # alternating winding turned: all face one way
    assert f[6].tolist() == [1, 2, 3]  # third in its strip (two stitches before it): as written
    assert {tuple(sorted(t)) for t in f.tolist()} == {(0, 1, 2), (1, 2, 3), (2, 3, 4), (3, 4, 5), (4, 5, 6), (5, 6, 7)}


@pytest.mark.parametrize("fmt", ["ascii", "<", ">"])
def test_polygons_of_mixed_sizes_are_fans(fmt):
    # a triangle, a quad and a pentagon (convex), each row with a flag after its list
    polygons = [[0, 1, 3], [2, 3, 5, 4], [4, 5, 7, 6], [0, 1, 3, 5, 2]]
    v, f, uv = read_ply(ply(fmt, [("face", polygons, [1, 2, 3, 4])], uv=True))
    assert len(f) == 1 + 2 + 2 + 3
    assert f[:3].tolist() == [[0, 1, 3], [2, 3, 5], [2, 5, 4]]
    assert f[-3:].tolist() == [[0, 1, 3], [0, 3, 5], [0, 5, 2]]
    assert np.array_equal(uv, GRID[:, :2])


@pytest.mark.parametrize("fmt", ["ascii", "<"])
def test_triangles_read_as_trimesh_reads_them(fmt):
    faces = [[0, 1, 3], [0, 3, 2], [2, 3, 5], [2, 5, 4]]
    data = ply(fmt, [("face", faces, [7, 7, 7, 7])], uv=True)
    v, f, uv = read_ply(data)
    theirs = trimesh.load(io.BytesIO(data), file_type="ply", process=False)
    # trimesh leaves out the vertices no face uses
    assert np.array_equal(v[f], theirs.vertices[theirs.faces])
    assert np.array_equal(uv[f], theirs.visual.uv[theirs.faces])


def test_faces_with_their_own_texcoords_are_left_to_trimesh():
    data = ply("ascii", [("face", [[0, 1, 3]], None)]).replace(
        b"property list uchar int vertex_indices\n", b"property list uchar int vertex_indices\nproperty list uchar float texcoord\n")
    assert read_ply(data) is None


def test_a_strip_file_loads_as_a_mesh(tmp_path):
    # before, "no faces: the file holds no triangle geometry"
    path = tmp_path / "scan.ply"
    path.write_bytes(ply("<", [("tristrips", [[*STRIP, -1, 6, 7, 4]], None)]))
    m = load_mesh(path)
    assert len(m.faces) == 7 and m.removed_degenerate == 0
    assert (facing(m.vertices, m.faces)[:6] > 0).all()


def test_a_truncated_binary_file_is_an_error(tmp_path):
    path = tmp_path / "cut.ply"
    path.write_bytes(ply("<", [("face", [[0, 1, 3], [2, 3, 5, 4]], None)])[:-3])
    with pytest.raises(MeshError, match="cut.ply: cannot parse PLY file"):
        load_mesh(path)
