"""Every texture baked on a reference mesh against its golden image (tests/data/golden)."""

import sys
from pathlib import Path

import numpy as np
import pytest

from texbake.output.images import read_image, srgb_encode

sys.path.insert(0, str(Path(__file__).parents[1] / "data" / "golden"))
import make


@pytest.mark.parametrize("name", make.TEXTURES)
def test_matches_golden_image(name):
    golden = read_image(make.HERE / f"{name}.png")
    now = make.bake(name)
    # compare in 8-bit sRGB levels: at most one level anywhere (rounding), 0.05 on average
    diff = np.abs(np.rint(srgb_encode(now) * 255) - np.rint(srgb_encode(golden) * 255))
    assert diff.max() <= 1 and diff.mean() < 0.05, (diff.max(), diff.mean())
