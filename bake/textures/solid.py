"""The lecture's solid textures built on noise: scaled noise, turbulence, fBm, marble,
wood grain and flame, and the spline colour maps they use.

Pure functions of texture-space points ``(n, 3)`` float64 and a footprint width
``(n,)`` float64 (texture-space size of one texel, or None to point-sample).
"""

from __future__ import annotations

import numpy as np

from .basic import _sign, _triangle
from .noise import octave_sum


def spline(t: np.ndarray, knots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Catmull-Rom spline through ``(k,)`` increasing knots and ``(k, c)`` values.

    ``t``: ``(n,)``, clamped to the knot range. Returns ``(n, c)``. With two knots it is
    a straight line.
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

    Unsigned (the lecture's form, noise in [0, 1]) it lies in [0, 1]; ``signed`` gives
    fBm, ``sum_k gain^k (2 noise - 1)``, normalised into [-1, 1]. ``max_octaves`` caps
    the octaves evaluated; the rest add their mean (the normalisation is unchanged).
    """
    q = np.asarray(points, dtype=np.float64) * scale + offset
    w = None if width is None else np.asarray(width, dtype=np.float64) * abs(scale)
    total = octave_sum(q, w, octaves=octaves, basis=basis, interpolation=interpolation,
                       lacunarity=lacunarity, gain=gain, signed=signed, seed=seed, max_octaves=max_octaves)
    norm = sum(gain**k for k in range(octaves))
    return total / norm


def marble(points, width, *, axis=0, frequency=6.0, amplitude=4.0, **turbulence_args) -> np.ndarray:
    """``0.5 + 0.5 sin(frequency * x + amplitude * turbulence(p))`` in [0, 1] (vein pattern).

    The colour comes from a spline colour map, ``MarbleColor`` in the lecture. With a
    footprint the sine is filtered too: a box of width w scales a sine of frequency f by
    about ``exp(-(f w)^2 / 24)`` (the Gaussian of the same variance), so veins finer than
    a texel fade to their mean instead of aliasing.
    """
    p = np.asarray(points, dtype=np.float64)
    turb = turbulence(p, width, **turbulence_args)
    wave = np.sin(frequency * p[:, axis] + amplitude * turb)
    if width is not None:
        wave *= np.exp(-((frequency * np.asarray(width)) ** 2) / 24.0)
    return 0.5 + 0.5 * wave


def wood(points, width, *, ring_width=0.1, wobble=0.0, wobbles=4.0, twist=0.0) -> np.ndarray:
    """Concentric rings about the z axis: ``rings(r / M + K sin(N theta + B z))`` in [0, 1].

    ``rings`` alternates 0 and 1 at whole numbers; it is box-filtered over the footprint
    (in ring units) in closed form, like the checkerboard. ``theta = atan2(x, y)``
    (the lecture's ``tan^-1(x / y)``); the wobble uses ``N theta`` rather than the
    lecture's ``theta / N`` so that the pattern is periodic in theta and has no seam
    across the negative axis. At r = 0 theta is 0: finite everywhere.
    """
    p = np.asarray(points, dtype=np.float64)
    r = np.hypot(p[:, 0], p[:, 1])
    theta = np.where(r > 0, np.arctan2(p[:, 0], p[:, 1]), 0.0)  # atan2(0, -0.0) is pi
    s = r / ring_width + wobble * np.sin(wobbles * theta + twist * p[:, 2])
    point = _sign(np.floor(s))  # +1 on even rings (from the whole ring number: s / 2 may underflow)
    if width is None:
        return 0.5 - 0.5 * point
    half = 0.5 * np.asarray(width, dtype=np.float64) / ring_width
    wide = half > 1e-12
    # mean of the 0/1 wave = 1/2 - 1/2 * mean of the +1/-1 wave
    mean = np.divide(_triangle(s + half) - _triangle(s - half), 2.0 * half, out=np.zeros_like(s), where=wide)
    np.clip(mean, -1.0, 1.0, out=mean)  # far out, s +- half round: keep the mean a mean
    return 0.5 - 0.5 * np.where(wide, mean, point)


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
