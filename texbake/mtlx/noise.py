"""MaterialX's noises, vectorised over points: a numpy port of ``mx_noise.glsl``.

Ported from MaterialX's ``libraries/stdlib/genglsl/lib/mx_noise.glsl`` (commit
4177b2cb, the same maths as its OSL and 1.39's shipped library): Bob Jenkins' ``bjmix``/
``bjfinal`` hash of the integer cell in uint32 arithmetic, the Perlin gradient noise of
OSL (gradients to the cube's edges, quintic fade, scaled by 0.9820), the cell noise, the
fractal sum and the Worley (cellular) noise with its jittered cell positions.

Every function takes ``(n, 3)`` float64 points and gives ``(n,)`` (a float noise) or
``(n, 3)`` (a vector3 noise) float64: the hash is bit-exact with the GLSL's; the floating
point is float64 where a GPU's is float32 (so values agree with a float32 run to ~1e-6,
except at points within float32's rounding of a cell boundary).

Footprint filtering (texbake's, not MaterialX's: its GLSL point-samples): given the
footprint's width in the noise's cells, each Perlin octave is shrunk towards its mean (0)
by the share of it a box filter over the footprint keeps (:func:`keep`, the same
``fade_factor`` as texbake's own noises), octaves past ``DROP_CELLS`` cells dropped.
Cell and Worley noise stay point-sampled.
"""

from __future__ import annotations

import functools

import numpy as np

_U32 = np.uint32
_SEED = {k: _U32((0xDEADBEEF + (k << 2) + 13) & 0xFFFFFFFF) for k in (1, 2, 3, 4, 5)}


def _rotl(x: np.ndarray, k: int) -> np.ndarray:
    return (x << _U32(k)) | (x >> _U32(32 - k))


def bjmix(a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Jenkins' ``mix`` of three uint32 arrays (new arrays; the GLSL's inout)."""
    a = a - c
    a ^= _rotl(c, 4)
    c = c + b
    b = b - a
    b ^= _rotl(a, 6)
    a = a + c
    c = c - b
    c ^= _rotl(b, 8)
    b = b + a
    a = a - c
    a ^= _rotl(c, 16)
    c = c + b
    b = b - a
    b ^= _rotl(a, 19)
    a = a + c
    c = c - b
    c ^= _rotl(b, 4)
    b = b + a
    return a, b, c


def bjfinal(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Jenkins' ``final``: a uint32 hash of three uint32 arrays."""
    c = c ^ b
    c = c - _rotl(b, 14)
    a = a ^ c
    a = a - _rotl(c, 11)
    b = b ^ a
    b = b - _rotl(a, 25)
    c = c ^ b
    c = c - _rotl(b, 16)
    a = a ^ c
    a = a - _rotl(c, 4)
    b = b ^ a
    b = b - _rotl(a, 14)
    c = c ^ b
    c = c - _rotl(b, 24)
    return c


def _u(x: np.ndarray) -> np.ndarray:
    """int32 cells to uint32 (GLSL's ``uint(int)``: the same bits)."""
    return np.asarray(x, dtype=np.int64).astype(np.int32).view(np.uint32)


def hash_int3(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``mx_hash_int(x, y, z)`` of int cells: uint32."""
    seed = _SEED[3]
    return bjfinal(seed + _u(x), seed + _u(y), seed + _u(z))


def hash_int2(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``mx_hash_int(x, y)`` of int cells: uint32."""
    seed = _SEED[2]
    return bjfinal(seed + _u(x), seed + _u(y), np.broadcast_to(seed, np.shape(x)).copy())


def cell_float2(p: np.ndarray) -> np.ndarray:
    """``mx_cell_noise_float(vec2)``: ``(n,)`` in [0, 1] over ``(n, 2)`` points."""
    cell = np.floor(p).astype(np.int64)
    return bits_to_01(hash_int2(cell[:, 0], cell[:, 1]))


def bits_to_01(bits: np.ndarray) -> np.ndarray:
    """``mx_bits_to_01``: uint32 to [0, 1]."""
    return bits.astype(np.float64) / float(0xFFFFFFFF)


def _fade(t: np.ndarray) -> np.ndarray:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _gradient(h: np.ndarray, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``mx_gradient_float(hash, x, y, z)``: the dot with one of the cube's edge vectors."""
    h = h & _U32(15)
    u = np.where(h < 8, x, y)
    v = np.where(h < 4, y, np.where((h == 12) | (h == 14), x, z))
    return np.where((h & _U32(1)) != 0, -u, u) + np.where((h & _U32(2)) != 0, -v, v)


def _corners(p: np.ndarray):
    cell = np.floor(p)
    return cell.astype(np.int64), p - cell


def _trilerp(values: list, s, t, r):
    s1, t1, r1 = 1.0 - s, 1.0 - t, 1.0 - r
    v0, v1, v2, v3, v4, v5, v6, v7 = values
    return r1 * (t1 * (v0 * s1 + v1 * s) + t * (v2 * s1 + v3 * s)) + r * (t1 * (v4 * s1 + v5 * s) + t * (v6 * s1 + v7 * s))


_OFFSETS = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)]


def perlin_float(p: np.ndarray) -> np.ndarray:
    """``mx_perlin_noise_float(vec3)``: ``(n,)`` signed noise, about -1 to 1."""
    cell, f = _corners(p)
    corners = []
    for dx, dy, dz in _OFFSETS:
        h = hash_int3(cell[:, 0] + dx, cell[:, 1] + dy, cell[:, 2] + dz)
        corners.append(_gradient(h, f[:, 0] - dx, f[:, 1] - dy, f[:, 2] - dz))
    return 0.9820 * _trilerp(corners, _fade(f[:, 0]), _fade(f[:, 1]), _fade(f[:, 2]))


def perlin_vec3(p: np.ndarray) -> np.ndarray:
    """``mx_perlin_noise_vec3(vec3)``: ``(n, 3)``, each component from 8 bits of one hash."""
    cell, f = _corners(p)
    corners = []
    for dx, dy, dz in _OFFSETS:
        h = hash_int3(cell[:, 0] + dx, cell[:, 1] + dy, cell[:, 2] + dz)
        x, y, z = f[:, 0] - dx, f[:, 1] - dy, f[:, 2] - dz
        corners.append(np.stack([_gradient((h >> _U32(s)) & _U32(0xFF), x, y, z) for s in (0, 8, 16)], axis=1))
    fades = [_fade(f[:, k])[:, None] for k in range(3)]
    return 0.9820 * _trilerp(corners, *fades)


def cell_float(p: np.ndarray) -> np.ndarray:
    """``mx_cell_noise_float(vec3)``: ``(n,)`` in [0, 1], constant over each unit cell."""
    cell = np.floor(p).astype(np.int64)
    return bits_to_01(hash_int3(cell[:, 0], cell[:, 1], cell[:, 2]))


def cell_vec3(p: np.ndarray) -> np.ndarray:
    """``mx_cell_noise_vec3(vec3)``: ``(n, 3)`` in [0, 1]."""
    cell = np.floor(p).astype(np.int64)
    seed = _SEED[4]
    a, b, c = bjmix(seed + _u(cell[:, 0]), seed + _u(cell[:, 1]), seed + _u(cell[:, 2]))
    return np.stack([bits_to_01(bjfinal(a + _U32(k), b, c)) for k in range(3)], axis=1)


@functools.cache
def _keep_table() -> tuple[np.ndarray, np.ndarray]:
    """texbake's own octave filter (``texbake._native.fade_factor``: the share of an octave a
    box over the footprint keeps, 0 from ``DROP_CELLS`` cells on), tabulated for numpy."""
    from .._native import DROP_CELLS, fade_factor

    s = np.linspace(0.0, float(DROP_CELLS), 8193)
    return s, np.array([fade_factor(float(x)) for x in s])


def keep(cells: np.ndarray) -> np.ndarray:
    """``(n,)``: the share of a zero-mean octave kept under a footprint ``cells`` lattice cells wide."""
    s, table = _keep_table()
    return np.interp(cells, s, table, right=0.0)


def filtered(value: np.ndarray, width: np.ndarray | None) -> np.ndarray:
    """One Perlin octave (mean 0) shrunk towards its mean by :func:`keep` of the footprint ``width`` (None: as it is)."""
    if width is None:
        return value
    k = keep(width)
    return value * (k[:, None] if value.ndim == 2 else k)


def fractal_float(p: np.ndarray, octaves, lacunarity, diminish, width: np.ndarray | None = None) -> np.ndarray:
    """``mx_fractal3d_noise_float``: the sum of ``octaves`` Perlin octaves (per point
    ``octaves``, ``lacunarity`` and ``diminish`` may be ``(n,)`` arrays); with ``width``
    ``(n,)`` (the footprint in the noise's cells), each octave filtered (:func:`filtered`)."""
    return _fractal(perlin_float, p, octaves, lacunarity, diminish, width)


def fractal_vec3(p: np.ndarray, octaves, lacunarity, diminish, width: np.ndarray | None = None) -> np.ndarray:
    """``mx_fractal3d_noise_vec3``: ``(n, 3)``."""
    return _fractal(perlin_vec3, p, octaves, lacunarity, diminish, width)


def _fractal(basis, p, octaves, lacunarity, diminish, width=None):
    n = len(p)
    octaves = np.broadcast_to(np.asarray(octaves, dtype=np.int64), (n,))
    lacunarity = np.broadcast_to(np.asarray(lacunarity, dtype=np.float64), (n,))[:, None]
    diminish = np.broadcast_to(np.asarray(diminish, dtype=np.float64), (n,))
    amplitude = np.ones(n)
    result = None
    p = np.array(p, dtype=np.float64)
    for i in range(int(octaves.max(initial=0))):
        live = (i < octaves).astype(np.float64)
        value = basis(p)
        weight = amplitude * live
        if width is not None:
            weight = weight * keep(width)
            width = width * lacunarity[:, 0]
        term = value * (weight[:, None] if value.ndim == 2 else weight)
        result = term if result is None else result + term
        amplitude = amplitude * diminish
        p = p * lacunarity
    if result is None:
        return np.zeros((n, 3)) if basis is perlin_vec3 else np.zeros(n)
    return result


def worley(p: np.ndarray, jitter, style, *, components: int = 1) -> np.ndarray:
    """``mx_worley_noise_float`` (``components`` 1: ``(n,)``) or ``_vec2``/``_vec3``
    (``(n, components)``), Euclidean metric (as the nodes use): the distances to the
    nearest ``components`` jittered cell points of the 27 cells around, or (``style`` 1)
    the cell noise of the nearest one's position."""
    n = len(p)
    jitter = np.broadcast_to(np.asarray(jitter, dtype=np.float64), (n,))[:, None]
    cell, local = _corners(p)
    best = np.full((n, components), 1e6)
    minpos = np.zeros((n, 3))
    for x in (-1, 0, 1):
        for y in (-1, 0, 1):
            for z in (-1, 0, 1):
                offset = np.array([x, y, z])
                off = (cell_vec3((cell + offset).astype(np.float64)) - 0.5) * jitter + 0.5
                cellpos = offset + off - local
                dist = np.einsum("ij,ij->i", cellpos, cellpos)
                nearer = dist < best[:, 0]
                minpos[nearer] = cellpos[nearer]
                _insert(best, dist)
    if int(style) == 1:
        out = cell_float(minpos + p) if components == 1 else cell_vec3(minpos + p)[:, :components]
        return out
    best = np.sqrt(best)
    return best[:, 0] if components == 1 else best


def _insert(best: np.ndarray, dist: np.ndarray) -> None:
    """The GLSL's insertion of ``dist`` into each row's ``best`` (ascending), in place."""
    k = best.shape[1]
    for j in range(k):
        nearer = dist < best[:, j]
        if j + 1 < k:
            best[nearer, j + 1:] = best[nearer, j:-1].copy()
        best[nearer, j] = dist[nearer]
        dist = np.where(nearer, np.inf, dist)
