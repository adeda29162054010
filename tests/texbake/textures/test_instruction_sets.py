"""The texture kernels give the same bits on every instruction set they are built for (AVX-512,
AVX2, the x86-64 baseline: native/textures.cpp), every path of them: each basis and
interpolation, signed, filtered, far out, NaN and infinity, marble, checker, every texture."""

import numpy as np
import pytest

from texbake import _native
from texbake.textures import TEXTURES, evaluate
from texbake.textures.colour import colours, marble_colours, wave_colours
from texbake.textures.noise import octave_sum
from texbake.textures.spec import MARBLE_COLOURS


@pytest.fixture
def instruction_set():
    """Sets the kernels' instruction set for a test, and puts the best one back after it."""
    yield _native.use_instruction_set
    _native.use_instruction_set(None)


def points(n=6000, seed=5):
    """``(points (n, 3), width (n,), footprints (n, 2, 3))``: random points with the edge
    cases in runs of their own, so that a block holds several kinds."""
    rng = np.random.default_rng(seed)
    p = rng.random((n, 3)) * 64 - 32
    p[:40] = np.nan
    p[40:50], p[50:60] = np.inf, -np.inf
    p[60:300] *= 1e15  # a top octave past 4e18: the one-point path, wrapped
    p[300:600] += 1e9  # cells past 2^31 at the top octave: mod 256 in floating point
    p[600:900] -= 10010
    p[900:1000] = 1e17 * rng.random((100, 3))
    p[1000:1100] = 0.0
    p[1100:1200] = -0.0
    width = rng.random(n) ** 4 * 3
    width[:20] = 0
    width[2000:2300] = 0  # a whole block point-sampled among filtered ones
    width[2300:2400] = np.nan
    width[2400:2600] = 1e-9
    width[2600:2900] = 50  # every octave dropped
    footprints = rng.normal(size=(n, 2, 3)) * width[:, None, None] * 0.3
    return p, width, footprints


def every_path():
    """``{name: array}`` of every texture kernel's path."""
    p, width, footprints = points()
    out = {}
    for basis, interp in (("value", "linear"), ("value", "cubic"), ("value", "catmull-rom"), ("perlin", "linear")):
        for signed in (False, True):
            for w in (None, width):
                for scale, offset in ((1.0, 0.0), (37.0, -5.0)):
                    out[f"octave_sum {basis} {interp} signed={signed} filtered={w is not None} scale={scale}"] = octave_sum(
                        p, w, octaves=8, basis=basis, interpolation=interp, signed=signed, scale=scale, offset=offset)
    out["octave_sum 30 octaves, lacunarity 1.93, capped at 20"] = octave_sum(p, width, octaves=30, lacunarity=1.93, gain=0.61,
                                                                             max_octaves=20)
    m = MARBLE_COLOURS
    out["marble_colours"] = marble_colours(p, width, m.knots, m.colours, frequency=7.5, amplitude=2.0)
    out["marble_colours point-sampled"] = marble_colours(p, None, m.knots, m.colours, frequency=7.5, amplitude=2.0)
    out["colours"] = colours(m.knots, m.colours, p[:, 0] / 32)
    out["wave_colours"] = wave_colours(m.knots, m.colours, p[:, 0], np.abs(p[:, 1]) / 4)
    bounds = np.array([[-30.0, -30, -30], [30, 30, 30]])
    with np.errstate(invalid="ignore"):  # evaluate's finiteness check sums inf and -inf
        for name in TEXTURES:
            out[f"evaluate {name}"] = evaluate(name, p)
            out[f"evaluate {name} filtered"] = evaluate(name, p, footprints, bounds=bounds)
    return out


def test_every_instruction_set_gives_the_baseline_bits(instruction_set):
    names = _native.instruction_sets()
    assert names[-1] == "baseline" and _native.instruction_set() == names[0]
    instruction_set("baseline")
    reference = every_path()
    assert all(np.isfinite(a).any() for a in reference.values())
    assert all(np.isnan(a).any() for path, a in reference.items() if not path.startswith("octave_sum"))  # NaN in, NaN out
    for name in names[:-1]:
        instruction_set(name)
        assert _native.instruction_set() == name
        for path, values in every_path().items():
            assert np.array_equal(values.view(np.uint64), reference[path].view(np.uint64)), f"{name}: {path}"


def test_an_unknown_instruction_set_is_refused(instruction_set):
    with pytest.raises(ValueError, match="'sse9'"):
        instruction_set("sse9")
    assert _native.instruction_set() == _native.instruction_sets()[0]
    assert instruction_set("baseline") == _native.instruction_sets()[0]  # the previous one
    assert instruction_set(None) == "baseline"


def test_the_threads_chunks_do_not_change_a_value():
    # 40 chunks of 16384 points, taken by the threads in whatever order they come, against
    # the same points in pieces under MIN_PIECE (32768), each run on the calling thread alone
    p, width, _ = points(n=655_360, seed=9)
    m = MARBLE_COLOURS
    kernels = {
        "octave_sum": lambda q, w: octave_sum(q, w, octaves=8),
        "marble_colours": lambda q, w: marble_colours(q, w, m.knots, m.colours, frequency=7.5, amplitude=2.0),
    }
    for name, kernel in kernels.items():
        for w in (None, width):
            whole = kernel(p, w)
            pieces = np.concatenate([kernel(p[a:a + 20_000], None if w is None else w[a:a + 20_000])
                                     for a in range(0, len(p), 20_000)])
            assert np.array_equal(whole.view(np.uint64), pieces.view(np.uint64)), f"{name} filtered={w is not None}"
