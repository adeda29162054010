"""Shading normals of the output mesh (bake/normals.py): split at hard edges only."""

import numpy as np
import pytest
import trimesh

from texbake.mesh.normals import split_normals


def test_a_cube_splits_at_every_edge_and_keeps_its_faces():
    box = trimesh.creation.box()
    source, faces, normals = split_normals(box.vertices, box.faces)
    assert len(source) == 24  # 8 corners, 3 fans each
    assert np.array_equal(box.vertices[source][faces], box.vertices[box.faces])  # the same triangles
    expected = np.repeat(box.face_normals, 3, axis=0).reshape(-1, 3, 3)
    assert np.abs(normals[faces] - expected).max() < 1e-15  # each corner has its face's normal: measured 0


def test_a_sphere_stays_smooth_and_a_uv_seam_does_not_split_it():
    s = trimesh.creation.icosphere(3)
    # the same sphere with its vertices split in two along a "UV seam" (x < 0 re-indexed)
    seam = s.vertices[:, 0] < 0
    vertices = np.concatenate([s.vertices, s.vertices[seam]])
    moved = np.full(len(s.vertices), -1)
    moved[seam] = len(s.vertices) + np.arange(seam.sum())
    faces = s.faces.copy()
    west = seam[s.faces].all(axis=1)  # faces wholly west of the seam use the copies
    faces[west] = moved[s.faces[west]]
    for v, f in ((s.vertices, s.faces), (vertices, faces)):
        source, new_faces, normals = split_normals(v, f)
        assert len(source) == len(np.unique(f))  # no hard edge: nothing split (unused vertices go)
        radial = v[source] / np.linalg.norm(v[source], axis=1, keepdims=True)
        assert np.abs(normals - radial).max() < 0.02  # area-weighted, not radial: measured 0.011
    # both copies of a seam vertex get the same normal
    source, _, normals = split_normals(vertices, faces)
    new = np.full(len(vertices), -1)
    new[source] = np.arange(len(source))  # nothing split: one new vertex per used old one
    copies = np.flatnonzero(seam)
    both = (new[copies] >= 0) & (new[moved[copies]] >= 0)  # seam vertices used on both sides
    assert both.sum() > 10
    assert np.abs(normals[new[copies[both]]] - normals[new[moved[copies[both]]]]).max() < 1e-15


def test_a_cylinder_splits_its_caps_from_its_side_only():
    c = trimesh.creation.cylinder(radius=1, height=2, sections=64)
    source, faces, normals = split_normals(c.vertices, c.faces)
    rim = np.linalg.norm(c.vertices[:, :2], axis=1) > 0.5  # not the caps' centres
    assert len(source) == len(c.vertices) + rim.sum()  # each rim vertex: one for the cap, one for the side
    side = np.abs(np.abs(normals[:, 2]) - 1) > 1e-9
    assert np.abs(normals[side, 2]).max() < 1e-12  # side normals are horizontal
    assert np.abs(np.linalg.norm(normals, axis=1) - 1).max() < 1e-15


def _numpy_split_normals(vertices, faces, angle):
    """The numpy implementation the compiled one replaced (sorts where it hashes), kept as its
    reference: the same vertices, faces and normal bits are expected."""
    from texbake.mesh.components import connected_components

    m = len(faces)
    _, position = np.unique(vertices + 0.0, axis=0, return_inverse=True)
    position = position.ravel()[faces]
    tri = vertices[faces]
    weighted = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(weighted, axis=1, keepdims=True)
    unit = np.divide(weighted, length, out=np.zeros_like(weighted), where=length > 0)
    start, end = position.ravel(), np.roll(position, -1, axis=1).ravel()
    key = np.minimum(start, end) * (int(start.max()) + 1) + np.maximum(start, end)
    order = np.argsort(key, kind="stable")
    same = np.flatnonzero(key[order][1:] == key[order][:-1])
    h, k = order[same], order[same + 1]
    soft = np.einsum("ij,ij->i", unit[h // 3], unit[k // 3]) >= np.cos(np.radians(angle))
    h, k = h[soft], k[soft]
    nxt = lambda c: c - c % 3 + (c % 3 + 1) % 3
    forward = start[k] == start[h]
    fan = connected_components(3 * m, np.concatenate([h, nxt(h)]),
                               np.concatenate([np.where(forward, k, nxt(k)), np.where(forward, nxt(k), k)]))
    corner_weight = np.repeat(weighted, 3, axis=0)
    normal = np.stack([np.bincount(fan, weights=corner_weight[:, c], minlength=fan.max() + 1) for c in range(3)], axis=1)
    length = np.linalg.norm(normal, axis=1)
    normal[length > 0] /= length[length > 0, None]
    normal[~(length > 0)] = (0.0, 0.0, 1.0)
    fans = int(fan.max()) + 1
    unique, first, inverse = np.unique(faces.ravel() * fans + fan, return_index=True, return_inverse=True)
    return unique // fans, inverse.reshape(m, 3), normal[fan[first]]


@pytest.mark.parametrize("angle", [30.0, 60.0, 89.0])
def test_the_compiled_pass_gives_the_numpy_versions_bits(angle):
    rng = np.random.default_rng(int(angle))
    meshes = [(trimesh.creation.cylinder(radius=1, height=2, sections=24).vertices,
               trimesh.creation.cylinder(radius=1, height=2, sections=24).faces)]
    v = rng.integers(-2, 3, (300, 3)).astype(float) * 0.5  # coarse: shared positions, -0.0, non-manifold edges
    v[::7] *= -0.0
    meshes.append((v, rng.integers(0, 300, (2500, 3))))
    meshes.append((rng.normal(size=(2000, 3)), rng.integers(0, 2000, (9000, 3))))
    for vertices, faces in meshes:
        faces = np.asarray(faces, dtype=np.int64)
        for a, b in zip(split_normals(vertices, faces, angle), _numpy_split_normals(vertices, faces, angle), strict=True):
            assert a.shape == b.shape and a.tobytes() == np.asarray(b, dtype=a.dtype).tobytes()
