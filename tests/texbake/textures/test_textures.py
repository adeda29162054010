import numpy as np
import pytest
import trimesh

from texbake.errors import TextureError
from texbake.textures import evaluate, parse_spec
from texbake.textures.basic import checker_parity


def brute_force_mean(centre, dpdx, dpdy, box, n=2000):
    """Mean of the point-sampled checker over the footprint parallelogram (midpoint rule).

    Its error is below about 1 / n per line the footprint crosses: 5e-4 here.
    """
    s = (np.arange(n) + 0.5) / n - 0.5
    a, b = np.meshgrid(s, s)
    pts = centre + a.ravel()[:, None] * dpdx + b.ravel()[:, None] * dpdy
    return checker_parity(pts, box).mean()


def test_filtered_checker_matches_numerical_integration_on_a_plane():
    # Axis-aligned footprints on the plane z = 0.3 (the box filter is then exact).
    rng = np.random.default_rng(7)
    box = np.array([0.25, 0.5, 1.0])
    for _ in range(10):
        c = np.array([*(rng.random(2) * 4 - 2), 0.3])
        dx = np.array([rng.random() * 0.6, 0, 0])
        dy = np.array([0, rng.random() * 0.9, 0])
        ours = checker_parity(c[None], box, dx[None], dy[None])[0]
        assert abs(ours - brute_force_mean(c, dx, dy, box)) < 1e-3  # stated tolerance


def test_filtered_checker_stays_on_an_oblique_texel():
    # Footprints on planes at random angles: the sub-parallelograms' boxes hug the plane.
    # One box around the whole footprint (the old filter) errs 0.117 RMS here, max 0.68.
    rng = np.random.default_rng(3)
    errors = []
    for _ in range(60):
        c, normal = rng.random(3) * 4, rng.normal(size=3)
        u = np.cross(normal, [1.0, 0, 0])
        u /= np.linalg.norm(u)
        v = np.cross(normal / np.linalg.norm(normal), u)
        w = rng.random() * 0.5 + 0.05  # up to half a cell
        dx, dy = u * w, v * w * (0.3 + rng.random())
        ours = checker_parity(c[None], np.ones(3), dx[None], dy[None])[0]
        errors.append(ours - brute_force_mean(c, dx, dy, np.ones(3), n=400))
    assert np.sqrt(np.mean(np.square(errors))) < 0.02 and np.abs(errors).max() < 0.15  # measured 0.011, 0.10


def test_checker_on_integer_planes_is_clean():
    # Points on z = 0 and on the faces x = +-1 of a cube centred at the origin, with
    # last-bit rounding noise, must all fall on one side of the lattice plane.
    rng = np.random.default_rng(0)
    xy = rng.random((2000, 2)) * 0.9 + 0.05
    for plane_axis, level in [(2, 0.0), (0, 1.0), (0, -1.0)]:
        p = np.zeros((2000, 3))
        others = [a for a in range(3) if a != plane_axis]
        p[:, others] = xy
        p[:, plane_axis] = level + rng.choice([-1, 0, 1], 2000) * np.spacing(max(abs(level), 1e-300))
        values = checker_parity(p, np.ones(3))
        assert np.unique(values).size == 1, (plane_axis, level)


def test_checker_uses_floor_not_truncation():
    # cells [-1, 0) and [0, 1) differ: no double-width cell at the origin
    p = np.array([[-0.5, 0.5, 0.5], [0.5, 0.5, 0.5], [-1.5, 0.5, 0.5]])
    assert checker_parity(p, np.ones(3)).tolist() == [-1.0, 1.0, 1.0]


def test_point_checker_is_the_parity_of_the_summed_floors():
    # the compiled point checker against its formula in numpy: points nudged off a cell plane
    # towards the clip box's centre (without one: up), (-1) ** (floor t summed); points on cell
    # planes, far out and NaN included
    rng = np.random.default_rng(3)
    box = np.array([0.25, 0.3, 0.125])
    p = np.concatenate([rng.normal(size=(3000, 3)), rng.normal(size=(1000, 3)) * 1e9,
                        np.round(rng.normal(size=(1000, 3)) * 8) * box, np.full((2, 3), np.nan)])
    for clip in (None, np.array([[-1.0, -2.0, -0.5], [1.5, 2.0, 3.0]])):
        t = p / box
        c = None if clip is None else clip / box
        inward = 1.0 if c is None else np.where(t > 0.5 * (c[0] + c[1]), -1.0, 1.0)
        t = t + inward * 1e-10 * np.maximum(1.0, np.abs(t))
        cells = np.floor(t).sum(axis=1)
        want = 1.0 - 2.0 * (cells - 2.0 * np.floor(0.5 * cells))
        got = checker_parity(p, box, clip=clip)
        assert np.array_equal(got, want, equal_nan=True) and np.isnan(got[-2:]).all()
        assert 0.3 < np.mean(got[:3000] > 0) < 0.7  # both signs


def test_wide_footprint_averages_to_grey():
    p = np.array([[0.3, 0.2, 0.1]])
    d = np.array([[40.0, 0, 0]]), np.array([[0, 40.0, 0]])
    assert abs(checker_parity(p, np.ones(3), *d)[0]) < 0.05


def test_evaluate_checker_colours_and_transform():
    spec = {"name": "checker", "box": [1, 1, 1], "color_even": [1, 0, 0], "color_odd": [0, 0, 1]}
    out = evaluate(spec, [[0.5, 0.5, 0.5], [1.5, 0.5, 0.5]])
    assert out.tolist() == [[1, 0, 0], [0, 0, 1]]
    moved = dict(spec, transform={"translate": [1, 0, 0]})
    assert evaluate(moved, [[1.5, 0.5, 0.5]]).tolist() == [[1, 0, 0]]
    bigger = dict(spec, transform={"scale": 2})
    assert evaluate(bigger, [[1.5, 0.5, 0.5]]).tolist() == [[1, 0, 0]]


def test_position_is_normalised_to_bounds():
    out = evaluate("position", [[1, 2, 3], [3, 2, 1]], bounds=[[1, 1, 1], [3, 3, 3]])
    assert np.allclose(out, [[0, 0.5, 1], [1, 0.5, 0]])


@pytest.mark.parametrize(
    "spec, words",
    [
        ("marbel", "unknown texture"),
        ({"name": "checker", "bx": 1}, "bx"),
        ({"name": "checker", "box": [0, 1, 1]}, "box"),
        ({"name": "checker", "transform": {"scale": -1}}, "scale"),
        ("{not json", "JSON"),
    ],
)
def test_bad_specs_name_the_problem(spec, words):
    with pytest.raises(TextureError, match=words):
        parse_spec(spec)


def test_filtered_checker_stays_in_range_far_out():
    # 8e9 cells out, t +- half rounds by 1e-6 of a footprint of 0.008 cells
    p = np.random.default_rng(1).random((2000, 3)) + 1e9
    d = np.full((2000, 3), 1e-3)
    assert np.abs(checker_parity(p, np.full(3, 0.125), d, d)).max() <= 1.0


def test_parse_spec_reads_no_files(tmp_path):
    """A string is a name or JSON, never a path: an existing spec file, a missing one and an
    unknown name get the same message, so a client cannot probe the server's files; JSON
    text that does not parse says where."""
    spec = tmp_path / "wood.yaml"
    spec.write_text("name: wood\n")
    texts = [str(spec), str(tmp_path / "missing.yaml"), "/etc/hostname", "plaid"]
    messages = set()
    for text in texts:
        with pytest.raises(TextureError) as error:
            parse_spec(text)
        messages.add(str(error.value).replace(repr(text), "TEXT"))
    assert messages == {"unknown texture TEXT (known: checker, fbm, flame, marble, noise, position, turbulence, wood)"}
    with pytest.raises(TextureError, match="^not valid JSON at line 1 column 2: expecting property name enclosed in double quotes$"):
        parse_spec("{not json")


@pytest.mark.parametrize("name", ["checker", "noise", "turbulence", "fbm", "marble", "wood", "flame", "position"])
def test_nan_and_infinite_points_give_nan(name):
    # NaN in, NaN out: no silent value of lattice point 0; the finite rows are untouched
    bad = [[np.nan, 0.2, 0.3], [np.inf, 0.2, 0.3], [0.1, -np.inf, 0.3]]
    good = [[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]]
    points = np.array([*bad, *good])
    footprint = np.tile(np.array([[1e-3, 0, 0], [0, 1e-3, 0]]), (len(points), 1, 1))
    for f in (None, footprint):
        out = evaluate(name, points, f)
        assert np.isnan(out[:3]).all() and np.isfinite(out[3:]).all()
        assert np.array_equal(out[3:], evaluate(name, good, None if f is None else f[3:]))
    nan_footprint = footprint.copy()
    nan_footprint[3, 0, 0] = np.nan
    out = evaluate(name, points, nan_footprint)
    assert np.isnan(out[3]).all() and np.isfinite(out[4]).all()


def test_flame_stands_on_the_centre_of_the_objects_base():
    # an object 2 wide, 4 high, from (1, 3, 0): the axis at x = 2, the foot at y = 3, the tip at y = 7
    bounds = np.array([[1.0, 3.0, 0.0], [3.0, 7.0, 1.0]])
    x = np.linspace(1.0, 3.0, 201)
    low = np.column_stack([x, np.full_like(x, 3.2), np.full_like(x, 0.5)])
    red = evaluate("flame", low, bounds=bounds)[:, 0]
    assert red[100] > 0.5 and red[0] < 1e-6 and red[-1] < 1e-6  # bright on the axis, dark at the sides
    assert abs(x[np.argmax(red)] - 2.0) < 0.3  # brightest near the axis (the turbulence moves it a little)
    column = np.column_stack([np.full(5, 2.0), [2.9, 3.1, 5.0, 6.9, 7.1], np.full(5, 0.5)])
    values = evaluate("flame", column, bounds=bounds).sum(axis=1)
    assert values[0] == values[-1] == 0.0 and (values[1:4] > 0).all()  # between the base and the object's top
    moved = evaluate({"name": "flame", "transform": {"translate": [0.5, 0, 0]}}, low + [0.5, 0, 0], bounds=bounds)
    assert np.allclose(moved[:, 0], red)  # the transform moves the flame from there
    tall = {"name": "flame", "transform": {"scale": 2.0}}  # twice the size, about the foot (2, 3)
    assert evaluate(tall, [[2.0, 10.9, 0.5]], bounds=bounds).sum() > 0 and not evaluate(tall, [[2.0, 11.1, 0.5]], bounds=bounds).any()


def test_flame_lights_most_of_an_ordinary_mesh(meshes):
    from texbake import bake_mesh

    result = bake_mesh(meshes / "suzanne.ply", "flame", size=64, margin=0)
    albedo = result.images["albedo"][result.coverage]
    assert (albedo.sum(axis=1) > 1e-3).mean() > 0.75  # a flame standing on the min-x face lights far less of it


# -- the rim seam of a box standing on its base (one chart a face, off the texel grid) --

BOX_SIZE, SCALE, CELL, SHIFT = 136, 40, 45, 2.3  # image texels, texels a unit, chart cell, chart offset (not on the texel grid)
# faces of the box [0, 1] x [0, 1] x [0, 0.5] standing on z = 0: (origin, u edge, v edge), outward
BOX_FACES = {
    "bottom": ((0, 1, 0), (1, 0, 0), (0, -1, 0)), "top": ((0, 0, 0.5), (1, 0, 0), (0, 1, 0)),
    "front": ((0, 0, 0), (1, 0, 0), (0, 0, 0.5)), "back": ((1, 1, 0), (-1, 0, 0), (0, 0, 0.5)),
    "left": ((0, 1, 0), (0, -1, 0), (0, 0, 0.5)), "right": ((1, 0, 0), (0, 1, 0), (0, 0, 0.5)),
}

def box_mesh():
    """A box standing on its base with one square chart a face, placed off the texel grid."""
    vertices, uv, faces = [], [], []
    for k, (o, eu, ev) in enumerate(BOX_FACES.values()):
        o, eu, ev = map(np.asarray, (o, eu, ev))
        lu, lv = np.linalg.norm(eu), np.linalg.norm(ev)
        corner = np.array([(k % 3) * CELL + SHIFT, (k // 3) * CELL + SHIFT])  # texels, from the image's bottom left
        n = len(vertices)
        for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
            vertices.append(o + a * eu + b * ev)
            uv.append((corner + SCALE * np.array([a * lu, b * lv])) / BOX_SIZE)
        faces += [(n, n + 1, n + 2), (n, n + 2, n + 3)]
    return trimesh.Trimesh(np.array(vertices, float), np.array(faces), process=False,
                           visual=trimesh.visual.TextureVisuals(uv=np.array(uv)))

def texel_at(face, a, b):
    """(row, col) of the texel at chart coordinates (a, b) in [0, 1] of ``face``."""
    k = list(BOX_FACES).index(face)
    o, eu, ev = map(np.asarray, BOX_FACES[face])
    x = (k % 3) * CELL + SHIFT + SCALE * a * np.linalg.norm(eu)
    y = (k // 3) * CELL + SHIFT + SCALE * b * np.linalg.norm(ev)
    return (BOX_SIZE - 1 - np.floor(y).astype(int), np.floor(x).astype(int))

def rim_mismatch(image, covered):
    """Mean and max |wall - base| over the rims of the base: per texel along each rim, the
    outermost covered texel of the wall against that of the base at the same point."""
    t = (np.arange(SCALE) + 0.5) / SCALE  # one per texel along an edge

    def outermost(face, at):  # at(d): chart coordinates d texels in from the rim
        rc = [texel_at(face, *at(d / SCALE)) for d in (0.25, 1.25)]
        first = covered[rc[0]]
        return tuple(np.where(first, np.broadcast_to(a, t.shape), np.broadcast_to(b, t.shape)) for a, b in zip(*rc, strict=True))

    pairs = [  # wall texel at its bottom edge, base texel at the same point of the rim
        (outermost("front", lambda d: (t, d / 0.5)), outermost("bottom", lambda d: (t, 1 - d))),
        (outermost("back", lambda d: (t, d / 0.5)), outermost("bottom", lambda d: (1 - t, d))),
        (outermost("left", lambda d: (t, d / 0.5)), outermost("bottom", lambda d: (d, t))),
        (outermost("right", lambda d: (t, d / 0.5)), outermost("bottom", lambda d: (1 - d, 1 - t))),
    ]
    d = np.concatenate([np.abs(image[w] - image[b]).mean(axis=1) for w, b in pairs])
    return float(d.mean()), float(d.max())


def test_filtered_checker_has_no_seam_at_the_rim_of_a_flat_base():
    # Wall texels at the rim have footprints reaching below the base (z < 0, where there is
    # no surface); cut to the object's bounding box they no longer average the cell below.
    # The tolerance: the mismatch across the rim within 2x of 16 point samples'.
    from texbake import bake_mesh

    mesh = box_mesh()
    one = bake_mesh(mesh, "checker", size=BOX_SIZE, uv="keep", margin=0)
    sixteen = bake_mesh(mesh, "checker", size=BOX_SIZE, uv="keep", margin=0, samples=16)
    filtered, _ = rim_mismatch(one.images["albedo"].astype(float), one.coverage)
    point, _ = rim_mismatch(sixteen.images["albedo"].astype(float), one.coverage)
    assert point < 0.1  # 0.050: only where the checks' own edges cross the rim (texels misaligned across it)
    assert filtered <= 2 * point, (filtered, point)  # 0.045 (0.26 with the footprint uncut)


def test_filtered_checker_is_cut_to_the_objects_box():
    # a texel 0.3 of its width above a base at y = 0
    p, f = [[0.3, 0.3 / 1024, 0.3]], [[[1 / 1024, 0, 0], [0, 1 / 1024, 0]]]
    assert evaluate("checker", p, f)[0, 0] == pytest.approx(0.73)  # no bounds: the whole footprint
    assert evaluate("checker", p, f, bounds=[[0, 0, 0], [1, 1, 1]])[0, 0] == pytest.approx(0.9)  # cut at y = 0
    # a face on the box's max face (x = 1, a cell plane) shows the cell inside, like one on x = 0
    on_faces = [[0.0, 0.3, 0.3], [1.0, 0.3, 0.3]]
    assert evaluate("checker", on_faces, bounds=[[0, 0, 0], [1, 1, 1]])[:, 0].tolist() == [0.9, 0.05]


def test_filtered_checker_is_cut_to_the_hull_of_a_cut_texel():
    # a cut footprint (the box standing in for a texel's covered part) that reaches 0.1 of
    # its width over the cell plane x = 0, while the covered part's hull lies at x >= 0 (a
    # triangle against a chart border on that plane): with the hull, the far cell is out
    box = np.ones(3)
    p, dx, dy = np.array([[0.4 * 0.25, 0.5, 0.5]]), np.array([[0.25, 0, 0]]), np.array([[0, 0.25, 0]])
    assert checker_parity(p, box, dx, dy)[0] == pytest.approx(0.8)  # 0.9 of the box in x >= 0 (+1), 0.1 in x < 0 (-1)
    triangle = np.array([[[-0.4, -0.5], [0.5, -0.5], [0.5, 0.5]] + [[np.nan, np.nan]] * 5])  # corners (a, b): x = 0.25 (0.4 + a)
    assert checker_parity(p, box, dx, dy, hull=(np.array([0]), triangle))[0] == pytest.approx(1.0)
    # a hull around the whole box changes nothing; a row of NaN (no hull) neither
    square = np.array([[[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]] + [[np.nan, np.nan]] * 4])
    assert checker_parity(p, box, dx, dy, hull=(np.array([0]), square))[0] == pytest.approx(0.8)
    assert checker_parity(p, box, dx, dy, hull=(np.array([0]), np.full((1, 8, 2), np.nan)))[0] == pytest.approx(0.8)


def test_json_nested_too_deep_is_refused_before_parsing():
    """json.loads recurses: 100000 levels would be a RecursionError, not a TextureError."""
    deep = '{"name": "marble", "x": ' + '{"a": ' * 100_000 + "1" + "}" * 100_000 + "}"
    with pytest.raises(TextureError, match="^JSON spec nested deeper than 32 levels$"):
        parse_spec(deep)
    assert parse_spec('{"name": "marble", "turbulence": {"octaves": 3}}').turbulence.octaves == 3  # shallow JSON still parses


def test_spread_colours_are_the_colour_maps_mean_over_a_gaussian():
    from texbake.textures.colour import colours, spread_colours

    knots, cols = (0.0, 0.35, 1.0), ((0.1, 0.0, 0.3), (0.9, 0.5, 0.2), (0.2, 1.0, 0.6))
    values, spread = np.array([0.02, 0.2, 0.5, 0.93, 1.2]), np.array([0.0, 0.03, 0.1, 0.05, 0.2])
    z = np.linspace(-8, 8, 40001)  # the Gaussian on a fine grid (the colour map's kinks at its end knots: no quadrature)
    weight = np.exp(-0.5 * z**2)
    expect = [(weight[:, None] * colours(knots, cols, v + s * z)).sum(axis=0) / weight.sum() for v, s in zip(values, spread, strict=True)]
    got = spread_colours(knots, cols, values, spread, 0.2)
    assert np.abs(got - np.array(expect)).max() < 2e-5  # stated: the table's grid (8192 values, 64 spreads)


def test_filtered_turbulence_converges_to_the_mean_colour():
    # A footprint that drops every octave: the mean colour over space (2^21 points over the
    # noise's period, with the turbulence's exact mean as a control variate: its error about
    # 1e-6), not the colour of the mean (0.9e-3 off). Tolerance 1e-4 (measured 6e-5).
    from texbake.textures.colour import colours
    from texbake.textures.noise import basis_mean
    from texbake.textures.solid import turbulence

    p = np.random.default_rng(3).random((1 << 21, 3)) * 64.0  # 256 lattice cells at the default scale 4
    t = turbulence(p, None, scale=4.0)
    c = colours((0.0, 1.0), ((0, 0, 0), (1, 1, 1)), t)[:, 0]
    mean = c.mean() - np.cov(c, t)[0, 1] / t.var() * (t.mean() - basis_mean("value"))
    wide = evaluate("turbulence", [[1.0, 2.0, 3.0]], [[[100.0, 0, 0], [0, 100.0, 0]]])[0]
    assert np.abs(wide - mean).max() < 1e-4, (wide, mean)
    assert abs(colours((0.0, 1.0), ((0, 0, 0), (1, 1, 1)), np.array([basis_mean("value")]))[0, 0] - mean) > 5e-4
