import numpy as np
import pytest

from texbake import bake_mesh
from texbake.errors import ParameterError
from texbake.sampling.adaptive import hardest, surrounded


def test_the_hardest_texels_are_those_that_differ_most_from_a_neighbour():
    # a 4 x 5 tile, flat but for one bright texel: it and its four neighbours score highest
    rows, width = 4, 5
    texel = np.arange(rows * width)
    values = np.zeros((rows * width, 3))
    values[7] = 1.0  # row 1, col 2
    picked = set(texel[hardest(texel, values, rows, width, 5 / 20)].tolist())
    assert picked == {7, 2, 12, 6, 8}
    assert len(hardest(texel, values, rows, width, 0.0)) == 0 and len(hardest(texel, values, rows, width, 1.0)) == 20


def test_only_eligible_texels_are_picked():
    # texels their chart covers in part are not refined (texbake.sampling.adaptive): the
    # hardest of the rest, and no more than there are
    rows, width = 4, 5
    texel = np.arange(20)
    values = np.zeros((20, 1))
    values[7] = 1.0  # it and its four neighbours score highest
    eligible = np.ones(20, dtype=bool)
    eligible[7] = False
    assert sorted(hardest(texel, values, rows, width, 4 / 20, eligible).tolist()) == [2, 6, 8, 12]
    few = np.zeros(20, dtype=bool)
    few[[3, 4]] = True
    assert sorted(hardest(texel, values, rows, width, 10 / 20, few).tolist()) == [3, 4]


def test_surrounded_texels_have_their_four_neighbours_in_the_tile():
    # a 3 x 4 tile with every texel but 0: only 5 and 6 have all four neighbours (the tile's
    # border counts as missing), and 5 loses it when 1 goes
    texel = np.arange(1, 12)
    assert texel[surrounded(texel, 3, 4)].tolist() == [5, 6]
    rest = np.delete(texel, 0)  # without texel 1
    assert rest[surrounded(rest, 3, 4)].tolist() == [6]


def test_adaptive_sub_samples_bring_marble_closer_to_the_converged_texels(meshes):
    # Suzanne at 256²: 1 filtered sample, and the same with a quarter of the texels refined,
    # against 256 point samples. Tolerance: the refined RMSE at most 0.95x (measured 0.90x
    # here, 0.76x at 512²; 0.9x before the quarter-footprint filter halved the 1-sample
    # error, leaving less for the sub-samples to take), its samples a covered texel at most
    # 1 + 4 x 0.25 (+ misses).
    mesh = meshes / "suzanne_blender_uv.obj"
    one = bake_mesh(mesh, "marble", size=256, margin=0)
    refined = bake_mesh(mesh, "marble", size=256, margin=0, adaptive=0.25)
    reference = bake_mesh(mesh, "marble", size=256, margin=0, samples=256)
    both = one.coverage & reference.coverage & refined.coverage

    def rmse(result):
        return float(np.sqrt(np.mean((result.images["albedo"][both].astype(float) - reference.images["albedo"][both]) ** 2)))

    assert rmse(refined) <= 0.95 * rmse(one), (rmse(refined), rmse(one))
    figures = refined.report["sets"][0]
    assert 1.9 < figures["rays"]["cast"] / figures["texels"]["covered"] < 2.2


def test_adaptive_is_a_share():
    with pytest.raises(ParameterError, match="adaptive"):
        bake_mesh("x.obj", "marble", adaptive=1.5)
