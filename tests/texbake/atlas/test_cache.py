"""Reuse across bakes (bake/cache.py): the atlas of a mesh kept for its later bakes."""

import json
import time

import numpy as np
import trimesh
from conftest import run_cli

import texbake
from texbake.atlas import AtlasCache, atlas_key, make_atlas


def test_a_second_bake_of_the_mesh_takes_its_atlas_from_the_cache(meshes, tmp_path):
    first = texbake.bake_mesh(meshes / "bunny.ply", "marble", size=128, cache=tmp_path)
    again = texbake.bake_mesh(meshes / "bunny.ply", "wood", size=128, cache=tmp_path)
    assert first.report["atlas"]["cached"] is False and again.report["atlas"]["cached"] is True
    why = {s["stage"]: s["why"] for s in again.report["skipped"]}
    assert "from the cache" in why["unwrap"]
    assert np.array_equal(first.mesh.uv, again.mesh.uv) and np.array_equal(first.coverage, again.coverage)
    assert again.report["seconds"]["atlas"] < 0.1 < first.report["seconds"]["atlas"]  # measured 0.002 against 0.3
    # another size, another charting or another mesh is another atlas
    other = texbake.bake_mesh(meshes / "bunny.ply", "wood", size=64, cache=tmp_path)
    assert other.report["atlas"]["cached"] is False
    assert len(list(tmp_path.glob("atlas-*.npz"))) == 2


def test_the_cache_keeps_to_its_size_and_survives_bad_files(tmp_path):
    m = trimesh.creation.icosphere(2)
    atlas = make_atlas(m.vertices, m.faces, mode="unwrap", size=64)
    keys = [atlas_key(str(i), "auto", 64, "auto", "v") for i in range(4)]
    one = AtlasCache(tmp_path / "one")
    one.put(keys[0], atlas)
    size = (tmp_path / "one" / f"atlas-{keys[0]}.npz").stat().st_size
    AtlasCache(tmp_path / "none", max_bytes=size - 1).put(keys[0], atlas)
    assert list((tmp_path / "none").glob("atlas-*.npz")) == []  # one atlas over the budget: not kept

    def kept():
        return sorted(p.name for p in (tmp_path / "c").glob("atlas-*.npz"))

    cache = AtlasCache(tmp_path / "c", max_bytes=2 * size + size // 2)  # room for two
    for key in keys[:3]:
        cache.put(key, atlas)
        time.sleep(0.05)  # file times a clock tick apart
    assert kept() == sorted(f"atlas-{k}.npz" for k in keys[1:3])  # the least recently used went
    back = cache.get(keys[1])  # now the most recently used
    assert back is not None and np.array_equal(back.uv, atlas.uv) and np.array_equal(back.faces, atlas.faces)
    time.sleep(0.05)
    cache.put(keys[3], atlas)
    assert kept() == sorted(f"atlas-{k}.npz" for k in (keys[1], keys[3]))
    key = atlas_key("x", "auto", 64, "auto", "v")
    (tmp_path / "c" / f"atlas-{key}.npz").write_bytes(b"not an npz")  # a file cut short, another version's
    assert cache.get(key) is None
    assert AtlasCache(tmp_path / "d").get(key) is None  # a folder that does not exist yet


def test_the_command_line_reuses_atlases_unless_told_not_to(meshes, tmp_path):
    args = ["bake", meshes / "bunny.ply", "--size", 64, "--cache", tmp_path / "cache"]
    assert run_cli(*args, "--out", tmp_path / "a").returncode == 0
    r = run_cli(*args, "--texture", "wood", "--out", tmp_path / "b")
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "b" / "report.json").read_text())["atlas"]["cached"] is True
    r = run_cli(*args, "--no-cache", "--out", tmp_path / "c")
    assert json.loads((tmp_path / "c" / "report.json").read_text())["atlas"]["cached"] is False


def test_a_cache_object_keeps_the_lookups_of_its_latest_bakes(meshes, tmp_path):
    cache = AtlasCache(tmp_path)
    first = texbake.bake_mesh(meshes / "bunny.ply", "marble", size=128, cache=cache)
    again = texbake.bake_mesh(meshes / "bunny.ply", "wood", size=128, cache=cache)
    alone = texbake.bake_mesh(meshes / "bunny.ply", "wood", size=128)  # no cache at all
    assert first.report["rays"]["lookup_reused"] is False and first.report["rays"]["lookup_rays"] > 0
    assert again.report["rays"]["lookup_reused"] is True and again.report["rays"]["lookup_rays"] == 0
    assert "lookup" in {s["stage"] for s in again.report["skipped"]}
    assert np.array_equal(again.images["albedo"], alone.images["albedo"]) and np.array_equal(again.coverage, alone.coverage)
    assert again.report["rays"]["cast"] == alone.report["rays"]["cast"]
    # another size or number of samples is another lookup; a folder (not the object) keeps none
    assert texbake.bake_mesh(meshes / "bunny.ply", "wood", size=128, samples=4, cache=cache).report["rays"]["lookup_reused"] is False
    assert texbake.bake_mesh(meshes / "bunny.ply", "wood", size=128, cache=tmp_path).report["rays"]["lookup_reused"] is False
    small = AtlasCache(tmp_path, max_lookup_bytes=1)  # over its budget: nothing kept
    texbake.bake_mesh(meshes / "bunny.ply", "wood", size=128, cache=small)
    assert texbake.bake_mesh(meshes / "bunny.ply", "wood", size=128, cache=small).report["rays"]["lookup_reused"] is False
