"""A numpy reference of the hemisphere rays (Moller-Trumbore against every triangle): slow,
for the tests' few points and faces only; the kernel it checks is native/embree.cpp's."""

import numpy as np


def cosine_directions(normal: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """``(count, 3)`` cosine-weighted unit directions about the unit ``normal`` ``(3,)``."""
    u, v = rng.random(count), rng.random(count)
    r, phi = np.sqrt(u), 2 * np.pi * v
    local = np.column_stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u)])
    helper = np.array([1.0, 0, 0]) if abs(normal[0]) < 0.9 else np.array([0, 1.0, 0])
    t = np.cross(normal, helper)
    t /= np.linalg.norm(t)
    b = np.cross(normal, t)
    return local @ np.stack([t, b, normal])


def first_hit(vertices, faces, origin, directions) -> np.ndarray:
    """``(k,)`` distance of each ray's first hit (inf: none)."""
    tri = vertices[faces]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    p = np.cross(directions[:, None], e2[None])
    det = np.einsum("kmi,mi->km", p, e1)
    safe = np.where(np.abs(det) > 1e-12, det, 1.0)
    s = origin - tri[:, 0]
    u = np.einsum("kmi,mi->km", p, s) / safe
    q = np.cross(s, e1)
    v = np.einsum("ki,mi->km", directions, q) / safe
    t = np.einsum("mi,mi->m", e2, q)[None] / safe
    ok = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9)
    return np.where(ok, t, np.inf).min(axis=1)


def open_share(vertices, faces, point, normal, distance, count=20000, seed=0) -> float:
    """The share of ``count`` cosine-weighted rays from ``point`` that hit nothing within ``distance``."""
    d = cosine_directions(np.asarray(normal, dtype=np.float64), count, np.random.default_rng(seed))
    return float((first_hit(vertices, faces, np.asarray(point, dtype=np.float64), d) > distance).mean())
