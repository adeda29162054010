"""The bake report: what was done, how long it took, and with which libraries."""

from __future__ import annotations

import json
import platform
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .atomic import write_bytes

if TYPE_CHECKING:  # for the annotations only: the report reads these objects, it does not make them
    from ..atlas import Atlas
    from ..mesh import LoadedMesh
    from ..settings import BakeSettings

_LIBRARIES = ("texbake", "numpy", "scipy", "trimesh", "xatlas", "embreex", "OpenImageIO", "pydantic")


def library_versions() -> dict[str, str | None]:
    """Installed versions of the libraries a bake uses (None where one is missing), and
    ``kernels``: how the compiled kernels were built (:func:`kernels_build`)."""
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in _LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    versions["kernels"] = kernels_build()
    return versions


def kernels_build() -> str:
    """The compiled kernels' (``texbake._native``) compiler, flags and build type, e.g.
    ``gcc 12.2.0, -O3 -ffp-contract=off -fno-math-errno -Wall -Wextra (Release, nanobind 3.1.0)``: the
    images depend on them."""
    from .. import _native

    info = _native.build_info()
    return f"{info['compiler']}, {info['flags']} ({info['build_type']}, nanobind {info['nanobind']})"


def write_json(path: Path, data: dict) -> None:
    """Write ``data`` as JSON to ``path`` atomically (temporary file, then rename)."""
    write_bytes(path, (json.dumps(data, indent=2) + "\n").encode())


@dataclass(frozen=True)
class BakeTally:
    """What a bake's stages counted and measured, for its report.

    Attributes
    ----------
    covered, filled : (h, w) bool ndarray
        Texels covered by the atlas (some sample hit them), and those the margin filled.
    cast : int
        Texel samples looked up (those of texels that some face's UV box touches).
    rays : int
        Lookup rays cast: a texel's first sample, and those off its face.
    transfer_missed : int
        Samples whose transfer ray found no source.
    hits : int
        Samples that reached a face.
    lookup_reused : bool
        Whether the lookups were an earlier bake's, kept in memory (then no ray was cast).
    error_estimate : dict
        The colour map's error estimate (``texbake.maps.estimate``).
    seconds : dict of str to float
        Seconds per stage, summed over the tiles that ran it.
    material : dict or None
        A material's bake: its maps and each node's evaluations (``texbake.maps.material``).
    """

    covered: np.ndarray
    filled: np.ndarray
    cast: int
    rays: int
    transfer_missed: int
    hits: int
    lookup_reused: bool = False
    error_estimate: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    material: dict | None = None


def bake_report(settings: BakeSettings, mesh: LoadedMesh, atlas: Atlas, tally: BakeTally, *,
                source: LoadedMesh | None = None, cage: float | None = None) -> dict:
    """The report of one bake (``report.json``).

    Parameters
    ----------
    settings : BakeSettings
        What was baked; ``report["settings"]`` is ``settings.model_dump(mode="json")``.
    mesh : LoadedMesh
        The mesh baked.
    atlas : Atlas
        Its atlas, and how it was made.
    tally : BakeTally
        What the stages counted and measured.
    source, cage : LoadedMesh and float, optional
        The mesh transferred from and the transfer rays' reach, or None.

    Returns
    -------
    dict
        JSON-ready: ``mesh``, ``source``, ``settings``, ``atlas``, ``texels``, ``rays``,
        ``error_estimate``, ``warnings``, ``skipped``, ``seconds``, ``versions``.
    """
    width, height = settings.width_height
    covered, filled = int(tally.covered.sum()), int(tally.filled.sum())
    return {
        "mesh": _mesh(mesh),
        "source": None if source is None else {"path": source.path, "sha256": source.sha256, "faces": int(len(source.faces)),
                                               "cage": cage},
        "settings": settings.model_dump(mode="json"),
        "atlas": {"method": atlas.method, "reason": atlas.reason, "cached": atlas.cached, **atlas.stats},
        "texels": {"total": width * height, "covered": covered, "margin": filled, "empty": width * height - covered - filled},
        "rays": {
            "texel_samples": width * height * settings.samples,
            "cast": tally.cast,  # samples of texels that some face's UV box touches, looked up
            "lookup_reused": tally.lookup_reused,
            "lookup_rays": tally.rays,  # of them: a texel's first sample, and those off its face
            "missed": tally.cast - tally.hits - tally.transfer_missed,
            "missed_inside_atlas": _cracks(tally.covered),
            "transfer_missed": tally.transfer_missed,
        },
        "error_estimate": tally.error_estimate,
        **({} if tally.material is None else {"material": tally.material}),
        "warnings": [*mesh.warnings, *atlas.warnings, *_transfer_warning(tally)],  # each stage's, in their order
        "skipped": _skipped(source, atlas, tally),
        "seconds": {k: round(v, 4) for k, v in tally.seconds.items()},
        "versions": library_versions(),
    }


def _mesh(mesh: LoadedMesh) -> dict:
    """The report's ``mesh``: where it came from, its counts and its bounds."""
    return {
        "name": mesh.name,
        "path": mesh.path,
        "sha256": mesh.sha256,
        "vertices": int(len(mesh.vertices)),
        "faces": int(len(mesh.faces)),
        "degenerate_faces_removed": int(mesh.removed_degenerate),
        "duplicate_faces_removed": int(mesh.removed_duplicate),
        "bounds": [mesh.vertices.min(axis=0).tolist(), mesh.vertices.max(axis=0).tolist()],
    }


def _skipped(source: LoadedMesh | None, atlas: Atlas, tally: BakeTally) -> list[dict]:
    """The stages a bake left out, and why."""
    skipped = []
    if source is None:
        skipped.append({"stage": "transfer", "why": "no source mesh given"})
    if atlas.cached:
        skipped.append({"stage": "unwrap", "why": f"the atlas of an earlier bake of this mesh, from the cache ({atlas.reason})"})
    elif atlas.method == "kept":
        skipped.append({"stage": "unwrap", "why": atlas.reason})
    if tally.lookup_reused:
        skipped.append({"stage": "lookup", "why": "the texel lookup of an earlier bake of this atlas at this size, kept in memory"})
    return skipped


def _transfer_warning(tally: BakeTally) -> list[str]:
    """A warning when more than 1 % of the transfer rays found no source."""
    cast, missed = tally.cast, tally.transfer_missed
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
