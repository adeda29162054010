"""A direct, literal transcription of MaterialX's ``mx_noise.glsl`` (libraries/stdlib/
genglsl/lib, materialx 1.39.5 as shipped, the same as MaterialX's main at 4177b2cb), one
point at a time in plain Python: uint arithmetic masked to 32 bits, floats as Python
floats. The independent reference the vectorised port (texbake/mtlx/noise.py) is tested
against: MaterialX's generated GLSL/OSL cannot run here (no GL context, no OSL runtime).
"""

import math

M = 0xFFFFFFFF


def mx_rotl32(x, k):
    return ((x << k) | (x >> (32 - k))) & M


def mx_bjmix(a, b, c):
    a = (a - c) & M; a ^= mx_rotl32(c, 4); c = (c + b) & M  # noqa: E702
    b = (b - a) & M; b ^= mx_rotl32(a, 6); a = (a + c) & M  # noqa: E702
    c = (c - b) & M; c ^= mx_rotl32(b, 8); b = (b + a) & M  # noqa: E702
    a = (a - c) & M; a ^= mx_rotl32(c, 16); c = (c + b) & M  # noqa: E702
    b = (b - a) & M; b ^= mx_rotl32(a, 19); a = (a + c) & M  # noqa: E702
    c = (c - b) & M; c ^= mx_rotl32(b, 4); b = (b + a) & M  # noqa: E702
    return a, b, c


def mx_bjfinal(a, b, c):
    c ^= b; c = (c - mx_rotl32(b, 14)) & M  # noqa: E702
    a ^= c; a = (a - mx_rotl32(c, 11)) & M  # noqa: E702
    b ^= a; b = (b - mx_rotl32(a, 25)) & M  # noqa: E702
    c ^= b; c = (c - mx_rotl32(b, 16)) & M  # noqa: E702
    a ^= c; a = (a - mx_rotl32(c, 4)) & M  # noqa: E702
    b ^= a; b = (b - mx_rotl32(a, 14)) & M  # noqa: E702
    c ^= b; c = (c - mx_rotl32(b, 24)) & M  # noqa: E702
    return c


def uint(x):
    return x & M


def mx_bits_to_01(bits):
    return float(bits) / float(0xFFFFFFFF)


def mx_fade(t):
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def mx_hash_int3(x, y, z):
    a = b = c = (0xDEADBEEF + (3 << 2) + 13) & M
    a = (a + uint(x)) & M
    b = (b + uint(y)) & M
    c = (c + uint(z)) & M
    return mx_bjfinal(a, b, c)


def mx_floorfrac(x):
    i = math.floor(x)
    return x - i, i


def mx_gradient_float(h, x, y, z):
    h = h & 15
    u = x if h < 8 else y
    v = y if h < 4 else (x if (h == 12 or h == 14) else z)
    return (-u if h & 1 else u) + (-v if h & 2 else v)


def mx_trilerp(v0, v1, v2, v3, v4, v5, v6, v7, s, t, r):
    s1, t1, r1 = 1.0 - s, 1.0 - t, 1.0 - r
    return r1 * (t1 * (v0 * s1 + v1 * s) + t * (v2 * s1 + v3 * s)) + r * (t1 * (v4 * s1 + v5 * s) + t * (v6 * s1 + v7 * s))


def mx_hash_vec3(x, y, z):
    h = mx_hash_int3(x, y, z)
    return h & 0xFF, (h >> 8) & 0xFF, (h >> 16) & 0xFF


def mx_perlin_noise_float(p):
    fx, X = mx_floorfrac(p[0])
    fy, Y = mx_floorfrac(p[1])
    fz, Z = mx_floorfrac(p[2])
    u, v, w = mx_fade(fx), mx_fade(fy), mx_fade(fz)
    result = mx_trilerp(
        mx_gradient_float(mx_hash_int3(X, Y, Z), fx, fy, fz),
        mx_gradient_float(mx_hash_int3(X + 1, Y, Z), fx - 1.0, fy, fz),
        mx_gradient_float(mx_hash_int3(X, Y + 1, Z), fx, fy - 1.0, fz),
        mx_gradient_float(mx_hash_int3(X + 1, Y + 1, Z), fx - 1.0, fy - 1.0, fz),
        mx_gradient_float(mx_hash_int3(X, Y, Z + 1), fx, fy, fz - 1.0),
        mx_gradient_float(mx_hash_int3(X + 1, Y, Z + 1), fx - 1.0, fy, fz - 1.0),
        mx_gradient_float(mx_hash_int3(X, Y + 1, Z + 1), fx, fy - 1.0, fz - 1.0),
        mx_gradient_float(mx_hash_int3(X + 1, Y + 1, Z + 1), fx - 1.0, fy - 1.0, fz - 1.0),
        u, v, w)
    return 0.9820 * result


def mx_perlin_noise_vec3(p):
    fx, X = mx_floorfrac(p[0])
    fy, Y = mx_floorfrac(p[1])
    fz, Z = mx_floorfrac(p[2])
    u, v, w = mx_fade(fx), mx_fade(fy), mx_fade(fz)
    corners = [((0, 0, 0), (fx, fy, fz)), ((1, 0, 0), (fx - 1.0, fy, fz)), ((0, 1, 0), (fx, fy - 1.0, fz)),
               ((1, 1, 0), (fx - 1.0, fy - 1.0, fz)), ((0, 0, 1), (fx, fy, fz - 1.0)), ((1, 0, 1), (fx - 1.0, fy, fz - 1.0)),
               ((0, 1, 1), (fx, fy - 1.0, fz - 1.0)), ((1, 1, 1), (fx - 1.0, fy - 1.0, fz - 1.0))]
    out = []
    for k in range(3):  # mx_gradient_vec3: one gradient per component of mx_hash_vec3
        g = [mx_gradient_float(mx_hash_vec3(X + o[0], Y + o[1], Z + o[2])[k], *f) for o, f in corners]
        out.append(0.9820 * mx_trilerp(*g, u, v, w))
    return out


def mx_cell_noise_float(p):
    return mx_bits_to_01(mx_hash_int3(math.floor(p[0]), math.floor(p[1]), math.floor(p[2])))


def mx_cell_noise_vec3(p):
    ix, iy, iz = math.floor(p[0]), math.floor(p[1]), math.floor(p[2])
    a = b = c = (0xDEADBEEF + (4 << 2) + 13) & M
    a = (a + uint(ix)) & M
    b = (b + uint(iy)) & M
    c = (c + uint(iz)) & M
    a, b, c = mx_bjmix(a, b, c)
    return [mx_bits_to_01(mx_bjfinal(a, b, c)), mx_bits_to_01(mx_bjfinal((a + 1) & M, b, c)),
            mx_bits_to_01(mx_bjfinal((a + 2) & M, b, c))]


def mx_fractal3d_noise_float(p, octaves, lacunarity, diminish):
    result, amplitude = 0.0, 1.0
    p = list(p)
    for _ in range(octaves):
        result += amplitude * mx_perlin_noise_float(p)
        amplitude *= diminish
        p = [c * lacunarity for c in p]
    return result


def mx_worley_cell_position(x, y, z, xoff, yoff, zoff, jitter):
    off = mx_cell_noise_vec3([x + xoff, y + yoff, z + zoff])
    off = [(o - 0.5) * jitter + 0.5 for o in off]
    return [x + off[0], y + off[1], z + off[2]]


def mx_worley_distance(p, x, y, z, xoff, yoff, zoff, jitter, metric):
    cellpos = mx_worley_cell_position(x, y, z, xoff, yoff, zoff, jitter)
    diff = [cellpos[k] - p[k] for k in range(3)]
    return sum(d * d for d in diff)


def mx_worley_noise_float(p, jitter, style, metric=0):
    lx, X = mx_floorfrac(p[0])
    ly, Y = mx_floorfrac(p[1])
    lz, Z = mx_floorfrac(p[2])
    localpos = [lx, ly, lz]
    sqdist = 1e6
    minpos = [0.0, 0.0, 0.0]
    for x in (-1, 0, 1):
        for y in (-1, 0, 1):
            for z in (-1, 0, 1):
                dist = mx_worley_distance(localpos, x, y, z, X, Y, Z, jitter, metric)
                cellpos = [c - lp for c, lp in zip(mx_worley_cell_position(x, y, z, X, Y, Z, jitter), localpos, strict=True)]
                if dist < sqdist:
                    sqdist = dist
                    minpos = cellpos
    if style == 1:
        return mx_cell_noise_float([minpos[k] + p[k] for k in range(3)])
    return math.sqrt(sqdist) if metric == 0 else sqdist


def mx_hash_int2(x, y):
    a = b = c = (0xDEADBEEF + (2 << 2) + 13) & M
    a = (a + uint(x)) & M
    b = (b + uint(y)) & M
    return mx_bjfinal(a, b, c)


def mx_cell_noise_float2(p):
    return mx_bits_to_01(mx_hash_int2(math.floor(p[0]), math.floor(p[1])))
