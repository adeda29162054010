"""The OBJ reader: corner formats, polygons, relative indices, seams."""

import sys
from pathlib import Path

import numpy as np
import pytest

from texbake import _native
from texbake.errors import MeshError
from texbake.mesh.objfile import _ODD_SPACE, ObjMesh, _marked, _read_fast, _read_lines, read_obj

QUAD = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n"


def read(text):
    return read_obj(text.encode(), Path("t.obj"), lambda name, what: None)[:3]


def read_all(text):
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


# The bulk reader (_read_fast) against the line reader (_read_lines, today's reader): the
# same arrays bit for bit, or the bulk reader gives up (None) and the line reader decides.

def both(text):
    """Whether the bulk reader took ``text``, and the line reader's mesh; the compiled reader
    (``native/objfile.cpp``), where it takes the text, gives the line reader's arrays too."""
    data = text.encode() if isinstance(text, str) else text
    names = []
    slow = _read_lines(data, "t.obj", lambda name, what: names.append(name))
    fast = _read_fast(data)
    compiled = _native.read_obj(data)
    taken = [] if fast is None else [fast]
    if compiled is not None:
        mtllibs, vertices, faces, uv, marks = compiled
        taken.append((mtllibs, ObjMesh(vertices, faces, uv, None, *_marked(marks, len(faces)))))
    for mtllibs, mesh in taken:
        assert mtllibs == names
        for a, b in zip(mesh, slow, strict=True):
            assert (a is None) == (b is None)
            if isinstance(a, list):
                assert a == b
            elif a is not None:
                assert a.shape == b.shape and a.tobytes() == np.asarray(b, dtype=a.dtype).tobytes()
    return fast is not None, slow[:3]


TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"


@pytest.mark.parametrize(
    "text",
    [QUAD + "f 1 2 3 4\n", QUAD + "f 1/1 2/2 3/3 4/4", QUAD + "f 1//1 2//1 3//1 4//1\n", QUAD + "f 1/1/1 2/2/1 3/3/1 4/4/1\n",
     QUAD + "f -4/-4 -3/-3 -2/-2 -1/-1\n", QUAD + "f 1 2 3\nf 1 3 4\nf 1 2 3 4\nf 4 3 2 1\n",
     "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -4 -3 -1\nv 6 6 6\nf 1 -1 -2\n",  # interleaved, relative
     "v 0 0 0\nvt 0 0\nv 1 0 0\nvt 1 0\nv 0 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\nvt 0.5 0.5\nf 1/-1 2/1 3/2\n",
     "o a\ng b\ns 1\nusemtl m\nvn 0 0 1\nvp 1 2\nvtx 5 5\n" + TRIANGLE + "f 1/1/1 2/2/1 3/3/1\n",
     "mtllib a.mtl  b.mtl\n" + TRIANGLE + "mtllib c.mtl\nmtllibs d.mtl\nf 1/1 2/2 3/3\n",
     "v 0 0 0\nv 1 0 0\nv 0 1 0\n", "", "\n\n", "# nothing\n",
     "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0.5 0.5 0.5 1\nvt 0.25\nvt 1 1 0\nvt\nf 1/1 2/2 3/3\n",  # rows of other lengths
     "  v 0 0 0\n\tv 1 0 0\n \t v 0 1 0\n    \nf  1   2\t3  \n",  # indentation, runs of spaces and tabs
     QUAD + "\to  Suzanne   one\nusemtl\tMat\nf 1 2 3 4\n",  # an object and its material before every face (one name each)
     QUAD + "g\nf 1 2 3\nusemtl a\ng b\nf 1 2 3 4\ng\r\nusemtl\nf 2 3 4\n",  # names left empty: "default"
     "v 0 0 0 # comment\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a comment after the numbers (the line reader skips fields past x, y, z when rows differ)
     "# caf\u00e9 \u2014 \u4e2d \U0001F600\nmtllib caf\u00e9.mtl\n" + TRIANGLE + "f 1 2 3\n"],
)
def test_bulk_reader_agrees_with_line_reader(text):
    both(text)


@pytest.mark.parametrize("end", ["\n", "\r\n", "\r"])
def test_line_ends_blank_lines_and_comments(end):
    text = "# a comment\n\n" + TRIANGLE + "\n# f 9 9 9\nf 1/1 2/2 3/3   \n\nf 3/3 2/2 1/1"
    taken, (v, f, uv) = both(text.replace("\n", end).encode())
    assert taken and _native.read_obj(text.replace("\n", end).encode()) is not None
    ref = read(TRIANGLE + "f 1/1 2/2 3/3\nf 3/3 2/2 1/1\n")
    assert all(np.array_equal(a, b) for a, b in zip((v, f, uv), ref, strict=True))


@pytest.mark.parametrize("exponents", [False, True])
def test_numbers_exactly_as_float(exponents):
    # without exponents the bulk reader's own path (digits / 10**places), with them numpy's parser
    rng = np.random.default_rng(7)
    x = rng.uniform(-1e4, 1e4, 500) * 10.0 ** rng.integers(-12, 8, 500)
    words = [f"{a:.6f}" for a in x[:100]] + [f"{a:.20f}" for a in x[100:200]] + [f"{a:.0f}." for a in x[200:300]]
    words += ["-0.000", "-0", "+1.5", ".5", "-.5", "5.", "007", "9007199254740992", "9007199254740993",
              "0.9007199254740993", "0." + "0" * 21 + "1", "0." + "0" * 22 + "1", "123456789012345678901234567890"]
    if exponents:
        words += [repr(float(a)) for a in x[300:400]] + [f"{a:.17e}" for a in x[400:]]
        words += ["1e-320", "4.9e-324", "2.4703282292062328e-324", "1e400", "-1E+2", "-0e0"]
    words += ["0"] * (-len(words) % 3)
    text = "".join(f"v {' '.join(words[i : i + 3])}\n" for i in range(0, len(words), 3))
    taken, (v, _, _) = both(text)
    assert taken
    assert v.ravel().tobytes() == np.array([float(w) for w in words]).tobytes()


@pytest.mark.parametrize(
    "text",
    ["v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "v 0 0 1_0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # float() takes these
     "v 0 0 0 x\nv 1 0 0\nv 0 1 0 0\nf 1 2 3\n",  # an unused fifth field, not a number
     QUAD + "f 1/1/1 2//1 3/3 4\n", QUAD + "f 1/ 2/ 3/ 4/\n",  # corners not all alike
     "# form feed\f" + TRIANGLE + "f 1 2 3\n", TRIANGLE + "# \u2028f 1 2 3\n",  # line breaks to str.splitlines()
     TRIANGLE + "f 1\u00a02 3 1\n", TRIANGLE + "f 1 2 3\v\n"],
)
def test_what_the_bulk_reader_leaves_to_the_line_reader(text):
    taken, _ = both(text)
    assert not taken and _native.read_obj(text.encode()) is None


def _random_obj(rng) -> str:
    """An OBJ of random elements, number formats, corner forms, relative indices, polygons,
    other lines, indentation, tabs and line ends (rarely an index out of range)."""
    nv, nvt = int(rng.integers(3, 30)), int(rng.integers(0, 30))
    form = str(rng.choice(["{v}", "{v}/{t}", "{v}//1", "{v}/{t}/1"] if nvt else ["{v}", "{v}//1"]))
    ops = ["v"] * nv + ["vt"] * nvt + ["f"] * int(rng.integers(1, 20)) + ["o"] * int(rng.integers(0, 3))
    ops = ["v", "v", "v", "vt"] + [ops[i] for i in rng.permutation(len(ops))]
    lines, defined = [], {"v": 0, "vt": 0}
    formats = ["%.7f", "%.17g", "%g", "%e", "%.3E", "%+.4f", "%.0f", "%.1f"]
    for op in ops:
        gap = str(rng.choice([" ", "  ", "\t"]))
        if op in defined:
            count = (3 if rng.random() < 0.9 else int(rng.choice([4, 6]))) if op == "v" else int(rng.choice([2, 2, 2, 0, 1, 3]))
            numbers = [str(rng.choice(formats)) % (rng.uniform(-10, 10) * 10.0 ** rng.integers(-6, 6)) for _ in range(count)]
            lines.append((op + gap + gap.join(numbers)).rstrip())
            defined[op] += 1
        elif op == "o":
            lines.append(str(rng.choice(["o thing", "# a comment", "g grp", "s off", "usemtl m", "vn 0 0 1", "", "   ", "mtllib a.mtl"])))
        elif defined["v"] and defined["vt"]:
            corners = []
            for _ in range(int(rng.choice([3, 3, 4, 5]))):
                v = -int(rng.integers(1, defined["v"] + 1)) if rng.random() < 0.2 else int(rng.integers(1, nv + 4))  # 3 more: the first ops
                v = nv + 4 if rng.random() < 0.005 else v  # past the last vertex
                t = -int(rng.integers(1, defined["vt"] + 1)) if rng.random() < 0.2 else int(rng.integers(1, max(nvt, 1) + 1))
                corners.append(form.format(v=v, t=t))
            lines.append("f" + gap + gap.join(corners))
        if rng.random() < 0.05:
            lines[-1] = "  " + lines[-1]
    end = str(rng.choice(["\n", "\r\n", "\r"]))
    return end.join(lines) + end


def test_the_compiled_reader_reads_random_files_as_the_line_reader():
    rng = np.random.default_rng(11)
    taken = 0
    for _ in range(400):
        text = _random_obj(rng)
        try:
            both(text)  # the compiled reader's arrays, where it takes the file, are the line reader's
        except MeshError:  # the line reader refuses it: so must the compiled one
            assert _native.read_obj(text.encode()) is None
        taken += _native.read_obj(text.encode()) is not None
    assert 300 < taken < 400  # most files are plain, some index past the end: measured 340 of 400


def test_backslash_does_not_continue_a_line():
    # as today: a trailing backslash is part of the last field
    with pytest.raises(MeshError, match="bad face index"):
        read(TRIANGLE + "f 1 2 \\\n3\n")
    with pytest.raises(MeshError, match="bad coordinate"):
        read("v 0 0 \\\n0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")


def test_errors_name_the_line_with_crlf_and_indentation():
    with pytest.raises(MeshError, match="line 4: vertex index 4 out of range"):
        read("v 0 0 0\r\n  v 1 0 0\r\n\tv 0 1 0\r\nf 1 2 4\r\n")


def test_odd_space_is_what_str_isspace_adds():
    spaces = {chr(c) for c in range(sys.maxunicode + 1) if chr(c).isspace()}
    assert set(_ODD_SPACE) == spaces - set(" \t\r\n")


@pytest.mark.parametrize("corner", ["{i}/{i}/{n}", "{i}//{n}", "{i}/{i}"])
def test_polygons_with_texture_and_normal_indices_are_fans(corner):
    # a convex pentagon and a triangle, corners with texture and normal indices as exporters write them
    text = ("v 0 0 0\nv 2 0 0\nv 3 1 0\nv 1 2 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 0.5\nvt 0.5 1\nvt 0 0.5\nvn 0 0 1\nvn 0 0 -1\n"
            "f " + " ".join(corner.format(i=i, n=1) for i in range(1, 6)) + "\n"
            "f " + " ".join(corner.format(i=i, n=2) for i in (1, 2, 3)) + "\n")
    v, f, uv = read(text)
    assert f.shape == (4, 3)
    assert np.array_equal(v[f[:3]][:, :, 0], [[0, 2, 3], [0, 3, 1], [0, 1, -1]])  # fan from the first corner
    assert (uv is not None) == ("/{i}" in corner)
    if uv is not None:
        assert np.array_equal(uv[f[:3]], [[[0, 0], [1, 0], [1, 0.5]], [[0, 0], [1, 0.5], [0.5, 1]], [[0, 0], [0.5, 1], [0, 0.5]]])


def test_groups_and_materials_name_each_face():
    # g/o lines name parts, usemtl lines materials, each in order of first use; "default" before any
    text = (QUAD + "v 2 0 0\nf 1 2 3\ng side\nusemtl red\nf 1 2 3 4\no other\nusemtl blue paint\nf 2 5 3\n"
            "g side\nusemtl red\nf 3 4 1\n")
    for taken, mesh in [(True, _read_fast(text.encode())[1]), (False, read_all(text))]:
        assert mesh.part_names == ["default", "side", "other"] and mesh.part.tolist() == [0, 1, 1, 2, 1], taken
        assert mesh.material_names == ["default", "red", "blue paint"] and mesh.material.tolist() == [0, 1, 1, 2, 1]
        assert mesh.has_uv is None and mesh.uv is None
    assert _native.read_obj(text.encode()) is not None
    both(text)  # the compiled reader's marks label the faces as both readers here do


def test_texture_coordinates_of_some_groups_are_kept():
    # a group with vt and a group without: the first keeps its UVs (the second's vertices get NaN)
    text = QUAD + "v 2 0 0\ng textured\nf 1/1 2/2 3/3 4/4\ng bare\nf 2 5 3\n"
    mesh = read_all(text)
    assert mesh.has_uv.tolist() == [True, True, False] and mesh.part.tolist() == [0, 0, 1]
    corners = mesh.uv[mesh.faces]
    assert np.array_equal(corners[:2], mesh.vertices[mesh.faces[:2]][:, :, :2]) and np.isnan(corners[2]).all()
    both(text)  # the line reader alone reads it (corners not all alike)


@pytest.mark.parametrize("end", ["\n", "\r\n"])
def test_a_file_of_megabytes_is_read_in_two_pieces_as_in_one(end):
    # past 4 MiB the compiled reader parses two halves at once: relative indices across the
    # cut count back into the first half, and the arrays are the bulk reader's bit for bit
    rng = np.random.default_rng(5)
    blocks = 40_000  # each: 3 positions, 3 texcoords, a triangle of relative and a quad of absolute indices
    xyz, uv = rng.random((blocks, 9)), rng.random((blocks, 6))
    absolute = rng.integers(1, 3 * np.arange(1, blocks + 1)[:, None] + 1, (blocks, 8))  # defined so far
    block = ("v %.6f %.6f %.6f\n" * 3 + "vt %.6f %.6f\n" * 3 + "f -1/-3 -2/-2 -3/-1\n" + "f" + " %d/%d" * 4 + "\n")
    text = "".join(block % (*a, *b, *c) for a, b, c in zip(xyz, uv, absolute, strict=True)).replace("\n", end)
    data = text.encode()
    assert len(data) > 2**22
    fast, compiled = _read_fast(data), _native.read_obj(data)
    assert fast is not None and compiled is not None
    for a, b in zip(compiled[1:4], fast[1][:3], strict=True):
        assert a.shape == b.shape and a.tobytes() == np.asarray(b, dtype=a.dtype).tobytes()
