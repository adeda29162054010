"""A material's ``mesh_map`` node: dirt where the ambient occlusion is low, read at each sample's texel."""

import numpy as np
import pytest
import trimesh
from trimesh.visual import TextureVisuals

import texbake
from texbake.errors import ParameterError
from texbake.materials import evaluate_material

CLEAN, DIRT = [0.9, 0.9, 0.9], [0.25, 0.15, 0.05]
DIRTY = {"name": "dirty", "base_color": {"op": "mix", "a": CLEAN, "b": DIRT, "mask": {"op": "invert", "input": {"op": "mesh_map", "map": "ao"}}},
         "roughness": {"op": "mesh_map", "map": "curvature"}}


def floor_and_wall():
    """A floor (z = 0) meeting a wall (x = 0), each a unit square, laid side by side in UV."""
    vertices = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [0, 1, 1]])
    faces = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 5], [0, 5, 4]])
    uv = np.array([[0.5, 0.0], [1.0, 0.0], [1.0, 1.0], [0.5, 1.0], [0.0, 0.0], [0.0, 1.0]]) * [0.98, 1] + [0.01, 0]
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.visual = TextureVisuals(uv=uv)
    return mesh


def test_dirt_follows_the_occlusion_texel_by_texel():
    result = texbake.bake_mesh(floor_and_wall(), material=DIRTY, maps=["ao", "curvature"], size=32, margin=0, map_rays=32,
                               map_distance=0.5)
    covered = result.coverage
    ao = result.images["ao"][covered, 0].astype(np.float64)
    assert ao.min() < 0.7 and ao.max() > 0.99  # the corner's floor and wall are occluded, their far edges open
    expected = np.asarray(CLEAN) + (np.asarray(DIRT) - np.asarray(CLEAN)) * (1.0 - ao)[:, None]
    # base_color is sRGB-encoded only when written: the image holds the linear values
    np.testing.assert_allclose(result.images["base_color"][covered], expected, atol=1e-6)
    np.testing.assert_allclose(result.images["roughness"][covered], result.images["curvature"][covered], atol=1e-6)


def test_a_material_reading_a_mesh_map_the_bake_does_not_make_is_refused():
    with pytest.raises(ParameterError) as info:
        texbake.bake_mesh(floor_and_wall(), material=DIRTY, maps=["ao"], size=16)
    assert "curvature" in info.value.problem


def test_evaluate_material_takes_the_mesh_maps_values():
    out = evaluate_material(DIRTY, np.zeros((2, 3)), mesh_maps={"ao": [1.0, 0.0], "curvature": [0.5, 0.7]})
    np.testing.assert_allclose(out["base_color"], [CLEAN, DIRT])
    np.testing.assert_allclose(out["roughness"][:, 0], [0.5, 0.7])
    with pytest.raises(ValueError, match="mesh map"):
        evaluate_material(DIRTY, np.zeros((2, 3)))
