"""A baked GLB in a real viewer: three.js (tools/node_modules/three, pinned in
tools/package.json) in headless Chromium (Debian's ``chromium``; ``scripts/run`` installs it
when missing and running as root), served from 127.0.0.1 by the test.

Each render is a screenshot of tools/render-glb.html: the model framed on its bounding box,
a directional and an ambient light, on a magenta background. The screenshots are kept under
pytest's tmp_path and, if TEXBAKE_ARTEFACTS names a folder, copied there.

Without chromium the test is skipped only when it cannot be installed (not root) and not
under CI (CI=true fails instead); as root, run it through ``scripts/run``.
"""

import functools
import http.server
import os
import shutil
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import ROOT, chromium, keep_artefact

import texbake
from texbake.output.export import write_glb
from texbake.output.images import encode_png_bytes, read_image

TOOLS = ROOT / "tools"
SIZE = 320  # screenshot width and height, pixels
MAGENTA = np.array([1.0, 0.0, 1.0])


@pytest.fixture
def server(tmp_path):
    """``(folder, base URL)``: a folder served on 127.0.0.1, with three.js under /three/
    and the render page."""
    if not (TOOLS / "node_modules" / "three" / "build" / "three.module.js").is_file():
        message = "three.js is not set up: run `npm ci` in tools/ (scripts/run does it)"
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(message)
        pytest.skip(message)
    site = tmp_path / "site"
    site.mkdir()
    (site / "three").symlink_to(TOOLS / "node_modules" / "three")
    shutil.copy(TOOLS / "render-glb.html", site / "render.html")
    handler = functools.partial(_QuietHandler, directory=str(site))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield site, f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()
        httpd.server_close()
        thread.join()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map, ".js": "text/javascript", ".glb": "model/gltf-binary"}

    def log_message(self, format, *args):  # the base class's signature
        pass


def render(server, glb: Path, name: str, tmp_path: Path) -> np.ndarray:
    """``(SIZE, SIZE, 3)`` float32 linear screenshot of ``glb`` in three.js; kept as an artefact.

    Headless screenshots have come out blank (all background) now and then: retried up to
    three times.
    """
    site, base = server
    shutil.copy(glb, site / f"{name}.glb")
    shot = tmp_path / f"{name}.png"
    for _ in range(3):
        shot.unlink(missing_ok=True)
        subprocess.run(
            [chromium(), "--headless", "--no-sandbox", "--use-gl=swiftshader", "--enable-unsafe-swiftshader",
             "--disable-gpu-sandbox", "--disable-background-networking", "--hide-scrollbars", "--no-first-run",
             f"--user-data-dir={tmp_path / 'chromium-profile'}", "--virtual-time-budget=20000",
             f"--window-size={SIZE},{SIZE}", f"--screenshot={shot}", f"{base}/render.html?glb=/{name}.glb&size={SIZE}"],
            capture_output=True, timeout=120, check=False)
        if shot.is_file():
            image = read_image(shot)[..., :3]
            if not (np.abs(image - MAGENTA).max(axis=2) < 0.05).all():
                break
    assert shot.is_file(), f"chromium wrote no screenshot of {name}"
    keep_artefact(shot)
    return image


def model_mask(image: np.ndarray) -> np.ndarray:
    """``(h, w)`` bool: pixels that are not the background."""
    return np.abs(image - MAGENTA).max(axis=2) > 0.05


def steps(image: np.ndarray, mask: np.ndarray, threshold: float = 0.02) -> float:
    """Share of the neighbouring pixel pairs inside the model (both in ``mask``, away from
    its outline) whose brightness jumps by more than ``threshold``: facet edges of flat
    shading are such jumps, smooth shading has almost none."""
    luma = image @ np.array([0.2126, 0.7152, 0.0722])
    from scipy import ndimage

    inner = ndimage.binary_erosion(mask, iterations=3)
    jumps, pairs = 0, 0
    for a, b, both in ((luma[:, 1:], luma[:, :-1], inner[:, 1:] & inner[:, :-1]), (luma[1:], luma[:-1], inner[1:] & inner[:-1])):
        jumps += int((np.abs(a - b)[both] > threshold).sum())
        pairs += int(both.sum())
    return jumps / max(pairs, 1)


def test_a_baked_glb_renders_textured_and_smooth_in_three_js(server, tmp_path):
    # A coarse sphere (320 faces) shows its facets when shaded flat. Three renders: the
    # checker bake as saved; the same mesh and normals with a plain grey texture; and the
    # plain one written without normals (three.js then shades it flat).
    sphere = trimesh.creation.icosphere(subdivisions=2)
    result = texbake.bake_mesh(sphere, "checker", size=256)
    result.save(tmp_path / "bake")
    m = result.mesh
    grey = encode_png_bytes(np.full((8, 8, 3), 0.5, np.float32))
    write_glb(tmp_path / "plain.glb", m.vertices, m.faces, m.uv, grey, normals=m.normals)
    write_glb(tmp_path / "flat.glb", m.vertices, m.faces, m.uv, grey)

    checker = render(server, tmp_path / "bake" / f"{m.name}.glb", "checker", tmp_path)
    plain = render(server, tmp_path / "plain.glb", "plain", tmp_path)
    flat = render(server, tmp_path / "flat.glb", "flat", tmp_path)

    # the model fills the centre of the frame
    c = slice(SIZE * 2 // 5, SIZE * 3 // 5)
    for image in (checker, plain, flat):
        assert model_mask(image)[c, c].all()
    # textured: the checker's light and dark squares (0.9 and 0.05 albedo) under the same
    # light as the plain grey: a wide spread of brightness where the grey has a narrow one
    luma = lambda image: image[model_mask(image)] @ np.array([0.2126, 0.7152, 0.0722])
    lo, hi = np.quantile(luma(checker), [0.1, 0.9])
    plain_lo, plain_hi = np.quantile(luma(plain), [0.1, 0.9])
    assert hi > 4 * lo and hi - lo > 2 * (plain_hi - plain_lo), (lo, hi, plain_lo, plain_hi)  # measured 17x and 2.8x
    # smooth: with the GLB's normals, far fewer brightness steps than the same mesh flat
    smooth_steps, flat_steps = steps(plain, model_mask(plain)), steps(flat, model_mask(flat))
    assert flat_steps > 0.02 and smooth_steps < flat_steps / 5, (smooth_steps, flat_steps)  # measured 0.054 and 0
