"""texbake.meshmaps.occlusion: ambient occlusion and bent normals of points whose answers are
known (a floor in a box corner), and the compiled rays against a numpy reference."""

import numpy as np
import pytest
from hemisphere_reference import open_share

from texbake.meshmaps.occlusion import ambient_occlusion
from texbake.sampling import Scene

UP = np.array([0.0, 0.0, 1.0])


def box_corner(side=100.0):
    """A floor (z = 0) and two walls (x = 0, y = 0), each a square of ``side``, two triangles each."""
    s = side
    vertices = np.array([[0, 0, 0], [s, 0, 0], [s, s, 0], [0, s, 0],  # floor
                         [0, 0, s], [0, s, s],  # wall x = 0: 0, 3, 5, 4
                         [s, 0, s]], dtype=np.float64)  # wall y = 0: 0, 1, 6, 4
    faces = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 5], [0, 5, 4], [0, 4, 6], [0, 6, 1]])
    return vertices, faces


def test_a_floor_in_a_box_corner_sees_a_quarter_beside_a_wall_half_and_in_the_open_all():
    vertices, faces = box_corner()
    scene = Scene(vertices, faces)
    points = np.array([[1e-3, 1e-3, 0.0], [1e-3, 50.0, 0.0], [50.0, 50.0, 0.0]])
    ao, _ = ambient_occlusion(scene, points, np.tile(UP, (3, 1)), 1024, 1.0, bias=1e-4)
    # the two walls cut the cosine-weighted hemisphere into four equal quadrants; rays of at
    # most 1 from 1e-3 off a wall miss it only within 1e-3 of the vertical
    np.testing.assert_allclose(ao[:, 0], [0.25, 0.5, 1.0], atol=0.01)


def test_the_bent_normal_in_a_corner_points_into_its_open_quadrant():
    vertices, faces = box_corner()
    scene = Scene(vertices, faces)
    _, bent = ambient_occlusion(scene, np.array([[1e-3, 1e-3, 0.0]]), UP[None], 4096, 1.0, bias=1e-4, bent=True)
    assert bent is not None
    # the cosine-weighted mean of the quadrant x, y > 0: (1/(3 pi), 1/(3 pi), 1/6), made unit
    expected = np.array([1 / (3 * np.pi), 1 / (3 * np.pi), 1 / 6])
    expected /= np.linalg.norm(expected)
    direction = 2.0 * bent[0] - 1.0
    assert np.degrees(np.arccos(np.clip(direction @ expected, -1, 1))) < 1.0


def test_an_open_point_bends_nowhere_and_a_shut_one_keeps_its_normal():
    vertices, faces = box_corner()
    scene = Scene(vertices, faces)
    ao, bent = ambient_occlusion(scene, np.array([[50.0, 50.0, 0.0]]), UP[None], 256, 10.0, bias=1e-4, bent=True)
    assert ao[0, 0] == 1.0 and bent is not None
    assert (2.0 * bent[0] - 1.0) @ UP > 0.99  # the cosine-weighted mean of the whole hemisphere is the normal
    # under the floor, facing it, with rays long enough that none passes its edge
    ao, bent = ambient_occlusion(scene, np.array([[50.0, 50.0, -0.01]]), UP[None], 256, 1e4, bias=1e-4, bent=True)
    assert ao[0, 0] == 0.0 and bent is not None
    np.testing.assert_allclose(2.0 * bent[0] - 1.0, UP, atol=1e-6)  # every ray occluded: the normal


@pytest.mark.parametrize("point", [[0.2, 0.3, 0.0], [0.05, 0.6, 0.0], [0.7, 0.7, 0.0]])
def test_the_compiled_rays_agree_with_a_numpy_reference_at_a_finite_distance(point):
    vertices, faces = box_corner(1.0)
    scene = Scene(vertices, faces)
    ao, _ = ambient_occlusion(scene, np.array([point]), UP[None], 4096, 0.5, bias=1e-6)
    reference = open_share(vertices, faces, point, UP, 0.5)
    # 4096 stratified rays against 20000 random ones: the reference's own standard error is 0.0035
    assert abs(ao[0, 0] - reference) < 0.015


def test_the_same_seed_gives_the_same_noise_and_another_seed_other_noise():
    vertices, faces = box_corner(1.0)
    scene = Scene(vertices, faces)
    points = np.column_stack([np.linspace(0.05, 0.9, 200), np.full(200, 0.1), np.zeros(200)])
    normals = np.tile(UP, (200, 1))
    a = ambient_occlusion(scene, points, normals, 16, 0.5, bias=1e-6, seed=1)[0]
    b = ambient_occlusion(scene, points, normals, 16, 0.5, bias=1e-6, seed=1)[0]
    c = ambient_occlusion(scene, points, normals, 16, 0.5, bias=1e-6, seed=2)[0]
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
