"""texbake.swatch: a texture (or a material's channel) on a sphere or a slice, without a
mesh (the service's /v1/swatch)."""

import numpy as np
import pytest

from texbake.errors import MaterialError, ParameterError, TextureError
from texbake.materials import evaluate_material
from texbake.swatch import material_swatch, swatch
from texbake.textures import evaluate


def test_a_sphere_on_a_transparent_ground():
    image = swatch("marble", 64)
    assert image.shape == (64, 64, 4) and image.dtype == np.float32
    alpha = image[..., 3]
    assert alpha[0, 0] == 0 and alpha[0, -1] == 0 and alpha[-1, 0] == 0 and alpha[-1, -1] == 0  # the corners are off the sphere
    assert (alpha[16:48, 16:48] == 1).all()
    assert ((alpha > 0) & (alpha < 1)).sum() > 0.8 * 2 * np.pi * 32  # the rim is antialiased, not a hard step
    assert np.isclose(alpha.sum(), np.pi * 32**2, rtol=0.01)  # the disk's area in pixels
    assert np.isfinite(image).all() and image[..., :3].min() >= 0


def test_the_slice_is_the_checkerboard_at_half_depth():
    # 8 cells of 0.125 across 64 pixels: 8-pixel squares, each of one colour, neighbours differing
    image = swatch("checker", 64, "slice")
    assert (image[..., 3] == 1).all()
    centres = image[4::8, 4::8, 0]
    assert (np.isclose(centres, 0.9) | np.isclose(centres, 0.05)).all()
    assert (centres[:, 1:] != centres[:, :-1]).all() and (centres[1:] != centres[:-1]).all()
    # row 0 is the top (y near 1): the cell of y in [0.875, 1) at z = 0.5 is parity 7 + 4 = odd
    assert np.isclose(image[4, 4, 0], 0.05)


def test_a_sphere_is_lit_as_a_lit_map_and_a_flame_is_not():
    grey = {"name": "checker", "color_even": [0.5, 0.5, 0.5], "color_odd": [0.5, 0.5, 0.5]}
    size = 32
    image = swatch(grey, size, light=(0, 0, 1))
    # pixel (row 16, column 16): u = 0.5 / 16, v = -0.5 / 16 on the unit disk; n.l = z
    u, v = (16 + 0.5) / size * 2 - 1, -((16 + 0.5) / size * 2 - 1)
    z = np.sqrt(1 - u * u - v * v)
    assert np.allclose(image[16, 16, :3], 0.5 * (0.2 + 0.8 * z), atol=1e-6)
    flame = swatch("flame", size)
    point = 0.5 + 0.5 * np.array([[u, v, z]])
    assert np.allclose(flame[16, 16, :3], evaluate("flame", point)[0], atol=1e-3)  # emitted light, not shaded (a footprint apart)


def test_the_swatch_follows_its_parameters_and_is_pure():
    a = swatch({"name": "marble", "frequency": 12}, 48)
    b = swatch({"name": "marble", "frequency": 40}, 48)
    assert np.abs(a - b).mean() > 0.02
    assert np.array_equal(a, swatch({"name": "marble", "frequency": 12}, 48))


@pytest.mark.parametrize("kwargs, error, words", [
    ({"size": 8}, ParameterError, "size"),
    ({"size": 5000}, ParameterError, "size"),
    ({"view": "cube"}, ParameterError, "view"),
    ({"spec": {"name": "marble", "frequency": -1}}, TextureError, "^frequency: expected a number above 0 and at most 1000000, got -1$"),
])
def test_bad_arguments_name_themselves(kwargs, error, words):
    with pytest.raises(error, match=words):
        swatch(**{"spec": "marble", **kwargs})


MASKED = {"nodes": {"mask": {"op": "texture", "output": "value", "texture": {"name": "checker"}}},
          "base_color": {"op": "mix", "a": [1.0, 0.0, 0.0], "b": [0.0, 0.0, 1.0], "mask": "mask"},
          "roughness": {"op": "mix", "a": 0.1, "b": 0.9, "mask": "mask"}, "emissive": {"name": "flame"}}


def test_a_material_channel_is_its_values_on_the_sphere_unlit():
    size = 32
    rough = material_swatch(MASKED, "roughness", size)
    assert rough.shape == (size, size, 4) and rough.dtype == np.float32
    assert np.array_equal(rough[..., 3], swatch("checker", size)[..., 3])  # the texture swatch's sphere
    assert np.allclose(rough[..., 0], rough[..., 1]) and np.allclose(rough[..., 0], rough[..., 2])  # a scalar: grey
    # each pixel on the sphere is the material at the point 0.5 + 0.5 n, as the library evaluates it: the same away from
    # the checker's edges, where the swatch's footprint filters them
    on = rough[..., 3] == 1
    c = (np.arange(size) + 0.5) / size * 2 - 1
    u, v = np.meshgrid(c, -c)
    points = 0.5 + 0.5 * np.column_stack([u[on], v[on], np.sqrt(np.maximum(1 - u[on] ** 2 - v[on] ** 2, 0))])
    sampled = evaluate_material(MASKED, points, channels=["roughness"])["roughness"][:, 0]
    assert (np.abs(rough[on, 0] - sampled) < 1e-4).mean() > 0.6, (np.abs(rough[on, 0] - sampled) < 1e-4).mean()
    assert np.isclose(rough[on, 0].min(), 0.1, atol=1e-3) and np.isclose(rough[on, 0].max(), 0.9, atol=1e-3)  # unlit: both layers exact
    colour = material_swatch(MASKED, "base_color", size)
    assert np.allclose(colour[on, 0] + colour[on, 2], 1.0, atol=1e-6)  # red or blue or a filtered mix, never shaded
    assert np.allclose((colour[on, 2] - 0.0) * 0.8 + 0.1, rough[on, 0], atol=1e-5)  # one mask under both channels
    assert np.abs(material_swatch(MASKED, "emissive", size)[on, :3]).max() > 0.1  # a texture's colour as the channel


def test_a_channel_the_material_does_not_give_is_its_default():
    metallic, normal = material_swatch(MASKED, "metallic", 16), material_swatch(MASKED, "normal", 16, "slice")
    assert (metallic[metallic[..., 3] > 0, :3] == 0).all()
    assert np.allclose(normal[..., :3], [0.5, 0.5, 1.0])


@pytest.mark.parametrize("kwargs, error, words", [
    ({"channel": "shine"}, ParameterError, "^channel: expected one of base_color, "),
    ({"size": 8}, ParameterError, "size"),
    ({"view": "cube"}, ParameterError, "view"),
    ({"material": {"base_color": "nowhere"}}, MaterialError, "^node 'base_color': unknown node 'nowhere'"),
    ({"material": {"base_color": 0.5, "roughness": {"op": "texture", "output": "value", "texture": {"name": "flame"}}}},
     MaterialError, "^node 'roughness': texture 'flame' has no value"),
])
def test_bad_material_swatches_name_themselves(kwargs, error, words):
    with pytest.raises(error, match=words):
        material_swatch(**{"material": MASKED, "channel": "roughness", **kwargs})
