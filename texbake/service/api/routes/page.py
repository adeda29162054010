"""The web page at ``/``: one HTML file, its script and style sheet, and the three.js
modules it imports (vendored by ``scripts/vendor``), all served from the package's
``static`` folder: no CDN, so it works offline and behind a firewall.

The page's Content-Security-Policy lets it load nothing from anywhere else; its one inline
script, the import map, is allowed by its hash.
"""

from __future__ import annotations

import base64
import functools
import hashlib
import re
from pathlib import Path

from fastapi import APIRouter, FastAPI, Response
from fastapi.staticfiles import StaticFiles

STATIC = Path(__file__).resolve().parents[2] / "static"
router = APIRouter(include_in_schema=False)


@functools.cache
def _page() -> tuple[bytes, str]:
    """The page's HTML and its Content-Security-Policy."""
    html = (STATIC / "index.html").read_bytes()
    found = re.search(rb'<script type="importmap">(.*?)</script>', html, re.S)
    if found is None:
        raise RuntimeError(f"{STATIC / 'index.html'} has no import map")
    digest = base64.b64encode(hashlib.sha256(found.group(1)).digest()).decode()
    csp = ("default-src 'self'; " f"script-src 'self' 'sha256-{digest}'; " "img-src 'self' blob: data:; connect-src 'self' blob: data:; "
           "style-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")
    return html, csp


@router.get("/")
def page():
    html, csp = _page()
    return Response(html, media_type="text/html; charset=utf-8", headers={"Content-Security-Policy": csp, "Cache-Control": "no-cache"})


def add_page(app: FastAPI) -> None:
    """The page at ``/`` and its files under ``/static``."""
    app.include_router(router)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
