"""The memory a bake needs, told before it starts (texbake.memory), against what bakes take."""

import inspect
import json
import subprocess
import sys
import time

import pytest

from texbake.errors import ParameterError
from texbake.memory import HALF_TEXELS, MIN_TILES, PER_FACE, TILE_SAMPLES, _tile_samples, available_bytes, bake_bytes, check_fits
from texbake.settings import BakeSettings


def test_the_estimate_follows_what_the_settings_hold():
    one = bake_bytes(BakeSettings.build(size=4096), 0)
    # both cut into tiles of 1M samples: only the texels differ, 12 bytes of float32 RGB and 2 of masks each
    assert bake_bytes(BakeSettings.build(size=8192), 0) - one == (8192**2 - 4096**2) * 14
    assert bake_bytes(BakeSettings.build(size=4096), 1000) - one == 1000 * PER_FACE
    lit = bake_bytes(BakeSettings.build(size=4096, shading="full"), 0)
    frames = bake_bytes(BakeSettings.build(size=4096, texture="flame", frames=[0, 1, 2]), 0)
    assert one < lit < frames and bake_bytes(BakeSettings.build(size=4096), 0, workers=1) < one
    # over 8192² texels, maps written as 8 bits are held as float16: half the bytes of a 16-bit PNG's
    png8, png16 = (bake_bytes(BakeSettings.build(size=16384, bits=bits), 0) for bits in (8, 16))
    maps = 16384**2 * 3 * 4
    assert png16 - png8 == pytest.approx(maps / 2, rel=0.01)


def test_the_estimate_cuts_tiles_as_the_bake_does():
    from texbake.maps import accumulate
    from texbake.pipeline import bake_mesh
    from texbake.sampling import lookup

    assert (HALF_TEXELS, MIN_TILES) == (accumulate.HALF_TEXELS, lookup.MIN_TILES)
    assert inspect.signature(bake_mesh).parameters["tile_samples"].default == TILE_SAMPLES
    for width, height, samples in ((2048, 2048, 1), (4096, 4096, 1), (4096, 4096, 16), (65536, 512, 64), (100, 3, 1)):
        tiles = lookup.tiles(height, width, samples, TILE_SAMPLES)
        assert _tile_samples(width, height, samples, TILE_SAMPLES) == max(t.stop - t.start for t in tiles) * width * samples


def test_what_does_not_fit_is_refused_naming_the_size():
    settings = BakeSettings.build(size=2048)
    need = bake_bytes(settings, 500, workers=1)
    assert check_fits(settings, 500, workers=1, limit=need) == need
    with pytest.raises(ParameterError) as error:
        check_fits(settings, 500, workers=1, limit=need - 1)
    assert error.value.name == "size" and str(error.value) == (
        f"size: a 2048x2048 bake needs about {need / 1e9:.2g} GB; this server's limit is {(need - 1) / 1e9:.2g} GB a bake")
    with pytest.raises(ParameterError, match=r"^size: a 65536x65536 bake needs about \d+ GB; [\d.]+ GB are available$"):
        check_fits(BakeSettings.build(size=65536, texture="flame", frames=list(range(64))), 0)
    memory = __import__("psutil").virtual_memory()  # read a moment apart: the machine's use moves between the two
    assert 0 < available_bytes() and abs(available_bytes() - memory.available) < 0.05 * memory.total


def test_the_library_refuses_before_the_atlas(meshes, tmp_path):
    """Raised after the mesh is loaded, before the unwrap: quickly, and no atlas is kept."""
    from texbake.pipeline import bake_mesh

    start = time.perf_counter()
    with pytest.raises(ParameterError, match="^size: a 65536x65536 bake needs about"):
        bake_mesh(meshes / "bunny.ply", "flame", size=65536, frames=list(range(64)), cache=tmp_path / "cache")
    assert time.perf_counter() - start < 20 and not any((tmp_path / "cache").rglob("*.*"))


def test_a_limit_counts_every_texture_set_and_tile(tmp_path):
    """``memory_limit=`` (a server's): four UDIM tiles, each an image, refused where one fits."""
    from conftest import udim_boxes

    from texbake.memory import sets_bytes
    from texbake.pipeline import bake_mesh

    udim_boxes(tmp_path / "boxes.obj")
    settings = BakeSettings.build(size=1024)
    need = sets_bytes([(settings, 4)], 48, workers=1)
    assert bake_bytes(settings, 48, workers=1) < need - 1
    with pytest.raises(ParameterError) as error:
        bake_mesh(tmp_path / "boxes.obj", settings, workers=1, memory_limit=need - 1)
    assert str(error.value) == (f"size: a bake of 4 images (texture sets and tiles) needs about {need / 1e9:.2g} GB; "
                                f"this server's limit is {(need - 1) / 1e9:.2g} GB a bake")
    assert [s.tile for s in bake_mesh(tmp_path / "boxes.obj", settings.model_copy(update={"size": 16}), workers=1,
                                      memory_limit=need - 1).sets] == [1001, 1002, 1003, 1004]


def _peak(mesh, settings: dict) -> float:
    """Peak resident bytes of a bake and its save, in a process of its own."""
    # VmHWM, not getrusage's ru_maxrss: Linux carries ru_maxrss across exec, so a child of a
    # large process (pytest late in the suite) starts at its parent's resident size
    code = ("import json, sys, tempfile\n"
            "from texbake.pipeline import bake_mesh\n"
            "r = bake_mesh(sys.argv[1], json.loads(sys.argv[2]))\n"
            "with tempfile.TemporaryDirectory() as d: r.save(d)\n"
            "hwm = next(line.split()[1] for line in open('/proc/self/status') if line.startswith('VmHWM:'))\n"
            "print(hwm, r.report['mesh']['faces'])\n")
    out = subprocess.run([sys.executable, "-c", code, str(mesh), json.dumps(settings)], capture_output=True, text=True, check=True)
    peak_kib, faces = map(int, out.stdout.split()[-2:])
    return peak_kib * 1024, faces


@pytest.mark.parametrize("size", [2048, 4096, pytest.param(8192, marks=pytest.mark.slow)])
def test_the_estimate_is_near_the_measured_peak(meshes, size):
    """Within 30 % of the peak resident memory the bake and its save take (the machine's
    allocator and the tile threads' timing move it by some 20 %)."""
    settings = {"texture": "checker", "size": size}
    peak, faces = _peak(meshes / "suzanne_blender_uv.obj", settings)
    estimate = bake_bytes(BakeSettings.build(settings), faces, workers=2)
    assert abs(estimate / peak - 1) < 0.3, (estimate / 2**20, peak / 2**20)
