"""Shading modes of the lecture: the texture colour used as is ("decal", the albedo map)
or modulating the local illumination ("lit" maps), for a fixed light direction.

- ``"ambient-diffuse"``: ``colour * (ka + kd max(0, n.l))``
- ``"full"``: the whole local illumination, ``colour * (ka + kd max(0, n.l)) + ks
  max(0, n.h)^shininess`` (Blinn-Phong, white highlight, view along ``view``).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

MODES = ("decal", "ambient-diffuse", "full")


def _unit(v, name) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    n = np.linalg.norm(v)
    if v.shape != (3,) or not np.isfinite(n) or n == 0:
        raise ParameterError(name, f"expected a non-zero 3-vector, got {v.tolist()}")
    return v / n


def lit(colour, normals, *, mode="ambient-diffuse", light=(0.3, 0.5, 0.8), view=(0.0, 0.0, 1.0),
        ambient=0.2, diffuse=0.8, specular=0.3, shininess=32.0) -> np.ndarray:
    """``(n, 3)`` lit colour from ``(n, 3)`` texture colour and unit ``(n, 3)`` normals."""
    if mode not in MODES[1:]:
        raise ParameterError("shading", f"expected one of {', '.join(MODES)}, got {mode!r}")
    ldir = _unit(light, "light")
    ndotl = np.maximum(normals @ ldir, 0.0)[:, None]
    out = colour * (ambient + diffuse * ndotl)
    if mode == "full":
        h = _unit(ldir + _unit(view, "view"), "view")
        out = out + specular * np.maximum(normals @ h, 0.0)[:, None] ** shininess
    return out
