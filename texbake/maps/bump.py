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
    return 0.5 + 0.5 * _tangent_space(bent, n, dpdx, dpdy, frame)


def _tangent_space(bent, n, dpdx, dpdy, frame) -> np.ndarray:
    """``(k, 3)`` unit normals ``bent`` in the tangent frame (rows T, B, N; None: the atlas's,
    T along +u, B along +v, from the texel's edges ``dpdx``, ``dpdy``) of normals ``n``."""
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
    return local


def height_normal_map(heights, centre, points, dpdx, dpdy, normals, scale=1.0, *, frame=None, detail=None) -> np.ndarray:
    """``(n, 3)`` encoded tangent-space normals of a height field (a material's ``height``).

    ``centre``: ``(n,)`` the heights at ``points``; ``heights(points, dpdx, dpdy) -> (m,)``
    evaluates the field at ``(m, 3)`` points with their footprints. It is called once, on
    the points half a texel on along each of the texel's two edges (``dpdx``, ``dpdy``,
    ``(n, 3)`` each): forward differences along the edges, as pbrt's bump mapping takes
    them (two evaluations a sample past the one the height map has already made; their
    gradient is the one a quarter texel on, no shift a map shows), the two directional
    derivatives giving the gradient in the surface's plane (the plane the edges span),
    which tilts the normal: ``n' = normalize(n - scale * grad h)``. Each height is
    filtered over the texel as the maps are. ``detail``: ``(n, 3)`` encoded normals (a
    material's ``normal`` channel) the relief is laid over (whiteout blend: the slopes
    added, the z multiplied); ``frame``, ``normals``: as :func:`normal_map`.
    """
    k = len(points)
    h = heights(np.concatenate([points + 0.5 * dpdx, points + 0.5 * dpdy]), np.concatenate([dpdx, dpdx]),
                np.concatenate([dpdy, dpdy])).reshape(2, k)
    along_x, along_y = 2.0 * (h[0] - centre), 2.0 * (h[1] - centre)  # the height's change over one texel edge
    xx, xy, yy = (dpdx * dpdx).sum(1), (dpdx * dpdy).sum(1), (dpdy * dpdy).sum(1)
    det = xx * yy - xy * xy
    ok = det > 1e-12 * np.maximum(xx * yy, 1e-300)  # edges that span a plane
    safe = np.where(ok, det, 1.0)
    alpha = np.where(ok, (yy * along_x - xy * along_y) / safe, 0.0)
    beta = np.where(ok, (xx * along_y - xy * along_x) / safe, 0.0)
    grad = alpha[:, None] * dpdx + beta[:, None] * dpdy  # in the plane: grad . dpdx = along_x, grad . dpdy = along_y
    n = _unit(normals if frame is None else frame[:, 2])
    grad -= (grad * n).sum(1, keepdims=True) * n
    local = _tangent_space(_unit(n - scale * grad), n, dpdx, dpdy, frame)
    if detail is not None:
        d = _unit(2.0 * np.asarray(detail, dtype=np.float64) - 1.0)
        local = _unit(np.column_stack([local[:, 0] + d[:, 0], local[:, 1] + d[:, 1], local[:, 2] * d[:, 2]]))
    return 0.5 + 0.5 * local
