"""The bake report: what was done, how long it took, and with which libraries."""

from __future__ import annotations

import json
import platform
from importlib import metadata
from pathlib import Path

import numpy as np

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


def bake_report(mesh, bounds, source: dict | None, settings, quality, atlas, covered: np.ndarray, filled: np.ndarray,
                counts: dict, error_estimate: dict, seconds: dict) -> dict:
    """The report of one bake (``report.json``).

    ``mesh``: the ``LoadedMesh``; ``bounds``: its ``(lo, hi)``; ``source``: what was
    transferred from, or None; ``settings``: the ``BakeSettings``; ``quality``: their
    resolved ``Quality``; ``atlas``: the ``Atlas``; ``covered``, ``filled``: ``(h, w)``
    bool texels covered by the atlas and by the margin; ``counts``: samples ``cast``
    (looked up), lookup ``rays``, ``transfer_missed`` and sample ``hits``; ``seconds``: per stage.
    """
    width, height = settings.width_height
    skipped = []
    if source is None:
        skipped.append({"stage": "transfer", "why": "no source mesh given"})
    if atlas.cached:
        skipped.append({"stage": "unwrap", "why": f"the atlas of an earlier bake of this mesh, from the cache ({atlas.reason})"})
    elif atlas.method == "kept":
        skipped.append({"stage": "unwrap", "why": atlas.reason})
    if counts.get("lookup_reused"):
        skipped.append({"stage": "lookup", "why": "the texel lookup of an earlier bake of this atlas at this size, kept in memory"})
    cracks = _cracks(covered)
    lo, hi = bounds
    return {
        "mesh": {
            "name": mesh.name,
            "path": mesh.path,
            "sha256": mesh.sha256,
            "vertices": int(len(mesh.vertices)),
            "faces": int(len(mesh.faces)),
            "degenerate_faces_removed": int(mesh.removed_degenerate),
            "duplicate_faces_removed": int(mesh.removed_duplicate),
            "bounds": [lo.tolist(), hi.tolist()],
        },
        "source": source,
        "parameters": {
            "texture": settings.texture.model_dump(mode="json"),
            "size": [width, height],
            "samples": quality.samples,
            "quality": settings.quality,
            "filtering": quality.filtering,
            "precision": quality.precision,
            "max_octaves": quality.max_octaves,
            "margin": settings.margin,
            "uv": settings.uv,
            "texture_space": settings.texture_space,
            "seed": settings.seed,
            "shading": settings.shading,
            "light": list(settings.light) if settings.shading != "decal" else None,
            "bump": None if settings.bump is None else {"texture": settings.bump.model_dump(mode="json"), "strength": settings.bump_strength},
            "frames": settings.frames,
        },
        "atlas": {"method": atlas.method, "reason": atlas.reason, "cached": atlas.cached, **atlas.stats},
        "texels": {
            "total": width * height,
            "covered": int(covered.sum()),
            "margin": int(filled.sum()),
            "empty": int(width * height - covered.sum() - filled.sum()),
        },
        "rays": {
            "texel_samples": width * height * quality.samples,
            "cast": counts["cast"],  # samples of texels that some face's UV box touches, looked up
            "lookup_reused": bool(counts.get("lookup_reused", False)),
            "lookup_rays": counts["rays"],  # of them: a texel's first sample, and those off its face
            "missed": counts["cast"] - counts["hits"] - counts["transfer_missed"],
            "missed_inside_atlas": cracks,
            "transfer_missed": counts["transfer_missed"],
        },
        "error_estimate": error_estimate,
        "warnings": list(atlas.warnings) + _transfer_warning(counts),
        "skipped": skipped,
        "seconds": {k: round(v, 4) for k, v in seconds.items()},
        "versions": library_versions(),
    }


def _transfer_warning(counts: dict) -> list[str]:
    """A warning when more than 1 % of the transfer rays found no source."""
    cast, missed = counts["cast"], counts["transfer_missed"]
    if cast and missed > 0.01 * cast:
        return [f"transfer: {missed} of {cast} texel samples found no source within the cage; they keep the margin's colour"]
    return []


def _cracks(covered: np.ndarray, band: int = 1024) -> int:
    """Texels that no sample hit although their four neighbours are covered, counted in
    bands of rows (no full-size temporaries: a 16384² mask is 268 MB)."""
    h = covered.shape[0]
    total = 0
    for top in range(1, h - 1, band):
        rows = slice(top, min(h - 1, top + band))
        up, down = slice(top - 1, rows.stop - 1), slice(top + 1, rows.stop + 1)
        c = covered[rows, 1:-1]
        total += int((~c & covered[up, 1:-1] & covered[down, 1:-1] & covered[rows, :-2] & covered[rows, 2:]).sum())
    return total
