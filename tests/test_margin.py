import numpy as np
from scipy import ndimage

from bake.margin import extend


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
