"""Tangent frames (bake/tangents.py): the glTF TANGENT attribute and the frame the normal
map is baked in, checked against what a viewer rebuilds from the GLB's attributes."""

import numpy as np
import pytest
import trimesh

import texbake
from texbake.mesh.tangents import sample_frames, vertex_tangents

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def quad(uv):
    """The unit square in the x-y plane (normal +z) as two triangles, with ``uv`` (4, 2)."""
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return v, f, np.asarray(uv, dtype=float)


# (u, v) of the corners (0,0), (1,0), (1,1), (0,1): u along +y and v along -x (a quarter
# turn: w = +1), and u along +y, v along +x (mirrored: w = -1)
TURNED = [[0.1, 0.9], [0.1, 0.1], [0.9, 0.1], [0.9, 0.9]]
MIRRORED = [[0.1, 0.1], [0.1, 0.9], [0.9, 0.9], [0.9, 0.1]]


@pytest.mark.parametrize(("uv", "w"), [(TURNED, 1.0), (MIRRORED, -1.0)])
def test_tangents_follow_u_and_the_bitangent_follows_v(uv, w):
    v, f, t = quad(uv)
    normals = np.tile([0.0, 0.0, 1.0], (4, 1))
    source, faces, tangents = vertex_tangents(v, f, t, normals)
    assert np.array_equal(source, np.arange(4)) and np.array_equal(faces, f)  # nothing to split
    assert np.allclose(tangents, [[0, 1, 0, w]] * 4, rtol=0, atol=1e-12)  # dP/du is +y; float64 round-off
    frames = sample_frames(normals[f], tangents[f], np.full((2, 3), 1 / 3))
    dpdv = np.array([-1.0, 0, 0]) if w > 0 else np.array([1.0, 0, 0])
    assert np.allclose(frames[:, 1], dpdv, rtol=0, atol=1e-12)  # B = w N x T points along +v
    assert np.allclose(frames[:, 2], [0, 0, 1], rtol=0, atol=1e-12)


def test_tangents_are_unit_and_orthogonal_on_a_real_mesh(meshes):
    result = texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=64, bump="noise")
    m = result.mesh
    assert m.tangents is not None and m.normals is not None and m.tangents.shape == (len(m.vertices), 4)
    assert np.abs(np.linalg.norm(m.tangents[:, :3], axis=1) - 1).max() < 1e-12
    assert np.abs(np.einsum("ij,ij->i", m.tangents[:, :3], m.normals)).max() < 1e-12
    assert set(np.unique(m.tangents[:, 3])) <= {-1.0, 1.0}
    assert texbake.bake_mesh(meshes / "suzanne.ply", "marble", size=16).mesh.tangents is None  # no normal map, no tangents


@pytest.mark.parametrize("uv", [TURNED, MIRRORED])
def test_a_viewer_rebuilds_the_bumped_normal_from_the_glb_frame(uv):
    # h = luminance of the position texture = 0.2126 x + 0.7152 y on the unit square: the
    # bumped normal is normalize(n - grad h) = normalize(-0.2126, -0.7152, 1) in object
    # space, whatever the UV layout. Rebuild it as glTF says a viewer does, from the
    # normal map and the mesh's NORMAL and TANGENT (B = w N x T): it must come back.
    v, f, t = quad(uv)
    mesh = trimesh.Trimesh(v, f, visual=trimesh.visual.TextureVisuals(uv=t), process=False)
    result = texbake.bake_mesh(mesh, "checker", size=32, bump="position", uv="keep", margin=0)
    m = result.mesh
    inside = np.zeros(result.coverage.shape, bool)
    inside[6:-6, 6:-6] = True  # away from the square's edges, where the position clamps
    assert (result.coverage & inside).sum() > 300
    local = 2.0 * result.images["normal"][result.coverage & inside].astype(np.float64) - 1.0
    tangent, normal = m.tangents[0], m.normals[0]  # one frame over the flat square
    assert np.allclose(m.tangents, tangent) and np.allclose(m.normals, normal)
    bitangent = tangent[3] * np.cross(normal, tangent[:3])
    world = local @ np.array([tangent[:3], bitangent, normal])
    expect = np.array([-LUMINANCE[0], -LUMINANCE[1], 1.0])
    expect /= np.linalg.norm(expect)
    assert np.abs(world - expect).max() < 1e-6  # float32 image: measured 5e-8


def fan(uv):
    """Four triangles around the origin in the x-y plane (normal +z): centre 0, then (1, 0),
    (0, 1) twice, (-1, 0), (0, -1) twice; faces 0 and 3 use the first copies of the shared
    rim vertices, faces 1 and 2 the second; ``uv`` (7, 2)."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [0, -1, 0]], dtype=float)
    f = np.array([[0, 1, 2], [0, 3, 4], [0, 4, 5], [0, 6, 1]])
    return v, f, np.asarray(uv, dtype=float), np.tile([0.0, 0.0, 1.0], (7, 1))


def test_a_uv_seam_that_meets_itself_at_a_vertex_splits_it():
    # faces 0 and 3 laid as (u, v) = (x, y), faces 1 and 2 turned a quarter, (u, v) = (y, -x):
    # they share the centre's UV (0, 0) but no edge, so MikkTSpace (and Blender) give the
    # centre two tangents, +x and +y; one per vertex, the mean would be 45° off both
    v, f, t, n = fan([[0, 0], [1, 0], [0, 1], [1, 0], [0, 1], [-1, 0], [0, -1]])
    source, faces, tangents = vertex_tangents(v, f, t, n)
    assert np.array_equal(source, [0, 1, 2, 3, 4, 5, 6, 0])  # the centre once more
    assert faces[:, 0].tolist() == [0, 7, 7, 0] and np.array_equal(faces[:, 1:], f[:, 1:])
    assert np.allclose(tangents[0], [1, 0, 0, 1], rtol=0, atol=1e-12)
    assert np.allclose(tangents[7], [0, 1, 0, 1], rtol=0, atol=1e-12)


def test_a_mirror_line_splits_its_vertices_with_opposite_signs():
    # (u, v) = (|x|, y): the UVs run on across the y axis, but mirrored on its left (faces 1
    # and 2): there u runs along -x and w = -1; one tangent per vertex would sum +x and -x
    v, f, t, n = fan([[0, 0], [1, 0], [0, 1], [0, 1], [1, 0], [0, -1], [0, -1]])
    f = f.copy()
    f[1, 1], f[3, 1] = 2, 5  # the shared rim vertices used once each: the UVs agree there
    source, faces, tangents = vertex_tangents(v, f, t, n)
    right, left = faces[[0, 3]], faces[[1, 2]]
    assert not set(right.ravel()) & set(left.ravel())  # the centre, (0, 1) and (0, -1) split
    assert np.allclose(tangents[right.ravel()], [1, 0, 0, 1], rtol=0, atol=1e-12)
    assert np.allclose(tangents[left.ravel()], [-1, 0, 0, -1], rtol=0, atol=1e-12)
    assert np.array_equal(v[source[faces]], v[f])  # the same positions, corner for corner


def test_an_edge_of_three_faces_joins_none_of_them():
    # Blender's corner normals part at an edge of more than two faces, so its tangents do:
    # the two faces on the edge 0-1's far side are no group with the near one there
    v = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, -1, 0.1]], dtype=float)
    f = np.array([[0, 1, 2], [1, 0, 3], [1, 0, 4]])
    t = v[:, :2].copy()
    t[4] = [0.5, -1.0]
    n = np.tile([0.0, 0.0, 1.0], (5, 1))
    source, faces, _ = vertex_tangents(v, f, t, n)
    assert len(source) == 5 + 4  # 0 and 1: one vertex for each of their three faces
    two = np.array([[0, 1, 2], [1, 0, 3]])
    assert len(vertex_tangents(v[:4], two, t[:4], n[:4])[0]) == 4  # two faces on the edge: one group
