"""The noise tables, pinned: ``noiseTable`` and ``indexTable`` of a seed, derived with
integer arithmetic written out here, so that no library upgrade can change every texture.

The derivation is NumPy's ``np.random.default_rng(seed)`` followed by ``random(256)`` and
``permutation(256)``, as NumPy 1.17-2.x compute it (the tables every earlier texbake
release used; checked equal to NumPy for seeds 0-19, 123456789 and 2^32 - 1), but NumPy
does not promise to keep that stream; this module does:

- ``SeedSequence(seed)``: the seed's 32-bit words (little end first) hashed into a pool of
  four 32-bit words (``hashmix``/``mix``, after O'Neill's ``seed_seq_fe``), then expanded
  into four 64-bit words;
- ``PCG64`` (PCG XSL-RR 128/64, O'Neill 2014) seeded with them: state and increment from
  words 0-1 and 2-3, as ``pcg_setseq_128_srandom_r``;
- ``noiseTable[i]``: 256 doubles ``(next64 >> 11) * 2^-53``;
- ``indexTable``: Fisher-Yates over ``0..255`` from the top, ``j`` drawn in ``[0, i]`` by
  masked rejection on 32-bit halves of the 64-bit outputs (low half first).

Plain Python integers (exact); 256 + ~300 steps a seed, cached by ``noise.tables``.
"""

from __future__ import annotations

import numpy as np

_M32, _M64, _M128 = (1 << 32) - 1, (1 << 64) - 1, (1 << 128) - 1
_INIT_A, _MULT_A, _INIT_B, _MULT_B = 0x43B0D7E5, 0x931E8875, 0x8B51F9DD, 0x58F38DED
_MIX_L, _MIX_R = 0xCA01F9DD, 0x4973F715
_PCG_MULT = (2549297995355413924 << 64) | 4865540595714422341


def _seed_words(seed: int) -> list[int]:
    """``seed`` (>= 0) as 32-bit words, least significant first (0: one word)."""
    words = [seed & _M32]
    while seed > _M32:
        seed >>= 32
        words.append(seed & _M32)
    return words


def _pool(seed: int, size: int = 4) -> list[int]:
    """SeedSequence's entropy pool: the seed's words hashed and mixed."""
    const = [_INIT_A]

    def hashmix(value: int) -> int:
        value ^= const[0]
        const[0] = (const[0] * _MULT_A) & _M32
        value = (value * const[0]) & _M32
        return value ^ (value >> 16)

    def mix(x: int, y: int) -> int:
        r = (_MIX_L * x - _MIX_R * y) & _M32
        return r ^ (r >> 16)

    entropy = _seed_words(seed)
    pool = [hashmix(entropy[i] if i < len(entropy) else 0) for i in range(size)]
    for src in range(size):
        for dst in range(size):
            if src != dst:
                pool[dst] = mix(pool[dst], hashmix(pool[src]))
    for src in range(size, len(entropy)):
        for dst in range(size):
            pool[dst] = mix(pool[dst], hashmix(entropy[src]))
    return pool


def _state(seed: int, words: int = 4) -> list[int]:
    """SeedSequence's ``generate_state(words, uint64)``."""
    pool, const, out = _pool(seed), _INIT_B, []
    for i in range(2 * words):
        value = pool[i % len(pool)] ^ const
        const = (const * _MULT_B) & _M32
        value = (value * const) & _M32
        out.append(value ^ (value >> 16))
    return [out[2 * i] | (out[2 * i + 1] << 32) for i in range(words)]


class _PCG64:
    """PCG XSL-RR 128/64 with NumPy's 32-bit halving of its outputs."""

    def __init__(self, seed: int):
        s = _state(seed)
        self.inc = (((s[2] << 64) | s[3]) << 1 | 1) & _M128
        self.state = 0
        self._step()
        self.state = (self.state + ((s[0] << 64) | s[1])) & _M128
        self._step()
        self.half: int | None = None

    def _step(self) -> None:
        self.state = (self.state * _PCG_MULT + self.inc) & _M128

    def next64(self) -> int:
        self._step()
        x, rot = ((self.state >> 64) ^ self.state) & _M64, self.state >> 122
        return ((x >> rot) | (x << (64 - rot))) & _M64 if rot else x

    def next32(self) -> int:
        if self.half is not None:
            value, self.half = self.half, None
            return value
        value = self.next64()
        self.half = value >> 32
        return value & _M32

    def below(self, top: int) -> int:
        """Uniform in ``[0, top]`` (``top < 2^32``): masked rejection."""
        if top == 0:
            return 0
        mask = top
        for shift in (1, 2, 4, 8, 16):
            mask |= mask >> shift
        while True:
            value = self.next32() & mask
            if value <= top:
                return value


def derive(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``(noiseTable (256,) float64 in [0, 1), indexTable (256,) int64 permutation)`` of ``seed``."""
    if not 0 <= seed < 2**64:
        raise ValueError(f"seed must be in [0, 2^64), got {seed}")
    g = _PCG64(int(seed))
    noise = np.array([(g.next64() >> 11) * (1.0 / 9007199254740992.0) for _ in range(256)])
    index = list(range(256))
    for i in range(255, 0, -1):
        j = g.below(i)
        index[i], index[j] = index[j], index[i]
    return noise, np.array(index, dtype=np.int64)
