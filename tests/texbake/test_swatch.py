"""texbake.swatch: a texture on a sphere or a slice, without a mesh (the service's /v1/swatch)."""

import numpy as np
import pytest

from texbake.errors import ParameterError, TextureError
from texbake.swatch import swatch
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
