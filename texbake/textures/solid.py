"""The lecture's solid textures built on noise: scaled noise, turbulence, fBm, marble,
wood grain and flame, and the spline colour maps they use.

Pure functions of texture-space points ``(n, 3)`` float64 and a footprint width
``(n,)`` float64 (texture-space size of one texel, or None to point-sample).
"""

from __future__ import annotations

import numpy as np

from .basic import _sign, _triangle
from .noise import octave_count, octave_sum, quarter_octave_sums


def spline(t: np.ndarray, knots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Catmull-Rom spline through ``(k,)`` increasing knots and ``(k, c)`` values.

    ``t``: ``(n,)``, clamped to the knot range. Returns ``(n, c)``. The end values are
    repeated as the outer control points, so with two knots it is not a straight line but
    an ease curve, ``a + (b - a)(u + 3u^2 - 2u^3) / 2`` (0.25 -> 0.203 from 0 to 1).
    """
    t = np.clip(np.asarray(t, dtype=np.float64), knots[0], knots[-1])
    if len(knots) == 1:
        return np.broadcast_to(values[0], (len(t), values.shape[1])).copy()
    seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
    k0, k1 = knots[seg], knots[seg + 1]
    u = ((t - k0) / np.where(k1 > k0, k1 - k0, 1.0))[:, None]
    p1, p2 = values[seg], values[seg + 1]
    p0 = values[np.maximum(seg - 1, 0)]
    p3 = values[np.minimum(seg + 2, len(knots) - 1)]
    # tangents scaled for uneven knots are not needed for a colour curve: uniform form
    return 0.5 * (2 * p1 + (p2 - p0) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u**2 + (3 * p1 - p0 - 3 * p2 + p3) * u**3)


def turbulence(points, width, *, scale=1.0, offset=0.0, octaves=8, lacunarity=2.0, gain=0.5,
               basis="value", interpolation="linear", signed=False, seed=0, max_octaves=None) -> np.ndarray:
    """Perlin's turbulence ``sum_k gain^k noise(lacunarity^k * (s p + o))``, normalised.

    Unsigned (the lecture's form, noise in [0, 1]) it lies in [0, 1] (Catmull-Rom noise
    overshoots to about [-0.10, 1.11], and so may the sum); ``signed`` gives
    fBm, ``sum_k gain^k (2 noise - 1)``, normalised into [-1, 1]. ``max_octaves`` caps
    the octaves evaluated; the rest add their mean (the normalisation is unchanged).
    """
    total = octave_sum(points, width, octaves=octaves, basis=basis, interpolation=interpolation, lacunarity=lacunarity,
                       gain=gain, signed=signed, seed=seed, max_octaves=max_octaves, scale=scale, offset=offset)
    return total / octave_count(octaves, gain).norm


def quarter_turbulence(points, dpdx, dpdy, width, *, scale=1.0, offset=0.0, octaves=8, lacunarity=2.0, gain=0.5,
                       basis="value", interpolation="linear", signed=False, seed=0, max_octaves=None) -> np.ndarray:
    """``(4, n)``: :func:`turbulence` at the four quarters of each footprint ``points`` ``(n,
    3)`` + ``a dpdx + b dpdy`` (``a``, ``b`` in [-1/2, 1/2], ``width`` ``(n,)``), each
    filtered by its quarter (``noise.quarter_octave_sums``)."""
    total = quarter_octave_sums(points, dpdx, dpdy, width, octaves=octaves, basis=basis, interpolation=interpolation,
                                lacunarity=lacunarity, gain=gain, signed=signed, seed=seed, max_octaves=max_octaves, scale=scale,
                                offset=offset)
    return total / octave_count(octaves, gain).norm


def marble_phase(points, width, *, axis=0, frequency=6.0, amplitude=4.0, **turbulence_args):
    """``(phase (n,), spread (n,))``: the marble's sine argument ``frequency * x + amplitude *
    turbulence(p)`` at the points, and the standard deviation of that phase over each
    texel's footprint (0 without one).

    A box of width w spreads ``frequency * x`` uniformly over ``frequency * w``: the
    Gaussian of the same variance, ``(frequency * w)^2 / 12``, is the spread (the
    turbulence's own spread within the texel is left out: its filtered octaves already
    fade towards their mean).
    """
    p = np.asarray(points, dtype=np.float64)
    turb = turbulence(p, width, **turbulence_args)
    phase = frequency * p[:, axis] + amplitude * turb
    spread = np.zeros(len(p)) if width is None else frequency * np.asarray(width, dtype=np.float64) / np.sqrt(12.0)
    return phase, spread


def marble(points, width, *, axis=0, frequency=6.0, amplitude=4.0, **turbulence_args) -> np.ndarray:
    """``0.5 + 0.5 sin(frequency * x + amplitude * turbulence(p))`` in [0, 1] (vein pattern).

    The colour comes from a spline colour map, ``MarbleColor`` in the lecture. With a
    footprint this is the sine's mean over a Gaussian phase spread (:func:`marble_phase`):
    ``exp(-spread^2 / 2)`` times the sine, so veins finer than a texel fade to their mean
    instead of aliasing. (The marble texture maps the phase and its spread to the mean
    colour directly: ``colour.wave_colours``.)
    """
    phase, spread = marble_phase(points, width, axis=axis, frequency=frequency, amplitude=amplitude, **turbulence_args)
    return 0.5 + 0.5 * np.sin(phase) * np.exp(-0.5 * spread**2)


def wood(points, width, *, ring_width=0.1, wobble=0.0, wobbles=4.0, twist=0.0, dpdx=None, dpdy=None) -> np.ndarray:
    """Concentric rings about the z axis: ``rings(r / M + K sin(N theta + B z))`` in [0, 1].

    ``rings`` alternates 0 and 1 at whole numbers; with a footprint it is filtered in
    closed form, like the checkerboard. ``theta = atan2(x, y)`` (the lecture's
    ``tan^-1(x / y)``); the wobble uses ``N theta`` rather than the lecture's ``theta / N``
    so that the pattern is periodic in theta and has no seam across the negative axis. At
    r = 0 theta is 0: finite everywhere.

    Footprint: ``dpdx``, ``dpdy`` ``(n, 3)``, the texel's edges: the ring number ``s`` is
    taken as linear across the texel, with the gradient of the radius and of the wobble
    (its angular and twist terms), so that ``s`` spreads over the texel as the sum of two
    uniform spreads ``|grad s . dpdx|`` and ``|grad s . dpdy|`` (a trapezoid), and the rings
    are averaged over exactly that; where ``width`` (the longer edge, ``(n,)``) reaches the
    ring axis, where ``s`` is far from linear, each of the two spreads is at least the box
    ``width / M``.
    Without the edges, ``width`` alone: that box (the wobble's gradient ignored).
    """
    p = np.asarray(points, dtype=np.float64)
    r = np.hypot(p[:, 0], p[:, 1])
    theta = np.where(r > 0, np.arctan2(p[:, 0], p[:, 1]), 0.0)  # atan2(0, -0.0) is pi
    angle = wobbles * theta + twist * p[:, 2]
    s = r / ring_width + wobble * np.sin(angle)
    point = _sign(np.floor(s))  # +1 on even rings (from the whole ring number: s / 2 may underflow)
    if dpdx is not None and dpdy is not None:
        # grad s = grad r / M + K cos(angle) (N grad theta + B z); grad theta = (y, -x, 0) / r^2
        inv = np.divide(1.0, np.maximum(r, 1e-150), out=np.zeros_like(r), where=r > 0)  # 1/r, finite
        k = wobble * np.cos(angle)
        grad = np.column_stack([p[:, 0] * inv / ring_width + k * wobbles * (p[:, 1] * inv) * inv,
                                p[:, 1] * inv / ring_width - k * wobbles * (p[:, 0] * inv) * inv, k * twist])
        a = 0.5 * np.abs(np.einsum("ij,ij->i", grad, dpdx))
        b = 0.5 * np.abs(np.einsum("ij,ij->i", grad, dpdy))
        a, b = np.maximum(a, b), np.minimum(a, b)
        if width is not None:  # a footprint wider than its distance to the axis: s is not linear across it
            near = np.asarray(width, dtype=np.float64) >= r
            box = 0.5 * np.asarray(width, dtype=np.float64) / ring_width
            a, b = np.where(near, np.maximum(a, box), a), np.where(near, np.maximum(b, box), b)
        return 0.5 - 0.5 * _square_mean(s, a, b, point)
    if width is None:
        return 0.5 - 0.5 * point
    half = 0.5 * np.asarray(width, dtype=np.float64) / ring_width
    return 0.5 - 0.5 * _square_mean(s, half, np.zeros_like(half), point)


def _ramp(t: np.ndarray) -> np.ndarray:
    """A periodic integral of ``_triangle - 1/2`` (period 2, zero at whole even numbers)."""
    u = t - 2.0 * np.floor(0.5 * t)
    return np.where(u <= 1.0, 0.5 * u * u - 0.5 * u, 1.5 * (u - 1.0) - 0.5 * (u * u - 1.0))


def _square_mean(s: np.ndarray, a: np.ndarray, b: np.ndarray, point: np.ndarray) -> np.ndarray:
    """``(n,)`` mean of the +1/-1 square wave (+1 on [0, 1), period 2) over ``s + U(-a, a) +
    U(-b, b)`` with ``a >= b >= 0`` (a box, or the trapezoid of two); ``point`` where
    ``a`` is 0 (the wave's value at ``s``)."""
    wide, both = a > 1e-12, b > 1e-9
    # one box: the difference of the triangle wave (the square wave's integral)
    mean = np.divide(_triangle(s + a) - _triangle(s - a), 2.0 * a, out=np.zeros_like(s), where=wide)
    if both.any():  # two: a second difference of the triangle wave's integral 0.5 t + _ramp(t)
        sa, aa, bb = s[both], a[both], b[both]
        second = (_ramp(sa + aa + bb) - _ramp(sa + aa - bb) - _ramp(sa - aa + bb) + _ramp(sa - aa - bb))
        mean[both] = second / (4.0 * aa * bb)
    np.clip(mean, -1.0, 1.0, out=mean)  # far out, s +- a round: keep the mean a mean
    return np.where(wide, mean, point)


def flame(points, width, *, half_width=0.5, height=1.0, time=0.0, rise=1.0, turbulence_amount=0.5,
          **turbulence_args) -> tuple[np.ndarray, np.ndarray]:
    """Watt and Watt's flame in the x-y plane between (-b, 0) and (b, h).

    Returns ``(s, weight)``: ``s = |x / b| + turbulence`` (the colour-map input, 0 at the
    centre) and ``weight = 1 - y / h`` clamped to [0, 1] (zero above the flame and below
    its base). The turbulence moves up at ``rise`` per unit of ``time`` and changes with
    time along its third axis.
    """
    p = np.asarray(points, dtype=np.float64)
    q = np.column_stack([p[:, 0], p[:, 1] - rise * time, np.full(len(p), time)])
    turb = turbulence(q, width, **turbulence_args)
    s = np.abs(p[:, 0] / half_width) + turbulence_amount * turb
    y = p[:, 1]
    weight = np.where((y >= 0) & (y <= height), 1.0 - y / height, 0.0)
    return s, weight
