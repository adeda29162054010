"""Texture sets and UDIM tiles: which faces bake into which images, with which settings.

A bake makes one texture set per material (``BakeSettings.texture_set="per-material"``, the
default) or one for the whole mesh ("single"). Each set is a mesh of its own faces
(:class:`TextureSet`: its own atlas, its own maps at its own size) with its settings
(``BakeSettings.for_material``: the bake's, with the material's own from
``BakeSettings.materials`` on top). A mesh of one material is one set holding the mesh
itself, so it bakes exactly as it did before there were sets.

A set whose atlas lies in UDIM tiles (``Atlas.udim``: the mesh's own layout kept,
:mod:`texbake.atlas.uvcheck`) bakes each tile as its own image: :func:`tiles` cuts the
set's mesh, atlas and output mesh into one :class:`Tile` each, its UVs moved into the unit
square, so every stage after the atlas sees a tile as it sees a set (the margin stays
inside the tile). A set in the unit square is one tile, ``number`` None, the set itself.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field, replace

import numpy as np

from .atlas import Atlas, udim_offset, udim_tiles
from .errors import ParameterError
from .mesh import LoadedMesh
from .settings import BakeSettings


@dataclass
class TextureSet:
    """One texture set: a material's faces (or all), as a mesh of their own.

    Attributes
    ----------
    name : str
        The material's name (for a set of several materials, ``texture_set="single"``,
        the mesh's name).
    materials : list of str
        The materials whose faces it holds.
    faces : (k,) int64
        Their indices into the whole mesh's faces, in order.
    mesh : LoadedMesh
        Those faces as a mesh (vertices compacted, their UVs, parts and ``has_uv``); the
        whole mesh itself when the set holds every face.
    settings : BakeSettings
        The set's settings (``BakeSettings.for_material``).
    warnings : list of str
        What a user should know of the set (one line each; the report collects them).
    """

    name: str
    materials: list[str]
    faces: np.ndarray
    mesh: LoadedMesh
    settings: BakeSettings
    warnings: list[str] = field(default_factory=list)


@dataclass
class Tile:
    """What one image of a set is baked from: the set's faces in one UDIM tile (or all of
    them), as mesh, atlas and output mesh, the atlas' UVs in the unit square.

    ``number``: the UDIM tile, 1001 + u + 10 v (None: the set's atlas is the unit
    square, and ``mesh``, ``atlas`` and ``baked`` are the set's own); ``offset``: the
    tile's corner ``(u, v)`` that was taken off its UVs.
    """

    number: int | None
    offset: tuple[int, int]
    mesh: LoadedMesh
    atlas: Atlas
    baked: object  # texbake.pipeline.BakedMesh (the pipeline's type: not imported here)


def texture_sets(mesh: LoadedMesh, settings: BakeSettings) -> list[TextureSet]:
    """The texture sets of a bake of ``mesh``: one per material (in ``mesh.material_names``'
    order) or, with ``texture_set="single"`` or a mesh of one material, one of every face.

    Raises
    ------
    ParameterError
        ``materials`` names a material the mesh does not have (the message lists those it
        has).
    """
    unknown = sorted(set(settings.materials or {}) - set(mesh.material_names))
    if unknown:
        have = ", ".join(map(repr, mesh.material_names))
        raise ParameterError("materials", f"{mesh.path} has no material {unknown[0]!r}; its materials: {have}")
    every = np.arange(len(mesh.faces), dtype=np.int64)
    if mesh.material is None or settings.texture_set == "single":
        name = mesh.material_names[0] if len(mesh.material_names) == 1 else mesh.name
        own = settings.for_material(name) if len(mesh.material_names) == 1 else settings
        return [TextureSet(name, list(mesh.material_names), every, mesh, own)]
    sets = []
    for i, name in enumerate(mesh.material_names):
        faces = np.flatnonzero(mesh.material == i)
        own, warnings = settings.for_material(name), []
        part = restricted(mesh, faces, name)
        if part.uv is None and own.uv == "keep":  # as a part without UVs beside parts with them
            own = own.model_copy(update={"uv": "unwrap"})
            warnings.append("unwrapped: it has no UVs (uv='keep' keeps those of the texture sets that have them)")
        sets.append(TextureSet(name, [name], faces, part, own, warnings))
    return sets


def images_of(texture_set: TextureSet) -> int:
    """How many images a set will bake, as far as its mesh tells before its atlas: one per
    UDIM tile its own UVs lie in (they may yet be unwrapped into one), else one."""
    mesh = texture_set.mesh
    if mesh.uv is None or mesh.has_uv is not None or texture_set.settings.uv == "unwrap":
        return 1
    tiles = udim_tiles(mesh.uv, mesh.faces)
    return 1 if tiles is None else len(set(np.asarray(tiles).ravel().tolist()))  # not np.unique: it imports numpy.ma (10 ms of a start)


def restricted(mesh: LoadedMesh, faces: np.ndarray, name: str) -> LoadedMesh:
    """The faces ``faces`` (indices) of ``mesh`` as a mesh of their own: the vertices they
    use, their UVs, parts and ``has_uv``; its hash is the mesh's and the faces' (the atlas
    cache's key)."""
    used, local = np.unique(mesh.faces[faces], return_inverse=True)
    uv = None if mesh.uv is None else mesh.uv[used]
    has_uv = None if mesh.has_uv is None else mesh.has_uv[faces]
    if has_uv is not None and (has_uv.all() or not has_uv.any()):
        uv, has_uv = (uv, None) if has_uv.all() else (None, None)
    digest = hashlib.sha256(f"{mesh.sha256}:{name}:".encode() + np.ascontiguousarray(faces).tobytes()).hexdigest()
    return LoadedMesh(mesh.vertices[used], local.reshape(-1, 3).astype(np.int64), uv, mesh.name, mesh.path, 0, digest, 0,
                      has_uv, None if mesh.part is None else mesh.part[faces], mesh.part_names, [], None, [name])


def safe_name(name: str) -> str:
    """A set's name as a file name takes it: letters, digits, ``.``, ``-`` and ``_``, the
    rest ``_`` (``"blue paint/2"`` -> ``"blue_paint_2"``)."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", name).strip(".") or "set"


def file_stems(names: list[str]) -> dict[str, str]:
    """Each set's name in file names (:func:`safe_name`), made unique with ``-2``, ``-3``..."""
    out: dict[str, str] = {}
    for name in names:
        stem, k = safe_name(name), 1
        while stem in out.values():
            k += 1
            stem = f"{safe_name(name)}-{k}"
        out[name] = stem
    return out


def tiles(mesh: LoadedMesh, atlas: Atlas, baked) -> list[Tile]:
    """The images a set bakes into: one :class:`Tile` per UDIM tile its faces use (in
    tile order) when its atlas keeps UDIM tiles (``atlas.udim``), else the set itself as
    one tile. ``baked``: the set's output mesh (``texbake.pipeline.BakedMesh``), faces in
    the atlas' order."""
    if not atlas.udim:
        return [Tile(None, (0, 0), mesh, atlas, baked)]
    number = udim_tiles(atlas.uv, atlas.faces)
    assert number is not None  # make_atlas keeps UDIM tiles only so
    out = []
    for tile in np.unique(number).tolist():
        faces = np.flatnonzero(number == tile)
        offset = udim_offset(tile)
        used, local = np.unique(atlas.faces[faces], return_inverse=True)
        part = Atlas(atlas.vmapping[used], local.reshape(-1, 3), atlas.uv[used] - offset, atlas.method, atlas.reason, atlas.stats,
                     atlas.warnings, atlas.cached)
        out.append(Tile(tile, offset, replace(mesh, faces=mesh.faces[faces], has_uv=None, part=None), part, _tile_mesh(baked, faces, offset)))
    return out


def _tile_mesh(baked, faces: np.ndarray, offset: tuple[int, int]):
    """The output mesh's ``faces`` (indices) with the vertices they use, UVs less ``offset``."""
    used, local = np.unique(baked.faces[faces], return_inverse=True)
    pick = lambda a: None if a is None else a[used]
    return replace(baked, vertices=baked.vertices[used], faces=local.reshape(-1, 3), uv=baked.uv[used] - offset,
                   normals=pick(baked.normals), tangents=pick(baked.tangents), offset=offset,
                   material=None if baked.material is None else baked.material[faces])
