"""texbake.meshmaps.thickness: the rays into a slab find its far side."""

import numpy as np
import trimesh

from texbake.meshmaps.thickness import thickness
from texbake.sampling import Scene


def slab(t):
    """A box 200 x 200 wide and ``t`` thick (z from -t to 0), outward normals."""
    box = trimesh.creation.box(extents=[200.0, 200.0, t])
    return box.vertices - [0, 0, t / 2], box.faces


def test_a_slabs_thickness_is_the_cosine_mean_of_its_capped_depth():
    distance = 2.0
    for t in (0.25, 1.0):
        scene = Scene(*slab(t))
        points = np.array([[0.0, 0.0, 0.0], [10.0, -20.0, 0.0]])
        value = thickness(scene, points, np.tile([0.0, 0.0, 1.0], (2, 1)), 1024, distance, bias=1e-5)
        expected = (2 * t - t * t / distance) / distance  # the mean of min(t / cos, d) under the cosine weight
        np.testing.assert_allclose(value[:, 0], expected, atol=0.01)


def test_a_thicker_slab_than_the_rays_reach_is_one():
    scene = Scene(*slab(5.0))
    value = thickness(scene, np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]]), 64, 2.0, bias=1e-5)
    assert abs(value[0, 0] - 1.0) < 1e-6  # every ray capped (float32 distances)
