"""The OBJ reader: corner formats, polygons, relative indices, seams."""

from pathlib import Path

import numpy as np
import pytest

from bake.errors import MeshError
from bake.objfile import read_obj

QUAD = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"


def read(text):
    return read_obj(text.encode(), Path("t.obj"), lambda name, what: None)


@pytest.mark.parametrize(
    "face, has_uv",
    [("f 1 2 3 4", False), ("f 1/1 2/2 3/3 4/4", True), ("f 1//1 2//1 3//1 4//1", False),
     ("f 1/1/1 2/2/1 3/3/1 4/4/1", True), ("f 1/1/1 2//1 3/3 4", False), ("f -4/-4 -3/-3 -2/-2 -1/-1", True)],
)
def test_corner_formats_and_quad_fan(face, has_uv):
    v, f, uv = read(QUAD + face + "\n")
    assert f.shape == (2, 3)
    assert np.array_equal(v[f], np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0]] + [[0, 0, 0], [1, 1, 0], [0, 1, 0]], float).reshape(2, 3, 3))
    assert (uv is not None) == has_uv
    if has_uv:
        assert np.array_equal(uv, v[:, :2])


def test_seams_split_vertices_by_texcoord():
    text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\nf 1/1 2/2 3/3\nf 2/4 4/2 3/3\n"
    v, f, uv = read(text)
    assert len(v) == 5  # vertex 2 carries two texture coordinates
    assert np.array_equal(v[f[1, 0]], [1, 0, 0]) and np.array_equal(uv[f[1, 0]], [0.5, 0.5])


@pytest.mark.parametrize(
    "text, words",
    [("v 0 0 0\nf 1 2 3\n", "out of range"), ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "out of range"),
     ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n", "out of range"), ("v 0 0 0\nf 1 x 3\n", "bad face index"),
     ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf /3 1 2\n", "bad face index"),
     ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 99999999999999999999 1 2\n", "bad face index"),
     ("v 0 0\nf 1 1 1\n", "x, y and z"), ("v 0 0 zero\n", "bad coordinate"), ("v 0 0 0\nf 1 1\n", "at least 3")],
)
def test_bad_files(text, words):
    with pytest.raises(MeshError, match=words):
        read(text)


def test_indented_lines_tabs_long_rows_and_short_texcoords():
    # what other writers produce: indentation, tabs, vertex colours after x y z, a "vt u"
    text = "  v 0 0 0 1 0 0\nv\t1 0 0\n\tv 0 1 0 0.5 0.5 0.5\nvt 0.25\nvt 1 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"
    v, f, uv = read(text)
    assert np.array_equal(v[f[0]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    assert np.array_equal(uv[f[0]], [[0.25, 0], [1, 1], [0, 1]])
