"""The unwrap's packing (texbake.atlas.pack): sound charts are never thrown away, and the
workers are kept warm between unwraps.

A packing that distorts a chart or collapses a face is injected by a worker script that
wraps the real one and spoils its first packing reply (``texbake.atlas.pack.WORKER``)."""

import sys

import numpy as np
import pytest
import trimesh

from texbake.atlas import make_atlas, uv_problem
from texbake.atlas import pack as atlas_pack
from texbake.atlas.charts import outline_triangles
from texbake.atlas.pack import MIN_PROXY_AREA, _place, _proxy
from texbake.mesh import uv_areas
from texbake.workers import Pool

# The real worker, whose first "pack" reply has one UV vertex of the first mesh moved, or
# the first face's corners put on one point (a flag file per worker says it was done):
# the chart that vertex is on comes back distorted, or the face collapses.
SPOILING_WORKER = """
import os, sys
import numpy as np
from texbake.atlas import packworker as worker

flag, how = sys.argv[1], sys.argv[2]
real = worker.pack


def spoiled(meshes, size, padding, *how_packed):
    out, info = real(meshes, size, padding, *how_packed)
    mine = f"{flag}-{os.getpid()}"  # each worker's first: both packings of a small mesh (u, v swapped)
    if os.path.exists(mine):
        return out, info
    open(mine, "w").close()
    vm, idx, uv = out[0]
    uv = uv.copy()
    if how == "collapse":  # the first face's corners to one point
        uv[idx[0]] = uv[idx[0, 0]]
    else:  # a vertex of the largest chart's proxy moved across the atlas
        uv[0] = 1 - uv[0]
    out[0] = vm, idx, uv
    return out, info


worker.JOBS["pack"] = spoiled
worker.main()
"""


@pytest.fixture
def spoiling_worker(tmp_path, monkeypatch):
    script = tmp_path / "spoiling_worker.py"
    script.write_text(SPOILING_WORKER)

    def inject(how):
        monkeypatch.setattr(atlas_pack, "WORKER", [sys.executable, str(script), str(tmp_path / "spoiled"), how])

    return inject


def check(a, v, f):
    assert np.array_equal(v[a.vmapping[a.faces]], v[f])
    assert (uv_areas(a.uv, a.faces) > 0).all() and uv_problem(v[a.vmapping], a.faces, a.uv) is None


@pytest.mark.parametrize("how, said", [("distort", "came back distorted from packing by their outline: packed again by "
                                                   "their own triangles"),
                                       ("collapse", "collapsed to a point in xatlas' float32 UVs: packed again as charts")])
def test_a_spoiled_chart_is_packed_again_not_the_charting_thrown_away(spoiling_worker, how, said):
    spoiling_worker(how)
    if how == "distort":  # six sides of 512 faces, each packed by its outline (a square)
        m = trimesh.creation.box().subdivide_loop(0)
        for _ in range(4):
            m = m.subdivide()
    else:  # small charts, packed by their own triangles
        m = trimesh.creation.icosphere(1)
    v, f = np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)
    a = make_atlas(v, f, mode="unwrap", size=256, charting="planar")
    assert a.method == "planar" and "after" not in a.reason, a.reason  # the planar charts kept
    assert len(a.stats["packing"]) == 1 and said in a.stats["packing"][0], a.stats["packing"]
    check(a, v, f)
    assert a.stats["utilisation"] > 0.3


def test_an_outline_triangulated_with_a_sliver_is_not_the_proxy():
    # a thin ring (two rows of quads, 256 faces): the ear-cut of its outline has 128
    # triangles as thin as the ring; where one is under MIN_PROXY_AREA texels, xatlas'
    # packer would take it as degenerate (and then parametrise the chart anew: distorted),
    # so the chart's own triangles are packed
    n = 64
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    uv = np.concatenate([r * np.column_stack([np.cos(t), np.sin(t)]) for r in (1.0, 0.9995, 0.999)])
    i, j = np.arange(n), (np.arange(n) + 1) % n
    faces = np.concatenate([np.concatenate([np.column_stack([i + k * n, j + k * n, j + (k + 1) * n]),
                                            np.column_stack([i + k * n, j + (k + 1) * n, i + (k + 1) * n])]) for k in (0, 1)])
    seen = set()
    for texel in np.geomspace(1e-3, 10, 9):
        outline = outline_triangles(uv, faces, 0.25 * texel)
        assert outline is not None and len(outline) == 2 * n
        sliver = bool(uv_areas(uv, outline).min() < MIN_PROXY_AREA * texel**2)
        _, tri, _ = _proxy(uv, faces, texel)
        assert len(tri) == (len(faces) if sliver else len(outline)), texel
        seen.add(sliver)
    assert seen == {True, False}  # both cases met


def test_charts_under_a_texel_get_a_minimum_size():
    # 200 spheres of a thousandth of a texel: none is lost, none collapses
    rng = np.random.default_rng(1)
    s = trimesh.creation.icosphere(1)
    parts = [(s.vertices * 1e-6 + rng.random(3), s.faces + i * len(s.vertices)) for i in range(200)]
    big = trimesh.creation.box()
    v = np.concatenate([p[0] for p in parts] + [big.vertices])
    f = np.concatenate([p[1] for p in parts] + [big.faces + 200 * len(s.vertices)])
    a = make_atlas(v, f, mode="unwrap", size=256, charting="planar")
    assert a.method == "planar" and "packing" not in a.stats, a.stats.get("packing")
    check(a, v, f)


@pytest.mark.parametrize("mirror", [False, True])
def test_charts_packed_by_their_outline_follow_the_packer(mirror):
    rng = np.random.default_rng(1)
    uv = rng.random((40, 2))
    chart = np.repeat([0, 1], 20)
    turn = np.exp(1j * np.array([0.3, 2.0])) * np.array([0.5, 2.0])  # each chart rotated and scaled
    z = uv[:, 0] + 1j * uv[:, 1]
    z_out = turn[chart] * (np.conj(z) if mirror else z) + np.array([1 + 1j, 5 - 2j])[chart]
    source = np.r_[0:5, 20:26]  # only outline vertices were packed
    placed = np.column_stack([z_out.real, z_out.imag])[source]
    out, distorted = _place(uv, chart, source, placed)
    assert np.abs(out - np.column_stack([z_out.real, z_out.imag])).max() < 1e-12 and not distorted.any()
    bent = placed.copy()
    bent[:5] += rng.normal(scale=0.01, size=(5, 2))  # the first chart's outline moved out of shape
    _, distorted = _place(uv, chart, source, bent)
    assert distorted.tolist() == [True, False]


def boxes(n, seed):
    """``n`` boxes of random extents 0.2-3 scattered in a 40-unit cube: each side two
    triangles, a chart of its own (a CAD part's boxy charts)."""
    rng = np.random.default_rng(seed)
    parts = []
    for _ in range(n):
        b = trimesh.creation.box(extents=rng.uniform(0.2, 3.0, size=3))
        b.apply_translation(rng.uniform(-20, 20, size=3))
        parts.append(b)
    m = trimesh.util.concatenate(parts)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


@pytest.fixture
def packings(monkeypatch):
    """The "pack" jobs of each call of the workers' ``Pool.run`` (the real one, recorded)."""
    calls: list[list[tuple]] = []
    real = Pool.run

    def recorded(self, jobs, **kw):
        calls.append([args for kind, args in jobs if kind == "pack"])
        return real(self, jobs, **kw)

    monkeypatch.setattr(Pool, "run", recorded)
    return calls


def test_boxy_charts_packed_far_under_their_promise_get_a_second_look_by_brute_force(packings, monkeypatch):
    v, f = boxes(12, 4)  # 72 charts; xatlas' greedy packing fills far less than their boxes promise
    looked = make_atlas(v, f, mode="unwrap", size=512, charting="planar")
    looks = [args for call in packings for args in call if len(args) > 4 and args[3]]  # brute force at a density
    assert len(looks) == 2 and looks[1][4] == pytest.approx(atlas_pack.LOOK_DENSER * looks[0][4])  # one pass a worker
    monkeypatch.setattr(atlas_pack, "LOOK_SHARE", 0.0)
    packings.clear()
    greedy = make_atlas(v, f, mode="unwrap", size=512, charting="planar")
    assert not [args for call in packings for args in call if args[3:4] == (True,)]
    check(looked, v, f)
    assert looked.stats["overlap"] < 1e-3
    assert looked.stats["utilisation"] > greedy.stats["utilisation"] + 0.03  # measured 0.731 against 0.655


def test_one_packing_searches_its_density_on_both_workers_at_once(packings, monkeypatch):
    monkeypatch.setattr(atlas_pack, "SWAP_FACES", 0)  # as for a mesh too large to pack twice (u and v swapped)
    monkeypatch.setattr(atlas_pack, "LOOK_SHARE", 0.0)
    v, f = boxes(30, 2)
    both = make_atlas(v, f, mode="unwrap", size=512, charting="planar", workers=2)
    rounds = [call for call in packings if call]
    assert 1 <= len(rounds) <= atlas_pack.SEARCH_ROUNDS
    densities = [args[4] for call in rounds for args in call]
    assert all(len(call) == 2 for call in rounds) and len(set(densities)) == len(densities)  # two new densities a round
    assert densities[:2] == list(atlas_pack.FIRST_DENSITIES)
    packings.clear()
    one = make_atlas(v, f, mode="unwrap", size=512, charting="planar", workers=1)  # the worker's own search
    assert [len(call) for call in packings if call] == [1] and len(packings[-1][0]) == 4
    check(both, v, f)
    assert both.stats["utilisation"] >= 0.97 * one.stats["utilisation"]
