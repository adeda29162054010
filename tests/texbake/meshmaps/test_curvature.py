"""texbake.meshmaps.curvature: the mean curvature of spheres of two radii, its sign, and the map's values."""

import numpy as np
import trimesh

from texbake.meshmaps.curvature import curvature_values, vertex_curvature


def test_spheres_of_two_radii_have_mean_curvature_one_over_their_radius():
    for radius in (0.5, 2.0):
        sphere = trimesh.creation.icosphere(subdivisions=4, radius=radius)
        h = vertex_curvature(sphere.vertices, sphere.faces)
        np.testing.assert_allclose(h, 1.0 / radius, rtol=0.02)


def test_an_inside_out_sphere_is_concave():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    h = vertex_curvature(sphere.vertices, sphere.faces[:, ::-1])
    np.testing.assert_allclose(h, -1.0, rtol=0.03)


def test_a_plane_is_flat_and_seams_do_not_break_it():
    grid = trimesh.creation.box(extents=[1, 1, 1]).subdivide().subdivide()
    vertices = grid.vertices[grid.faces].reshape(-1, 3)  # every face its own corners, as UV seams split them
    faces = np.arange(len(vertices)).reshape(-1, 3)
    h = vertex_curvature(vertices, faces)
    on_face_centres = np.all(np.abs(vertices) < 0.49, axis=1) | (np.sum(np.abs(vertices) > 0.49, axis=1) == 1)
    np.testing.assert_allclose(h[on_face_centres], 0.0, atol=1e-9)


def test_the_map_is_a_half_plus_half_the_scaled_curvature_clipped():
    curvature = np.array([1.0, 1.0, 1.0, -4.0, -4.0, -4.0])
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    values = curvature_values(curvature, faces, np.array([0, 1]), np.full((2, 3), 1 / 3), 0.5)
    np.testing.assert_allclose(values[:, 0], [0.75, 0.0])
