"""Fixtures and helpers shared by the test modules (import helpers with ``from conftest import ...``)."""

import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]  # the repository
SHARED = ROOT.parent / "shared"
MESHES = SHARED / "meshes"


def pytest_configure(config):
    config.addinivalue_line("markers", "xatlas_failure: relies on a real xatlas failure (a hang or a crash a new xatlas may fix)")


@pytest.fixture(scope="session")
def meshes() -> Path:
    if not MESHES.is_dir():
        pytest.fail(f"test meshes not found at {MESHES}: ../shared must sit beside the repo")
    return MESHES


def texbake(*args, cwd=None, timeout=300):
    """Run the ``texbake`` command line as a real process; the CompletedProcess (text)."""
    env = {k: v for k, v in os.environ.items() if k != "COLUMNS"} | {"COLUMNS": "200"}
    return subprocess.run(
        [sys.executable, "-m", "bake.cli", *map(str, args)],
        capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env,
    )


def glb_with_image_uri(uri):
    doc = json.dumps({"asset": {"version": "2.0"}, "images": [{"uri": uri}]}).encode()
    doc += b" " * (-len(doc) % 4)
    return struct.pack("<4sII", b"glTF", 2, 20 + len(doc)) + struct.pack("<I4s", len(doc), b"JSON") + doc


def glb_with_accessor(count):
    """A GLB whose position accessor claims ``count`` items of a 36-byte buffer view."""
    doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 44}],
           "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": count, "type": "VEC3"},
                         {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}], "nodes": [{"mesh": 0}]}
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    binary = bytes(44)
    body = struct.pack("<I4s", len(j), b"JSON") + j + struct.pack("<I4s", len(binary), b"BIN\x00") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body
