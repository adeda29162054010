"""What a client uploads: one mesh and the files it refers to (its companions), received
into a folder of their own, each name and the references between them checked.

A mesh is one ``mesh`` part; an OBJ's MTL files and their images, or a glTF's ``.bin``
buffers and images, come as ``files`` parts beside it, each under the name the mesh (or
its MTL) uses. What must be sent follows what the loader needs (:func:`texbake.mesh.load_mesh`):

- a glTF's (or GLB's) buffer files: without them there is no geometry (a 422 naming the file);
- not an OBJ's MTL, nor the images: the loader checks them where they are and bakes
  without them (a bake draws its own texture), as the command line does;
- every part sent is one the mesh or a sent MTL refers to, by a plain file name with a
  known suffix: nothing else is stored with a job.

Only names and references are read here; the bake's process parses the mesh.
"""

from __future__ import annotations

import hashlib
import json
import mmap
import re
import shutil
import struct
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote

from fastapi import HTTPException, UploadFile

from texbake.errors import MeshError
from texbake.mesh import FORMATS, check_file

UPLOAD_FORMATS = tuple(FORMATS)
# What a mesh may refer to: an OBJ's MTL, a glTF's buffers, and the images either may use.
COMPANION_FORMATS = (".mtl", ".bin", ".png", ".jpg", ".jpeg", ".webp", ".ktx2", ".tga", ".bmp", ".tif", ".tiff")
MAX_COMPANIONS = 64
MAX_NAME = 255
_CHUNK = 1 << 20
# Not a plain file name: folders, what Windows, a shell or a URL parser reads as more than
# a name, control characters, lone surrogates, a hidden name, a name ending in a dot or a space.
_NOT_PLAIN = re.compile(r'[\x00-\x1f\x7f\ud800-\udfff/\\:*?"<>|]|^[.\s]|[.\s]$')
# An OBJ's material libraries, and an MTL's texture maps as the loader reads them (the
# file name is the last word, options come before it). The first starts with its keyword,
# which re finds at memchr's speed (20x the form anchored at a line's start); _scan keeps
# the matches that begin a line.
_MTLLIB = re.compile(rb"mtllib[ \t]+([^\r\n]*)")
_MTL_MAPS = re.compile(rb"^[ \t]*(?:map_\w+|bump|disp|decal|refl|norm)[ \t]+([^\r\n]*)", re.M | re.I)

MESH_DOC = f"The mesh: {', '.join(UPLOAD_FORMATS)} (a .gltf with its buffers as data: URIs, or with them in 'files')"
FILES_DOC = (f"The files the mesh refers to, each under the name it uses ({', '.join(COMPANION_FORMATS)}): an OBJ's MTL and its "
             "images, a glTF's .bin buffers and images. A glTF's buffers must be sent; an OBJ's MTL and the images may be left "
             "out (the bake draws its own texture). Every file must be one the mesh or a sent MTL refers to, by a plain file name.")


@dataclass
class Upload:
    """One request's parts, received into ``folder``: the mesh as ``mesh`` (a name made from
    the client's: it names the outputs), the companions under their own names."""

    folder: Path
    mesh: str
    companions: list[str] = field(default_factory=list)
    mesh_digest: hashlib._Hash | None = None  # of the mesh's bytes
    digests: dict[str, str] = field(default_factory=dict)  # companion -> sha256 of its bytes

    def files(self) -> dict[str, Path]:
        """Every part's name -> its file, the mesh first."""
        return {name: self.folder / name for name in [self.mesh, *self.companions]}

    def key(self, options: dict, client: str | None) -> str:
        """The dedup key: the bytes of every part, the companions' names (the mesh refers to
        them by name), the settings and (with API keys) the client. A lone mesh's key is what
        it was before companions: its bytes, the settings, the client."""
        assert self.mesh_digest is not None
        digest = self.mesh_digest.copy()
        digest.update(json.dumps(options, sort_keys=True).encode())
        if client is not None:
            digest.update(client.encode())
        for name in sorted(self.digests):
            digest.update(b"\x00" + name.encode() + b"\x00" + bytes.fromhex(self.digests[name]))
        return digest.hexdigest()

    def discard(self) -> None:
        shutil.rmtree(self.folder, ignore_errors=True)


def safe_stem(filename: str | None) -> str:
    """The upload's name without folders or odd characters (it names the outputs), at most
    64 characters and 200 bytes as UTF-8 (a file name on disk takes 255 bytes, and a letter
    may take 4)."""
    stem = Path((filename or "mesh").replace("\\", "/")).stem
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in stem)[:64]
    return safe.encode()[:200].decode(errors="ignore") or "mesh"


def check_names(mesh: UploadFile, files: list[UploadFile]) -> tuple[str, list[str]]:
    """The mesh's suffix and the companions' names, or a 422 naming the part, before a byte
    is read."""
    if mesh.filename and (len(mesh.filename) > MAX_NAME or "\x00" in mesh.filename):
        raise HTTPException(422, detail=f"mesh: the file name must be at most {MAX_NAME} characters, without NUL "
                                        f"(got {len(mesh.filename)}: {mesh.filename[:40]!r}...)")
    suffix = Path(mesh.filename or "").suffix.lower()
    if suffix in COMPANION_FORMATS:
        raise HTTPException(422, detail=f"mesh: {mesh.filename!r} is not a mesh: send the mesh as 'mesh' and the files it refers to as 'files'")
    if suffix not in UPLOAD_FORMATS:
        raise HTTPException(422, detail=f"mesh: {mesh.filename!r} is not a mesh file this server takes ({' '.join(UPLOAD_FORMATS)})")
    if len(files) > MAX_COMPANIONS:
        raise HTTPException(422, detail=f"files: {len(files)} files; at most {MAX_COMPANIONS} are taken beside a mesh")
    names: list[str] = []
    for part in files:
        name = part.filename or ""
        if not name or len(name.encode()) > MAX_NAME or _NOT_PLAIN.search(name):  # (a file name on disk: 255 bytes)
            raise HTTPException(422, detail=f"files: {name[:80]!r} is not a plain file name (at most {MAX_NAME} bytes as UTF-8, "
                                            "no folders, no control characters or any of \\:*?\"<>|, not hidden)")
        if Path(name).suffix.lower() not in COMPANION_FORMATS:
            raise HTTPException(422, detail=f"files: {name!r} is not a file a mesh refers to ({' '.join(COMPANION_FORMATS)})")
        if name in names:
            raise HTTPException(422, detail=f"files: {name!r} is sent twice")
        names.append(name)
    return suffix, names


def receive(mesh: UploadFile, files: list[UploadFile], names: list[str], mesh_name: str, uploads: Path, limit: int) -> Upload:
    """Stream every part into a folder of its own under ``uploads``, ``limit`` bytes at most
    in all (413), then check the mesh's references (:func:`check_references`) and what can
    be told of it without parsing (:func:`texbake.mesh.check_file`): a 422 naming the file."""
    upload = Upload(uploads / uuid.uuid4().hex, mesh_name, list(names))
    upload.folder.mkdir(parents=True)
    try:
        upload.mesh_digest, used = _copy(mesh, upload.folder / mesh_name, limit, f"mesh: larger than the limit of {limit} bytes")
        for part, name in zip(files, names, strict=True):
            digest, size = _copy(part, upload.folder / name, limit - used,
                                 f"files: the mesh and its files are larger than the limit of {limit} bytes together")
            upload.digests[name], used = digest.hexdigest(), used + size
        try:
            check_references(upload.folder / mesh_name, names)
            check_file(upload.folder / mesh_name)
        except MeshError as exc:
            raise HTTPException(422, detail=f"mesh {mesh.filename!r}: {exc.problem}") from None
    except BaseException:
        upload.discard()
        raise
    return upload


def _copy(part: UploadFile, to: Path, budget: int, too_large: str) -> tuple[hashlib._Hash, int]:
    """Copy ``part`` to ``to``, stopped with a 413 saying ``too_large`` once it passes
    ``budget`` bytes; its sha256 and size."""
    digest, size = hashlib.sha256(), 0
    with open(to, "wb") as f:
        while chunk := part.file.read(_CHUNK):
            size += len(chunk)
            if size > budget:
                raise HTTPException(413, detail=too_large)
            digest.update(chunk)
            f.write(chunk)
    return digest, size


def check_references(mesh: Path, sent: list[str]) -> None:
    """Raise a :class:`MeshError` for a buffer the mesh needs that was not sent, or for a
    part sent that neither the mesh nor a sent MTL refers to.

    Only plain file names count: a reference that leaves the folder, a URL or a data URI
    is :func:`texbake.mesh.check_file`'s to judge, as is a file that cannot be parsed."""
    found = _references(mesh, sent)
    if found is None:  # not readable: check_file says why
        return
    needed, optional = found
    for name in needed:
        if name not in sent and not _NOT_PLAIN.search(name):
            raise MeshError(str(mesh), f"refers to {name!r}, which was not sent: send it as a 'files' part beside the mesh")
    referred = set(needed) | set(optional)
    for name in sent:
        if name not in referred:
            others = ", ".join(repr(n) for n in sorted(referred - {name})) or "no other file"
            raise MeshError(str(mesh), f"does not refer to {name!r}, sent beside it (it refers to {others})")


def _references(mesh: Path, sent: list[str]) -> tuple[list[str], list[str]] | None:
    """The files ``mesh`` refers to: (needed to load it, optional), as written in it; None
    for a glTF whose JSON cannot be read."""
    kind = FORMATS.get(mesh.suffix.lower())
    if kind == "obj":
        if not sent:  # nothing to match: a lone OBJ's MTL is the loader's business
            return [], []
        libraries = [name for line in _scan(mesh, _MTLLIB) for name in line.split()]
        maps = [words[-1] for lib in libraries if lib in sent for line in _scan(mesh.parent / lib, _MTL_MAPS) if (words := line.split())]
        return [], libraries + maps
    if kind in ("gltf", "glb"):
        doc = _gltf_json(mesh)
        return None if doc is None else (_uris(doc, "buffers"), _uris(doc, "images"))
    return [], []


def _scan(path: Path, pattern: re.Pattern[bytes]) -> list[str]:
    """The first group of each match of ``pattern`` in the file (mapped, not read: an OBJ
    may be as large as the upload limit), decoded as the loader decodes names."""
    if path.stat().st_size == 0:
        return []
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
        return [m.group(1).decode("utf-8", "replace").strip() for m in pattern.finditer(data)
                if not data[data.rfind(b"\n", 0, m.start()) + 1:m.start()].strip(b" \t")]


def _gltf_json(path: Path) -> dict | None:
    """A glTF's JSON, or a GLB's first chunk; None when it cannot be read."""
    try:
        with open(path, "rb") as f:
            if path.suffix.lower() == ".glb":
                f.seek(12)
                length, kind = struct.unpack("<I4s", f.read(8))
                doc = json.loads(f.read(length)) if kind == b"JSON" else None
            else:
                doc = json.loads(f.read())
    except (ValueError, struct.error, RecursionError):
        return None
    return doc if isinstance(doc, dict) else None


def _uris(doc: dict, section: str) -> list[str]:
    """The file URIs of a glTF's ``buffers`` or ``images`` (not data URIs), percent-decoded."""
    items = doc.get(section)
    found = [item.get("uri") for item in items if isinstance(item, dict)] if isinstance(items, list) else []
    return [unquote(uri) for uri in found if isinstance(uri, str) and not uri.startswith("data:")]


def copy_of(folder: Path, job: dict, uploads: Path) -> Upload:
    """A copy of a stored upload (``folder`` from :meth:`Storage.fetch_input`, described by
    its ``job.json``) in a folder of its own under ``uploads``: for a job made again from it."""
    upload = Upload(uploads / uuid.uuid4().hex, job["mesh"], list(job.get("files", [])))
    upload.folder.mkdir(parents=True)
    try:
        for name, path in upload.files().items():
            shutil.copyfile(folder / name, path)
    except BaseException:
        upload.discard()
        raise
    return upload
