"""texbake.meshmaps.highpoly: high to low onto planes and spheres whose answers are known, a
cage mesh, the misses, and parts matched by their _high / _low names."""

import numpy as np
import pytest
import trimesh
from trimesh.visual import TextureVisuals

import texbake
from texbake.errors import ParameterError
from texbake.meshmaps.highpoly import match_parts, part_key

SOURCE_MAPS = ["source_normal", "source_height", "source_missed"]


def plane(z=0.0, slope=0.0, x0=0.0, x1=1.0, n=4, margin=0.0):
    """A square grid z = z + slope x over x in [x0, x1], y in [0, 1] (each ``margin`` wider), its
    UVs its x, y (scaled in)."""
    xs, ys = np.meshgrid(np.linspace(x0 - margin, x1 + margin, n + 1), np.linspace(-margin, 1 + margin, n + 1))
    vertices = np.column_stack([xs.ravel(), ys.ravel(), z + slope * xs.ravel()])
    k = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()
    faces = np.concatenate([np.column_stack([k, k + 1, k + n + 2]), np.column_stack([k, k + n + 2, k + n + 1])])
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    mesh.visual = TextureVisuals(uv=0.02 + 0.96 * (vertices[:, :2] - [x0 - margin, -margin]) / [x1 - x0 + 2 * margin, 1 + 2 * margin])
    return mesh


def test_a_tilted_source_plane_gives_its_normal_in_the_targets_frame_and_its_height():
    result = texbake.bake_mesh(plane(), maps=SOURCE_MAPS, source=plane(0.02, 0.05), size=32, margin=0, front_distance=0.1)
    covered = result.coverage
    normal = np.array([-0.05, 0.0, 1.0]) / np.linalg.norm([-0.05, 0.0, 1.0])  # T = +x, B = +y, N = +z: the same coefficients
    np.testing.assert_allclose(result.images["source_normal"][covered], np.broadcast_to(0.5 + 0.5 * normal, (int(covered.sum()), 3)),
                               atol=2e-6)
    assert not result.images["source_missed"][covered].any()
    rows, cols = np.nonzero(covered)
    x = (cols + 0.5) / 32
    x = (x - 0.02) / 0.96
    np.testing.assert_allclose(result.images["source_height"][rows, cols, 0], 0.5 + 0.5 * (0.02 + 0.05 * x) / 0.1, atol=2e-5)
    figures = result.report["mesh_maps"]
    assert figures["source_missed"] == 0 and figures["source_rays"] == int(covered.sum()) and not figures["cage"]


def test_a_source_beyond_the_rays_is_missed_counted_and_flat():
    result = texbake.bake_mesh(plane(), maps=SOURCE_MAPS, source=plane(0.5), size=16, margin=0, front_distance=0.1)
    missed = result.images["source_missed"][:, :, 0] == 1.0  # the texture's transfer missed too: no texel is covered
    figures = result.report["mesh_maps"]
    assert missed.sum() == figures["source_missed"] == figures["source_rays"] > 100
    np.testing.assert_allclose(result.images["source_normal"][missed], np.broadcast_to([0.5, 0.5, 1.0], (int(missed.sum()), 3)))
    np.testing.assert_allclose(result.images["source_height"][missed], 0.5)


def test_a_subdivided_sphere_onto_its_low_poly_version_is_nearly_flat():
    low = trimesh.creation.icosphere(subdivisions=3)
    high = trimesh.creation.icosphere(subdivisions=5)
    result = texbake.bake_mesh(low, maps=SOURCE_MAPS, source=high, size=64, margin=0, uv="unwrap")
    covered = result.coverage
    n = 2.0 * result.images["source_normal"][covered].astype(np.float64) - 1.0
    angle = np.degrees(np.arccos(np.clip(n[:, 2] / np.linalg.norm(n, axis=1), -1, 1)))
    assert angle.mean() < 1.0 and result.report["mesh_maps"]["source_missed"] == 0
    # the high sphere lies outside the flat faces of the low one, by at most its sagitta (1.3 % at 3 subdivisions)
    height = result.images["source_height"][covered, 0]
    assert height.min() >= 0.5 - 1e-6 and height.max() < 0.5 + 0.5 * 0.02 / (0.05 * np.linalg.norm([2, 2, 2]))


def test_rays_from_a_cage_mesh_of_the_same_topology():
    low = trimesh.creation.icosphere(subdivisions=2)
    cage = low.copy()
    cage.vertices *= 1.2
    high = trimesh.creation.icosphere(subdivisions=4, radius=1.1)
    result = texbake.bake_mesh(low, maps=SOURCE_MAPS, source=high, cage_mesh=cage, size=32, margin=0, uv="unwrap", back_distance=0.1)
    assert result.report["mesh_maps"]["cage"] and result.report["mesh_maps"]["source_missed"] == 0
    without = texbake.bake_mesh(low, maps=SOURCE_MAPS, source=high, size=32, margin=0, uv="unwrap", front_distance=0.05)
    figures = without.report["mesh_maps"]
    assert figures["source_missed"] == figures["source_rays"] > 0  # the high sphere is out of its reach


def test_a_cage_of_another_topology_is_refused():
    low = trimesh.creation.icosphere(subdivisions=2)
    with pytest.raises(ParameterError) as info:
        texbake.bake_mesh(low, maps=SOURCE_MAPS, source=low, cage_mesh=trimesh.creation.icosphere(subdivisions=1), size=16, uv="unwrap")
    assert info.value.name == "cage_mesh"


def test_source_maps_without_a_source_are_refused():
    with pytest.raises(ParameterError) as info:
        texbake.bake_mesh(plane(), maps=["source_normal"], size=16)
    assert info.value.name == "maps"


def write_parts(path, parts):
    """An OBJ of named groups: ``parts`` is ``[(name, trimesh)]``."""
    lines, base = [], 1
    for name, mesh in parts:
        lines.append(f"o {name}")
        lines += [f"v {x} {y} {z}" for x, y, z in mesh.vertices]
        lines += [f"vt {u} {v}" for u, v in mesh.visual.uv]
        lines += [f"f {a + base}/{a + base} {b + base}/{b + base} {c + base}/{c + base}" for a, b, c in mesh.faces]
        base += len(mesh.vertices)
    path.write_text("\n".join(lines) + "\n")


def test_parts_see_only_their_own_high_part(tmp_path):
    write_parts(tmp_path / "low.obj", [("a_low", plane(0.0, x0=0, x1=1)), ("b_low", plane(0.0, x0=2, x1=3))])
    # b_high lies over both low parts, above a_high: a_low's rays would find it first (the high
    # parts a little wider than the low ones: rays down a shared edge may pass either side)
    write_parts(tmp_path / "high.obj", [("a_high", plane(0.02, x0=0, x1=1, margin=0.01)), ("b_high", plane(0.08, x0=-0.5, x1=3.5, margin=0.01))])
    result = texbake.bake_mesh(tmp_path / "low.obj", maps=["source_height"], source=tmp_path / "high.obj", size=64, margin=0,
                               front_distance=0.1, uv="unwrap")
    heights = np.unique(np.round(result.images["source_height"][result.coverage, 0].astype(np.float64), 3))
    np.testing.assert_allclose(heights, [0.6, 0.9])  # a_low sees a_high (0.02), b_low b_high (0.08)


def test_part_names_match_by_their_suffixes():
    assert part_key("Bolt_HIGH") == ("bolt", "high") and part_key("body") == ("body", None)
    matches = match_parts(["bolt_low", "body", "nut_low"], ["nut_high", "bolt_high", "bolt.high", "other_high"])
    assert {k: v.tolist() for k, v in matches.items()} == {0: [1, 2], 2: [0]}


def test_the_glb_carries_the_high_to_low_normal_map_and_its_tangents(tmp_path):
    import json
    import struct

    result = texbake.bake_mesh(plane(), maps=["source_normal"], source=plane(0.02, 0.05), size=16, front_distance=0.1)
    result.save(tmp_path)
    data = next(tmp_path.glob("*.glb")).read_bytes()
    gltf = json.loads(data[20 : 20 + struct.unpack("<I", data[12:16])[0]])
    material = gltf["materials"][0]
    assert "normalTexture" in material
    image = gltf["images"][gltf["textures"][material["normalTexture"]["index"]]["source"]]
    assert "source_normal" in image.get("uri", image.get("name", "source_normal"))
    assert "TANGENT" in gltf["meshes"][0]["primitives"][0]["attributes"]


def test_a_bake_of_mesh_maps_only_has_no_albedo_and_the_same_maps(tmp_path):
    """texture none: the mesh maps alone, from the mesh maps' own texels; the same source maps and coverage."""
    low, high = trimesh.creation.icosphere(subdivisions=2), trimesh.creation.icosphere(subdivisions=4)
    kwargs = dict(maps=SOURCE_MAPS, source=high, size=64, margin=2, uv="unwrap")
    full = texbake.bake_mesh(low, **kwargs)
    alone = texbake.bake_mesh(low, texture="none", **kwargs)
    assert "albedo" not in alone.images and "albedo" in full.images
    np.testing.assert_array_equal(alone.coverage, full.coverage)  # one sample a texel: the texel centres both
    for name in SOURCE_MAPS:
        np.testing.assert_allclose(alone.images[name], full.images[name], atol=1e-6)
    report = alone.report
    assert report["error_estimate"] is None and report["settings"]["texture"] is None
    assert {"stage": "texture", "why": "texture none: the mesh maps alone (no albedo, no samples or error estimate of its own)"} in report["skipped"]
    written = alone.save(tmp_path)
    assert "albedo" not in written and (tmp_path / "source_normal.png").exists() and not (tmp_path / "albedo.png").exists()
    import json
    import struct

    data = (tmp_path / f"{next(p.stem for p in tmp_path.glob('*.glb'))}.glb").read_bytes()
    doc = json.loads(data[20 : 20 + struct.unpack_from("<I", data, 12)[0]])
    (material,) = doc["materials"]
    assert "baseColorTexture" not in material["pbrMetallicRoughness"] and "normalTexture" in material


@pytest.mark.parametrize(("options", "named"), [({}, "texture"), ({"maps": ["ao"], "shading": "full"}, "shading"),
                                                ({"maps": ["ao"], "bump": "wood"}, "bump")])
def test_texture_none_needs_maps_and_no_colour_settings(options, named):
    with pytest.raises(ParameterError) as caught:
        texbake.BakeSettings.build(texture="none", **options)
    assert caught.value.name == named, caught.value


@pytest.mark.parametrize("directx", [False, True])
def test_the_compiled_tangent_codes_are_tangent_space_where_hit_and_flat_elsewhere(directx):
    from texbake import _native
    from texbake.mesh.tangents import sample_frames
    from texbake.meshmaps.highpoly import tangent_space

    rng = np.random.default_rng(5)
    n = 2000
    corner_normals = rng.normal(size=(n, 3, 3))
    corner_normals /= np.linalg.norm(corner_normals, axis=2, keepdims=True)
    corner_tangents = np.concatenate([rng.normal(size=(n, 3, 3)), rng.choice([-1.0, 1.0], size=(n, 3, 1))], axis=2)
    frame = sample_frames(corner_normals, corner_tangents, rng.dirichlet([1, 1, 1], size=n))
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    normals[:10] = 0.0  # no normal: (0, 0, 1)
    hit = rng.random(n) < 0.8
    codes = np.empty((n, 3))
    _native.tangent_codes(normals, frame, hit.view(np.uint8), directx, codes)
    expect = tangent_space(normals, frame, directx)
    assert np.abs(codes[hit] - expect[hit]).max() < 1e-15  # float64 round-off, sums in another order
    assert np.array_equal(codes[~hit], np.tile([0.5, 0.5, 1.0], ((~hit).sum(), 1)))
    assert np.array_equal(codes[:10], np.tile([0.5, 0.5, 1.0], (10, 1)))  # no normal: flat, whichever the convention


def test_the_compiled_interpolated_normals_are_the_unit_mean_of_the_corners():
    from texbake import _native

    rng = np.random.default_rng(6)
    faces = rng.integers(0, 50, size=(80, 3))
    normals = rng.normal(size=(50, 3))
    normals[7] = 0.0
    faces[3] = 7  # all three corners without a normal: 0
    face = rng.integers(0, 80, size=3000)
    face[:5] = 3
    bary = rng.dirichlet([1, 1, 1], size=3000)
    out = np.empty((3000, 3))
    _native.interpolated_normals(face, bary, faces, normals, out)
    smooth = np.einsum("ni,nij->nj", bary, normals[faces[face]])
    smooth /= np.maximum(np.linalg.norm(smooth, axis=1, keepdims=True), 1e-300)
    assert np.abs(out - smooth).max() < 1e-15 and np.array_equal(out[:5], np.zeros((5, 3)))
    with pytest.raises(ValueError, match="outside"):
        _native.interpolated_normals(np.array([80]), bary[:1], faces, normals, out[:1])
