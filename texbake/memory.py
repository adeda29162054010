"""How much memory a bake needs, told before it starts: a size that cannot fit is refused
with the figure instead of unwrapping for minutes and dying of a MemoryError.

:func:`bake_bytes` is a pure function of the settings, the face count and the tile
threads; :func:`check_fits` compares it with the memory there is (or a limit) and raises
:class:`~texbake.errors.ParameterError`. What a bake holds at its peak (the tiles', or the
writer's after them, whichever is more):

- the process itself: Python, numpy, the compiled kernels, Embree, OpenImageIO (``BASE``);
- per face: the mesh, its atlas, the lookup's layout and the surface's per-face arrays;
- per texel: each map (3 channels of float32, or float16 for images over ``HALF_TEXELS``
  texels written as 8 bits: ``texbake.maps.accumulate``; a material's maps and packed
  maps their own channels), and two bytes: the sample counts while the tiles run, the
  coverage and margin masks after them;
- while the tiles run, per sample of each tile in flight (one a thread): the lookup's
  rays and coordinates, the surface point, its footprint and normal, and the texture's
  temporaries, for each colour map (``PER_SAMPLE_COLOUR``) and each lit or normal map
  (``PER_SAMPLE_OTHER``); a material's: beside one colour map's temporaries,
  ``PER_SAMPLE_MAP`` a map (the node kernel works a block of points at a time) and
  ``PER_SAMPLE_LEAF`` a texture (four a warp: its moved points and footprints), and its tables (``MATERIAL_BASE``);
  one filtered sample a texel, besides: the footprints' cut at chart edges and the crease
  parts (``PER_SAMPLE_FILTERED``);
- after them, the margin's and the writer's bands and buffers (``AFTER_TILES``: both work
  a band at a time).

The constants are fitted to the measured peak resident memory of bakes from 512² to
16384², of 63k to 1M faces, with one and several maps (the figures are in the commit
that set them); ``tests/texbake/test_memory.py`` measures some again.
"""

from __future__ import annotations

from pathlib import Path

from .errors import ParameterError
from .formats import DEFAULT_BITS

BASE = 48 * 2**20  # measured: a 64x64 bake of a 63k-face mesh peaks at 194 MB, this and its faces and tiles
PER_FACE = 900
PER_SAMPLE_COLOUR = 150
PER_SAMPLE_OTHER = 60
PER_SAMPLE_MAP = 20  # a material's, beside one colour map's: its node kernel works a block at a time
PER_SAMPLE_LEAF = 40  # and each of its textures' values (a warp's moved points too)
# One filtered sample a texel: the cut and the crease parts (texbake.sampling.creases). Measured
# (suzanne_blender_uv.obj, checker, bake + save): the crease parts alone add 50-120 MB to a
# 4096² bake's peak (737-790 MB without, 841-856 with, 98k parts). With this term the estimate
# is 0.83-0.84x the peak at 4096² (0.73-0.74x without; tests/texbake/test_memory.py allows 0.7)
# and 0.95x at 8192² (0.85-0.87x); at 2048² the tiles stay under AFTER_TILES (0.84-0.89x)
PER_SAMPLE_FILTERED = 40
MATERIAL_BASE = 40 * 2**20  # a material's tables (its curves smoothed over spreads) and buffers
AFTER_TILES = 100 * 2**20
HALF_TEXELS = 8192 * 8192  # as texbake.maps.accumulate: larger 8-bit images are held as float16
MIN_TILES = 16  # as texbake.sampling.lookup.tiles
TILE_SAMPLES = 1 << 20  # bake_mesh's default


def _tile_samples(width: int, height: int, samples: int, budget: int) -> int:
    """Samples of one tile as ``texbake.sampling.lookup.tiles`` cuts them."""
    rows = max(1, min(budget // max(1, width * samples), -(-height // MIN_TILES)))
    return min(rows, height) * width * samples


def bake_bytes(settings, faces: int, workers: int = 2, tile_samples: int = TILE_SAMPLES) -> int:
    """Bytes of memory a bake with ``settings`` (``BakeSettings``) of a mesh of ``faces``
    faces needs at its peak, on ``workers`` tile threads, in tiles of about
    ``tile_samples`` samples (bake_mesh's arguments)."""
    held, working = _image_bytes(settings, workers, tile_samples)
    return BASE + PER_FACE * int(faces) + held + working


def sets_bytes(sets: list[tuple], faces: int, workers: int = 2, tile_samples: int = TILE_SAMPLES) -> int:
    """:func:`bake_bytes` of a bake of several texture sets or tiles, ``(settings, images)``
    each, of a mesh of ``faces`` faces: the sets bake one after another, each one's images
    kept until they are written."""
    parts = [(_image_bytes(s, workers, tile_samples), images) for s, images in sets]
    return BASE + PER_FACE * int(faces) + sum(held * n for (held, _), n in parts) + max(working for (_, working), _ in parts)


def _image_bytes(settings, workers: int, tile_samples: int) -> tuple[int, int]:
    """``(bytes held, bytes while baking)`` of one image of a bake: its maps and masks,
    and its tiles in flight (or the margin's and the writer's bands)."""
    width, height = settings.width_height
    texels = width * height
    samples = settings.samples
    colours = len(settings.frames) if settings.frames is not None else 1
    others = (settings.shading != "decal") + (settings.bump is not None)
    bits = settings.bits or DEFAULT_BITS[settings.format]
    channel = 2 if bits == 8 and texels > HALF_TEXELS else 4
    channels, per_sample, fixed = (colours + others) * 3, PER_SAMPLE_COLOUR * colours + PER_SAMPLE_OTHER * others, 0
    if settings.material is not None:
        channels, maps = _material_maps(settings)
        leaves = sum({"texture": 1, "warp": 4}.get(node.op, 0) for node in settings.material.graph.nodes.values())  # a warp's moved points
        per_sample, fixed = PER_SAMPLE_COLOUR + PER_SAMPLE_MAP * maps + PER_SAMPLE_LEAF * leaves, MATERIAL_BASE
    if settings.filtering and samples == 1:
        per_sample += PER_SAMPLE_FILTERED
    masks = 2 * texels  # the coverage and margin masks (the sample counts before them take no more)
    tile = _tile_samples(width, height, samples, tile_samples)
    in_flight = min(max(1, workers), -(-texels * samples // tile)) * tile
    return channels * channel * texels + masks + fixed, max(in_flight * per_sample, AFTER_TILES)


def _material_maps(settings) -> tuple[int, int]:
    """``(channels, maps)`` of a material's bake: its maps' channels (one a scalar, three a
    colour, the normal map, packed maps, a lit map) and how many maps."""
    from .materials.graph import CHANNELS

    given = [c for c in settings.material.channels if c != "normal"]
    lit = settings.shading != "decal"
    channels = sum(3 if CHANNELS[c] == "colour" else 1 for c in given) + 3 * (settings.normal_map + lit)
    return channels + sum(len(t.channels) for t in settings.packing or ()), len(given) + settings.normal_map + lit


def available_bytes() -> int:
    """Memory this process may still take: the system's available memory, or less where
    a control group (a container's limit) leaves less."""
    free = _system_available()
    for limit_file, usage_file in (("memory.max", "memory.current"), ("memory/memory.limit_in_bytes", "memory/memory.usage_in_bytes")):
        try:
            limit = Path("/sys/fs/cgroup", limit_file).read_text().strip()
            usage = Path("/sys/fs/cgroup", usage_file).read_text().strip()
        except OSError:
            continue
        if limit.isdigit() and usage.isdigit() and int(limit) < 2**60:  # "max", or v1's "no limit"
            free = min(free, max(0, int(limit) - int(usage)))
    return free


def _system_available() -> int:
    """The kernel's estimate of the memory available to new work (``MemAvailable``, as
    psutil reads it on Linux, without importing psutil for every bake), else psutil's."""
    try:
        with open("/proc/meminfo", "rb") as f:
            for line in f:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024  # kB
    except (OSError, ValueError, IndexError):
        pass
    import psutil

    return int(psutil.virtual_memory().available)


def gigabytes(n: float) -> str:
    """``"48 GB"``, ``"3.2 GB"``, ``"0.45 GB"``: two figures or the whole number."""
    gb = n / 1e9
    return f"{gb:.0f} GB" if gb >= 10 else f"{gb:.2g} GB"


def check_fits(settings, faces: int, workers: int = 2, tile_samples: int = TILE_SAMPLES, *, limit: int | None = None,
               sets: list[tuple] | None = None) -> int:
    """Raise :class:`ParameterError` naming ``size`` when a bake would need more memory
    than there is (:func:`available_bytes`), or than ``limit`` bytes (a server's limit a
    bake); else return the estimate (:func:`bake_bytes`; :func:`sets_bytes` of ``sets``,
    ``(settings, images)`` each, for a bake of several texture sets or tiles).

    ``size: a 65536x65536 bake needs about 40 GB; 20 GB are available``.
    """
    if sets is not None and len(sets) == 1 and sets[0][1] == 1:  # one image: a bake as there were before sets
        settings, sets = sets[0][0], None
    need = bake_bytes(settings, faces, workers, tile_samples) if sets is None else sets_bytes(sets, faces, workers, tile_samples)
    have = available_bytes() if limit is None else int(limit)
    if need > have:
        width, height = settings.width_height
        what = f"a {width}x{height} bake" if sets is None else f"a bake of {sum(n for _, n in sets)} images (texture sets and tiles)"
        where = f"{gigabytes(have)} are available" if limit is None else f"this server's limit is {gigabytes(have)} a bake"
        raise ParameterError("size", f"{what} needs about {gigabytes(need)}; {where}")
    return need


__all__ = ["available_bytes", "bake_bytes", "check_fits", "gigabytes", "sets_bytes"]
