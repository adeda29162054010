"""Normal maps of the geometry: the shading normal at each texel, ``0.5 + 0.5 n``.

Object and world space are one frame here: the loaded mesh has its scene's node transforms
applied (``texbake.mesh.load``), so its object space is the world's; both names are kept
for the bakers' vocabulary, and a user's template may ask for either.
"""

from __future__ import annotations

import numpy as np


def encoded_normals(normals: np.ndarray) -> np.ndarray:
    """``(n, 3)`` float64 ``0.5 + 0.5 n`` of unit ``(n, 3)`` normals."""
    return 0.5 + 0.5 * np.asarray(normals, dtype=np.float64)
