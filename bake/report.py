"""The bake report: what was done, how long it took, and with which libraries."""

from __future__ import annotations

import json
import platform
from importlib import metadata
from pathlib import Path

from .atomic import write_bytes

_LIBRARIES = ("texbake", "numpy", "scipy", "trimesh", "xatlas", "embreex", "OpenImageIO", "numba", "pydantic")


def library_versions() -> dict[str, str | None]:
    """Installed versions of the libraries a bake uses (None where one is missing)."""
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in _LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def write_json(path: Path, data: dict) -> None:
    """Write ``data`` as JSON to ``path`` atomically (temporary file, then rename)."""
    write_bytes(path, (json.dumps(data, indent=2) + "\n").encode())
