"""The bake's texture mapping: object-space surface samples to a texture's space, points
and footprints together (pbrt's ``TextureMapping3D``).

Three steps, in this order: the bake's texture space ("unit": ``(p - origin) * scale``,
computed in that order so that a mesh far from the origin keeps its precision, with the
bounding box then starting at 0 and its longest side 1; "object": as it is); rounding to
float32 where the bake asks for it (as a float32 pipeline would hold the points); then the
spec's own placement (``model`` in world space, ``transform``, the wood's ``tilt``).
Every evaluation of a texture, the bake's maps, the bump's heights, the error probe and
``texbake.textures.evaluate``, takes these steps here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .context import EvalContext


@dataclass(frozen=True)
class TextureMapping:
    """``origin`` (3,) and ``scale`` of the bake's texture space, ``bounds`` (2, 3) of the
    mesh in it, and the ``precision`` the texture sees points in."""

    origin: np.ndarray
    scale: float
    bounds: np.ndarray
    precision: str = "float64"

    @classmethod
    def for_mesh(cls, lo: np.ndarray, hi: np.ndarray, texture_space: str, precision: str = "float64") -> TextureMapping:
        """For a mesh with bounding box ``lo``, ``hi`` ((3,) each)."""
        if texture_space == "unit":
            origin, scale = lo, 1.0 / (float(np.max(hi - lo)) or 1.0)
        else:
            origin, scale = np.zeros(3), 1.0
        return cls(origin, scale, (np.array([lo, hi]) - origin) * scale, precision)

    def to_space(self, points: np.ndarray, dpdx: np.ndarray | None = None, dpdy: np.ndarray | None = None):
        """``(q, dqdx, dqdy)``: ``(n, 3)`` points (and differentials) in the bake's texture space."""
        scaled = (None, None) if dpdx is None or dpdy is None else (dpdx * self.scale, dpdy * self.scale)
        return (_affine(points, self.origin, self.scale), *scaled)

    def evaluate(self, spec, points: np.ndarray, dpdx: np.ndarray | None, dpdy: np.ndarray | None, *,
                 max_octaves: int | None = None, exact: bool = False, hull=None) -> np.ndarray:
        """``(n, channels)`` float64 values of ``spec`` at ``(n, 3)`` float64 object-space points.

        ``dpdx``, ``dpdy``: ``(n, 3)`` float64 footprints, or None to point-sample.
        ``exact``: in float64 whatever the bake's precision (the error probe's reference).
        ``hull``: the cut footprints' hulls (``EvalContext.hull``: footprint coordinates,
        unchanged by the affine steps), or None.
        """
        q, dqdx, dqdy = self.to_space(points, dpdx, dpdy)
        return self.evaluate_in_space(spec, q, dqdx, dqdy, max_octaves=max_octaves, exact=exact, hull=hull)

    def evaluate_in_space(self, spec, q: np.ndarray, dqdx: np.ndarray | None = None, dqdy: np.ndarray | None = None, *,
                          max_octaves: int | None = None, exact: bool = False, hull=None) -> np.ndarray:
        """:meth:`evaluate` at ``(n, 3)`` float64 points ``q`` (and footprints) already in
        the bake's texture space, as the bump's offset points are: rounded to the bake's
        precision, then through the spec's placement."""
        if self.precision == "float32" and not exact:
            q = q.astype(np.float32).astype(np.float64)
            if dqdx is not None and dqdy is not None:
                dqdx, dqdy = dqdx.astype(np.float32).astype(np.float64), dqdy.astype(np.float32).astype(np.float64)
        return place_and_evaluate(spec, q, dqdx, dqdy, bounds=self.bounds, max_octaves=max_octaves, hull=hull)


def place_and_evaluate(spec, points: np.ndarray, dpdx: np.ndarray | None, dpdy: np.ndarray | None, *,
                       bounds: np.ndarray | None = None, max_octaves: int | None = None, hull=None) -> np.ndarray:
    """``(n, channels)`` float64 values of the texture ``spec`` (a spec object) at
    ``(n, 3)`` float64 points: the points and their ``(n, 3)`` footprints (None: point
    sampling) through the spec's placement into its own space, where it evaluates itself
    with an :class:`EvalContext` of ``bounds`` ``(2, 3)``, ``max_octaves`` and ``hull``."""
    q, dqdx, dqdy = spec.placement()(points, dpdx, dpdy)
    return spec(q, EvalContext(dqdx, dqdy, bounds, max_octaves, hull if dqdx is not None else None))


def _affine(points: np.ndarray, origin: np.ndarray, scale: float) -> np.ndarray:
    """``(points - origin) * scale`` for ``(n, 3)`` points, the same bits, in one pass
    (numpy's broadcast over rows of three is several times slower)."""
    from .. import _native

    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.empty_like(p)
    _native.affine(p, np.ascontiguousarray(origin, dtype=np.float64).reshape(3), float(scale), out)
    return out
