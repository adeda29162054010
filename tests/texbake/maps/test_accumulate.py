"""texbake.maps.accumulate: each texel holds the mean of its samples, and the count of them."""

import numpy as np
import pytest

from texbake.maps.accumulate import Maps
from texbake.quality import PRESETS
from texbake.sampling.lookup import Tile
from texbake.settings import BakeSettings
from texbake.textures.mapping import TextureMapping


@pytest.mark.parametrize("quality", ["default", "final"])
def test_accumulate_writes_the_mean_of_each_texels_samples(quality):
    settings = BakeSettings.build(None, texture="marble", size=64, shading="full")
    q = PRESETS[quality]
    maps = Maps(settings, q, 64, 64, TextureMapping.for_mesh(np.zeros(3), np.ones(3), settings.texture_space, q.precision))
    tile = Tile(8, 24)
    rng = np.random.default_rng(3)
    hit = np.sort(rng.choice(16 * 64, 500, replace=False))
    counts = rng.integers(1, q.samples + 1, len(hit)) if q.samples > 1 else np.ones(len(hit), dtype=int)
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
