"""Image writing: formats, bit depths, colour spaces, and nothing half-written."""

import os
import subprocess
import uuid

import numpy as np
import pytest

from bake.errors import OutputError, ParameterError
from bake.imageio import read_image, srgb_decode, srgb_encode, write_image


def ramp(h=32, w=48, c=3):
    rng = np.random.default_rng(2)
    return rng.random((h, w, c)).astype(np.float32)


@pytest.mark.parametrize(
    "name, bits, tol",
    [
        # tolerances in linear units: half a quantisation step where sRGB steps are widest
        ("a.png", 8, 0.5 / 255 * 2.4 + 1e-6),
        ("a.png", 16, 0.5 / 65535 * 2.4 + 1e-6),
        ("a.tif", 8, 0.5 / 255 * 2.4 + 1e-6),
        ("a.tif", 16, 0.5 / 65535 * 2.4 + 1e-6),
        ("a.tif", 32, 0.0),
        ("a.exr", 16, 1e-3),  # half: 11 bits of mantissa
        ("a.exr", 32, 0.0),
    ],
)
@pytest.mark.parametrize("channels", [1, 3, 4])
def test_round_trip(tmp_path, name, bits, tol, channels):
    img = ramp(c=channels)
    info = write_image(tmp_path / name, img, bits=bits)
    back = read_image(tmp_path / name)
    assert back.shape == img.shape and info["bits"] == bits
    assert np.abs(back - img).max() <= tol
    linear = name.endswith(".exr") or bits == 32
    assert info["colorspace"] == ("lin_rec709_scene" if linear else "srgb_rec709_scene")
    assert sorted(os.listdir(tmp_path)) == [name]  # no temporary file left


def test_alpha_is_not_colour_encoded(tmp_path):
    img = np.full((2, 2, 4), 0.5, np.float32)
    write_image(tmp_path / "a.png", img, bits=16)
    import OpenImageIO as oiio

    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    raw = oiio.ImageInput.open(str(tmp_path / "a.png"), config).read_image(oiio.FLOAT)
    assert abs(raw[0, 0, 3] - 0.5) < 1e-4 and abs(raw[0, 0, 0] - srgb_encode(0.5)) < 1e-4


def test_srgb_functions_invert():
    x = np.linspace(0, 1, 1001)
    assert np.abs(srgb_decode(srgb_encode(x)) - x).max() < 1e-12


def test_bad_format_and_bits(tmp_path):
    with pytest.raises(ParameterError, match="format"):
        write_image(tmp_path / "a.bmp", ramp())
    with pytest.raises(ParameterError, match="bits"):
        write_image(tmp_path / "a.png", ramp(), bits=32)
    with pytest.raises(ParameterError, match="pixels"):
        write_image(tmp_path / "a.png", np.zeros((4, 4, 5)))


def test_missing_folder_is_an_output_error(tmp_path):
    with pytest.raises(OutputError, match="nope"):
        write_image(tmp_path / "nope" / "a.png", ramp())


@pytest.fixture
def tiny_disk(tmp_path):
    """A real 64 KiB tmpfs (needs root, as on the project's machines)."""
    mount = tmp_path / f"tiny-{uuid.uuid4().hex[:6]}"
    mount.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)], capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", str(mount)], check=True)


def test_full_disk_leaves_nothing_under_the_final_name(tiny_disk):
    noisy = np.random.default_rng(0).random((512, 512, 3)).astype(np.float32)  # ~800 KB PNG
    with pytest.raises(OutputError):
        write_image(tiny_disk / "albedo.png", noisy)
    assert os.listdir(tiny_disk) == []
    write_image(tiny_disk / "small.png", np.zeros((8, 8, 3), np.float32))  # room for a small one
    assert os.listdir(tiny_disk) == ["small.png"]
