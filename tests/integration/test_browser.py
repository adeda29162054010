"""A baked GLB in a real viewer: three.js (tools/node_modules/three, pinned in
tools/package.json) in headless Chromium (Debian's ``chromium``; ``scripts/run`` installs it
when missing and running as root), served from 127.0.0.1 by the test.

Each render is a screenshot of tools/render-glb.html: the model framed on its bounding box,
a directional and an ambient light (or an environment light only, for a material's
roughness and metal), on a magenta background; or, from the same view, each
material drawn in a flat colour of its own, which tells which pixels show which material. The screenshots are kept under
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
from urllib.parse import quote

import numpy as np
import pytest
import trimesh
from conftest import ROOT, chromium, keep_artefact

import texbake
from texbake.output.export import GlbPart, write_glb, write_glb_parts
from texbake.output.images import encode_png_bytes, read_image

TOOLS = ROOT / "tools"
SIZE = 320  # screenshot width and height, pixels
MAGENTA = np.array([1.0, 0.0, 1.0])
IDS = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [1.0, 1.0, 0]])  # render-glb.html's first flat colours (sRGB = linear at 0 and 1)


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


def render(server, glb: Path, name: str, tmp_path: Path, ids: list[str] | None = None, *, environment: bool = False,
           cover: np.ndarray | None = None) -> np.ndarray:
    """``(SIZE, SIZE, 3)`` float32 linear screenshot of ``glb`` in three.js (lit by a
    directional and an ambient light, or ``environment``: by an environment light only);
    kept as an artefact. ``ids``: material names, each drawn flat in its colour of
    :data:`IDS` instead (the same view).

    Headless screenshots have come out blank (all background, or in one CI run one flat
    colour everywhere) now and then, or, once in a CI run, with one primitive of two not
    drawn, or (in a CI run, under the environment light) with the model one flat colour:
    retried up to five times, each in a fresh profile (a chromium that finds its profile in
    use hands the page to the other one and writes nothing), also while over 5 % of the
    pixels ``cover`` ((SIZE, SIZE) bool: where another render of the same view drew the
    model) show the background, and, for ``environment``, while the model's pixels span
    under 0.01 in brightness (a lit model never does: its shading varies over it).
    """
    site, base = server
    shutil.copy(glb, site / glb.name)
    shot = tmp_path / f"{name}.png"
    for attempt in range(5):
        shot.unlink(missing_ok=True)
        subprocess.run(
            [chromium(), "--headless", "--no-sandbox", "--use-gl=swiftshader", "--enable-unsafe-swiftshader",
             "--disable-gpu-sandbox", "--disable-background-networking", "--hide-scrollbars", "--no-first-run",
             f"--user-data-dir={tmp_path / f'chromium-profile-{name}-{attempt}'}", "--virtual-time-budget=20000",
             f"--window-size={SIZE},{SIZE}", f"--screenshot={shot}",
             f"{base}/render.html?glb=/{glb.name}&size={SIZE}" + ("" if ids is None else "&ids=" + quote(",".join(ids)))
             + ("&env=1" if environment else "")],
            capture_output=True, timeout=120, check=False)
        if shot.is_file():
            image = read_image(shot)[..., :3]
            background = np.abs(image - MAGENTA).max(axis=2) < 0.05
            flat = np.ptp(image.reshape(-1, 3), axis=0).max() < 1e-3
            unlit = environment and not background.all() and np.ptp(image[~background] @ np.array([0.2126, 0.7152, 0.0722])) < 0.01
            if not background.all() and not flat and not unlit and (cover is None or background[cover].mean() <= 0.05):
                break
    assert shot.is_file(), f"chromium wrote no screenshot of {name}"
    assert not flat, f"every screenshot of {name} came out one flat colour"
    assert not unlit, f"every screenshot of {name} shows the model one flat colour under the environment light"
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


def test_roughness_and_metal_vary_where_the_material_says_under_an_environment_light(server, tmp_path):
    # A sphere whose material makes the even cells of a checker smooth metal and the odd ones
    # rough paint, against the same bake with one roughness (and no metal) everywhere, both
    # under an environment light only (three's RoomEnvironment). Which pixel shows which
    # cell: a third render of the checker alone as emitted light on black.
    from scipy import ndimage

    sphere = trimesh.creation.icosphere(subdivisions=4)
    cell = {"op": "texture", "texture": {"name": "checker", "box": [0.25, 0.25, 0.25]}, "output": "value"}  # 1 on even cells
    varied = {"nodes": {"cell": cell}, "base_color": [0.5, 0.5, 0.5], "roughness": {"op": "mix", "a": 0.9, "b": 0.05, "mask": "cell"},
              "metallic": "cell"}
    plain = {"base_color": [0.5, 0.5, 0.5], "roughness": 0.5, "metallic": 0.0}
    checker = texbake.bake_mesh(sphere, {"name": "checker", "box": [0.25, 0.25, 0.25], "color_even": [1, 1, 1], "color_odd": [0, 0, 0]},
                                size=256)
    m = checker.mesh
    cells = encode_png_bytes(checker.images["albedo"])
    write_glb(tmp_path / "material-cells.glb", m.vertices, m.faces, m.uv, {"baseColor": cells, "emissive": cells}, normals=m.normals,
              base_factor=(0.0, 0.0, 0.0, 1.0))
    where = render(server, tmp_path / "material-cells.glb", "material-cells", tmp_path, environment=True)
    inside = ndimage.binary_erosion(model_mask(where), iterations=3)
    luma = where @ np.array([0.2126, 0.7152, 0.0722])
    even = ndimage.binary_erosion((luma > 0.5) & inside, iterations=3)  # away from the cells' edges
    odd = ndimage.binary_erosion((luma < 0.2) & inside, iterations=3)
    assert even.sum() > 2000 and odd.sum() > 2000, (even.sum(), odd.sum())
    shots = {}
    for name, material in (("varied", varied), ("plain", plain)):
        result = texbake.bake_mesh(sphere, material=material, size=256)
        result.save(tmp_path / name)
        glb = shutil.copy(tmp_path / name / f"{result.mesh.name}.glb", tmp_path / f"material-{name}.glb")  # its own URL
        shots[name] = render(server, Path(glb), f"material-{name}", tmp_path, environment=True,
                             cover=model_mask(where))  # the whole sphere, as the cells' render drew it

    def detail(image):  # how sharp the shading is: the mean step to a neighbour (a mirror shows the room's edges)
        y = image @ np.array([0.2126, 0.7152, 0.0722])
        return np.hypot(*np.gradient(y))

    for name, image in shots.items():
        d, y = detail(image), image @ np.array([0.2126, 0.7152, 0.0722])
        shots[name] = (abs(y[even].mean() - y[odd].mean()), d[even].mean(), d[odd].mean())
    plain_gap, plain_even, plain_odd = shots["plain"]
    varied_gap, varied_even, varied_odd = shots["varied"]
    # one roughness everywhere: the cells look alike (measured: 0.007 apart in brightness, their
    # detail 0.76x); the material's: the metal cells mirror the room (0.37 apart, 9.9x the rough
    # cells' detail, 11x what the same cells show with one roughness)
    assert plain_gap < 0.03 and 0.5 < plain_even / plain_odd < 2, shots
    assert varied_gap > 0.15 and varied_even > 4 * varied_odd, shots
    assert varied_even > 4 * plain_even, shots


def material_masks(ids: np.ndarray, names: list[str]) -> dict[str, np.ndarray]:
    """Each material's pixels in a render with ``ids`` (``(h, w)`` bool), two pixels in from
    its outline (where antialiasing and the other materials blur into it)."""
    from scipy import ndimage

    return {name: ndimage.binary_erosion(np.abs(ids - IDS[k]).max(axis=2) < 0.05, iterations=2) for k, name in enumerate(names)}


def colour_share(image: np.ndarray, mask: np.ndarray, channel: int) -> np.ndarray:
    """Per pixel of ``mask``: the share of ``channel`` in its colour (1/3 for a grey)."""
    pixels = image[mask]
    return pixels[:, channel] / np.maximum(pixels.sum(axis=1), 1e-6)


def test_every_material_of_a_multi_material_bake_renders_with_its_own_texture(server, tmp_path):
    # A GLB of two materials (texbake.output: a primitive each, its own maps), each given a
    # checker of its own colours: body red, wheels blue. Rendered once as it is and once
    # with each material drawn in a flat colour, which tells which pixels show which. Each
    # material's pixels must carry its own colour and squares (a texture that is not bound
    # shows the material's plain white, lit: grey); the same GLB with the wheels' texture
    # replaced by a plain grey one fails that check on the wheels alone.
    from conftest import two_material_scene

    two_material_scene(tmp_path / "pair.glb")
    red = {"name": "checker", "color_even": [0.8, 0.05, 0.05], "color_odd": [0.15, 0.01, 0.01], "box": [0.1, 0.1, 0.1]}
    blue = {"name": "checker", "color_even": [0.05, 0.05, 0.8], "color_odd": [0.01, 0.01, 0.15], "box": [0.1, 0.1, 0.1]}
    result = texbake.bake_mesh(tmp_path / "pair.glb", "checker", size=256, materials={"body": {"texture": red}, "wheels": {"texture": blue}})
    result.save(tmp_path / "bake")
    names = [s.name for s in result.sets]
    assert sorted(names) == ["body", "wheels"]
    glb = tmp_path / "bake" / "pair.glb"
    masks = material_masks(render(server, glb, "pair-ids", tmp_path, ids=names), names)
    textured = render(server, glb, "pair", tmp_path, cover=np.logical_or.reduce(list(masks.values())))
    channel = {"body": 0, "wheels": 2}  # red, blue
    luma = lambda image, mask: image[mask] @ np.array([0.2126, 0.7152, 0.0722])
    for name, mask in masks.items():
        assert mask.sum() > 1000, (name, mask.sum())  # in view: measured body 6609, wheels 4260 pixels
        share = colour_share(textured, mask, channel[name])
        assert np.median(share) > 0.7, (name, np.median(share))  # its own colour: measured 0.84, 0.85 (a grey: 1/3)
        lo, hi = np.quantile(luma(textured, mask), [0.1, 0.9])
        assert hi > 3 * lo, (name, lo, hi)  # its squares, light and dark: measured 4.4x, 5.1x
    # the control: the wheels' texture a plain grey, as a material whose maps were lost shows
    grey = encode_png_bytes(np.full((8, 8, 3), 0.5, np.float32))
    parts = [GlbPart(s.mesh.vertices, s.mesh.faces, s.mesh.uv, grey if s.name == "wheels" else tmp_path / "bake" / f"{s.name}_albedo.png",
                     s.mesh.normals, material=s.name) for s in result.sets]
    write_glb_parts(tmp_path / "grey-wheels.glb", parts, name="pair")
    control = render(server, tmp_path / "grey-wheels.glb", "grey-wheels", tmp_path)
    assert np.median(colour_share(control, masks["body"], 0)) > 0.7
    assert abs(np.median(colour_share(control, masks["wheels"], 2)) - 1 / 3) < 0.05  # grey: the check above fails on it


def test_every_udim_tile_of_a_bake_renders_textured(server, tmp_path):
    # Four boxes in UDIM tiles 1001-1004: the GLB has a primitive per tile, each with its
    # tile's image (glTF has no UDIM). Each tile's box must show the red checker's squares.
    from conftest import udim_boxes

    udim_boxes(tmp_path / "boxes.obj")
    red = {"name": "checker", "color_even": [0.8, 0.05, 0.05], "color_odd": [0.15, 0.01, 0.01], "box": [0.1, 0.1, 0.1]}
    result = texbake.bake_mesh(tmp_path / "boxes.obj", red, size=128)
    result.save(tmp_path / "bake")
    names = [f"boxes_baked.{s.tile}" for s in result.sets]
    assert [s.tile for s in result.sets] == [1001, 1002, 1003, 1004]
    glb = tmp_path / "bake" / "boxes.glb"
    textured = render(server, glb, "boxes", tmp_path)
    for name, mask in material_masks(render(server, glb, "boxes-ids", tmp_path, ids=names), names).items():
        assert mask.sum() > 1000, (name, mask.sum())  # measured 3287-3696 pixels a box
        assert np.median(colour_share(textured, mask, 0)) > 0.7, name
        lo, hi = np.quantile(textured[mask] @ np.array([0.2126, 0.7152, 0.0722]), [0.1, 0.9])
        assert hi > 3 * lo, (name, lo, hi)  # measured 4.4-5.1x
