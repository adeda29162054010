"""The pinned noise tables (bake/textures/tables.py)."""

import hashlib

import numpy as np
import pytest

from texbake.textures.noise import tables
from texbake.textures.tables import derive

# SHA-256 of noiseTable (float64, little-endian) then indexTable (int64, little-endian),
# as NumPy 2.x's default_rng(seed).random(256), .permutation(256) made them when pinned:
# every texture depends on these bytes.
PINNED = {
    0: "b47e481c36ad49ffd48db4be99d2c1b35128b9fca4abb534cc1fbf1038dd51b5",
    1: "dfc5c8dece424c9ecbb596479207f8f29704049f11378038419abcf36d8a7e65",
    2**32 - 1: "3e69fbb8564dc0cd536ec0651385082ccae46ea08ceef5b16900e4cffd169e2c",
}


@pytest.mark.parametrize("seed", sorted(PINNED))
def test_tables_are_pinned(seed):
    noise, index = derive(seed)
    digest = hashlib.sha256(noise.astype("<f8").tobytes() + index.astype("<i8").tobytes()).hexdigest()
    assert digest == PINNED[seed]


def test_tables_are_a_table_and_a_permutation():
    for seed in (0, 7, 123456789):
        noise, index = tables(seed)
        assert noise.shape == (256,) and noise.dtype == np.float64 and ((noise >= 0) & (noise < 1)).all()
        assert np.array_equal(np.sort(index), np.arange(256)) and index.dtype == np.int64
        assert not noise.flags.writeable  # cached and shared: nobody may change them


def test_different_seeds_give_different_tables():
    assert not np.array_equal(derive(0)[0], derive(1)[0])
    assert not np.array_equal(derive(0)[1], derive(1)[1])
    with pytest.raises(ValueError, match="seed"):
        derive(-1)
