"""Reuse across bakes: the atlas of a mesh kept on disk, keyed by what made it.

The same mesh baked again (another texture, another map, a flame frame) at the same atlas
settings gets the same atlas; :class:`AtlasCache` keeps each one as an ``.npz`` in a
folder the caller names (the library reads no environment: the command line and the
service choose the folder), so the second bake skips the unwrap and the UV checks, and
its report says so (``atlas.cached``).

The key (:func:`atlas_key`) is the SHA-256 of the mesh's content hash (``LoadedMesh.sha256``),
the atlas settings (``uv``, the texture's larger side, ``charting``) and texbake's
version (a new release may chart differently). Files are written under a temporary name
and renamed, so concurrent bakes (the service's workers) never read half a file; the
folder is kept under ``max_bytes`` by removing the least recently used files.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from .atlas import Atlas

MAX_BYTES = 1 << 30  # an atlas of a 1M-face mesh is about 60 MB


def atlas_key(mesh_sha256: str, uv: str, size: int, charting: str, version: str) -> str:
    """The cache key of the atlas that ``make_atlas`` makes of a mesh with these settings."""
    text = json.dumps([mesh_sha256, uv, int(size), charting, version])
    return hashlib.sha256(text.encode()).hexdigest()


class AtlasCache:
    """Atlases kept in ``folder`` (made if missing), at most ``max_bytes`` of them."""

    def __init__(self, folder: str | os.PathLike, max_bytes: int = MAX_BYTES):
        self.folder = Path(folder)
        self.max_bytes = max_bytes

    def _path(self, key: str) -> Path:
        return self.folder / f"atlas-{key}.npz"

    def get(self, key: str) -> Atlas | None:
        """The atlas kept under ``key``, or None (also for a file that does not read)."""
        path = self._path(key)
        try:
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(str(data["meta"]))
                atlas = Atlas(data["vmapping"], data["faces"], data["uv"], meta["method"], meta["reason"],
                              meta["stats"], meta["warnings"], cached=True)
            os.utime(path)  # recently used
        except (OSError, ValueError, KeyError):
            return None
        return atlas

    def put(self, key: str, atlas: Atlas) -> None:
        """Keep ``atlas`` under ``key`` (a fallback grid is not kept: a later bake may have
        the time to unwrap), then trim the folder. A full disk or a read-only folder only
        means nothing is kept."""
        if atlas.method == "fallback-grid":
            return
        meta = json.dumps({"method": atlas.method, "reason": atlas.reason, "stats": atlas.stats, "warnings": atlas.warnings})
        tmp = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            with tempfile.NamedTemporaryFile(dir=self.folder, prefix=".atlas-", suffix=".npz", delete=False) as f:
                tmp = Path(f.name)
                np.savez(f, vmapping=atlas.vmapping, faces=atlas.faces, uv=atlas.uv, meta=np.array(meta))
            tmp.replace(self._path(key))
        except OSError:
            if tmp is not None:
                tmp.unlink(missing_ok=True)
            return
        self._trim()

    def _trim(self) -> None:
        files = []
        for p in self.folder.glob("atlas-*.npz"):
            try:
                st = p.stat()
            except OSError:
                continue  # removed by another bake meanwhile
            files.append((st.st_mtime, st.st_size, p))
        total = sum(size for _, size, _ in files)
        for _, size, p in sorted(files):
            if total <= self.max_bytes:
                break
            p.unlink(missing_ok=True)
            total -= size
