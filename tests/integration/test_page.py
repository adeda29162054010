"""The web page at ``/`` in a real browser: Debian's chromium driven by Playwright (its
``executable_path``: no browser is downloaded), against the real API and its worker
(``texbake serve``), with every request to anywhere but 127.0.0.1 aborted.

A person's round trip: upload bunny.ply, pick a texture and change a parameter (the swatch
changes), bake at a small size, watch the progress reach 100 %, turn the model in the
viewer, download the zip; a bad file shows the API's reason. A screenshot of each step is
kept under pytest's tmp_path and, if TEXBAKE_ARTEFACTS names a folder, copied there.
"""

import io
import os
import re
import subprocess
import sys
import time
import zipfile
from urllib.parse import urlsplit

import httpx
import numpy as np
import pytest
from conftest import ROOT, chromium, free_port, keep_artefact, start, stop
from playwright.sync_api import expect, sync_playwright

from texbake.output.images import read_image

BACKGROUND = np.array([0x26, 0x2B, 0x33]) / 255  # the viewer's (page.css, app.js), sRGB


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
    errors and screenshots."""

    def __init__(self, browser, tmp_path, width=1280, height=900):
        self.context = browser.new_context(viewport={"width": width, "height": height}, accept_downloads=True)
        self.page = self.context.new_page()
        self.tmp_path, self.blocked, self.requests, self.errors = tmp_path, [], [], []
        self.context.route("**/*", self._route)
        self.page.on("pageerror", lambda error: self.errors.append(str(error)))
        self.page.on("console", lambda m: m.type == "error" and self.errors.append(m.text))

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
    # 4xx answers are logged by chromium as failed loads; anything else is a bug of the page
    assert not [e for e in p.errors if "the server responded with a status of 4" not in e], p.errors


def swatch(p, name):
    expect(p.page.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
    return p.shot(name, p.page.locator("#swatch"))


def field_error(p, label):
    """The error line beside the control labelled ``label``."""
    return p.page.locator(".field", has=p.page.get_by_label(label, exact=True)).locator(".error").first


def test_a_round_trip_on_the_page(api, page, meshes, tmp_path):
    p = page.page
    p.goto(api + "/")
    swatch(page, "01-start")

    # the texture: marble, then its frequency changed; the swatch follows
    p.select_option("#texture", "marble")
    before = swatch(page, "02-swatch-marble")
    p.get_by_label("Frequency", exact=True).fill("-1")  # the API's reason beside the field
    expect(field_error(page, "Frequency")).to_contain_text("expected a number above 0", timeout=10000)
    p.get_by_label("Frequency", exact=True).fill("40")
    after = swatch(page, "03-swatch-frequency-40")
    assert np.abs(after - before).mean() > 0.02, np.abs(after - before).mean()  # measured 0.14
    expect(field_error(page, "Frequency")).to_be_empty()
    for knot in range(1, 6):  # the colour map, every knot red: a red marble
        p.get_by_label(f"Colormap: colour of knot {knot}").fill("#ff0000")
    red = swatch(page, "04-swatch-red-colour-map")
    disk = red[96:160, 96:160]
    assert disk[..., 0].mean() > 0.5 > disk[..., 1].mean() * 4, disk.mean(axis=(0, 1))
    p.get_by_role("button", name="Reset the parameters").click()
    p.get_by_label("Frequency", exact=True).fill("40")
    assert np.abs(swatch(page, "05-swatch-reset") - after).mean() < 0.01  # the same swatch as before the colours

    # the mesh and the settings, then the bake: progress up to 100 %, polled without hammering
    p.set_input_files("#mesh", meshes / "bunny.ply")
    expect(p.locator("#mesh-info")).to_contain_text("bunny.ply")
    p.get_by_label("Size", exact=True).fill("128")
    p.get_by_label("Shading", exact=True).select_option("ambient-diffuse")
    page.shot("06-ready-to-bake")
    p.evaluate("""() => {  // every status the page shows, as it shows them
        window.seen = [];
        new MutationObserver(() => window.seen.push(document.querySelector("#status").textContent + " " + document.querySelector("#percent").textContent))
            .observe(document.querySelector(".progress-row"), { subtree: true, childList: true, characterData: true });
    }""")
    began = time.monotonic()
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#percent")).to_have_text("100 %", timeout=60000)
    seen = p.evaluate("() => window.seen")
    assert any(s.startswith("Uploading bunny.ply") for s in seen), seen  # the upload's own progress first
    expect(p.locator("#status")).to_contain_text("Done: bunny.ply")
    seconds = time.monotonic() - began
    polls = [t for t, method, path in page.requests if t >= began and method == "GET" and path.count("/") == 3 and path.startswith("/v1/jobs/")]
    assert len(polls) <= seconds / 0.45 + 2, (len(polls), seconds)

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
    images = p.locator("#images img")
    expect(images).to_have_count(3)  # albedo, lit, coverage
    for i in range(3):
        images.nth(i).scroll_into_view_if_needed()
        expect(images.nth(i)).to_have_js_property("complete", True)
        assert images.nth(i).evaluate("img => img.naturalWidth") == 128
    page.shot("10-result")

    # the download of every file in one zip
    with p.expect_download() as download:
        p.get_by_role("link", name="All files (result.zip)").click()
    names = set(zipfile.ZipFile(io.BytesIO(download.value.path().read_bytes())).namelist())
    assert {"albedo.png", "lit.png", "coverage.png", "bunny.glb", "report.json"} <= names, names
    expect(p.locator("#jobs tbody tr").first).to_contain_text("done")

    # a GLB whose own UVs overlap, kept: the report's warning is shown with the result
    p.set_input_files("#mesh", meshes / "Duck.glb")
    p.get_by_label("Size", exact=True).fill("64")
    p.locator("#bake-card summary").click()  # More settings
    p.get_by_label("Uv", exact=True).select_option("keep")
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Done: Duck.glb", timeout=60000)
    expect(p.locator("#warnings li")).to_have_count(1, timeout=20000)
    expect(p.locator("#warnings")).to_contain_text("overlap")
    expect(p.locator("#viewer[data-ready='1']")).to_be_attached(timeout=20000)
    page.shot("11-warnings")
    p.get_by_label("Uv", exact=True).select_option("auto")

    # a bad file: the API's reason beside the mesh field (dropped, as a person would)
    p.evaluate("""() => {
        const files = new DataTransfer();
        files.items.add(new File([new Uint8Array([0x50, 0x4b, 0x03, 0x04, 1, 2, 3, 4])], "bad.obj"));
        document.querySelector("#drop").dispatchEvent(new DragEvent("drop", { dataTransfer: files, bubbles: true, cancelable: true }));
    }""")
    expect(p.locator("#mesh-info")).to_contain_text("bad.obj")
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#mesh-error")).to_contain_text("zip archive", timeout=20000)
    page.shot("12-bad-file")
    # too large for the server: said before anything is sent
    posts = sum(1 for _, method, path in page.requests if method == "POST")
    p.set_input_files("#mesh", files=[{"name": "big.obj", "mimeType": "text/plain", "buffer": b"v 0 0 0\n" * 300_000}])
    expect(p.locator("#mesh-error")).to_contain_text("larger than this server's limit of 2.00 MB")
    p.get_by_role("button", name="Bake", exact=True).click()
    assert sum(1 for _, method, path in page.requests if method == "POST") == posts

    # cancel a long bake, retry it from the list, cancel again
    p.set_input_files("#mesh", meshes / "bunny.ply")
    p.get_by_label("Size", exact=True).fill("4096")
    p.get_by_label("Quality", exact=True).select_option("final")
    p.get_by_role("button", name="Bake", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Baking", timeout=30000)
    p.get_by_role("button", name="Cancel", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Cancelled", timeout=10000)
    p.get_by_role("button", name="bake bunny.ply again").click()
    expect(p.locator("#status")).to_contain_text(re.compile("(Queued|Baking): bunny.ply"), timeout=10000)
    expect(p.locator("#cancel")).to_be_enabled(timeout=10000)
    p.get_by_role("button", name="Cancel", exact=True).click()
    expect(p.locator("#status")).to_contain_text("Cancelled", timeout=10000)
    expect(p.locator("#jobs tbody tr")).to_have_count(4)
    page.shot("13-cancelled-and-retried")

    # /docs works offline too
    p.goto(api + "/docs")
    expect(p.locator(".swagger-ui .opblock").first).to_be_visible(timeout=20000)
    page.shot("14-docs")


def test_the_page_at_phone_width(api, browser, tmp_path):
    page = Page(browser, tmp_path, width=390, height=844)
    try:
        page.page.goto(api + "/")
        expect(page.page.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        # nothing wider than the window: readable without scrolling sideways
        assert page.page.evaluate("() => document.documentElement.scrollWidth") <= 390
        page.page.keyboard.press("Tab")  # the controls are reachable by keyboard, in order
        assert page.page.evaluate("() => document.activeElement.textContent") == "API documentation"
        page.page.keyboard.press("Tab")
        assert page.page.evaluate("() => document.activeElement.id") == "mesh"
        # every control has a name a screen reader says (a label, or aria-label)
        unnamed = page.page.evaluate("""() => [...document.querySelectorAll("input, select, button")]
            .filter((c) => !c.labels?.length && !c.getAttribute("aria-label") && !c.textContent.trim() && c.getAttribute("aria-hidden") !== "true")
            .map((c) => c.outerHTML)""")
        assert not unnamed, unnamed
        # every texture's form is made and swatched
        names = page.page.locator("#texture option").all_text_contents()
        assert len(names) == 8, names
        for name in names:
            page.page.select_option("#texture", name)
            expect(page.page.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        # an animated texture: its frames can be set, and the page says what the bake writes
        page.page.select_option("#texture", "checker")
        frames = page.page.get_by_label("Frames", exact=True)
        expect(frames).to_be_hidden()
        page.page.select_option("#texture", "flame")
        expect(frames).to_be_visible()
        frames.fill("0, 0.5, 1")
        expect(page.page.locator("#maps")).to_contain_text("an albedo map per frame and a flipbook")
        expect(page.page.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        page.shot("15-phone")
    finally:
        page.close()
    assert not page.blocked and not page.errors, (page.blocked, page.errors)


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
        page.shot("16-key-asked")
        p.get_by_label("API key").fill("sesame")
        p.get_by_role("button", name="Use this key").click()
        expect(p.locator("#jobs tbody")).to_contain_text("No jobs yet", timeout=10000)
        expect(p.locator("#swatch[data-ready='1']")).to_be_attached(timeout=20000)
        expect(p.locator("#key-error")).to_be_empty()
        # kept for this tab only
        assert p.evaluate("() => [sessionStorage.getItem('texbake.key'), localStorage.length]") == ["sesame", 0]
        # a bake with the key: the maps, the model and the downloads come through it too
        p.set_input_files("#mesh", meshes / "suzanne.ply")
        p.get_by_label("Size", exact=True).fill("32")
        p.get_by_role("button", name="Bake", exact=True).click()
        expect(p.locator("#viewer[data-ready='1']")).to_be_attached(timeout=60000)
        image = p.locator("#images img").first
        image.scroll_into_view_if_needed()
        expect(image).to_have_js_property("naturalWidth", 32)
        with p.expect_download() as download:
            p.get_by_role("link", name="report.json").click()
        assert b'"suzanne"' in download.value.path().read_bytes()
        expect(p.locator("#jobs tbody tr")).to_have_count(1)  # the key's own
        page.shot("17-key-given")
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
