"""texbake.meshmaps.bake through bake_mesh: position and normal maps exact on a plane, ID maps
per material and part, the report's ray counts, the command line's option and bad names."""

import json

import numpy as np
import pytest
import trimesh
from trimesh.visual import TextureVisuals

import texbake
from texbake.cli import app
from texbake.errors import ParameterError


def plane(tilt=False):
    """The unit square z = 0 (z = x / 2 when ``tilt``), its UVs its x, y."""
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    if tilt:
        vertices[:, 2] = vertices[:, 0] / 2
    mesh = trimesh.Trimesh(vertices, [[0, 1, 2], [0, 2, 3]], process=False)
    mesh.visual = TextureVisuals(uv=vertices[:, :2])
    return mesh


def centres(size):
    """``(rows, cols, u, v)`` of every texel centre of a ``size``² image (v up)."""
    rows, cols = np.mgrid[0:size, 0:size]
    return rows, cols, (cols + 0.5) / size, 1.0 - (rows + 0.5) / size


def test_position_and_normal_maps_are_exact_on_a_plane():
    size = 32
    result = texbake.bake_mesh(plane(tilt=True), maps=["position_object", "position_world", "normal_object", "normal_world"],
                               size=size, margin=0)
    rows, cols, u, v = centres(size)
    inside = result.coverage
    assert inside.mean() > 0.95
    got = result.images["position_object"][inside]
    np.testing.assert_allclose(got[:, 0], u[inside], atol=1e-6)  # x spans the box: 0 to 1
    np.testing.assert_allclose(got[:, 1], v[inside], atol=1e-6)
    np.testing.assert_allclose(got[:, 2], u[inside], atol=1e-6)  # z = x / 2 spans 0 to 1/2: its own bounds
    world = result.images["position_world"][inside]
    np.testing.assert_allclose(world[:, 2], u[inside] / 2, atol=1e-6)  # one scale, the largest side: proportions kept
    normal = np.array([-0.5, 0.0, 1.0]) / np.linalg.norm([-0.5, 0.0, 1.0])
    for name in ("normal_object", "normal_world"):
        np.testing.assert_allclose(result.images[name][inside], np.broadcast_to(0.5 + 0.5 * normal, (int(inside.sum()), 3)), atol=1e-6)


def test_a_flat_plane_is_open_flat_and_a_thin_sheet(tmp_path):
    result = texbake.bake_mesh(plane(), maps=["ao", "curvature", "thickness"], size=16, margin=0, map_rays=8)
    inside = result.coverage
    assert np.all(result.images["ao"][inside] == 1.0)  # nothing above it
    assert np.all(result.images["thickness"][inside] == 1.0)  # nothing below it: every ray counts its whole length
    np.testing.assert_allclose(result.images["curvature"][inside], 0.5, atol=1e-9)
    figures = result.report["mesh_maps"]
    assert figures["maps"] == ["ao", "curvature", "thickness"]
    assert figures["rays"] == 2 * 8 * figures["texels"] and figures["texels"] == int(inside.sum())
    assert figures["rays_per_second"] > 0
    result.save(tmp_path)
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["mesh_maps"]["rays"] == figures["rays"]
    assert {"ao.png", "curvature.png", "thickness.png"} <= {p.name for p in tmp_path.iterdir()}


def test_id_maps_give_each_material_and_part_its_own_colour(tmp_path):
    from conftest import two_material_scene

    two_material_scene(tmp_path / "scene.glb")
    result = texbake.bake_mesh(tmp_path / "scene.glb", maps=["id_material", "id_part", "id_chart"], size=64, texture_set="single",
                               margin=0)
    covered = result.coverage
    colours = lambda name: {tuple(c) for c in np.round(result.images[name][covered], 4)}
    assert len(colours("id_material")) == 2  # body, wheels
    assert len(colours("id_part")) == 3  # the box and two balls
    assert len(colours("id_chart")) > 3  # the box's 12 UV triangles are charts of their own


def test_the_margin_fills_the_mesh_maps_too():
    mesh = plane()
    mesh.visual = TextureVisuals(uv=0.25 + 0.5 * mesh.vertices[:, :2])  # the middle of the UV square
    result = texbake.bake_mesh(mesh, maps=["normal_object"], size=32, margin=4)
    filled = result.margin
    assert filled.any()
    assert np.all(result.images["normal_object"][filled] > 0.4)  # the chart's values, not the empty black


def test_the_command_line_takes_a_comma_separated_list(tmp_path):
    from typer.testing import CliRunner

    path = tmp_path / "plane.obj"
    plane().export(path)
    out = CliRunner().invoke(app, ["bake", str(path), "--maps", "ao,curvature", "--map-rays", "4", "--size", "16", "--out", str(tmp_path / "out")])
    assert out.exit_code == 0, out.output
    assert {"ao.png", "curvature.png"} <= {p.name for p in (tmp_path / "out").iterdir()}
    bad = CliRunner().invoke(app, ["bake", str(path), "--maps", "ao,crevices", "--size", "16", "--out", str(tmp_path / "bad")])
    assert bad.exit_code == 2 and "maps" in bad.output


@pytest.mark.parametrize("kwargs, name", [({"maps": ["crevices"]}, "maps"), ({"map_rays": 0}, "map_rays"),
                                          ({"map_distance": -1.0}, "map_distance"), ({"occluders": "some"}, "occluders")])
def test_bad_mesh_map_settings_are_named(kwargs, name):
    with pytest.raises(ParameterError) as info:
        texbake.bake_mesh(plane(), size=16, **kwargs)
    assert info.value.name.split(".")[0] == name
