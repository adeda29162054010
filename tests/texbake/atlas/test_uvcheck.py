"""The packing estimate (texbake.atlas.uvcheck.packing_estimate), against sums worked by hand."""

import numpy as np
import pytest

from texbake.atlas.uvcheck import BOX_PACKING, packing_estimate


def squares(n, uv_sides):
    """``n`` separate unit squares on the plane z = 0, side by side, two triangles each, and
    UVs of each as a square of ``uv_sides[i]`` (anywhere: the estimate moves them)."""
    vertices, uv, faces = [], [], []
    for i in range(n):
        corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
        vertices.append(np.column_stack([corners + [2 * i, 0], np.zeros(4)]))
        uv.append(corners * uv_sides[i] + [0.01 * i, 0])  # overlapping: the estimate does not care
        faces.append(np.array([[0, 1, 2], [0, 2, 3]]) + 4 * i)
    return np.concatenate(vertices), np.concatenate(faces), np.concatenate(uv)


@pytest.mark.parametrize("padding", [0.0, 0.01])
def test_square_islands_fill_their_boxes(padding):
    v, f, uv = squares(4, [0.1, 0.1, 0.1, 0.1])
    # four boxes of side g + p filling BOX_PACKING of the tile: 4 (g + p)^2 = 0.9, islands' area 4 g^2
    side = np.sqrt(BOX_PACKING / 4) - padding
    assert packing_estimate(v, f, f, uv, padding) == pytest.approx(4 * side**2, rel=1e-12)


def test_islands_are_brought_to_one_density_first():
    v, f, uv = squares(4, [0.1, 0.01, 0.3, 0.05])  # the same squares at four densities
    assert packing_estimate(v, f, f, uv, 0.0) == pytest.approx(BOX_PACKING, rel=1e-12)


def test_triangles_fill_half_their_boxes_and_too_much_padding_gives_zero():
    v, f, uv = squares(2, [0.2, 0.2])
    split = np.array([[0, 1, 2], [4, 6, 7]])  # one triangle of each square, each its own island
    assert packing_estimate(v, split, split, uv, 0.0) == pytest.approx(BOX_PACKING / 2, rel=1e-12)
    assert packing_estimate(v, f, f, uv, 0.8) == 0.0  # two padded boxes already over the tile
