"""Image writing: formats, bit depths, colour spaces, and nothing half-written.

Tolerances of the round trips (write linear values, read them back decoded to linear):

* 8/16-bit sRGB (PNG, TIFF): compared in sRGB space, the error is the quantisation's,
  at most half a step: 0.5/255 (0.5/65535) plus 1e-6 for float arithmetic;
  and the stored codes are exactly ``round(oetf(x) * (2**bits - 1))``.
* EXR half: relative 2**-11 (11-bit significand), checked as 1e-3 relative + 1e-7 absolute.
* EXR float, 32-bit TIFF: exact.
"""

import os
import struct
import subprocess
import uuid
import zlib

import numpy as np
import OpenImageIO as oiio
import pytest

import texbake.formats as formats
import texbake.output.images as imageio
from texbake.errors import OutputError, ParameterError
from texbake.output.images import encode_png_bytes, read_image, srgb_decode, srgb_encode, write_image


def ramp(h=32, w=48, c=3):
    rng = np.random.default_rng(2)
    return rng.random((h, w, c)).astype(np.float32)


def raw_pixels(path, fmt=oiio.UNKNOWN):
    """Pixels as stored (integers not scaled when fmt is UNKNOWN) and the file's spec."""
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(path), config)
    assert inp is not None, oiio.geterror()
    try:
        return inp.read_image(fmt), inp.spec()
    finally:
        inp.close()


def colour_channels(c):
    return 1 if c <= 2 else 3


@pytest.mark.parametrize(
    "name, bits",
    [("a.png", 8), ("a.png", 16), ("a.tif", 8), ("a.tif", 16), ("a.tiff", 8), ("a.tif", 32), ("a.exr", 16), ("a.exr", 32)],
)
@pytest.mark.parametrize("channels", [1, 2, 3, 4])
def test_round_trip(tmp_path, name, bits, channels):
    img = ramp(c=channels)
    img[0, 0] = 0.0
    img[0, 1] = 1.0
    info = write_image(tmp_path / name, img, bits=bits)
    back = read_image(tmp_path / name)
    assert back.shape == img.shape and back.dtype == np.float32
    h, w, c = img.shape
    assert info == {
        "path": str(tmp_path / name), "format": {"png": "png", "tif": "tif", "iff": "tif", "exr": "exr"}[name[-3:]], "bits": bits,
        "colorspace": info["colorspace"], "width": w, "height": h, "channels": c,
        "bytes": (tmp_path / name).stat().st_size,
    }
    linear = name.endswith(".exr") or bits == 32
    assert info["colorspace"] == ("lin_rec709_scene" if linear else "srgb_rec709_scene")
    if name.endswith(".exr") and bits == 16:
        assert np.allclose(back, img, rtol=1e-3, atol=1e-7)
    elif linear:
        assert np.array_equal(back, img)
    else:
        k = colour_channels(channels)
        step = 1 / (2**bits - 1)
        assert np.abs(srgb_encode(back[..., :k]) - srgb_encode(img[..., :k])).max() <= 0.5 * step + 1e-6
        assert np.abs(back[..., k:] - img[..., k:]).max(initial=0) <= 0.5 * step + 1e-6  # alpha: linear
    assert sorted(os.listdir(tmp_path)) == [name]  # no temporary file left


@pytest.mark.parametrize("bits", [8, 16])
def test_stored_codes_are_the_exact_rounded_oetf(tmp_path, bits):
    # values right beside the 8-bit rounding thresholds, where a table alone goes wrong
    thresholds = srgb_decode((np.arange(255) + 0.5) / 255).astype(np.float32)
    near = np.concatenate([np.nextafter(thresholds, -np.inf), thresholds, np.nextafter(thresholds, np.inf)])
    values = np.concatenate([near, ramp(64, 64, 1).ravel(), [0.0, 1.0, 1e-9, 0.0031308]]).astype(np.float32)
    values = values[: (len(values) // 4) * 4]
    img = np.repeat(values.reshape(-1, 4, 1), 3, axis=2)
    img = np.concatenate([img, np.full(img.shape[:2] + (1,), 0.25, np.float32)], axis=2)
    write_image(tmp_path / "a.png", img, bits=bits)
    stored, _ = raw_pixels(tmp_path / "a.png")
    top = 2**bits - 1
    expect = np.rint(srgb_encode(img[..., :3].astype(np.float64)) * top)
    assert np.array_equal(stored[..., :3], expect)
    assert np.all(stored[..., 3] == np.rint(0.25 * top))  # alpha is not colour-encoded


def test_alpha_is_not_colour_encoded(tmp_path):
    img = np.full((2, 2, 4), 0.5, np.float32)
    write_image(tmp_path / "a.png", img, bits=16)
    raw, _ = raw_pixels(tmp_path / "a.png", oiio.FLOAT)
    assert abs(raw[0, 0, 3] - 0.5) < 1e-4 and abs(raw[0, 0, 0] - srgb_encode(0.5)) < 1e-4


@pytest.mark.parametrize(
    "name, bits, attribute, value",
    [
        ("a.png", 8, "oiio:ColorSpace", "srgb_rec709_scene"),
        ("a.png", 16, "oiio:ColorSpace", "srgb_rec709_scene"),
        ("a.exr", 16, "oiio:ColorSpace", "lin_rec709_scene"),
        ("a.exr", 32, "oiio:ColorSpace", "lin_rec709_scene"),
        ("a.tif", 8, "oiio:ColorSpace", "srgb_rec709_scene"),
        ("a.tif", 16, "Exif:ColorSpace", 1),  # sRGB
        ("a.tif", 32, "Exif:ColorSpace", 0xFFFF),  # uncalibrated: linear float
    ],
)
def test_colour_space_in_the_metadata(tmp_path, name, bits, attribute, value):
    write_image(tmp_path / name, ramp(), bits=bits)
    _, spec = raw_pixels(tmp_path / name)
    assert spec.getattribute(attribute) == value
    assert spec.getattribute("Software") == "texbake"


@pytest.mark.parametrize("name, bits", [("a.png", 8), ("a.tif", 16), ("a.exr", 32)])
def test_data_and_srgb_inputs(tmp_path, name, bits):
    img = ramp(c=4)
    info = write_image(tmp_path / name, img, bits=bits, colorspace="data")
    assert info["colorspace"] == "data"
    stored, _ = raw_pixels(tmp_path / name, oiio.FLOAT)
    tol = 0.5 / (2**bits - 1) + 1e-6 if bits < 32 else 0
    assert np.abs(stored - img).max() <= tol  # stored as given, no transfer function
    assert np.abs(read_image(tmp_path / name) - img).max() <= tol  # and read back as such

    write_image(tmp_path / name, img, bits=bits, colorspace="srgb")  # already encoded
    expect = img.astype(np.float64).copy()
    expect[..., :3] = srgb_decode(img[..., :3])
    assert np.abs(read_image(tmp_path / name) - expect).max() <= 4 * tol + 1e-6


@pytest.mark.parametrize("bits", [8, 16])
def test_a_data_png_says_linear_and_a_colour_png_srgb(tmp_path, bits):
    """Viewers read a PNG without colour chunks as sRGB: a data PNG carries gAMA 1.0 (linear)
    and no sRGB or cHRM chunk; a colour PNG its sRGB chunk."""
    import struct

    def chunks(path):
        data, p, found = path.read_bytes(), 8, {}
        while p < len(data):
            n, kind = struct.unpack_from(">I4s", data, p)
            found[kind] = data[p + 8 : p + 8 + n]
            p += 12 + n
        return found

    write_image(tmp_path / "data.png", ramp(), bits=bits, colorspace="data")
    data = chunks(tmp_path / "data.png")
    assert data[b"gAMA"] == struct.pack(">I", 100000) and b"sRGB" not in data and b"cHRM" not in data
    write_image(tmp_path / "colour.png", ramp(), bits=bits)
    colour = chunks(tmp_path / "colour.png")
    assert b"sRGB" in colour and colour[b"gAMA"] == struct.pack(">I", 45455)  # 1 / 2.2


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64, np.bool_])
@pytest.mark.parametrize("bits", [8, 16])
def test_every_map_dtype_is_written(tmp_path, dtype, bits):
    # maps of 8192² and more are held as float16; the coverage is bool
    img = (ramp(c=4) > 0.5) if dtype == np.bool_ else ramp(c=4).astype(dtype)
    write_image(tmp_path / "a.png", img, bits=bits)
    stored, _ = raw_pixels(tmp_path / "a.png")
    top = 2**bits - 1
    linear = img.astype(np.float32).astype(np.float64)
    assert np.array_equal(stored[..., :3], np.rint(srgb_encode(linear[..., :3]) * top))
    assert np.array_equal(stored[..., 3], np.rint(img[..., 3].astype(np.float32) * np.float32(top)))  # alpha: in float32


def test_png_rows_take_the_up_filter(tmp_path):
    # one filter for every row (libpng's trial of all five per row took 2-3x as long)
    img = ramp(40, 33, 3)
    write_image(tmp_path / "a.png", img)
    data = (tmp_path / "a.png").read_bytes()
    idat, p = b"", 8
    while p < len(data):
        length, kind = struct.unpack_from(">I4s", data, p)
        idat += data[p + 8 : p + 8 + length] if kind == b"IDAT" else b""
        p += 12 + length
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(40, 1 + 33 * 3)
    assert set(rows[:, 0].tolist()) <= {0, 2}  # "up" (row 0 has nothing above it: libpng may write it as "none")
    assert np.array_equal(raw_pixels(tmp_path / "a.png")[0], np.rint(srgb_encode(img.astype(np.float64)) * 255))


def test_srgb_functions_invert():
    x = np.linspace(0, 1, 1001)
    assert np.abs(srgb_decode(srgb_encode(x)) - x).max() < 4e-15  # float64 round-off: measured 4.4e-16


def test_non_finite_values(tmp_path):
    img = np.zeros((2, 2, 3), np.float32)
    img[0, 0, 0], img[0, 1, 0], img[1, 0, 0] = np.nan, np.inf, -np.inf
    write_image(tmp_path / "a.png", img)
    assert read_image(tmp_path / "a.png")[..., 0].tolist() == [[0.0, 1.0], [0.0, 0.0]]
    write_image(tmp_path / "a.exr", img, bits=32)  # float files keep them
    back = read_image(tmp_path / "a.exr")
    assert np.isnan(back[0, 0, 0]) and back[0, 1, 0] == np.inf and back[1, 0, 0] == -np.inf


@pytest.mark.parametrize("colorspace", ["linear", "data"])
def test_encode_png_bytes_are_the_file_write_image_writes(tmp_path, colorspace):
    img = ramp(c=4)
    data = encode_png_bytes(img, bits=16, colorspace=colorspace)
    assert data.startswith(b"\x89PNG\r\n\x1a\n") and data.endswith(b"IEND\xaeB`\x82")
    write_image(tmp_path / "a.png", img, bits=16, colorspace=colorspace)
    assert data == (tmp_path / "a.png").read_bytes()
    (tmp_path / "b.png").write_bytes(data)
    stored, spec = raw_pixels(tmp_path / "b.png")
    assert spec.format == oiio.UINT16 and stored.shape == img.shape


def test_bad_parameters(tmp_path):
    with pytest.raises(ParameterError, match="format"):
        write_image(tmp_path / "a.bmp", ramp())
    with pytest.raises(ParameterError, match="format"):
        write_image(tmp_path / "a.png", ramp(), fmt="jpeg")
    with pytest.raises(ParameterError, match="bits"):
        write_image(tmp_path / "a.png", ramp(), bits=32)
    with pytest.raises(ParameterError, match="bits"):
        write_image(tmp_path / "a.exr", ramp(), bits=8)
    with pytest.raises(ParameterError, match="colorspace"):
        write_image(tmp_path / "a.png", ramp(), colorspace="acescg")
    with pytest.raises(ParameterError, match="pixels"):
        write_image(tmp_path / "a.png", np.zeros((4, 4, 5)))
    with pytest.raises(ParameterError, match="pixels"):
        write_image(tmp_path / "a.png", np.zeros((0, 4, 3)))
    assert os.listdir(tmp_path) == []


def test_fmt_overrides_the_extension(tmp_path):
    info = write_image(tmp_path / "albedo.bin", ramp(), fmt="png")
    assert info["format"] == "png" and (tmp_path / "albedo.bin").read_bytes().startswith(b"\x89PNG")
    assert os.listdir(tmp_path) == ["albedo.bin"]


# -- failures: nothing half-written under the final name, no temporary file left ----------


def test_missing_folder_is_an_output_error(tmp_path):
    with pytest.raises(OutputError, match="nope"):
        write_image(tmp_path / "nope" / "a.png", ramp())
    assert os.listdir(tmp_path) == []


def test_final_name_taken_by_a_folder(tmp_path):
    (tmp_path / "a.png").mkdir()
    with pytest.raises(OutputError, match="a.png"):
        write_image(tmp_path / "a.png", ramp())
    assert os.listdir(tmp_path) == ["a.png"] and (tmp_path / "a.png").is_dir()


@pytest.mark.parametrize("name", ["a.png", "a.exr", "a.tif"])
@pytest.mark.parametrize("keep", [0.5, -1])  # half the file, all but its last byte
def test_truncated_file_is_caught(tmp_path, monkeypatch, name, keep):
    """Failure injection: the file is cut short between its writing and its check."""
    write_image(tmp_path / name, np.zeros((64, 64, 3), np.float32))  # an older version
    before = (tmp_path / name).read_bytes()
    real_sync = imageio._sync
    cut = []

    def sync_then_truncate(path):
        real_sync(path)
        size = path.stat().st_size
        os.truncate(path, int(size * keep) if keep > 0 else size + keep)
        cut.append(path)

    monkeypatch.setattr(imageio, "_sync", sync_then_truncate)
    with pytest.raises(OutputError, match=name):
        write_image(tmp_path / name, ramp(64, 64))
    assert cut and not cut[0].exists()
    assert os.listdir(tmp_path) == [name] and (tmp_path / name).read_bytes() == before  # untouched


def test_a_png_whose_pixel_data_is_short_is_caught(tmp_path, monkeypatch):
    """Failure injection: a PNG whose chunks are all sound (CRCs right) but whose pixel
    stream lacks its last row: caught without decoding the image."""
    import struct
    import zlib

    real_sync = imageio._sync

    def sync_then_drop_a_row(path):
        real_sync(path)
        data, p, chunks = path.read_bytes(), 8, []
        while p < len(data):  # (kind, body) of every chunk
            (length,) = struct.unpack_from(">I", data, p)
            chunks.append((data[p + 4 : p + 8], data[p + 8 : p + 8 + length]))
            p += 12 + length
        raw = zlib.decompress(b"".join(body for kind, body in chunks if kind == b"IDAT"))
        short = zlib.compress(raw[: -(1 + 64 * 3)])  # one row (its filter byte and pixels) less
        first = next(i for i, (kind, _) in enumerate(chunks) if kind == b"IDAT")
        chunks = [c for c in chunks if c[0] != b"IDAT"]
        chunks.insert(first, (b"IDAT", short))
        path.write_bytes(data[:8] + b"".join(struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
                                             for kind, body in chunks))

    monkeypatch.setattr(imageio, "_sync", sync_then_drop_a_row)
    with pytest.raises(OutputError, match="pixel data"):
        write_image(tmp_path / "a.png", ramp(64, 64))
    assert os.listdir(tmp_path) == []


def _mount_tmpfs(where, options):
    where.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True, text=True)
    if r.returncode != 0:
        where.rmdir()
        pytest.skip(f"cannot mount a tmpfs here (needs root and mount rights): {r.stderr.strip()}")
    return where


@pytest.fixture
def tiny_disk(tmp_path):
    """A real 64 KiB tmpfs (needs root, as on the project's machines)."""
    mount = _mount_tmpfs(tmp_path / f"tiny-{uuid.uuid4().hex[:6]}", "size=64k")
    yield mount
    subprocess.run(["umount", str(mount)], check=True)


@pytest.fixture
def read_only_disk(tmp_path):
    mount = _mount_tmpfs(tmp_path / f"ro-{uuid.uuid4().hex[:6]}", "ro,size=64k")
    yield mount
    subprocess.run(["umount", str(mount)], check=True)


@pytest.mark.parametrize("name", ["albedo.png", "albedo.exr", "albedo.tif"])
def test_full_disk_leaves_nothing_under_the_final_name(tiny_disk, name):
    noisy = np.random.default_rng(0).random((512, 512, 3)).astype(np.float32)  # ~800 KB
    with pytest.raises(OutputError, match=name):
        write_image(tiny_disk / name, noisy, bits=16)
    assert os.listdir(tiny_disk) == []
    write_image(tiny_disk / "small.png", np.zeros((8, 8, 3), np.float32))  # room for a small one
    assert os.listdir(tiny_disk) == ["small.png"]


def test_read_only_folder(read_only_disk):
    with pytest.raises(OutputError, match="albedo.png"):
        write_image(read_only_disk / "albedo.png", ramp())
    assert os.listdir(read_only_disk) == []


def test_read_image_of_a_broken_file(tmp_path):
    (tmp_path / "a.png").write_bytes(b"\x89PNG\r\n\x1a\nnot really")
    with pytest.raises(OutputError, match="a.png"):
        read_image(tmp_path / "a.png")


@pytest.mark.parametrize("name, fmt", [("png", "png"), (".PNG", "png"), ("tif", "tif"), ("TIFF", "tif"), (".tiff", "tif"), ("exr", "exr")])
def test_one_format_rule_for_the_settings_the_writer_and_the_saver(tmp_path, name, fmt):
    """``tiff`` is ``tif`` and the bit depths are :data:`BITS`, wherever a format is named."""
    from texbake.output.save import save_result
    from texbake.settings import BakeSettings

    assert formats.image_format(name) == fmt and BakeSettings(format=name).format == fmt
    for bits in (8, 16, 32):
        takes = bits in formats.BITS[fmt]
        assert (formats.bits_problem(fmt, bits) is None) == takes
        if not takes:
            with pytest.raises(ParameterError, match=f"bits: {fmt} takes"):
                write_image(tmp_path / f"a.{fmt}", ramp(), bits=bits)
            with pytest.raises(ParameterError, match=f"bits: {fmt} takes"):
                save_result(None, tmp_path / "out", fmt=name, bits=bits)  # checked before the result is read
            with pytest.raises(ValueError, match=f"bits: {fmt} takes"):
                BakeSettings(format=name, bits=bits)
    assert not (tmp_path / "out").exists()


def test_an_unknown_format_is_refused_by_each_of_them(tmp_path):
    from pydantic import ValidationError

    from texbake.output.save import save_result
    from texbake.settings import BakeSettings

    for call in (lambda: write_image(tmp_path / "a.jpg", ramp()), lambda: save_result(None, tmp_path / "out", fmt="jpeg")):
        with pytest.raises(ParameterError, match="format: expected png, exr, tif or tiff, got 'jp"):
            call()
    with pytest.raises(ValidationError, match="format"):
        BakeSettings(format="jpeg")


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_16_bit_data_codes_are_the_rounded_float32_products(tmp_path, dtype):
    # the compiled 16-bit encoding of data (native/images.cpp) against numpy's: round half to
    # even of 65535 x in float32, NaN 0, clipped; values on and beside the rounding thresholds
    rng = np.random.default_rng(3)
    codes = rng.integers(0, 65535, 4000)
    x = np.concatenate([(codes + 0.5) / 65535, (codes + 0.5) / 65535 + 1e-9, rng.random(3990), [np.nan, np.inf, -np.inf, -0.5, 1.5, 0.0, 1.0, -0.0, 1e-300, 0.99999999]])
    img = x.astype(dtype).reshape(-1, 10, 1).repeat(3, axis=2)
    img[..., 1] *= 0.5  # three channels apart
    expect = np.rint(np.clip(np.nan_to_num(img.astype(np.float32), nan=0.0), 0.0, 1.0) * np.float32(65535)).astype(np.uint16)
    write_image(tmp_path / "a.png", img, bits=16, colorspace="data")
    stored, _ = raw_pixels(tmp_path / "a.png", oiio.UINT16)
    assert np.array_equal(stored, expect)


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("bits", [8, 16])
@pytest.mark.parametrize("stored", ["data", "srgb_rec709_scene"])
def test_the_png_header_is_the_one_openimageio_writes(tmp_path, channels, bits, stored):
    # texbake writes a PNG's chunks before its pixels itself (and its stream on two cores):
    # they must be OpenImageIO's for the same spec, byte for byte (its writer, _write_bands)
    import struct

    dtype = np.uint8 if bits == 8 else np.uint16
    probe = tmp_path / "probe.png"
    imageio._write_bands(probe, probe, np.zeros((3, 5, channels), np.float32), imageio._spec((3, 5, channels), dtype, "png", stored),
                         ("png", bits, "data"))
    data, p = probe.read_bytes(), 8
    while data[p + 4 : p + 8] != b"IDAT":
        p += 12 + struct.unpack_from(">I", data, p)[0]
    assert imageio._png_header(5, 3, channels, bits, stored) == data[:p]
