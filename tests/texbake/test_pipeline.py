"""End-to-end bakes through the library call, on real meshes and small fixtures."""

import hashlib
import json
from importlib import metadata

import numpy as np
import pytest
import trimesh

import texbake
from texbake.errors import ParameterError


def exact_points_at_texels(mesh, uv, faces, rows, cols, size):
    """Surface points under texel centres, by brute-force point-in-triangle search in UV."""
    q = np.stack([(cols + 0.5) / size, 1 - (rows + 0.5) / size], axis=1)
    t = uv[faces]  # (m, 3, 2)
    out = np.full((len(q), 3), np.nan)
    for i, p in enumerate(q):
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        d = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        l1 = ((p[0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (p[1] - a[:, 1]) * (c[:, 0] - a[:, 0])) / d
        l2 = ((b[:, 0] - a[:, 0]) * (p[1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[0] - a[:, 0])) / d
        inside = np.flatnonzero((l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1))
        if len(inside):
            f = inside[0]
            out[i] = (1 - l1[f] - l2[f]) * mesh.vertices[faces[f, 0]] + l1[f] * mesh.vertices[faces[f, 1]] + l2[f] * mesh.vertices[faces[f, 2]]
    return out


def test_position_bake_matches_exact_surface_points(meshes):
    size = 128
    # point-sampled: filtered, a texel a chart's border cuts holds the mean position of its covered part
    result = texbake.bake_mesh(meshes / "ico4uv.obj", "position", size=size, margin=0, texture_space="object", filtering=False)
    assert result.report["atlas"]["method"] == "kept"
    m = result.mesh
    rows, cols = np.nonzero(result.coverage)
    pick = np.random.default_rng(0).choice(len(rows), 300, replace=False)
    rows, cols = rows[pick], cols[pick]
    exact = exact_points_at_texels(m, m.uv, m.faces, rows, cols, size)
    found = ~np.isnan(exact[:, 0])
    assert found.mean() > 0.95  # texel centres on a shared edge may fall either side
    lo, hi = np.array(result.report["mesh"]["bounds"])
    expect = (exact[found] - lo) / (hi - lo)
    got = result.images["albedo"][rows[found], cols[found]]
    assert np.abs(got - expect).max() < 2e-6  # float32 image of values in [0, 1]


def sample_nearest(image, uv):
    h, w = image.shape[:2]
    c = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    r = np.clip(((1 - uv[:, 1]) * h).astype(int), 0, h - 1)
    return image[r, c]


@pytest.mark.parametrize("mode", ["auto", "unwrap"])
def test_uv_reuse_and_unwrap_both_bake_the_surface(meshes, mode):
    size = 256
    result = texbake.bake_mesh(meshes / "suzanne.ply", "position", size=size, uv=mode, texture_space="object")
    assert result.report["atlas"]["method"] == ("kept" if mode == "auto" else "xatlas")
    m = result.mesh
    # face centroids: the nearest texel must hold the position of the centroid
    centroid_uv = m.uv[m.faces].mean(axis=1)
    centroid = m.vertices[m.faces].mean(axis=1)
    lo, hi = np.array(result.report["mesh"]["bounds"])
    got = sample_nearest(result.images["albedo"], centroid_uv)
    expect = (centroid - lo) / (hi - lo)
    # one texel of footprint, in normalised units, bounds the error
    texel = np.linalg.norm(hi - lo) / (hi - lo).min() / size * 8
    err = np.abs(got - expect).max(axis=1)
    assert np.median(err) < texel / 4 and np.quantile(err, 0.95) < texel


def test_unwrap_is_skipped_when_uvs_are_usable(meshes):
    kept = texbake.bake_mesh(meshes / "suzanne_blender_uv.obj", "checker", size=64)
    assert kept.report["atlas"]["method"] == "kept"
    assert kept.report["skipped"] == [{"stage": "transfer", "why": "no source mesh given"},
                                      {"stage": "unwrap", "why": "the mesh's UVs are usable"}]
    # the same mesh unwrapped, from a source mesh: neither stage is skipped
    unwrapped = texbake.bake_mesh(meshes / "suzanne_blender_uv.obj", "checker", size=64, uv="unwrap",
                                  source=meshes / "suzanne_blender_uv.obj", cage=0.01)
    assert unwrapped.report["atlas"]["method"] != "kept" and unwrapped.report["skipped"] == []


def test_uvs_outside_the_unit_square_are_unwrapped(meshes):
    # BoxTextured's UVs run from 0 to 6 (a repeating texture): not an atlas
    result = texbake.bake_mesh(meshes / "BoxTextured.glb", "checker", size=64)
    assert result.report["atlas"]["method"] == "planar"  # a box: its sides are flat
    assert "unit square" in result.report["atlas"]["reason"]
    assert result.warnings == result.report["warnings"] == [
        "the mesh's UVs were replaced by an unwrap: the mesh's UVs leave the unit square (range 0 to 6); they repeat a tiling "
        "texture: 1 of its 4 UV islands spans more than one tile (up to 2 across), and a bake needs a place of its own for "
        "every point of the surface"]


def test_the_report_collects_every_stages_warnings_in_their_order(meshes):
    """The load's, the atlas', the transfer's: one list, ``report["warnings"]``."""
    from texbake.mesh import load_mesh

    mesh = load_mesh(meshes / "BoxTextured.glb")
    mesh.warnings.append("a warning of the load")
    far = trimesh.creation.icosphere(subdivisions=1)
    far.apply_translation([10, 0, 0])
    result = texbake.bake_mesh(mesh, "checker", size=32, source=far, cage=0.1, margin=0)
    assert result.warnings[0] == "a warning of the load"
    assert result.warnings[1].startswith("the mesh's UVs were replaced by an unwrap")
    assert result.warnings[2].startswith("transfer: ") and len(result.warnings) == 3


def test_transfer_from_a_subdivided_mesh():
    fine = trimesh.creation.icosphere(subdivisions=5)
    coarse = trimesh.creation.icosphere(subdivisions=1)
    kw = dict(size=128, margin=0, texture_space="object", uv="unwrap")
    plain = texbake.bake_mesh(coarse, "position", **kw)
    moved = texbake.bake_mesh(coarse, "position", source=fine, cage=0.2, **kw)
    assert moved.report["rays"]["transfer_missed"] == 0
    lo, hi = np.array(moved.report["mesh"]["bounds"])

    def radii(result):
        p = result.images["albedo"][result.coverage] * (hi - lo) + lo
        return np.linalg.norm(p, axis=1)

    assert radii(plain).min() < 0.95  # the coarse mesh cuts inside the sphere
    r = radii(moved)
    assert np.abs(r - 1).max() < 2e-3  # the fine mesh lies within its chord error


def test_transfer_misses_are_reported():
    far = trimesh.creation.icosphere(subdivisions=2)
    far.apply_translation([10, 0, 0])
    result = texbake.bake_mesh(trimesh.creation.box(), "checker", size=32, source=far, cage=0.1, margin=0)
    assert result.report["rays"]["transfer_missed"] > 0 and not result.coverage.any()


def test_samples_and_report(meshes, tmp_path):
    result = texbake.bake_mesh(meshes / "suzanne.ply", "checker", size=64, samples=4, margin=4)
    r = result.report
    assert r["rays"]["texel_samples"] == 64 * 64 * 4 and 0 < r["rays"]["cast"] < 64 * 64 * 4
    assert r["texels"]["covered"] + r["texels"]["margin"] + r["texels"]["empty"] == 64 * 64
    assert r["texels"]["margin"] > 0 and r["rays"]["missed_inside_atlas"] < 0.01 * r["texels"]["covered"]
    assert set(r["seconds"]) >= {"load", "atlas", "lookup", "texture", "margin"}
    assert r["versions"]["embreex"] == metadata.version("embreex") and r["versions"]["xatlas"] == metadata.version("xatlas")
    assert r["mesh"]["sha256"] == hashlib.sha256((meshes / "suzanne.ply").read_bytes()).hexdigest()
    result.save(tmp_path)
    on_disk = json.loads((tmp_path / "report.json").read_text())
    assert {"albedo", "coverage", "glb"} <= set(on_disk["outputs"]) and "write" in on_disk["seconds"]
    for output in on_disk["outputs"].values():  # each file the report names is on disk, at its size
        assert (tmp_path / output["path"]).stat().st_size == output["bytes"], output
    assert on_disk["outputs"]["glb"]["path"] == "suzanne.glb" and on_disk["outputs"]["albedo"]["path"] == "albedo.png"


@pytest.mark.parametrize(
    "kwargs, name",
    [({"size": 0}, "size"), ({"samples": 0}, "samples"), ({"margin": -1}, "margin"),
     ({"texture_space": "world"}, "texture_space"), ({"cage": -1.0}, "cage"), ({"uv": "maybe"}, "uv")],
)
def test_bad_parameters_are_named(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        texbake.bake_mesh(trimesh.creation.box(), "checker", **kwargs)


def test_lit_normal_and_frames(meshes, tmp_path):
    result = texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=64, shading="ambient-diffuse", bump="turbulence")
    assert set(result.images) == {"albedo", "lit", "normal"}
    cov = result.coverage
    assert (result.images["lit"][cov] <= result.images["albedo"][cov] + 1e-6).all()  # ka + kd <= 1
    n = result.images["normal"][cov] * 2 - 1
    # unit normals, stored in a float32 image: measured 1.2e-7 off
    assert np.allclose(np.linalg.norm(n, axis=1), 1, atol=1e-6) and (n[:, 2] > 0).all()
    frames = texbake.bake_mesh(meshes / "suzanne.ply", "flame", size=32, frames=[0, 0.5, 1])
    assert frames.images["flipbook"].shape == (64, 64, 3)
    assert not np.allclose(frames.images["albedo_0000"], frames.images["albedo_0002"])
    frames.save(tmp_path)
    assert (tmp_path / "flipbook.png").exists() and (tmp_path / "albedo_0002.png").exists()
    with pytest.raises(ParameterError, match="frames"):
        texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=32, frames=[0, 1])


def test_quality_presets_and_explicit_overrides(meshes):
    mesh = meshes / "suzanne.ply"
    final = texbake.bake_mesh(mesh, "marble", size=32, quality="final")
    p = final.report["settings"]
    assert (p["samples"], p["filtering"], p["precision"], p["max_octaves"]) == (16, False, "float64", None)
    assert final.report["rays"]["texel_samples"] == 32 * 32 * 16  # the bake took the preset's samples
    mixed = texbake.bake_mesh(mesh, "marble", size=32, quality="final", samples=4, max_octaves=3)
    p = mixed.report["settings"]
    assert (p["quality"], p["samples"], p["filtering"], p["max_octaves"]) == ("final", 4, False, 3)
    assert mixed.report["rays"]["texel_samples"] == 32 * 32 * 4
    assert p == mixed.settings.model_dump(mode="json")
    default = texbake.bake_mesh(mesh, "marble", size=32, margin=2)
    named = texbake.bake_mesh(mesh, "marble", size=32, margin=2, quality="default")
    assert np.array_equal(default.images["albedo"], named.images["albedo"])  # "default" is bake_mesh's defaults
    for kwargs, name in (({"quality": "best"}, "quality"), ({"precision": "float16"}, "precision"),
                         ({"max_octaves": 0}, "max_octaves"), ({"filtering": "yes"}, "filtering")):
        with pytest.raises(ParameterError, match=name):
            texbake.bake_mesh(mesh, "marble", size=16, **kwargs)


def test_filtering_precision_and_octave_cap_change_only_what_they_should(meshes):
    mesh = meshes / "suzanne.ply"
    base = texbake.bake_mesh(mesh, "marble", size=48, margin=0)
    cov = base.coverage
    f32 = texbake.bake_mesh(mesh, "marble", size=48, margin=0, precision="float32")
    # float32 points in unit space: rounding of ~6e-8 times the texture's slope, far below
    # one 8-bit level (measured 4.5e-7)
    assert np.abs(f32.images["albedo"][cov] - base.images["albedo"][cov]).max() < 5e-6
    point = texbake.bake_mesh(mesh, "marble", size=48, margin=0, filtering=False)
    capped = texbake.bake_mesh(mesh, "marble", size=48, margin=0, filtering=False, max_octaves=2)
    assert not np.allclose(point.images["albedo"][cov], base.images["albedo"][cov])
    assert not np.allclose(capped.images["albedo"][cov], point.images["albedo"][cov])
    assert capped.report["settings"]["max_octaves"] == 2


def test_report_carries_an_error_estimate(meshes):
    one = texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=48).report["error_estimate"]
    assert one["method"] == "probe" and one["rmse"] > 0 and one["texels"] > 100 and one["map"] == "albedo"
    low, high = one["rmse_interval"]
    assert 0 <= low <= one["rmse"] <= high
    point = texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=48, filtering=False).report["error_estimate"]
    many = texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=48, samples=16).report["error_estimate"]
    assert many["probe_grid"] == [8, 16] and 0 < many["rmse"] < point["rmse"]
    filtered = texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=48, samples=64, filtering=True).report["error_estimate"]
    # filtering blurs the finest octaves, however many samples: an error the probe sees
    # clear of its own uncertainty (the interval's lower end above 0)
    low, high = filtered["rmse_interval"]
    assert 0 < low <= filtered["rmse"] <= high, filtered


def test_the_estimate_in_threads_is_the_estimate_in_one(meshes, monkeypatch):
    # the probe's points evaluated in parts, one a thread, give the values one call gives:
    # the same report. PROBE_SPLIT lowered so every probe here is split
    import texbake.pipeline as pipeline

    monkeypatch.setattr(pipeline, "PROBE_SPLIT", 64)
    one = texbake.bake_mesh(meshes / "suzanne.ply", "checker", size=96, workers=1).report["error_estimate"]
    two = texbake.bake_mesh(meshes / "suzanne.ply", "checker", size=96, workers=2).report["error_estimate"]
    assert one == two and one["rmse"] > 0 and one["fine_texels"] > 0


def test_progress_is_reported_from_start_to_end(meshes):
    seen = []
    texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=256, tile_samples=4096, progress=seen.append)
    assert seen[0] == 0.05 and seen[-1] == 1.0 and len(seen) > 10
    assert all(0 <= f <= 1 for f in seen) and max(seen[:-1]) < 1.0


def test_the_lit_map_shades_with_the_normals_the_glb_gets():
    # a box's faces meet at hard edges: split normals, so each face is lit evenly (lit /
    # albedo constant over it), as a viewer shades the GLB; smooth normals would grade
    # every face towards its corners (they gave 718 distinct shades here)
    result = texbake.bake_mesh(trimesh.creation.box(), "checker", size=64, shading="ambient-diffuse", margin=0)
    cov = result.coverage
    ratio = result.images["lit"][cov][:, 0] / np.maximum(result.images["albedo"][cov][:, 0], 1e-6)
    bright = result.images["albedo"][cov][:, 0] > 0.05
    levels = np.unique(np.round(ratio[bright], 4))
    assert len(levels) <= 6, levels  # one shade a face at most
    assert np.allclose(result.mesh.normals[result.mesh.faces].std(axis=1), 0)  # the GLB's: flat per face


def test_a_double_sided_mesh_bakes_as_its_front_side(tmp_path):
    # a box with every face doubled in the opposite winding: both sides on one chart, and the
    # texels hold the front side's shading (not whichever side a texel's ray met)
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    double = trimesh.Trimesh(box.vertices, np.concatenate([box.faces, box.faces[:, ::-1]]), process=False)
    kw = dict(size=64, shading="ambient-diffuse", uv="unwrap", charting="planar", texture_space="object")
    one, two = texbake.bake_mesh(box, "marble", **kw), texbake.bake_mesh(double, "marble", **kw)
    assert two.report["atlas"]["double_sided_faces"] == 12 and two.report["atlas"]["charts"] == 6
    assert np.array_equal(one.coverage, two.coverage)
    for name in ("albedo", "lit"):
        assert np.allclose(one.images[name], two.images[name], atol=1e-5), name


def test_texel_means_are_a_point_sampled_bakes_texels(meshes):
    # the sweep's reference on drawn texels: at the same samples and jitter as a 16-sample
    # point-sampled bake, its texels' values (to float32) and coverage, on every third texel
    from texbake.pipeline import texel_means

    mesh = meshes / "bunny.ply"
    settings = {"texture": "wood", "size": 64, "filtering": False}
    baked = texbake.bake_mesh(mesh, settings, samples=16, seed=5, margin=0)
    texels = np.arange(0, 64 * 64, 3)
    means, hits = texel_means(mesh, settings, texels, 16, seed=5)
    covered = baked.coverage.ravel()[texels]
    assert covered.sum() > 100 and ((hits > 0) == covered).all() and hits.max() == 16
    assert np.abs(means[covered] - baked.images["albedo"].reshape(-1, 3)[texels][covered]).max() < 1e-6
    other, _ = texel_means(mesh, settings, texels, 16, seed=6)  # other jitter: other values
    assert np.abs(other[covered] - means[covered]).max() > 1e-3
    with pytest.raises(ParameterError, match="texels"):
        texel_means(mesh, settings, np.array([64 * 64]), 16)
