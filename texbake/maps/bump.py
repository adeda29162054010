"""Bump to normal map: a tangent-space normal map from the gradient of a scalar texture.

The height is the luminance of the texture's colour. Its gradient is taken by central
differences in texture space (a step of a quarter texel, at least 1e-6), projected onto
the surface, and tilts the normal: ``n' = normalize(n - strength * grad_s h)``. The
tangent frame is the one a glTF viewer rebuilds from the output mesh's normals and
tangents (``texbake.mesh.tangents``), given per sample; without one, the atlas' own: T along +u,
B along +v, N the surface normal, made orthonormal. Either way B points along +v (up in
the image): the green channel is "+Y up" (OpenGL, glTF). Normal maps are data, not
colour: ``0.5 + 0.5 * (x, y, z)``.
"""

from __future__ import annotations

import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _unit(v):
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def normal_map(height, points, dpdx, dpdy, normals, strength=1.0, *, frame=None) -> np.ndarray:
    """``(n, 3)`` encoded tangent-space normals.

    ``height(points) -> (n,)``; ``points``, ``dpdx``, ``dpdy``, ``normals``: ``(n, 3)``;
    ``frame``: optional ``(n, 3, 3)`` tangent frames, rows T, B, N (then ``normals`` is
    not used: N is the frame's).
    """
    step = np.maximum(0.25 * np.sqrt(np.maximum((dpdx**2).sum(1), (dpdy**2).sum(1))), 1e-6)[:, None]
    grad = np.empty_like(points)
    for axis in range(3):
        e = np.zeros(3)
        e[axis] = 1.0
        grad[:, axis] = (height(points + step * e) - height(points - step * e)) / (2 * step[:, 0])
    n = _unit(normals if frame is None else frame[:, 2])
    surface_grad = grad - (grad * n).sum(1, keepdims=True) * n
    bent = _unit(n - strength * surface_grad)
    if frame is not None:
        t, b = frame[:, 0], frame[:, 1]
    else:
        t = _unit(dpdx - (dpdx * n).sum(1, keepdims=True) * n)
        b = np.cross(n, t)
        # +v is up in the atlas and dpdy points one texel down: flip B to match +v
        if len(b):
            b *= np.sign(((-dpdy) * b).sum(1, keepdims=True) + 1e-300)
    local = np.column_stack([(bent * t).sum(1), (bent * b).sum(1), (bent * n).sum(1)])
    local[~(np.linalg.norm(n, axis=1) > 0)] = (0.0, 0.0, 1.0)
    return 0.5 + 0.5 * local
