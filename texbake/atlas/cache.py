"""Reuse across bakes: the atlas of a mesh kept on disk, keyed by what made it.

The same mesh baked again (another texture, another map, a flame frame) at the same atlas
settings gets the same atlas; :class:`AtlasCache` keeps each one as an ``.npz`` in a
folder the caller names (the library reads no environment: the command line and the
service choose the folder), so the second bake skips the unwrap and the UV checks, and
its report says so (``atlas.cached``).

The texel lookup of a bake (which face under which sample: ``samples.Located`` per tile)
depends only on the atlas, the size, the samples and the seed: an ``AtlasCache`` also
keeps the most recent lookups in memory (``max_lookup_bytes``), for the next bake in the
same process (the service's bake processes serve job after job).

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
import threading
from collections import OrderedDict
from pathlib import Path

import numpy as np

from .decide import Atlas

MAX_BYTES = 1 << 30  # an atlas of a 1M-face mesh is about 60 MB
MAX_LOOKUP_BYTES = 1 << 28  # lookups kept in memory: one 2048² bake at one sample is about 110 MB


def atlas_key(mesh_sha256: str, uv: str, size: int, charting: str, version: str) -> str:
    """The cache key of the atlas that ``make_atlas`` makes of a mesh with these settings."""
    text = json.dumps([mesh_sha256, uv, int(size), charting, version])
    return hashlib.sha256(text.encode()).hexdigest()


class AtlasCache:
    """Atlases kept in ``folder`` (made if missing), at most ``max_bytes`` of them, and the
    latest lookups in memory, at most ``max_lookup_bytes``."""

    def __init__(self, folder: str | os.PathLike, max_bytes: int = MAX_BYTES, max_lookup_bytes: int = MAX_LOOKUP_BYTES):
        self.folder = Path(folder)
        self.max_bytes = max_bytes
        self.max_lookup_bytes = max_lookup_bytes
        self._lookups: OrderedDict[tuple, list] = OrderedDict()
        self._lock = threading.Lock()

    def lookups(self, key: tuple) -> list | None:
        """The per-tile lookups kept under ``key`` (see the module), or None."""
        with self._lock:
            found = self._lookups.get(key)
            if found is not None:
                self._lookups.move_to_end(key)
            return found

    def keep_lookups(self, key: tuple, tiles: list) -> None:
        """Keep a bake's per-tile lookups (``(texels, Located)`` each), dropping the oldest
        beyond ``max_lookup_bytes``; a bake's that alone is over it is not kept."""
        if _nbytes(tiles) > self.max_lookup_bytes:
            return
        with self._lock:
            self._lookups[key] = tiles
            total = sum(_nbytes(v) for v in self._lookups.values())
            while total > self.max_lookup_bytes:
                total -= _nbytes(self._lookups.popitem(last=False)[1])

    def _path(self, key: str) -> Path:
        return self.folder / f"atlas-{key}.npz"

    def get(self, key: str) -> Atlas | None:
        """The atlas kept under ``key``, or None (also for a file that does not read)."""
        path = self._path(key)
        try:
            with np.load(path, allow_pickle=False) as data:
                meta = json.loads(str(data["meta"]))
                atlas = Atlas(data["vmapping"], data["faces"], data["uv"], meta["method"], meta["reason"],
                              meta["stats"], meta["warnings"], cached=True, udim=bool(meta.get("udim", False)))
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
        meta = json.dumps({"method": atlas.method, "reason": atlas.reason, "stats": atlas.stats, "warnings": atlas.warnings,
                           "udim": atlas.udim})
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


def _nbytes(tiles: list) -> int:
    """Bytes of a bake's per-tile lookups (``(texels, Located)`` each)."""
    return sum(texels.nbytes + located.nbytes for texels, located in tiles)
