"""/v1/inspect: what a mesh holds before it is baked (its materials, their faces, UVs and
UDIM tiles), read by the bake's own loader in a child process (:mod:`..meshinfo`), so a
client (the page) can give each material settings of its own by the names a bake takes."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, Depends, File, HTTPException, UploadFile

from ..deps import SettingsDep, client_id
from ..meshinfo import WAIT_SECONDS, Busy, Inspector
from ..schemas import MeshInfo
from ..uploads import FILES_DOC, MESH_DOC, Upload, check_names, receive, safe_stem

router = APIRouter(prefix="/v1/inspect", tags=["jobs"], dependencies=[Depends(client_id)])  # with API keys, a key is needed


_readers: dict[tuple[int, Path], Inspector] = {}  # one per configuration (tests change the settings)
_readers_lock = threading.Lock()


def inspector(memory_mb: int, folder: Path) -> Inspector:
    """The API process's reader of meshes with these settings."""
    with _readers_lock:
        return _readers.setdefault((memory_mb, folder), Inspector(memory_mb, folder))


def stop_inspectors() -> None:
    """End every reader's thread and child (the API is stopping)."""
    with _readers_lock:
        readers = list(_readers.values())
        _readers.clear()
    for reader in readers:
        reader.stop()


def read_upload(upload: Upload, filename: str | None, settings) -> dict:
    """What the mesh of ``upload`` holds (:func:`..meshinfo.describe`'s ``info``), read in
    the reader's child; a 422 naming the mesh when it cannot be read, a 503 when the
    reader is busy."""
    try:
        answer = inspector(settings.job_memory_mb, settings.data_dir / "inspect").inspect(upload.folder, upload.mesh, settings.max_faces)
    except Busy:
        raise HTTPException(503, detail=f"the server is busy reading other meshes: try again in {WAIT_SECONDS:g} s",
                            headers={"Retry-After": str(int(WAIT_SECONDS))}) from None
    if "problem" in answer:
        raise HTTPException(422, detail=f"mesh {filename!r}: {answer['problem']}")
    return answer["info"]


@router.post("", response_model=MeshInfo)
def inspect_mesh(settings: SettingsDep, mesh: Annotated[UploadFile, File(description=MESH_DOC)],
                 files: Annotated[list[UploadFile], File(default_factory=list, description=FILES_DOC)]):
    """Read a mesh (with the files it refers to, as ``POST /v1/jobs`` takes them) and say
    what a bake of it would see: its materials, in the order of their texture sets, with
    their faces, whether they have UVs and the UDIM tiles those lie in. Nothing is kept.

    The names are the keys ``settings.materials`` takes. A file that is not a mesh this
    server can read is a 422 naming it; a server busy reading others, a 503."""
    suffix, names = check_names(mesh, files)
    upload = receive(mesh, files, names, safe_stem(mesh.filename) + suffix, settings.data_dir / "uploads", settings.max_upload_bytes)
    try:
        return MeshInfo(mesh=mesh.filename or upload.mesh, **read_upload(upload, mesh.filename, settings))
    finally:
        upload.discard()
