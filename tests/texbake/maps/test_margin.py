"""The margin (bake/margin.py): nearest covered texels, as SciPy's feature transform finds them."""

import numpy as np
import pytest
from scipy import ndimage

from texbake.maps.margin import extend, feature_transform


def test_extend_copies_the_nearest_covered_texel_within_the_margin():
    rng = np.random.default_rng(1)
    covered = np.zeros((300, 200), bool)
    covered[40:90, 30:80] = True
    covered[200:260, 120:190] = True
    image = np.where(covered[..., None], rng.random((300, 200, 3)), 0).astype(np.float32)
    ref = image.copy()
    filled = extend(image, covered, margin=8, band=64)  # bands smaller than the image
    dist, (ri, ci) = ndimage.distance_transform_edt(~covered, return_indices=True)
    expect = (dist <= 8) & ~covered
    assert np.array_equal(filled, expect)
    assert np.array_equal(image[expect], ref[ri[expect], ci[expect]])
    assert not image[~covered & ~expect].any() and np.array_equal(image[covered], ref[covered])


def test_no_margin_and_full_coverage():
    img = np.zeros((4, 4, 1), np.float32)
    assert not extend(img, np.ones((4, 4), bool), 3).any()
    assert not extend(img, np.eye(4, dtype=bool), 0).any()


@pytest.mark.parametrize("density", [0.0, 0.002, 0.02, 0.2, 0.6, 0.98, 1.0])
def test_feature_transform_is_scipys_to_the_texel(density):
    # identical arrays, not close: the margin copies from these texels, and where several
    # covered texels are equally near, the one SciPy picks is the one the golden images hold
    rng = np.random.default_rng(int(density * 1000))
    for h, w in [(1, 1), (1, 37), (41, 1), (7, 300), (300, 7), (64, 64), (97, 131), (40, 900)]:
        covered = rng.random((h, w)) < density
        expect = ndimage.distance_transform_edt(~covered, return_indices=True)[1]
        assert np.array_equal(feature_transform(covered), expect), (h, w)


def test_feature_transform_ties_on_lattices():
    # covered texels on a regular lattice: most empty texels have two or four nearest ones
    for step_r, step_c in [(2, 2), (3, 5), (4, 4), (6, 1)]:
        for offset in range(3):
            covered = np.zeros((90, 70), bool)
            covered[offset::step_r, offset::step_c] = True
            expect = ndimage.distance_transform_edt(~covered, return_indices=True)[1]
            assert np.array_equal(feature_transform(covered), expect), (step_r, step_c, offset)
