"""Load and validate a mesh: one triangle mesh in float64, or a clear error.

Formats: OBJ (+MTL, read by :mod:`texbake.mesh.objfile`), PLY (:mod:`texbake.mesh.plyfile`:
polygons and triangle strips), STL (ASCII and binary), OFF, glTF and GLB (read with trimesh).
A scene is flattened, node transforms applied, into one mesh. The file is checked before
and after parsing: archives, references that leave the mesh's folder, a glTF's buffers,
views and accessors that claim more bytes than there are, its node tree past
``MAX_GLTF_NODES`` nodes or ``MAX_GLTF_DEPTH`` levels (or not a tree), non-finite or
out-of-range coordinates, out-of-range face indices and too many faces are rejected with
a :class:`~texbake.errors.MeshError` naming the file; zero-area faces are removed and counted.

Vertices that are equal in position *and* UV are merged (file formats and trimesh split
every face corner), so UV seams survive and a closed surface stays connected.

UVs are kept per part: in a scene where some parts have UVs and others have none (or an
OBJ where some groups have ``vt`` and others not), the parts that have them keep them
(``LoadedMesh.has_uv`` says which faces), and the atlas unwraps only the others.

Parts and materials: each face has its part (a scene's mesh, an OBJ's ``g``/``o`` group)
and its material (a glTF primitive's material, an OBJ's ``usemtl``; a PLY, STL or OFF is
one part of one material, ``default``), with their names; the texture sets
(:mod:`texbake.sets`) are made per material.
"""

from __future__ import annotations

import collections
import hashlib
import io
import itertools
import json
import mmap
import os
import re
import struct
import threading
from collections.abc import Callable
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import NamedTuple

import numpy as np

from .. import _native
from ..errors import MeshError, ParameterError
from .grouping import group_rows
from .objfile import DEFAULT, read_obj
from .plyfile import read_ply
from .uvgeometry import areas

FORMATS = {".obj": "obj", ".ply": "ply", ".stl": "stl", ".off": "off", ".gltf": "gltf", ".glb": "glb"}
FLOAT32_MAX = float(np.finfo(np.float32).max)
# A glTF's node tree: a file of a few MB may hold 100,000 nodes, nested as deep; these
# bound the time a load takes (each mesh node's transform is the product of its path),
# far above what modelling tools write.
MAX_GLTF_NODES = 100_000
MAX_GLTF_DEPTH = 64

# Leading bytes of archive and compressed formats (which trimesh would open).
_ARCHIVES = {
    b"PK\x03\x04": "zip",
    b"PK\x05\x06": "zip",
    b"\x1f\x8b": "gzip",
    b"BZh": "bzip2",
    b"\xfd7zXZ\x00": "xz",
    b"7z\xbc\xaf\x27\x1c": "7z",
    b"Rar!\x1a\x07": "rar",
    b"\x28\xb5\x2f\xfd": "zstd",
}


@dataclass
class LoadedMesh:
    """A validated triangle mesh.

    Attributes
    ----------
    vertices : (n, 3) float64
        Object-space positions, node transforms applied; finite, within float32 range.
    faces : (m, 3) int64
        Indices into ``vertices``, m >= 1; zero-area faces removed.
    uv : (n, 2) float64 or None
        Per-vertex texture coordinates as loaded (OpenGL convention: v up); NaN on the
        vertices of parts that have none; None when no part has any.
    name : str
        The file's stem, or the name given for an in-memory mesh.
    path : str
        The file as given, or ``"<mesh>"``.
    removed_degenerate : int
        How many zero-area faces were removed.
    removed_duplicate : int
        How many faces were removed because an earlier face has the same corners (position
        and UV, after welding) in the same winding: a face doubled. A flipped copy is a
        back face, and a copy with other UVs is mapped twice: both stay.
    sha256 : str
        Hex digest of the file's bytes, or of the arrays of an in-memory mesh.
    has_uv : (m,) bool or None
        Which faces have UVs, when only some do (their parts had UVs); None when every
        face has them (``uv`` given) or none has (``uv`` None).
    part : (m,) int32 or None
        Each face's part (index into ``part_names``) for a mesh of several parts (a
        scene's meshes); None for one part. The atlas keeps or unwraps UVs part by part.
    part_names : list of str
        The parts' names (a scene's mesh names, with the node where a mesh is used twice;
        an OBJ's group names).
    material : (m,) int32 or None
        Each face's material (index into ``material_names``) for a mesh of several; None
        for one.
    material_names : list of str
        The materials' names, one or more, each once (a glTF's material names, an OBJ's
        ``usemtl`` names; ``default`` for faces without one; ``material_N`` for the N-th
        unnamed glTF material), in order of first use.
    warnings : list of str
        What a user should know of the loading (one line each; the report collects them).
    """

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None
    name: str
    path: str
    removed_degenerate: int
    sha256: str
    removed_duplicate: int = 0
    has_uv: np.ndarray | None = None
    part: np.ndarray | None = None
    part_names: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    material: np.ndarray | None = None
    material_names: list[str] = field(default_factory=lambda: [DEFAULT])

    @property
    def without_uv(self) -> list[str]:
        """The names of the parts whose faces have no UVs, when others have."""
        if self.has_uv is None or self.part is None:
            return []
        return [self.part_names[i] for i in np.unique(self.part[~self.has_uv])]


def load_mesh(path, *, max_faces: int = 5_000_000) -> LoadedMesh:
    """Read and validate the mesh file at ``path`` (see the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        An OBJ, PLY, STL, OFF, glTF or GLB file (by its suffix, case-insensitive); an
        OBJ's MTL files and a glTF's buffers must lie in its folder.
    max_faces : int, optional
        The most triangles (after triangulation) the file may hold; at least 1.

    Returns
    -------
    LoadedMesh
        ``vertices`` (n, 3) float64, ``faces`` (m, 3) int64 and ``uv`` (n, 2) float64
        or None, with the counts of the faces removed and the file's SHA-256.

    Raises
    ------
    MeshError
        Naming the file and the problem, for a file that is missing, unreadable,
        unsafe (an archive, a reference outside its folder or a URL), malformed, over
        ``max_faces``, or without a usable triangle.
    ParameterError
        ``max_faces`` is not a positive integer.
    """
    _check_max_faces(max_faces)
    path = Path(path)
    where = str(path)
    kind = check_file(path)
    warnings: list[str] = []
    with _file_bytes(path, kind) as data:
        sha256 = _sha256_beside(data)
        try:
            with np.errstate(over="raise"):  # a float32 field overflowing to inf
                parts = _read(data, kind, path, warnings)
        except MeshError:
            raise
        except FloatingPointError:
            raise MeshError(where, f"a number overflows when read: coordinates must lie within float32 range (|x| <= {FLOAT32_MAX:.3g})") from None
        except Exception as exc:  # the parsers raise many kinds on corrupt input
            raise MeshError(where, f"cannot parse {kind.upper()} file: {_short(exc)}") from None
        digest = sha256()
    return _validate(parts, path.stem, where, digest, max_faces, warnings)


@contextmanager
def _file_bytes(path: Path, kind: str):
    """The file's bytes: an OBJ of megabytes mapped (``mmap``: the compiled reader reads the
    page cache, where a copy of hundreds of MB would be new pages for the kernel to zero),
    any other file read; a :class:`MeshError` where it cannot be read."""
    try:
        with open(path, "rb") as f:
            if kind != "obj" or os.fstat(f.fileno()).st_size < 1 << 23:
                data: bytes | mmap.mmap = f.read()
            else:
                data = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    except OSError as exc:
        raise MeshError(str(path), f"cannot read: {exc.strerror}") from None
    try:
        yield data
    finally:
        if isinstance(data, mmap.mmap):
            with suppress(BufferError):  # a view still held (a traceback's): the collector closes it
                data.close()


def _sha256_beside(data: bytes | mmap.mmap) -> Callable[[], str]:
    """The hex SHA-256 of ``data``, as a call that waits for it: a file of megabytes is
    hashed on a thread of its own while it is parsed (hashlib and the compiled reader both
    let go of the GIL; 0.2 s of a 375 MB OBJ)."""
    if len(data) < 1 << 23:
        digest = hashlib.sha256(data).hexdigest()
        return lambda: digest
    out: list[str] = []
    thread = threading.Thread(target=lambda: out.append(hashlib.sha256(data).hexdigest()), daemon=True)
    thread.start()

    def result() -> str:
        thread.join()
        return out[0]

    return result


def check_file(path) -> str:
    """Check a mesh file as far as can be done without parsing it; return its format.

    Reads only the first bytes (and a glTF's JSON): the file must be a file, not an
    archive, of a known format and not empty; a binary STL's triangle count must match
    its length; a glTF's URIs must stay in its folder and its accessors fit their buffer
    views. Raises :class:`~texbake.errors.MeshError` naming the file and the problem.
    """
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise MeshError(where, "no such file" if not path.exists() else "not a file")
    try:
        size = path.stat().st_size
        with open(path, "rb") as f:
            head = f.read(1024)
    except OSError as exc:
        raise MeshError(where, f"cannot read: {exc.strerror}") from None
    for magic, archive in _ARCHIVES.items():
        if head.startswith(magic):
            raise MeshError(where, f"is a {archive} archive; archives are not accepted")
    if path.name.lower().endswith(".tar") or (len(head) > 262 and head[257:262] == b"ustar"):
        raise MeshError(where, "is a tar archive; archives are not accepted")
    kind = FORMATS.get(path.suffix.lower())
    if kind is None:
        raise MeshError(where, f"unknown mesh format {path.suffix!r} (expected one of {', '.join(FORMATS)})")
    if size <= len(head) and not head.strip():
        raise MeshError(where, "file is empty")
    if kind == "stl":
        _check_stl_header(head, size, where)
    elif kind in ("gltf", "glb"):
        doc, binary = _gltf_json(path, kind, where)
        _check_gltf_uris(doc, path)
        _check_gltf_buffers(doc, path, binary)
        _check_gltf_accessors(doc, where)
        _check_gltf_nodes(doc, where)
    return kind


class _Piece(NamedTuple):
    """A mesh as a reader gives it, before the pieces are joined and checked: ``part`` and
    ``material`` (m,) index its own ``part_names`` and ``material_names`` (None: all the
    first); ``has_uv`` (m,) says which faces have UVs when only some do."""

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None
    part_names: list[str]
    material_names: list[str]
    has_uv: np.ndarray | None = None
    part: np.ndarray | None = None
    material: np.ndarray | None = None


def _read(data: bytes, kind: str, path: Path, warnings: list[str]) -> list[_Piece]:
    """Parse checked file bytes into pieces; what a user should know goes to ``warnings``."""
    if kind == "obj":  # our own reader: trimesh 5.2 resolves relative indices wrongly
        return [_read_obj(data, path, warnings)]
    if kind == "ply":  # our own reader first: trimesh reads no triangle strips, nor mixed binary polygons
        ply = read_ply(data)
        if ply is not None:
            return [_Piece(*ply, ["mesh"], [DEFAULT])]

    import trimesh  # pip install trimesh

    loaded = trimesh.load(
        io.BytesIO(data),
        file_type=kind,
        resolver=trimesh.resolvers.FilePathResolver(str(path.parent)),
        process=False,
    )
    return _parts(loaded)


def _read_obj(data: bytes, path: Path, warnings: list[str]) -> _Piece:
    """An OBJ as one piece of its groups and materials; a material library that is missing,
    or a ``usemtl`` name none of them defines, is a warning."""
    missing: list[str] = []
    defined: set[str] = set()

    def check(name, what):
        _check_reference(name, path, what)
        names = _check_mtl(path.parent / name, path)
        if names is None:
            missing.append(name)
        else:
            defined.update(names)

    obj = read_obj(data, path, check)
    for name in missing:
        warnings.append(f"the material library {name!r} (mtllib) is missing beside the mesh: its materials are known by "
                        "their usemtl names alone")
    unknown = [name for name in obj.material_names if name != DEFAULT and name not in defined]
    if unknown and defined:  # (all of them missing: said above)
        warnings.append(f"usemtl names materials that no material library defines: {', '.join(map(repr, unknown))}")
    return _Piece(obj.vertices, obj.faces, obj.uv, obj.part_names, obj.material_names, obj.has_uv, obj.part, obj.material)


def mesh_from_trimesh(mesh, *, name: str = "mesh", max_faces: int = 5_000_000) -> LoadedMesh:
    """Validate an in-memory ``trimesh.Trimesh`` or ``trimesh.Scene``.

    The same checks as :func:`load_mesh`; errors name the file ``"<mesh>"``. The input is
    not modified.
    """
    import trimesh

    _check_max_faces(max_faces)
    if not isinstance(mesh, (trimesh.Trimesh, trimesh.Scene)):
        raise TypeError(f"expected trimesh.Trimesh or trimesh.Scene, got {type(mesh).__name__}")
    h = hashlib.sha256()
    for g in [mesh] if isinstance(mesh, trimesh.Trimesh) else mesh.geometry.values():
        if isinstance(g, trimesh.Trimesh):
            h.update(np.ascontiguousarray(g.vertices, dtype=np.float64).tobytes())
            h.update(np.ascontiguousarray(g.faces, dtype=np.int64).tobytes())
    # copies: the loaded mesh must not share the caller's arrays
    parts = [p._replace(vertices=np.array(p.vertices, dtype=np.float64), faces=np.array(p.faces),
                        uv=None if p.uv is None else np.array(p.uv, dtype=np.float64)) for p in _parts(mesh)]
    return _validate(parts, name, "<mesh>", h.hexdigest(), max_faces)


def _check_max_faces(max_faces) -> None:
    if isinstance(max_faces, bool) or not isinstance(max_faces, (int, np.integer)) or max_faces < 1:
        raise ParameterError("max_faces", f"expected a positive integer, got {max_faces!r}")


def _short(exc: Exception) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return text[:200]


# -- references -------------------------------------------------------------------


def _check_reference(ref: str, path: Path, what: str) -> None:
    """Reject a referenced file name that is absolute, a URL, or escapes the folder."""
    ref = ref.strip()
    if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", ref) and not re.match(r"^[a-zA-Z]:[\\/]", ref):
        raise MeshError(str(path), f"{what} {ref!r} is a URL; only files beside the mesh are allowed")
    parts = PurePosixPath(ref.replace("\\", "/"))
    if parts.is_absolute() or re.match(r"^[a-zA-Z]:[\\/]", ref) or ".." in parts.parts:
        raise MeshError(str(path), f"{what} {ref!r} leaves the mesh's folder")
    folder = path.parent.resolve()
    try:
        target = (folder / parts).resolve()
    except (OSError, RuntimeError, ValueError):  # a symlink loop, a NUL byte
        raise MeshError(str(path), f"{what} {ref!r} cannot be resolved") from None
    if not target.is_relative_to(folder):  # a symbolic link out of the folder
        raise MeshError(str(path), f"{what} {ref!r} leaves the mesh's folder (through a link)")


_MTL_MAPS = re.compile(r"^\s*(map_\w+|bump|disp|decal|refl|norm)\s+(.*)$", re.M | re.I)


_NEWMTL = re.compile(r"^\s*newmtl\s+(.*?)\s*$", re.M)


def _check_mtl(mtl: Path, path: Path) -> set[str] | None:
    """The names of the materials ``mtl`` defines, its texture maps checked; None when it
    is missing (a missing MTL only loses the materials' definitions)."""
    if not mtl.is_file():
        return None
    try:
        text = mtl.read_text(errors="replace")
    except OSError as exc:
        raise MeshError(str(path), f"cannot read {mtl.name}: {exc.strerror}") from None
    for _, args in _MTL_MAPS.findall(text):
        words = args.split()
        if words:  # the file name is the last word; options come before it
            _check_reference(words[-1], path, f"texture in {mtl.name}")
    return {" ".join(name.split()) for name in _NEWMTL.findall(text)}


def _gltf_json(path: Path, kind: str, where: str) -> tuple[dict, int | None]:
    """The JSON of a glTF file, or of a GLB's first chunk (read alone), and the length of a
    GLB's binary chunk (None: a glTF, or a GLB without one)."""
    binary = None
    try:
        with open(path, "rb") as f:
            if kind == "glb":
                magic, _, length = struct.unpack("<4sII", f.read(12))
                chunk_length, chunk_type = struct.unpack("<I4s", f.read(8))
                if magic != b"glTF" or chunk_type != b"JSON" or chunk_length > path.stat().st_size - 20:
                    raise ValueError("not a GLB file")
                doc = json.loads(f.read(chunk_length))
                header = f.read(8)
                if len(header) == 8 and header[4:] == b"BIN\x00":
                    binary = min(struct.unpack_from("<I", header)[0], path.stat().st_size - 28 - chunk_length)
            else:
                doc = json.loads(f.read())
    except (ValueError, struct.error, RecursionError) as exc:
        raise MeshError(where, f"cannot parse {kind.upper()} header: {_short(exc)}") from None
    if not isinstance(doc, dict):
        raise MeshError(where, f"cannot parse {kind.upper()} header: the JSON is a {type(doc).__name__}, not an object")
    return doc, binary


def _check_gltf_uris(doc: dict, path: Path) -> None:
    for section in ("buffers", "images"):
        items = doc.get(section) or []
        if not isinstance(items, list):
            raise MeshError(str(path), f"glTF {section!r} must be a list, got {type(items).__name__}")
        for item in items:
            uri = item.get("uri") if isinstance(item, dict) else None
            if isinstance(uri, str) and not uri.startswith("data:"):
                from urllib.parse import unquote

                _check_reference(unquote(uri), path, f"{section[:-1]} uri")


def _buffer_bytes(buffer: dict, path: Path, binary: int | None) -> int:
    """How many bytes a glTF buffer has: a GLB's binary chunk (no ``uri``), a data URI's
    payload (base64 decoded, counted without decoding) or the file beside the mesh."""
    from urllib.parse import unquote

    uri = buffer.get("uri")
    if uri is None:
        return binary or 0
    if not isinstance(uri, str):
        raise TypeError(uri)
    if uri.startswith("data:"):
        header, _, payload = uri.partition(",")
        if header.endswith(";base64"):
            payload = "".join(payload.split())
            return len(payload) * 3 // 4 - (len(payload) - len(payload.rstrip("=")))  # less the padding
        return len(unquote(payload).encode())
    try:
        return (path.parent / unquote(uri)).stat().st_size
    except OSError:
        raise MeshError(str(path), f"glTF buffer file {uri!r} is missing") from None


def _check_gltf_buffers(doc: dict, path: Path, binary: int | None) -> None:
    """Every buffer must hold the bytes it claims, every buffer view lie inside its buffer
    (trimesh trusts the claims: past the data it fails an assertion, with no reason)."""
    where = str(path)
    sizes = []
    for i, buffer in enumerate(doc.get("buffers") or []):
        try:
            claimed, held = int(buffer["byteLength"]), _buffer_bytes(buffer, path, binary)
        except (KeyError, TypeError, ValueError, AttributeError):
            raise MeshError(where, f"glTF buffer {i} is malformed") from None
        if claimed < 0 or claimed > held:
            raise MeshError(where, f"glTF buffer {i} claims {claimed:,} bytes but the file holds {held:,}")
        sizes.append(claimed)
    views = doc.get("bufferViews") or []
    if not isinstance(views, list):
        raise MeshError(where, f"glTF 'bufferViews' must be a list, got {type(views).__name__}")
    for i, view in enumerate(views):
        try:
            start, length, size = int(view.get("byteOffset", 0)), int(view["byteLength"]), sizes[view["buffer"]]
        except (KeyError, IndexError, TypeError, ValueError, AttributeError):
            raise MeshError(where, f"glTF buffer view {i} is malformed") from None
        if start < 0 or length < 0 or start + length > size:
            raise MeshError(where, f"glTF buffer view {i} (bytes {start:,} to {start + length:,}) lies outside its buffer of {size:,} bytes")


def _check_gltf_nodes(doc: dict, where: str) -> None:
    """The nodes must form trees (every child in range, one parent each, no cycle), at most
    ``MAX_GLTF_NODES`` of them, nested at most ``MAX_GLTF_DEPTH`` deep (a root: 1)."""
    nodes = doc.get("nodes") or []
    if not isinstance(nodes, list):
        raise MeshError(where, f"glTF 'nodes' must be a list, got {type(nodes).__name__}")
    if len(nodes) > MAX_GLTF_NODES:
        raise MeshError(where, f"glTF has {len(nodes):,} nodes: the limit is {MAX_GLTF_NODES:,}")
    children: list[list[int]] = []
    parent: dict[int, int] = {}
    for i, node in enumerate(nodes):
        listed = node.get("children") or [] if isinstance(node, dict) else None
        if not isinstance(listed, list) or not all(type(c) is int and 0 <= c < len(nodes) for c in listed):
            raise MeshError(where, f"glTF node {i} has malformed children")
        for child in listed:
            if parent.get(child) == i:
                raise MeshError(where, f"glTF node {i} lists its child {child} twice")
            if child in parent:
                raise MeshError(where, f"glTF node {child} has two parents (nodes {parent[child]} and {i}): the nodes must form trees")
            parent[child] = i
        children.append(listed)
    level, deepest, reached = [i for i in range(len(nodes)) if i not in parent], 0, 0
    while level:  # breadth first from the roots, each node once (one parent each)
        deepest, reached = deepest + 1, reached + len(level)
        level = [c for i in level for c in children[i]]
    if reached < len(nodes):  # the others hang from a cycle
        raise MeshError(where, "glTF nodes form a cycle (a node is its own ancestor): the nodes must form trees")
    if deepest > MAX_GLTF_DEPTH:
        raise MeshError(where, f"glTF nodes nest {deepest:,} deep: the limit is {MAX_GLTF_DEPTH}")


_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def _check_gltf_accessors(doc: dict, where: str) -> None:
    """Every accessor must fit in its buffer view (a lying count would allocate it all)."""
    views = doc.get("bufferViews") or []
    for i, acc in enumerate(doc.get("accessors") or []):
        try:
            count = int(acc.get("count", 0))
            item = _COMPONENT_BYTES[acc["componentType"]] * _TYPE_COMPONENTS[acc["type"]]
            if "bufferView" not in acc:
                continue  # all zeros (or sparse): nothing is read
            view = views[acc["bufferView"]]
            stride = int(view.get("byteStride") or item)
            need = int(acc.get("byteOffset", 0)) + (count - 1) * stride + item if count > 0 else 0
            have = int(view["byteLength"])
        except (KeyError, IndexError, TypeError, ValueError, AttributeError):
            raise MeshError(where, f"glTF accessor {i} is malformed") from None
        if count < 0 or need > have:
            raise MeshError(where, f"glTF accessor {i} asks for {count} items ({need:,} bytes) but its buffer view holds {have:,} bytes")


def _check_stl_header(head: bytes, size: int, where: str) -> None:
    """A binary STL's triangle count must match the file's length (``size`` bytes)."""
    if size < 84 or (head.lstrip()[:5].lower() == b"solid" and b"facet" in head):
        return  # ASCII STL (or too short to be binary: the parser says why)
    count = struct.unpack_from("<I", head, 80)[0]
    if 84 + 50 * count != size:
        raise MeshError(where, f"binary STL header says {count:,} triangles ({84 + 50 * count:,} bytes) but the file has {size:,} bytes")


# -- geometry ----------------------------------------------------------------------


def _parts(loaded) -> list[_Piece]:
    """A piece for every triangle mesh, transforms applied; a scene's parts are named by
    their meshes, and each has its material (:func:`_material_names`)."""
    import trimesh

    if isinstance(loaded, trimesh.Trimesh):
        return [_Piece(loaded.vertices, loaded.faces, _uv(loaded), ["mesh"], [DEFAULT])]
    if not isinstance(loaded, trimesh.Scene):
        return []
    parts = []
    nodes = loaded.graph.nodes_geometry
    uses = collections.Counter(loaded.graph.transforms.node_data[node]["geometry"] for node in nodes)
    materials = _material_names(loaded)
    for node in nodes:
        transform, name = _world_transform(loaded.graph, node), loaded.graph.transforms.node_data[node]["geometry"]
        g = loaded.geometry[name]
        if isinstance(g, trimesh.Trimesh):
            v = np.asarray(g.vertices, dtype=np.float64)
            v = v @ transform[:3, :3].T + transform[:3, 3]
            f = np.asarray(g.faces)
            if np.linalg.det(transform[:3, :3]) < 0:  # a mirroring node: keep faces outward
                f = f[:, ::-1]
            # the mesh's name (trimesh names a glTF file's unnamed nodes at random), and its node's where it is used twice
            parts.append(_Piece(v, f, _uv(g), [name if uses[name] == 1 else f"{name} at node {node}"], [materials[name]]))
    return parts


def _material_names(scene) -> dict[str, str]:
    """Each geometry's material name: its own, ``material_N`` for the N-th unnamed one
    (trimesh keeps one object per glTF material), ``default`` without one."""
    names: dict[str, str] = {}
    unnamed: dict[int, str] = {}
    for key, g in scene.geometry.items():
        material = getattr(getattr(g, "visual", None), "material", None)
        name = getattr(material, "name", None)
        if material is None:
            names[key] = DEFAULT
        elif isinstance(name, str) and name.strip():
            names[key] = " ".join(name.split())
        else:
            names[key] = unnamed.setdefault(id(material), f"material_{len(unnamed)}")
    return names


_IDENTITY = np.eye(4)


def _world_transform(graph, node) -> np.ndarray:
    """``graph[node]``'s transform (trimesh's scene graph: from its base frame to ``node``),
    the same bits, in time linear in the node's depth.

    trimesh takes the matrices along the path from the base frame, leaves out those within
    1e-8 of the identity (on a path of two edges or more), multiplies the rest with
    ``np.linalg.multi_dot`` and repairs a nearly rigid result (``fix_rigid``). For square
    matrices of one size multi_dot multiplies from the right, ``A @ (B @ (C @ ...))``, but
    first searches for that order in time cubic in their number. Here the same products,
    in that order, without the search.
    """
    from trimesh.transformations import fix_rigid

    forest = graph.transforms
    path = [node]
    while path[-1] != graph.base_frame:
        path.append(forest.parents[path[-1]])
    edges = [forest.edge_data[(u, v)] for v, u in itertools.pairwise(path)]  # leaf first
    if len(edges) == 1:
        matrix = edges[0]["matrix"]
    else:
        matrices = [e["matrix"] for e in edges if "matrix" in e and np.abs(e["matrix"] - _IDENTITY).max() > 1e-8]
        matrix = matrices[0] if matrices else _IDENTITY
        for m in matrices[1:]:  # leaf first: each next one multiplies from the left
            matrix = np.dot(m, matrix)
    return matrix if graph.repair_rigid is None else fix_rigid(matrix, max_deviance=graph.repair_rigid)


def _uv(mesh):
    uv = getattr(mesh.visual, "uv", None)
    if uv is None or len(uv) != len(mesh.vertices):
        return None
    return np.asarray(uv, dtype=np.float64)


def _weld(vertices, faces, uv):
    """Merge vertices equal in position and UV (trimesh splits every face corner).

    Exact equality only: corners that differ in UV stay separate (UV seams survive), and
    a welded surface keeps its connectivity for the unwrap and the normals. Rows of
    position and UV are grouped by their bits in a compiled hash table
    (``native/grouping.cpp``), kept in file order. A vertex
    without UVs (NaN, from a part that has none) merges only with others without them.
    """
    welded = _native.weld(np.ascontiguousarray(vertices, dtype=np.float64), None if uv is None else np.ascontiguousarray(uv, dtype=np.float64))
    if welded is None:
        return vertices, faces, uv  # not finite: rejected (vertices) or judged by the atlas (UVs)
    first, inverse = welded  # numbered in file order: the first of each group kept
    if len(first) == len(vertices):  # nothing merged: the arrays as they are
        return vertices, faces, uv
    return vertices[first], inverse[faces], None if uv is None else uv[first]


def _joined_uv(parts: list[_Piece]) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(uv, has_uv)`` of the pieces put together: UVs with NaN rows for the pieces that
    have none (None if none has any), and which faces have UVs (None if all or none do)."""
    if all(p.uv is None for p in parts):
        return None, None
    if len(parts) == 1:  # a file of one mesh: its arrays as they are
        return np.asarray(parts[0].uv, dtype=np.float64), parts[0].has_uv
    uv = np.concatenate([np.asarray(p.uv, dtype=np.float64) if p.uv is not None else np.full((len(p.vertices), 2), np.nan)
                         for p in parts])
    has = np.concatenate([p.has_uv if p.has_uv is not None else np.full(len(p.faces), p.uv is not None) for p in parts])
    return uv, None if has.all() else has


def _joined_labels(parts: list[_Piece], what: str) -> tuple[np.ndarray | None, list[str]]:
    """``(label (m,) int32 or None, names)`` of the pieces' ``what``: "part", each piece's
    parts its own; "material", one per name whichever piece has it. None for one name."""
    known: dict[str, int] = {}  # material name -> its index
    names: list[str] = []
    labels = []
    for p in parts:
        local, given = (p.part_names, p.part) if what == "part" else (p.material_names, p.material)
        if what == "part":
            code = list(range(len(names), len(names) + len(local)))
            names += local
        else:
            code = [known.setdefault(n, len(known)) for n in local]
            names = list(known)
        labels.append(np.asarray(code, dtype=np.int32)[np.zeros(len(p.faces), dtype=np.int64) if given is None else given])
    return (np.concatenate(labels) if len(names) > 1 else None), names


def _validate(parts: list[_Piece], name: str, where: str, sha256: str, max_faces: int, warnings: list[str] | None = None) -> LoadedMesh:
    """One checked mesh from the pieces a reader gave."""
    parts = [p for p in parts if len(p.faces)]
    if not parts:
        raise MeshError(where, "no faces: the file holds no triangle geometry")
    n_faces = sum(len(p.faces) for p in parts)
    if n_faces > max_faces:
        raise MeshError(where, f"{n_faces} faces is more than the limit of {max_faces}")
    vertex_parts, face_parts, offset = [], [], 0
    for p in parts:
        v = np.asarray(p.vertices, dtype=np.float64)
        f = np.asarray(p.faces)
        if f.ndim != 2 or f.shape[1] != 3:
            raise MeshError(where, f"faces must be triangles, got shape {f.shape}")
        if f.min() < 0 or f.max() >= len(v):
            raise MeshError(where, f"face index {int(f.max()) if f.max() >= len(v) else int(f.min())} out of range ({len(v)} vertices)")
        vertex_parts.append(v)
        f = np.asarray(f, dtype=np.int64)
        face_parts.append(f + offset if offset else f)
        offset += len(v)
    # one part (a file of one mesh): its arrays as they are; copies of millions of rows cost
    vertices = vertex_parts[0] if len(parts) == 1 else np.concatenate(vertex_parts)
    faces = face_parts[0] if len(parts) == 1 else np.concatenate(face_parts)
    uv, has_uv = _joined_uv(parts)
    part, names = _joined_labels(parts, "part")
    material, material_names = _joined_labels(parts, "material")
    vertices, faces, uv = _weld(vertices, faces, uv)
    if not np.isfinite(vertices).all():
        bad = int((~np.isfinite(vertices)).any(axis=1).sum())
        raise MeshError(where, f"{bad} vertices have non-finite (NaN or infinite) coordinates")
    largest = max(-float(vertices.min()), float(vertices.max()))  # np.abs(vertices).max() of finite ones
    if largest > FLOAT32_MAX:
        raise MeshError(where, f"coordinate {largest:.3g} is beyond float32 range")

    area2 = areas(vertices, faces)
    area2 *= 2.0  # |e1 x e2|
    diag = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    keep = area2 > 1e-30 * diag * diag
    if not keep.any():
        raise MeshError(where, f"all {len(faces)} faces are degenerate (zero area at the scale of the bounding-box diagonal {diag:.3g})")
    faces_kept = faces if keep.all() else faces[keep]
    unique = _without_duplicates(faces_kept)
    if len(unique) < len(faces_kept):
        faces_kept = faces_kept[unique]
    part = None if part is None else part[keep][unique]
    material, material_names = _used_materials(None if material is None else material[keep][unique], material_names)
    if has_uv is not None:
        has_uv = has_uv[keep][unique]
        if has_uv.all() or not has_uv.any():  # the parts with (or without) UVs were all degenerate
            uv, has_uv = (uv, None) if has_uv.all() else (None, None)
    return LoadedMesh(vertices, faces_kept, uv, name, where, int((~keep).sum()), sha256, int(keep.sum()) - len(unique),
                      has_uv, part, names, list(warnings or []), material, material_names)


def _used_materials(material: np.ndarray | None, names: list[str]) -> tuple[np.ndarray | None, list[str]]:
    """The materials some face kept (the faces removed may take a material's all), numbered
    in order; None for one."""
    if material is None:
        return None, names
    used, label = np.unique(material, return_inverse=True)
    if len(used) == 1:
        return None, [names[used[0]]]
    return label.astype(np.int32).ravel(), [names[i] for i in used]


def _without_duplicates(faces: np.ndarray) -> np.ndarray:
    """The indices, in order, of ``faces`` (of welded vertices) less those that repeat an
    earlier face's corners in the same winding: a doubled face takes atlas space twice and
    splits charts."""
    corners = np.empty_like(faces)
    _native.rotated_faces(np.ascontiguousarray(faces, dtype=np.int64), corners)  # each face from its smallest corner
    return group_rows(corners)[0]  # ascending
