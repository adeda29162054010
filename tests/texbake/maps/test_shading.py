import numpy as np
import pytest

from texbake.errors import ParameterError
from texbake.maps.shading import lit


def test_decal_versus_modulated():
    colour = np.array([[0.5, 0.2, 0.1], [0.5, 0.2, 0.1]])
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])  # facing the light, facing away
    out = lit(colour, n, light=(0, 0, 1), ambient=0.2, diffuse=0.8)
    assert np.allclose(out[0], colour[0]) and np.allclose(out[1], 0.2 * colour[1])
    full = lit(colour, n, mode="full", light=(0, 0, 1), view=(0, 0, 1), specular=0.3)
    assert np.allclose(full[0], colour[0] + 0.3) and np.allclose(full[1], 0.2 * colour[1])


def test_bad_light_and_mode():
    with pytest.raises(ParameterError, match="light"):
        lit(np.zeros((1, 3)), np.zeros((1, 3)), light=(0, 0, 0))
    with pytest.raises(ParameterError, match="shading"):
        lit(np.zeros((1, 3)), np.zeros((1, 3)), mode="toon")
