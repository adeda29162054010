"""The web page at ``/`` in a real browser: Debian's chromium driven by Playwright (its
``executable_path``: no browser is downloaded), against the real API and its worker
(``texbake serve``), with every request to anywhere but 127.0.0.1 aborted.

A person's round trip: upload bunny.ply, pick a texture and change a parameter (the swatch
changes), bake at a small size (width and height), watch the progress reach 100 %, turn the
model in the viewer, download the zip (named after the mesh and the texture); a bake that
fails clears the result and says why; a bad file shows the API's reason. The same page at
phone width: nothing cut off, the jobs stacked. A screenshot of each step, at laptop
(1366x768) and phone (375x812) width, is kept under pytest's tmp_path and, if
TEXBAKE_ARTEFACTS names a folder, copied there.
"""

import io
import os
import re
import subprocess
import sys
import time
import zipfile
from urllib.parse import quote, urlsplit

import httpx
import numpy as np
import pytest
from conftest import ROOT, chromium, free_port, keep_artefact, start, stop, upload, wait
from playwright.sync_api import expect, sync_playwright

from texbake.output.images import read_image

BACKGROUND = np.array([0x26, 0x2B, 0x33]) / 255  # the viewer's (page.css, app.js), sRGB
LAPTOP, PHONE = (1366, 768), (375, 812)


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium(), args=[
            "--no-sandbox", "--use-gl=swiftshader", "--enable-unsafe-swiftshader", "--disable-gpu-sandbox",
            "--disable-background-networking", "--no-first-run"])
        yield browser
        browser.close()


def serve(tmp_path_factory, extra_env=None, workers="1"):
    data = tmp_path_factory.mktemp("data")
    port = free_port()
    env = {"BAKE_MAX_UPLOAD_BYTES": "2000000", **(extra_env or {})}
    proc = start(["serve", "--port", str(port), "--workers", workers], data, env, port=port)
    return f"http://127.0.0.1:{port}", proc


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    url, proc = serve(tmp_path_factory)
    end = time.monotonic() + 60
    while not httpx.get(f"{url}/readyz", timeout=5).json()["ok"] and time.monotonic() < end:  # the worker has registered
        time.sleep(0.2)
    yield url
    stop(proc)


class Page:
    """A browser page cut off from everything but 127.0.0.1, keeping its requests,
    errors, fields left unworded (the page warns of each) and screenshots."""

    def __init__(self, browser, tmp_path, size=LAPTOP):
        self.context = browser.new_context(viewport={"width": size[0], "height": size[1]}, accept_downloads=True)
        self.page = self.context.new_page()
        self.tmp_path, self.blocked, self.requests, self.errors, self.unworded = tmp_path, [], [], [], []
        self.context.route("**/*", self._route)
        self.page.on("pageerror", lambda error: self.errors.append(str(error)))
        self.page.on("console", self._console)

    def _console(self, message):
        if message.type == "error":
            self.errors.append(message.text)
        elif message.type == "warning" and "no label for" in message.text:
            self.unworded.append(message.text)

    def _route(self, route):
        url = route.request.url
        if urlsplit(url).hostname == "127.0.0.1" or url.startswith(("data:", "blob:")):
            self.requests.append((time.monotonic(), route.request.method, urlsplit(url).path))
            return route.continue_()
        self.blocked.append(url)
        return route.abort()

    def shot(self, name, locator=None):
        path = self.tmp_path / f"page-{name}.png"
        (locator or self.page).screenshot(path=path, animations="disabled", **({} if locator else {"full_page": True}))  # fades finished
        keep_artefact(path)
        return read_image(path)[..., :3]

    def close(self):
        self.context.close()


@pytest.fixture
def page(browser, tmp_path):
    p = Page(browser, tmp_path)
    yield p
    p.close()
    assert not p.blocked, p.blocked  # the page asked for nothing beyond the server
    assert not p.unworded, p.unworded  # every field it showed has a written label
    # 4xx answers are logged by chromium as failed loads; anything else is a bug of the page
    assert not [e for e in p.errors if "the server responded with a status of 4" not in e], p.errors


def swatch(p, name):
    expect(p.page.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
    return p.shot(name, p.page.locator("#swatch"))


def field_error(p, label):
    """The error line beside the control labelled ``label``."""
    return p.page.locator(".field", has=p.page.get_by_label(label, exact=True)).locator(".error").first


def posts(page):
    return sum(1 for _, method, path in page.requests if method == "POST")


def options(p, label):
    return p.get_by_label(label, exact=True).locator("option").all_text_contents()


def test_the_fields_read_as_words(api, page):
    """Every label and option is written for a person (words.js), not a field's name."""
    p = page.page
    p.goto(api + "/")
    swatch(page, "00-labels")
    p.locator("#bake-card summary").click()  # More settings
    for label in ("Image size", "Quality preset", "Shading", "Bump texture", "Image format", "UV layout", "Unwrap method",
                  "Bit depth", "Also write OBJ + MTL", "Samples per texel", "Octave cap (noise textures)"):
        expect(p.get_by_label(label, exact=True)).to_be_visible()
    assert options(p, "Quality preset") == ["Default (1 sample a texel)", "Final (16 samples a texel, slower)"]
    assert options(p, "Bit depth") == ["Format default", "8 bits", "16 bits", "32 bits"]
    expect(p.get_by_label("Bit depth", exact=True)).to_have_value("null")  # the format's own, until chosen
    assert options(p, "Bump texture")[:3] == ["No bump", "Position (RGB = XYZ)", "Checker"]
    assert options(p, "PBR material")[:3] == ["No material (the texture)", "Polished marble", "Oak planks"]  # the built-ins
    expect(p.get_by_label("Also write OBJ + MTL", exact=True)).to_have_attribute("type", "checkbox")
    # no label is a field's name ("Uv", "Obj", "Max Octaves"), no option a bare "none"
    schema = httpx.get(api + "/v1/config", timeout=10).json()["settings_schema"]
    titles = {prop["title"] for prop in schema["properties"].values()} - {"Shading", "Margin"}  # the two already words
    labels = set(p.locator("#bake-card .field > label").all_text_contents())
    assert labels and not labels & titles, labels & titles
    assert "none" not in p.locator("select option").all_text_contents()
    # the pattern's scale: one number or x, y, z in one box, like the size
    checker = swatch(page, "00-labels-checker")
    p.get_by_text("Placement of the pattern", exact=True).click()
    scale = p.get_by_label("Scale", exact=True)
    scale.fill("2, 1,")
    expect(field_error(page, "Scale")).to_have_text('one number, or x, y and z separated by commas, not "2, 1,"')
    expect(p.locator("#swatch-state")).to_have_text("not updated: see the error")
    scale.fill("2, 1, 1")
    stretched = swatch(page, "00-labels-checker-scale-2-1-1")
    assert np.abs(stretched - checker).mean() > 0.02, np.abs(stretched - checker).mean()
    expect(field_error(page, "Scale")).to_be_empty()
    for name in ("marble", "flame", "wood"):  # the texture's fields too (the fixture: none left unworded)
        p.select_option("#texture", name)
        swatch(page, f"00-labels-{name}")
    page.shot("00-labels-laptop")


def tune_the_texture(page):
    """Marble, its frequency changed, its colours and back: the swatch follows."""
    p = page.page
    p.select_option("#texture", "marble")
    before = swatch(page, "02-swatch-marble")
    p.get_by_label("Stripe frequency", exact=True).fill("-1")  # the API's reason beside the field
    expect(field_error(page, "Stripe frequency")).to_contain_text("expected a number above 0", timeout=10000)
    p.get_by_label("Stripe frequency", exact=True).fill("40")
    after = swatch(page, "03-swatch-frequency-40")
    assert np.abs(after - before).mean() > 0.02, np.abs(after - before).mean()  # measured 0.14
    expect(field_error(page, "Stripe frequency")).to_be_empty()
    for knot in range(1, 6):  # the colour map, every knot red: a red marble
        p.get_by_label(f"Colour map: colour of knot {knot}").fill("#ff0000")
    red = swatch(page, "04-swatch-red-colour-map")
    disk = red[96:160, 96:160]
    assert disk[..., 0].mean() > 0.5 > disk[..., 1].mean() * 4, disk.mean(axis=(0, 1))
    p.get_by_role("button", name="Reset the parameters").click()
    p.get_by_label("Stripe frequency", exact=True).fill("40")
    assert np.abs(swatch(page, "05-swatch-reset") - after).mean() < 0.01  # the same swatch as before the colours


def bake_at_width_and_height(page, meshes):
    """bunny.ply at 96x64, after two sizes the page cannot read (said beside the field,
    nothing sent): progress up to 100 %, polled without hammering."""
    p = page.page
    # the mesh and the settings; a size the page cannot read is said beside it, nothing sent
    p.set_input_files("#mesh", meshes / "bunny.ply")
    expect(p.locator("#mesh-info")).to_contain_text("bunny.ply")
    size = p.get_by_label("Image size", exact=True)
    sent = posts(page)
    for typed, said in (("96x", 'width and height as 2048x1024, not "96x"'), ("96x0", "0 is not allowed (1 ≤ each")):
        size.fill(typed)
        p.get_by_role("button", name="Bake", exact=True).click()
        expect(field_error(page, "Image size")).to_contain_text(said)
        expect(size).to_be_focused()
        expect(size).to_have_attribute("aria-invalid", "true")
    assert posts(page) == sent
    size.fill("96x64")  # width and height
    p.get_by_label("Shading", exact=True).select_option(label="Ambient + diffuse: a lit map too")
    page.shot("06-ready-to-bake")
    p.evaluate("""() => {  // every status the page shows, as it shows them
        window.seen = [];
        new MutationObserver(() => window.seen.push(document.querySelector("#status").textContent + " " + document.querySelector("#percent").textContent))
            .observe(document.querySelector(".progress-row"), { subtree: true, childList: true, characterData: true });
    }""")
    began = time.monotonic()
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#percent")).to_have_text("100 %", timeout=60000)
    expect(field_error(page, "Image size")).to_be_empty()
    seen = p.evaluate("() => window.seen")
    assert any(s.startswith("Uploading bunny.ply") for s in seen), seen  # the upload's own progress first
    expect(p.locator("#status")).to_contain_text("Done: bunny.ply")
    seconds = time.monotonic() - began
    polls = [t for t, method, path in page.requests if t >= began and method == "GET" and path.count("/") == 3 and path.startswith("/v1/jobs/")]
    assert len(polls) <= seconds / 0.45 + 2, (len(polls), seconds)


def look_at_the_result(page):
    """The model in the viewer, lit and unlit, turned; the maps and the figures; the zip."""
    p = page.page
    # the result: the model in the viewer, lit and unlit, the maps, the figures
    viewer = p.locator("#viewer")
    expect(p.locator("#viewer[data-ready='1']")).to_be_attached(timeout=20000)
    lit = page.shot("07-viewer-lit", viewer)
    h, w = lit.shape[:2]
    centre = lit[h * 2 // 5 : h * 3 // 5, w * 2 // 5 : w * 3 // 5]
    assert (np.abs(centre - BACKGROUND).max(axis=2) > 0.05).mean() > 0.9  # the bunny, not the background
    p.get_by_label("Lit", exact=True).uncheck()
    unlit = page.shot("08-viewer-unlit", viewer)
    assert np.abs(unlit - lit).mean() > 0.01
    p.get_by_role("button", name="turn the model left").click()
    turned = page.shot("09-viewer-turned", viewer)
    assert np.abs(turned - unlit).mean() > 0.01
    expect(p.locator("#figures")).to_contain_text("16,295 faces")
    expect(p.locator("#figures")).to_contain_text("96 × 64 texels")
    images = p.locator("#images img")
    expect(images).to_have_count(3)  # albedo, lit, coverage
    for i in range(3):
        images.nth(i).scroll_into_view_if_needed()
        expect(images.nth(i)).to_have_js_property("complete", True)
        assert images.nth(i).evaluate("img => [img.naturalWidth, img.naturalHeight]") == [96, 64]
    page.shot("10-result")

    # the download of every file in one zip, named after the mesh and the texture
    with p.expect_download() as download:
        p.get_by_role("link", name="All files (result.zip)").click()
    assert download.value.suggested_filename == "bunny-marble.zip"
    names = set(zipfile.ZipFile(io.BytesIO(download.value.path().read_bytes())).namelist())
    assert {"albedo.png", "lit.png", "coverage.png", "bunny.glb", "report.json"} <= names, names
    expect(p.locator("#jobs tbody tr").first).to_contain_text("done")


def keep_uvs_then_fail(page, meshes):
    """The Duck's own UVs kept (their overlap warned of), then a mesh with none: that bake
    fails, and the Duck's result gives way to the reason."""
    p = page.page
    # a GLB whose own UVs overlap, kept: the report's warning is shown with the result
    p.set_input_files("#mesh", meshes / "Duck.glb")
    p.get_by_label("Image size", exact=True).fill("64, 32")  # width and height, as a list
    p.locator("#bake-card summary").click()  # More settings
    p.get_by_label("UV layout", exact=True).select_option(label="Keep the mesh's UVs")
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Done: Duck.glb", timeout=60000)
    expect(p.locator("#warnings li")).to_have_count(1, timeout=20000)
    expect(p.locator("#warnings")).to_contain_text("overlap")
    expect(p.locator("#figures")).to_contain_text("64 × 32 texels")
    expect(p.locator("#viewer[data-ready='1']")).to_be_attached(timeout=20000)
    page.shot("11-warnings")

    # a bake that fails: the Duck's result is gone, the reason is in its place
    p.set_input_files("#mesh", meshes / "bunny.ply")  # no UVs to keep
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Failed: bunny.ply", timeout=60000)
    expect(p.locator("#result-error")).to_have_text("The bake of bunny.ply failed: uv='keep' but the mesh has no UVs. Change the settings and bake again.")
    expect(p.locator("#result-title")).to_have_text("4. Result: bunny.ply failed")
    for gone in ("#viewer", "#images", "#downloads", "#figures"):
        expect(p.locator(gone)).to_be_hidden()
    expect(p.locator("#images img, #downloads li, #warnings li, #viewer[data-ready='1']")).to_have_count(0)
    expect(p.locator("#jobs tbody tr").first).to_contain_text("uv='keep' but the mesh has no UVs")
    page.shot("12-failed")
    p.get_by_label("UV layout", exact=True).select_option(label="Automatic")


def refuse_bad_files(page):
    """A file that is no mesh (the API's reason), and one too large (said before anything
    is sent): beside the mesh field."""
    p = page.page
    # dropped, as a person would
    p.evaluate("""() => {
        const files = new DataTransfer();
        files.items.add(new File([new Uint8Array([0x50, 0x4b, 0x03, 0x04, 1, 2, 3, 4])], "bad.obj"));
        document.querySelector("#drop").dispatchEvent(new DragEvent("drop", { dataTransfer: files, bubbles: true, cancelable: true }));
    }""")
    expect(p.locator("#mesh-info")).to_contain_text("bad.obj")
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#mesh-error")).to_contain_text("zip archive", timeout=20000)
    page.shot("13-bad-file")
    # too large for the server: said before anything is sent
    sent = posts(page)
    p.set_input_files("#mesh", files=[{"name": "big.obj", "mimeType": "text/plain", "buffer": b"v 0 0 0\n" * 300_000}])
    expect(p.locator("#mesh-error")).to_contain_text("larger than this server's limit of 2.00 MB")
    p.get_by_role("button", name="Bake", exact=True).click()
    assert posts(page) == sent


def cancel_and_retry(page, meshes):
    """A long bake cancelled, retried from the list, cancelled again."""
    p = page.page
    p.set_input_files("#mesh", meshes / "bunny.ply")
    p.get_by_label("Image size", exact=True).fill("4096")
    p.get_by_label("Quality preset", exact=True).select_option(label="Final (16 samples a texel, slower)")
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Baking", timeout=30000)
    p.get_by_role("button", name="Cancel", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Cancelled", timeout=10000)
    p.get_by_role("button", name="bake bunny.ply again").first.click()  # the newest job; the failed one is below
    expect(p.locator("#status")).to_contain_text(re.compile("(Queued|Baking): bunny.ply"), timeout=10000)
    expect(p.locator("#cancel")).to_be_enabled(timeout=10000)
    p.get_by_role("button", name="Cancel", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Cancelled", timeout=10000)
    expect(p.locator("#result")).to_be_hidden()  # nothing of the failed bake's left either
    expect(p.locator("#jobs tbody tr")).to_have_count(5)
    page.shot("14-cancelled-and-retried")


def test_a_round_trip_on_the_page(api, page, meshes):
    p = page.page
    p.goto(api + "/")
    swatch(page, "01-start")
    tune_the_texture(page)
    bake_at_width_and_height(page, meshes)
    look_at_the_result(page)
    keep_uvs_then_fail(page, meshes)
    refuse_bad_files(page)
    cancel_and_retry(page, meshes)
    # /docs works offline too
    p.goto(api + "/docs")
    expect(p.locator(".swagger-ui .opblock").first).to_be_visible(timeout=20000)
    page.shot("15-docs")


def test_the_material_editor(api, page, meshes):
    """A new material of two layers built on the page: a swatch per channel (each its own),
    the PBR-lit sphere (not blank; its metal shows), a node's error beside its channel, and a
    bake with it whose report names the material."""
    p = page.page
    p.goto(api + "/")
    swatch(page, "20-material-start")
    p.get_by_label("PBR material", exact=True).select_option(label="A new material")
    channel = lambda name: p.locator(f"#material-card fieldset.channel[data-channel='{name}']")
    p.get_by_label("Material name", exact=True).fill("two_layers")
    # the base colour: a red base, blue over it through the default checker mask
    base = channel("base_color")
    base.get_by_label("Base colour", exact=True).select_option(label="Layers through masks")
    base.get_by_label("Base: value", exact=True).fill("#cc2211")
    base.get_by_label("Layer 1: value", exact=True).fill("#1133cc")
    # the roughness: 0.1, and 0.9 over it through a noise mask
    rough = channel("roughness")
    rough.get_by_label("Roughness", exact=True).select_option(label="Layers through masks")
    rough.get_by_label("Base: value", exact=True).fill("0.1")
    rough.get_by_label("Layer 1: value", exact=True).fill("0.9")
    rough.get_by_label("Layer 1 mask: texture", exact=True).select_option(label="Noise")
    metal = channel("metallic")
    metal.get_by_label("Metallic", exact=True).select_option(label="A constant")
    metal.get_by_label("Metallic: value", exact=True).fill("1")

    def swatches(name):
        shots = {}
        for c in ("base_color", "roughness", "metallic"):
            expect(channel(c).locator("img.channel-swatch[data-ready='1']")).to_be_attached(timeout=30000)
            shots[c] = page.shot(f"{name}-{c}", channel(c).locator("img.channel-swatch"))
        expect(p.locator("#material-sphere[data-ready='1']")).to_be_attached(timeout=30000)
        return shots, page.shot(f"{name}-sphere", p.locator("#material-sphere"))

    shots, metallic_sphere = swatches("21-material")
    unnamed = p.evaluate("""() => [...document.querySelectorAll("#material-card input, #material-card select, #material-card button")]
        .filter((c) => !c.labels?.length && !c.getAttribute("aria-label") && !c.textContent.trim() && c.getAttribute("aria-hidden") !== "true")
        .map((c) => c.outerHTML)""")
    assert not unnamed, unnamed  # every control of the editor has a name a screen reader says
    disk = {c: shot[40:88, 40:88] for c, shot in shots.items()}  # the middle of each 128-pixel swatch
    # both layers show: red and blue in the base colour, low and high in the roughness
    red, blue = (disk["base_color"][..., 0] > 0.5).mean(), (disk["base_color"][..., 2] > 0.5).mean()
    assert red > 0.2 and blue > 0.2, (red, blue)
    assert np.ptp(disk["roughness"][..., 0]) > 0.4 and np.ptp(disk["metallic"]) < 0.02, (np.ptp(disk["roughness"]), np.ptp(disk["metallic"]))
    for a, b in (("base_color", "roughness"), ("base_color", "metallic"), ("roughness", "metallic")):  # each channel its own
        assert np.abs(disk[a] - disk[b]).mean() > 0.05, (a, b)
    # the lit sphere: not the background, and not flat
    h, w = metallic_sphere.shape[:2]
    middle = metallic_sphere[h // 4 : h * 3 // 4, w // 4 : w * 3 // 4]
    assert (np.abs(middle - BACKGROUND).max(axis=2) > 0.05).mean() > 0.95 and middle.std() > 0.03, middle.std()
    # metal 0: the same sphere, lit otherwise (a dielectric takes its base colour, a metal the environment's tint by it)
    metal.get_by_label("Metallic: value", exact=True).fill("0")
    _, plastic_sphere = swatches("22-material-metal-0")
    assert np.abs(plastic_sphere - metallic_sphere).mean() > 0.02, np.abs(plastic_sphere - metallic_sphere).mean()

    # a node's error from the server, beside its channel: the roughness's mask of marble at a bad frequency
    rough.get_by_label("Layer 1 mask: texture", exact=True).select_option(label="Marble")
    rough.get_by_text("Layer 1 mask: texture: its parameters", exact=True).click()
    rough.get_by_label("Stripe frequency", exact=True).fill("-1")
    expect(rough.locator(".channel-edit > .error")).to_contain_text("node 'roughness.mask': texture: frequency: expected a number above 0",
                                                                      timeout=20000)
    expect(p.locator("#material-state")).to_have_text("not updated: see the error")
    page.shot("23-material-error")
    # baked so, the bake's own 422 says the same beside the channel
    p.set_input_files("#mesh", meshes / "bunny.ply")
    p.get_by_label("Image size", exact=True).fill("64")
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#status")).to_have_text("Not sent: see the error above", timeout=20000)
    expect(rough.locator(".channel-edit > .error")).to_have_text(
        "node 'roughness.mask': texture: frequency: expected a number above 0 and at most 1000000, got -1")
    rough.get_by_label("Stripe frequency", exact=True).fill("8")
    expect(rough.locator(".channel-edit > .error")).to_be_empty(timeout=20000)
    swatches("24-material-fixed")

    # a bake with it: the material's maps, and its name in the report
    expect(p.locator("#maps")).to_contain_text("the material's base colour")
    p.get_by_role("button", name="Bake", exact=True).click()
    job, report = _baked(p, page, api, "two_layers", "25-material-baked", timeout=90000)
    assert report["material"]["name"] == "two_layers" and {"base_color", "roughness", "metallic"} <= set(report["material"]["maps"]), report["material"]
    assert job["settings"]["material"]["roughness"]["op"] == "mix", job["settings"]["material"]


def test_a_built_in_material_in_the_editor(api, page):
    """A built-in loaded into the editor: a channel mixed through a named node is layers with
    that node as its mask, one the editor has no form for is its JSON; every channel it gives
    swatched; an edit to a layer changes its swatch; JSON that does not read is said beside its
    channel without asking the server."""
    p = page.page
    p.goto(api + "/")
    swatch(page, "30-built-in-start")
    p.get_by_label("PBR material", exact=True).select_option(label="Glazed ceramic checker")
    channel = lambda name: p.locator(f"#material-card fieldset.channel[data-channel='{name}']")
    rough, height = channel("roughness"), channel("height")
    expect(rough.get_by_label("Roughness", exact=True)).to_have_value("layers")  # mix(0.03, 0.1, "wave")
    expect(rough.get_by_label("Layer 1 mask", exact=True)).to_have_value("node")
    expect(rough.get_by_label("Layer 1 mask: node", exact=True)).to_have_value("wave")
    expect(height.get_by_label("Height", exact=True)).to_have_value("json")  # an add of two multiplies
    for c in ("base_color", "roughness", "metallic", "height"):
        expect(channel(c).locator("img.channel-swatch[data-ready='1']")).to_be_attached(timeout=30000)
    expect(channel("emissive").locator("img.channel-swatch")).to_have_attribute("data-ready", "none")  # not given: no swatch
    expect(p.locator("#material-sphere[data-ready='1']")).to_be_attached(timeout=30000)
    glossy = page.shot("31-built-in-roughness", rough.locator("img.channel-swatch"))
    page.shot("31-built-in-sphere", p.locator("#material-sphere"))
    rough.get_by_label("Layer 1: value", exact=True).fill("0.9")
    expect(rough.locator("img.channel-swatch[data-ready='1']")).to_be_attached(timeout=30000)
    rougher = page.shot("32-built-in-roughness-0.9", rough.locator("img.channel-swatch"))
    assert rougher[40:88, 40:88].mean() > glossy[40:88, 40:88].mean() + 0.1
    # JSON that does not read: said beside the channel, nothing sent
    sent = posts(page)
    height.get_by_label("Height: expression", exact=True).fill('{"op": "add",')
    expect(height.locator(".channel-edit > .error")).to_contain_text("expression: not JSON", timeout=10000)
    expect(p.locator("#material-state")).to_have_text("not updated: see the error")
    assert posts(page) == sent
    page.shot("33-built-in-bad-json")


MARBLE_MTLX = ROOT / "tests" / "data" / "mtlx" / "standard_surface_marble_solid.mtlx"  # MaterialX's own example
WOOD_MTLX = """<?xml version="1.0"?>
<materialx version="1.39">
  <image name="wood_image" type="color3"><input name="file" type="filename" value="wood.png"/></image>
  <standard_surface name="SR" type="surfaceshader"><input name="base_color" type="color3" nodename="wood_image"/></standard_surface>
  <surfacematerial name="M" type="material"><input name="surfaceshader" type="surfaceshader" nodename="SR"/></surfacematerial>
</materialx>
"""


def test_a_materialx_document_in_the_editor(api, page, meshes, tmp_path):
    """A .mtlx loaded into the material editor: one that cannot be baked is said beside the
    field (its node and category), the editor left as it was; MaterialX's marble becomes the
    editor's material (its base colour the document's graph, its roughness a constant, its
    warning listed), its base colour's swatch shows the veins, the lit sphere renders, and a
    bake with it sends the document's material and names it in the result."""
    p = page.page
    p.goto(api + "/")
    swatch(page, "40-mtlx-start")
    expect(p.get_by_label("Or load a MaterialX document (.mtlx)", exact=True)).to_have_attribute("type", "file")
    (tmp_path / "wood.mtlx").write_text(WOOD_MTLX)
    p.set_input_files("#mtlx", tmp_path / "wood.mtlx")
    expect(p.locator("#mtlx-error")).to_contain_text("wood.mtlx: node 'wood_image': image: an image node reads a file", timeout=20000)
    expect(p.get_by_label("PBR material", exact=True)).to_have_value("")
    page.shot("41-mtlx-unsupported")

    p.set_input_files("#mtlx", MARBLE_MTLX)
    material = p.get_by_label("PBR material", exact=True)
    expect(material).to_have_value("mtlx", timeout=20000)
    assert material.locator("option:checked").text_content() == f"Marble_3D (from {MARBLE_MTLX.name})"
    expect(p.locator("#mtlx-error")).to_be_empty()
    expect(p.locator("#mtlx-hint")).to_have_text(f"{MARBLE_MTLX.name}: the material Marble_3D, its standard_surface SR_marble1.")
    expect(p.locator("#mtlx-warnings li")).to_have_count(1)
    expect(p.locator("#mtlx-warnings")).to_contain_text("subsurface, subsurface_color")
    expect(p.locator("#material-about")).to_contain_text(f"MaterialX standard_surface 'SR_marble1' from {MARBLE_MTLX.name}")
    expect(p.get_by_label("Material name", exact=True)).to_have_value("Marble_3D")
    channel = lambda name: p.locator(f"#material-card fieldset.channel[data-channel='{name}']")
    base, rough = channel("base_color"), channel("roughness")
    expect(base.get_by_label("Base colour", exact=True)).to_have_value("mtlx")
    expect(base).to_contain_text("From the document: its shader's base_color × base, a graph evaluated at each point of the mesh.")
    expect(rough.get_by_label("Roughness", exact=True)).to_have_value("constant")
    expect(rough.get_by_label("Roughness: value", exact=True)).to_have_value("0.1")  # MaterialX's float32, shown as written
    expect(channel("metallic").get_by_label("Metallic", exact=True)).to_have_value("none")
    for c in ("base_color", "roughness"):
        expect(channel(c).locator("img.channel-swatch[data-ready='1']")).to_be_attached(timeout=30000)
    veins = page.shot("42-mtlx-base-colour", base.locator("img.channel-swatch"))[40:88, 40:88]
    assert np.ptp(veins.reshape(-1, 3), axis=0).max() > 0.2, np.ptp(veins.reshape(-1, 3), axis=0)  # the marble, not one colour
    expect(p.locator("#material-sphere[data-ready='1']")).to_be_attached(timeout=30000)
    lit = page.shot("43-mtlx-sphere", p.locator("#material-sphere"))
    h, w = lit.shape[:2]
    middle = lit[h // 4 : h * 3 // 4, w // 4 : w * 3 // 4]
    assert (np.abs(middle - BACKGROUND).max(axis=2) > 0.05).mean() > 0.95 and middle.std() > 0.03, middle.std()

    # the bake: the document's material sent as the bake's material, named in the result
    p.set_input_files("#mesh", meshes / "bunny.ply")
    p.get_by_label("Image size", exact=True).fill("64")
    with p.expect_request(lambda r: r.method == "POST" and urlsplit(r.url).path == "/v1/jobs") as request:
        p.get_by_role("button", name="Bake", exact=True).click()
    sent = sent_settings(request.value)["material"]
    assert sent["base_color"]["op"] == "mtlx" and sent["base_color"]["path"] == MARBLE_MTLX.name, sent["base_color"].keys()
    assert sent["base_color"]["document"] == MARBLE_MTLX.read_text()
    job, report = _baked(p, page, api, "Marble_3D", "44-mtlx-baked", timeout=120000)
    assert report["material"]["name"] == "Marble_3D" and "base_color" in report["material"]["maps"], report["material"]


def test_the_page_at_phone_width(api, browser, tmp_path, meshes):
    # two jobs for the list: one done under a long name (not ASCII), one failed with its reason
    long_name = "suzanne-с-длинным-именем-из-сканера-2024-05-17.ply"
    done = wait(api, upload(api, meshes / "suzanne.ply", {"texture": "wood", "size": 32}, name=long_name).json()["id"])
    failed = wait(api, upload(api, meshes / "bunny.ply", {"texture": "wood", "size": 32, "uv": "keep"}).json()["id"])
    assert (done["state"], failed["state"]) == ("done", "failed"), (done, failed)
    # the zip is named after them: exactly as filename*, in ASCII as filename
    disposition = httpx.get(f"{api}/v1/jobs/{done['id']}/result.zip", timeout=30).headers["Content-Disposition"]
    assert disposition == ("attachment; filename=\"suzanne-_-_______-______-__-_______-2024-05-17-wood.zip\"; filename*=UTF-8''"
                           + quote("suzanne-с-длинным-именем-из-сканера-2024-05-17-wood.zip")), disposition

    page = Page(browser, tmp_path, size=PHONE)
    try:
        p = page.page
        p.goto(api + "/")
        expect(p.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        expect(p.locator("#jobs tbody")).to_contain_text(long_name, timeout=10000)
        # nothing wider than the window: readable without scrolling sideways
        assert p.evaluate("() => document.documentElement.scrollWidth") <= PHONE[0]
        # the jobs stacked: each cell inside the card, said with its column's name
        cells = p.evaluate("""() => [...document.querySelectorAll("#jobs tbody td")].map((td) => {
            const box = td.getBoundingClientRect(), card = document.querySelector("#jobs-card").getBoundingClientRect();
            return [td.dataset.label, getComputedStyle(td, "::before").content, box.left >= card.left && box.right <= card.right, td.scrollWidth <= td.clientWidth];
        })""")
        assert cells and all(inside and fits and before == f'"{label}"' for label, before, inside, fits in cells), cells
        table = p.locator("#jobs-card .table")
        assert table.evaluate("t => t.scrollWidth <= t.clientWidth"), "the jobs table scrolls sideways"
        expect(p.locator("#jobs thead")).not_to_be_in_viewport()  # the header only for screen readers
        failed_row = p.locator("#jobs tbody tr").first  # the newest job
        expect(failed_row.locator("[data-label='State']")).to_contain_text("failed")
        expect(failed_row.locator(".reason")).to_have_text("uv='keep' but the mesh has no UVs")
        expect(failed_row.locator(".reason")).to_be_visible()
        p.locator("#jobs-card").scroll_into_view_if_needed()
        page.shot("16-phone-jobs", p.locator("#jobs-card"))
        p.keyboard.press("Tab")  # the controls are reachable by keyboard, in order
        assert p.evaluate("() => document.activeElement.textContent") == "API documentation"
        p.keyboard.press("Tab")
        assert p.evaluate("() => document.activeElement.id") == "mesh"
        # every control has a name a screen reader says (a label, or aria-label)
        unnamed = p.evaluate("""() => [...document.querySelectorAll("input, select, button")]
            .filter((c) => !c.labels?.length && !c.getAttribute("aria-label") && !c.textContent.trim() && c.getAttribute("aria-hidden") !== "true")
            .map((c) => c.outerHTML)""")
        assert not unnamed, unnamed
        # every texture's form is made and swatched
        names = p.locator("#texture option").all_text_contents()
        assert len(names) == 8, names
        for name in names:
            p.select_option("#texture", label=name)
            expect(p.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        # an animated texture: its frames can be set, and the page says what the bake writes
        p.select_option("#texture", "checker")
        frames = p.get_by_label("Animation frames (times)", exact=True)
        expect(frames).to_be_hidden()
        p.select_option("#texture", "flame")
        expect(frames).to_be_visible()
        frames.fill("0, 0.5, 1")
        expect(p.locator("#maps")).to_contain_text("an albedo map per frame and a flipbook")
        expect(p.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        assert p.evaluate("() => document.documentElement.scrollWidth") <= PHONE[0]  # the flame's form too
        page.shot("17-phone")
    finally:
        page.close()
    assert not page.blocked and not page.errors and not page.unworded, (page.blocked, page.errors, page.unworded)


def test_with_api_keys_the_page_asks_for_the_key(browser, tmp_path, tmp_path_factory, meshes):
    url, proc = serve(tmp_path_factory, {"BAKE_API_KEYS": '["sesame"]'})
    page = Page(browser, tmp_path)
    try:
        p = page.page
        p.goto(url + "/")
        expect(p.locator("#key-form")).to_be_visible()
        expect(p.locator("#key-error")).to_contain_text("missing or unknown API key", timeout=10000)
        p.get_by_label("API key").fill("wrong")
        p.get_by_role("button", name="Use this key").click()
        expect(p.locator("#key-error")).to_contain_text("missing or unknown API key", timeout=10000)
        page.shot("18-key-asked")
        p.get_by_label("API key").fill("sesame")
        p.get_by_role("button", name="Use this key").click()
        expect(p.locator("#jobs tbody")).to_contain_text("No jobs yet", timeout=10000)
        expect(p.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        expect(p.locator("#key-error")).to_be_empty()
        # kept for this tab only
        assert p.evaluate("() => [sessionStorage.getItem('texbake.key'), localStorage.length]") == ["sesame", 0]
        # a bake with the key: the maps, the model and the downloads come through it too
        p.set_input_files("#mesh", meshes / "suzanne.ply")
        p.get_by_label("Image size", exact=True).fill("32")
        p.get_by_role("button", name="Bake", exact=True).click()
        expect(p.locator("#viewer[data-ready='1']")).to_be_attached(timeout=60000)
        image = p.locator("#images img").first
        image.scroll_into_view_if_needed()
        expect(image).to_have_js_property("naturalWidth", 32)
        with p.expect_download() as download:
            p.get_by_role("link", name="report.json").click()
        assert b'"suzanne"' in download.value.path().read_bytes()
        with p.expect_download() as download:  # through fetch, named as the server names it
            p.get_by_role("link", name="All files (result.zip)").click()
        assert download.value.suggested_filename == "suzanne-checker.zip"
        assert "suzanne.glb" in zipfile.ZipFile(io.BytesIO(download.value.path().read_bytes())).namelist()
        expect(p.locator("#jobs tbody tr")).to_have_count(1)  # the key's own
        page.shot("19-key-given")
    finally:
        page.close()
        stop(proc)
    assert not page.blocked, page.blocked


def test_the_vendored_three_js_is_the_pinned_one():
    """service/static/vendor/three holds tools/node_modules/three's files (pinned by
    tools/package.json), every module the page imports: ``scripts/vendor --check``."""
    if not (ROOT / "tools" / "node_modules" / "three" / "package.json").is_file():
        message = "three.js is not set up: run `npm ci` in tools/ (scripts/run does it)"
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(message)
        pytest.skip(message)
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "vendor"), "--check"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr


def test_a_mesh_with_its_files_on_the_page(api, page, meshes):
    """The upload field takes several files: an OBJ chosen with its MTL and image is sent
    as the mesh and its files, and bakes; a glTF without one of its buffers gets the API's
    reason beside the field; a file that is neither a mesh nor one a mesh refers to is
    said before anything is sent."""
    import trimesh

    p = page.page
    p.goto(api + "/")
    swatch(page, "17-files")
    sent = posts(page)
    p.set_input_files("#mesh", [{"name": "capsule.obj", "mimeType": "text/plain", "buffer": (meshes / "capsule.obj").read_bytes()},
                                {"name": "notes.txt", "mimeType": "text/plain", "buffer": b"x"}])
    expect(p.locator("#mesh-error")).to_contain_text("notes.txt is not a mesh file this server takes (.obj")
    p.get_by_role("button", name="Bake", exact=True).click()
    assert posts(page) == sent
    p.set_input_files("#mesh", [meshes / "capsule.mtl", meshes / "capsule.obj", meshes / "capsule0.jpg"])
    expect(p.locator("#mesh-info")).to_contain_text("capsule.obj with capsule.mtl, capsule0.jpg")
    expect(p.locator("#mesh-error")).to_be_empty()
    p.get_by_label("Image size", exact=True).fill("64")
    with p.expect_request(lambda r: r.method == "POST" and r.url.endswith("/v1/jobs")) as request:
        p.get_by_role("button", name="Bake", exact=True).click()
    body = request.value.post_data_buffer
    assert all(f'name="{field}"; filename="{name}"'.encode() in body
               for field, name in (("mesh", "capsule.obj"), ("files", "capsule.mtl"), ("files", "capsule0.jpg"))), body[:2000]
    expect(p.locator("#status")).to_contain_text("Done: capsule.obj", timeout=60000)
    newest = httpx.get(f"{api}/v1/jobs", params={"limit": 1}, timeout=10).json()["jobs"][0]
    assert (newest["mesh"], newest["state"]) == ("capsule.obj", "done"), newest
    page.shot("18-mesh-with-files")
    # a glTF whose first buffer is left out: the API names it beside the field
    parts = trimesh.exchange.gltf.export_gltf(trimesh.creation.icosphere(subdivisions=2))
    buffers = sorted(name for name in parts if name.endswith(".bin"))
    p.set_input_files("#mesh", [{"name": name, "mimeType": "application/octet-stream", "buffer": parts[name]}
                                for name in ["model.gltf", *buffers[1:]]])
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#mesh-error")).to_have_text(f"model.gltf: refers to {buffers[0]!r}, which was not sent: "
                                                  "send it as a 'files' part beside the mesh", timeout=20000)


def sent_settings(request) -> dict:
    """The ``settings`` form field of a multipart POST the page sent, as JSON."""
    import json

    found = re.search(rb'name="settings"\r\n\r\n(.*?)\r\n--', request.post_data_buffer, re.S)
    assert found, request.post_data_buffer[-600:]
    return json.loads(found.group(1))


def test_two_materials_given_two_textures_on_the_page_bake_as_such(api, page, tmp_path):
    """A GLB of two materials: the page lists them (read by the server's loader), a person
    gives each its own texture, the bake makes a texture set each with that texture, the
    result lists the sets and the viewer shows both materials."""
    from conftest import two_material_scene

    from texbake.mesh import load_mesh

    two_material_scene(tmp_path / "pair.glb")
    order = load_mesh(tmp_path / "pair.glb").material_names
    p = page.page
    p.goto(api + "/")
    swatch(page, "20-materials")
    p.set_input_files("#mesh", tmp_path / "pair.glb")
    expect(p.locator("#materials-list select")).to_have_count(2, timeout=30000)
    assert p.locator("#materials-list label").all_text_contents() == order  # in the order of their texture sets
    expect(p.locator("#materials-list")).to_contain_text("12 faces, its own UVs")
    expect(p.locator("#materials-list")).to_contain_text("640 faces, no UVs")
    p.get_by_label("body", exact=True).select_option(label="Wood")
    p.get_by_label("wheels", exact=True).select_option(label="Marble")
    p.get_by_label("Image size", exact=True).fill("64")
    page.shot("21-materials-chosen")
    with p.expect_request(lambda r: r.method == "POST" and r.url.endswith("/v1/jobs")) as request:
        p.get_by_role("button", name="Bake", exact=True).click()
    assert sent_settings(request.value)["materials"] == {"body": {"texture": "wood"}, "wheels": {"texture": "marble"}}
    expect(p.locator("#status")).to_contain_text("Done: pair.glb", timeout=60000)
    job = httpx.get(f"{api}/v1/jobs", params={"limit": 1}, timeout=10).json()["jobs"][0]
    assert {s["name"]: s["texture"] for s in job["sets"]} == {"body": "wood", "wheels": "marble"}, job["sets"]
    assert {f"{m}_albedo.png" for m in order} <= set(job["files"])
    expect(p.locator("#sets li")).to_have_count(2)
    expect(p.locator("#sets li[data-set='body']")).to_contain_text("body: Wood, 64 × 64 texels")
    expect(p.locator("#sets li[data-set='wheels']")).to_contain_text("wheels: Marble, 64 × 64 texels")
    expect(p.locator("#viewer[data-ready='1']")).to_have_attribute("data-materials", "body,wheels", timeout=20000)
    expect(p.locator("#images img")).to_have_count(4)  # each set's albedo and coverage
    page.shot("22-materials-result")
    # one texture set for the whole mesh: the materials take the bake's texture
    p.locator("#bake-card summary").click()  # More settings
    p.get_by_label("Texture sets", exact=True).select_option(label="One for the whole mesh")
    expect(p.get_by_label("body", exact=True)).to_be_disabled()
    with p.expect_request(lambda r: r.method == "POST" and r.url.endswith("/v1/jobs")) as request:
        p.get_by_role("button", name="Bake", exact=True).click()
    settings = sent_settings(request.value)
    assert settings["texture_set"] == "single" and "materials" not in settings, settings
    expect(p.locator("#status")).to_contain_text("Done: pair.glb", timeout=60000)
    expect(p.locator("#sets li")).to_have_count(1)
    expect(p.locator("#sets li")).to_contain_text("pair (materials ")


def _baked(p, page, api: str, figure: str, shot: str, *, timeout: int) -> tuple[dict, dict]:
    """Wait for the page's bake of bunny.ply to be done, ``figure`` among its figures and
    the viewer ready; keep the shot ``shot``; the latest job and its report."""
    expect(p.locator("#status")).to_contain_text("Done: bunny.ply", timeout=timeout)
    expect(p.locator("#figures")).to_contain_text(figure, timeout=20000)
    expect(p.locator("#viewer[data-ready='1']")).to_be_attached(timeout=20000)
    page.shot(shot)
    job = httpx.get(f"{api}/v1/jobs", params={"limit": 1}, timeout=10).json()["jobs"][0]
    return job, httpx.get(f"{api}/v1/jobs/{job['id']}", timeout=10).json()["report"]
