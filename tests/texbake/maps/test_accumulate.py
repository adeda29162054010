"""texbake.maps.accumulate: each texel holds the mean of its samples, and the count of them."""

import numpy as np
import pytest

from texbake.maps.accumulate import Maps
from texbake.sampling.lookup import Tile
from texbake.settings import BakeSettings
from texbake.textures.mapping import TextureMapping


@pytest.mark.parametrize("quality", ["default", "final"])
def test_accumulate_writes_the_mean_of_each_texels_samples(quality):
    settings = BakeSettings.build(None, texture="marble", size=64, shading="full", quality=quality)
    maps = Maps(settings, TextureMapping.for_mesh(np.zeros(3), np.ones(3), settings.texture_space, settings.precision))
    tile = Tile(8, 24)
    rng = np.random.default_rng(3)
    hit = np.sort(rng.choice(16 * 64, 500, replace=False))
    counts = rng.integers(1, settings.samples + 1, len(hit)) if settings.samples > 1 else np.ones(len(hit), dtype=int)
    texel = np.repeat(hit, counts)
    values = {name: rng.random((len(texel), 3)) for name in maps.images}
    maps.images["albedo"][:] = 7.0  # stale rows of the tile are overwritten, others kept
    maps.accumulate(tile, texel, values)
    for name, v in values.items():
        expect = np.zeros((16 * 64, 3))
        for c in range(3):
            expect[:, c] = np.bincount(texel, weights=v[:, c], minlength=16 * 64)
        expect[hit] /= counts[:, None]
        np.testing.assert_allclose(maps.images[name][8:24].reshape(-1, 3), expect, rtol=1e-6)  # float32 images
    assert (maps.images["albedo"][:8] == 7.0).all() and (maps.images["albedo"][24:] == 7.0).all()
    np.testing.assert_array_equal(maps.hits[8:24].ravel(), np.bincount(texel, minlength=16 * 64))
    assert maps.hits[:8].sum() == 0 and maps.hits[24:].sum() == 0


def test_the_bump_sees_its_points_at_the_bakes_precision():
    from texbake.maps.bump import LUMINANCE, normal_map
    from texbake.sampling.sampler import Samples
    from texbake.textures.mapping import place_and_evaluate

    rng = np.random.default_rng(4)
    n = 400
    points = rng.uniform(0, 1, (n, 3))
    dpdx, dpdy = np.tile([1e-3, 0, 0], (n, 1)), np.tile([0, -1e-3, 0], (n, 1))
    s = Samples(np.arange(n), points, np.tile([0.0, 0.0, 1.0], (n, 1)), dpdx, dpdy)
    normals = {}
    for precision in ("float64", "float32"):
        settings = BakeSettings(texture="checker", size=16, bump={"name": "noise", "scale": 40}, precision=precision)
        mapping = TextureMapping.for_mesh(np.zeros(3), np.ones(3), "unit", precision)
        normals[precision] = Maps(settings, mapping).values(s)["normal"]
        rounded = (lambda x: x.astype(np.float32).astype(np.float64)) if precision == "float32" else (lambda x: x)
        q, dqdx, dqdy = mapping.to_space(points, dpdx, dpdy)
        height = lambda x: place_and_evaluate(settings.bump, rounded(x), None, None, bounds=mapping.bounds) @ LUMINANCE  # noqa: B023
        np.testing.assert_array_equal(normals[precision], normal_map(height, q, dqdx, dqdy, s.normals, settings.bump_strength))
    assert not np.array_equal(normals["float32"], normals["float64"])
    np.testing.assert_allclose(normals["float32"], normals["float64"], atol=1e-3)  # float32's rounding, not another map
