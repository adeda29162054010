import numpy as np
import pytest

from bake.errors import ParameterError
from bake.texels import Tile, UVLookup, sample_offsets, sample_uv, tiles


def test_one_sample_is_the_texel_centre():
    assert np.array_equal(sample_offsets(1), [[0.5, 0.5]])


@pytest.mark.parametrize("n", [4, 16, 64, 5])
def test_offsets_are_stratified(n):
    off = sample_offsets(n, seed=3)
    assert off.shape == (n, 2) and (off >= 0).all() and (off < 1).all()
    k = int(round(np.sqrt(n)))
    if k * k == n:  # one sample per cell of a k x k grid
        cells = np.floor(off * k).astype(int)
        assert len({tuple(c) for c in cells}) == n
    else:  # n-rooks: one sample per row and per column stratum
        for axis in range(2):
            assert sorted(np.floor(off[:, axis] * n).astype(int)) == list(range(n))
    assert np.array_equal(off, sample_offsets(n, seed=3))


def test_bad_sample_count():
    with pytest.raises(ParameterError, match="samples"):
        sample_offsets(0)


def test_tiles_cover_the_image_once():
    t = tiles(100, 37, 4, budget=1000)
    rows = np.concatenate([np.arange(x.start, x.stop) for x in t])
    assert np.array_equal(rows, np.arange(100))


def test_sample_uv_convention():
    uv = sample_uv(Tile(0, 2), np.arange(8), 4, 2, sample_offsets(1))
    # row 0 is the top of the image: v close to 1
    assert np.allclose(uv[0], [0.125, 0.75]) and np.allclose(uv[4], [0.125, 0.25])


def test_lookup_finds_faces_and_exact_barycentrics():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    look = UVLookup(uv, faces)
    rng = np.random.default_rng(0)
    q = rng.random((1000, 2)) * 0.98 + 0.01
    f = look.faces_at(q)
    expect = np.where(q[:, 0] > q[:, 1], 0, 1)
    clear = np.abs(q[:, 0] - q[:, 1]) > 1e-5
    assert np.array_equal(f[clear], expect[clear])
    b = look.barycentric(q, f)
    back = np.einsum("ni,nij->nj", b, uv[faces[f]])
    assert np.abs(back - q).max() < 2e-15  # float64 round-off, not Embree's float32: measured 2.2e-16


def test_lookup_misses_outside_and_on_degenerate_faces():
    uv = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [0.6, 0.6], [0.9, 0.9], [0.75, 0.75]])
    look = UVLookup(uv, np.array([[0, 1, 2], [3, 4, 5]]))
    f = look.faces_at(np.array([[0.1, 0.1], [0.8, 0.1], [0.75, 0.75]]))
    assert f.tolist() == [0, -1, -1]


def test_candidates_cover_every_texel_a_face_can_hit():
    rng = np.random.default_rng(5)
    uv = (rng.random((100, 1, 2)) * 0.9 + rng.random((100, 3, 2)) * 0.1).reshape(-1, 2)  # small
    faces = np.arange(300).reshape(100, 3)
    look = UVLookup(uv, faces)
    width, height = 64, 48
    for tile in tiles(height, width, 4, budget=2000):
        cand = set(look.candidates(tile, width, height).tolist())
        texels = np.arange((tile.stop - tile.start) * width)
        q = sample_uv(tile, texels, width, height, sample_offsets(16, seed=1))
        hit = look.faces_at(q) >= 0
        assert set(np.unique(texels.repeat(16)[hit]).tolist()) <= cand
        assert len(cand) < len(texels)  # and leaves some out
