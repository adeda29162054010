"""A material's maps in a real bake: each channel its own map (checked against texture
bakes of the same fields through the same sampler), the normal map from the height in
both conventions, the packed maps exact, the report's counts and per-channel estimates."""

import numpy as np
import pytest

import texbake
from texbake.errors import ParameterError
from texbake.output.images import read_image

MARBLE_R = {"op": "channel", "input": {"name": "marble"}, "channel": "r"}


@pytest.fixture(scope="module")
def mesh(meshes):
    return meshes / "suzanne.ply"


def test_every_channel_is_its_own_map_baked_through_the_same_samples(mesh):
    material = {"base_color": {"name": "marble"}, "roughness": MARBLE_R, "metallic": 0.0, "emissive": [0.1, 0.2, 0.3],
                "opacity": {"op": "invert", "input": MARBLE_R}}
    result = texbake.bake_mesh(mesh, material=material, size=64)
    albedo = texbake.bake_mesh(mesh, "marble", size=64).images["albedo"]  # the same atlas, samples and filtering
    images, covered = result.images, result.coverage
    assert set(images) == {"base_color", "roughness", "metallic", "emissive", "opacity", "orm"}
    assert images["base_color"].shape == (64, 64, 3) and images["roughness"].shape == (64, 64, 1)
    np.testing.assert_array_equal(images["base_color"], albedo)
    np.testing.assert_array_equal(images["roughness"][..., 0], albedo[..., 0])
    np.testing.assert_allclose(images["opacity"][..., 0][covered], 1 - albedo[..., 0][covered], rtol=0, atol=6e-8)  # float32
    assert (images["metallic"][covered] == 0).all() and np.allclose(images["emissive"][covered], [0.1, 0.2, 0.3])
    assert "normal" not in images and result.mesh.tangents is None  # no height, no normal channel: no normal map


def test_the_lit_map_shades_the_base_colour(mesh):
    result = texbake.bake_mesh(mesh, material={"base_color": [0.5, 0.5, 0.5]}, size=32, shading="ambient-diffuse")
    lit, covered = result.images["lit"], result.coverage
    assert lit[covered].min() >= 0.5 * 0.2 - 1e-6 and lit[covered].max() <= 0.5 + 1e-6 and lit[covered].std() > 0.01


def relief(convention, mesh, size=64):
    material = {"base_color": 0.5, "height": {"op": "texture", "texture": {"name": "turbulence", "scale": 3}, "output": "value"},
                "height_scale": 0.05}
    return texbake.bake_mesh(mesh, material=material, size=size, normal_convention=convention)


def test_the_normal_map_from_height_bends_and_directx_flips_green_exactly(mesh, tmp_path):
    gl, dx = relief("opengl", mesh), relief("directx", mesh)
    a, b, covered = gl.images["normal"], dx.images["normal"], gl.coverage
    assert gl.mesh.tangents is not None  # baked in the output mesh's tangent frame
    assert np.abs(a[covered][:, :2] - 0.5).max() > 0.05  # the relief tilts it
    np.testing.assert_array_equal(a[..., [0, 2]], b[..., [0, 2]])
    np.testing.assert_allclose(b[..., 1][covered], 1.0 - a[..., 1][covered], rtol=0, atol=6e-8)  # 1 - g, then float32
    gl.save(tmp_path / "gl")
    dx.save(tmp_path / "dx")
    green_gl = np.round(read_image(tmp_path / "gl" / "normal.png")[..., 1] * 255).astype(int)
    green_dx = np.round(read_image(tmp_path / "dx" / "normal.png")[..., 1] * 255).astype(int)
    ties = np.abs(a[..., 1].astype(np.float64) * 255 % 1 - 0.5) < 1e-4
    assert ((green_gl + green_dx == 255) | ties).all()
    # the GLB reads +Y whatever the maps are: a DirectX bake embeds a flipped copy
    gltf = np.round(read_image(tmp_path / "dx" / "normal_gltf.png")[..., 1] * 255).astype(int)
    assert np.abs(gltf - green_gl).max() <= 1


def test_a_known_normal_channel_is_written_exactly_in_both_conventions(mesh, tmp_path):
    material = {"base_color": 0.5, "normal": [0.5, 0.8, 0.9]}  # (0, 0.6, 0.8): unit already
    for convention, green in (("opengl", 204), ("directx", 51)):  # round(0.8 * 255), round(0.2 * 255)
        result = texbake.bake_mesh(mesh, material=material, size=16, normal_convention=convention, margin=0)
        result.save(tmp_path / convention)
        png = np.round(read_image(tmp_path / convention / "normal.png") * 255).astype(int)[result.coverage]
        assert (png == [128, green, 230]).all(), np.unique(png, axis=0)  # 0.5, 0.8 or 0.2, 0.9


def test_orm_and_the_hdrp_mask_pack_the_maps_exactly(mesh, tmp_path):
    material = {"base_color": 0.5, "occlusion": MARBLE_R, "roughness": 0.25,
                "metallic": {"op": "threshold", "input": MARBLE_R, "at": 0.6}}
    result = texbake.bake_mesh(mesh, material=material, size=64, packing=["orm", "hdrp-mask"])
    images = result.images
    np.testing.assert_array_equal(images["orm"], np.concatenate([images["occlusion"], images["roughness"], images["metallic"]], axis=2))
    mask = images["hdrp-mask"]
    np.testing.assert_array_equal(mask[..., :2], np.concatenate([images["metallic"], images["occlusion"]], axis=2))
    assert (mask[..., 2] == 1).all() and (mask[..., 3][result.coverage] == np.float32(0.75)).all()  # smoothness 1 - 0.25
    result.save(tmp_path)
    byte = lambda name: np.round(read_image(tmp_path / f"{name}.png") * 255).astype(int)
    orm, mask8 = byte("orm"), byte("hdrp-mask")
    for k, name in enumerate(("occlusion", "roughness", "metallic")):
        np.testing.assert_array_equal(orm[..., k], byte(name)[..., 0])  # the same data bytes
    assert (mask8[..., 3][result.coverage] == 191).all() and (byte("roughness")[..., 0][result.coverage] == 64).all()


def test_a_user_template_packs_what_it_names(mesh):
    template = {"name": "rma", "channels": ["roughness", "metallic", {"channel": "occlusion", "invert": True}]}
    result = texbake.bake_mesh(mesh, material={"base_color": 0.5, "roughness": MARBLE_R}, size=32, packing=[template])
    rma, covered = result.images["rma"], result.coverage
    np.testing.assert_array_equal(rma[..., 0], result.images["roughness"][..., 0])
    assert (rma[..., 1] == 0).all() and (rma[..., 2] == 0).all()  # the defaults: metallic 0, occlusion 1 inverted
    assert "orm" not in result.images and covered.any()


@pytest.mark.parametrize(("settings", "words"), [
    ({"packing": ["orm"]}, "packing: packs a material's channels; give a material"),
    ({"material": "lava", "packing": ["orn"]}, "packing: unknown template 'orn' (did you mean 'orm'?"),
    ({"material": "lava", "packing": [{"name": "x", "channels": ["base_color"]}]}, "packing: channels.0"),
    ({"material": "lava", "packing": ["orm", "orm"]}, "two templates named 'orm'"),
    ({"material": "lava", "bump": "noise"}, "bump: a material's normal map comes from its height"),
    ({"material": "lava", "texture": "flame", "frames": [0, 1]}, "frames: a material bakes one set of maps"),
])
def test_bad_material_settings_are_named(settings, words):
    with pytest.raises(ParameterError) as info:
        texbake.BakeSettings.build(settings)
    assert words in str(info.value)


def test_the_report_counts_a_shared_node_once_a_sample_and_estimates_each_map(mesh):
    turb = {"op": "texture", "texture": "turbulence", "output": "value"}
    material = {"nodes": {"t": turb}, "base_color": {"op": "remap", "input": "t", "colormap": {}}, "roughness": "t",
                "metallic": {"op": "smoothstep", "input": "t", "edge0": 0.4, "edge1": 0.6}, "height": "t"}
    report = texbake.bake_mesh(mesh, material=material, size=64).report
    samples = report["rays"]["cast"] - report["rays"]["missed"] + report["rays"]["crease_parts"]
    node = report["material"]["nodes"]["t"]
    assert report["rays"]["crease_parts"] > 0  # the mesh's texels at 64² span faces that meet at angles
    assert node["evaluations"] == samples and node["gradient_evaluations"] == 2 * samples
    assert sorted(node["channels"]) == ["base_color", "height", "metallic", "roughness"]
    assert report["material"]["maps"] == ["base_color", "roughness", "metallic", "height", "normal"]
    channels = report["error_estimate"]["channels"]
    assert set(channels) == {"base_color", "roughness", "metallic", "height", "normal"}
    assert all(0 < e["rmse"] < 0.1 for e in channels.values()), channels
    assert report["error_estimate"]["map"] == "base_color" and report["settings"]["material"]["nodes"]["t"] == turb

