"""/v1/materials/mtlx: a MaterialX document read for the page's material editor.

The client uploads one ``.mtlx`` (multipart, the part ``mtlx``); the answer is what the
editor shows (``texbake.mtlx.material.describe_mtlx``): the material as the object the
bake's ``material`` setting takes (its graph-driven channels ``mtlx`` nodes holding the
document and its file name, so a job baked with it reads as ``--material FILE.mtlx`` does),
the shader, each channel's shader inputs, and warnings. Nothing is stored: the document is
read in memory and forgotten (a job made with the material keeps it in its settings).

A document over :data:`MAX_BYTES` is a 413; one that is not UTF-8, not XML, not valid
MaterialX, that includes another file, or whose graph texbake cannot bake is a 422 naming
the node and its category (``mtlx: wood.mtlx: node 'wood_image': image: ...``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, Depends, File, HTTPException, UploadFile
from fastapi.responses import JSONResponse
from pydantic import BaseModel

from texbake.errors import MtlxError

from ..deps import client_id
from ..jsondepth import MAX_BYTES as MAX_JSON_BYTES
from ..uploads import safe_stem

router = APIRouter(prefix="/v1/materials", tags=["textures"], dependencies=[Depends(client_id)])  # with API keys, a key is needed
MAX_BYTES = 256 * 1024  # of a document: MaterialX's examples are a few kB; in memory, never on disk
# the material is sent back whole with each swatch (a JSON body, at most MAX_JSON_BYTES): room kept for the rest
_JSON_ROOM = 16 * 1024


class ChannelOut(BaseModel):
    inputs: list[str]  # the shader's inputs whose product the channel is
    graph: bool  # evaluated at each point (an mtlx node); else a constant


class MtlxOut(BaseModel):
    name: str  # the material's
    file: str  # the document's name, as messages and the material's nodes give it
    material: dict  # the material object the bake's `material` setting takes
    shader: dict[str, str]  # {"category", "name"}
    channels: dict[str, ChannelOut]
    warnings: list[str]


class MtlxProblem(BaseModel):
    detail: str
    node: str | None = None  # the document's node that cannot be baked ("" for the document as a whole)


def _text(data: bytes, filename: str) -> str:
    if not data.strip():
        raise HTTPException(422, detail=f"mtlx: {filename!r} is empty")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise HTTPException(422, detail=f"mtlx: {filename!r} is not UTF-8 text (byte {exc.start})") from None


@router.post("/mtlx", response_model=MtlxOut, responses={422: {"model": MtlxProblem}})
def read_mtlx(mtlx: Annotated[UploadFile, File(description=f"A MaterialX document (.mtlx), at most {MAX_BYTES} bytes")]):
    """Read a ``.mtlx`` for the material editor: its material (the object the bake's
    ``material`` takes), shader, channels and warnings; nothing is kept."""
    from texbake.mtlx.material import describe_mtlx

    given = (mtlx.filename or "").replace("\\", "/")
    if Path(given).suffix.lower() != ".mtlx":
        raise HTTPException(422, detail=f"mtlx: {Path(given).name[:80]!r} is not a MaterialX document (.mtlx)")
    name = safe_stem(given) + ".mtlx"
    data = mtlx.file.read(MAX_BYTES + 1)
    if len(data) > MAX_BYTES:
        raise HTTPException(413, detail=f"mtlx: {name!r} is larger than the limit of {MAX_BYTES} bytes")
    try:
        found = describe_mtlx(_text(data, name), path=name)
    except MtlxError as exc:
        return JSONResponse(status_code=422, content={"detail": f"mtlx: {exc}", "node": exc.node})
    if len(json.dumps(found["material"])) > MAX_JSON_BYTES - _JSON_ROOM:  # each channel's node holds the document
        raise HTTPException(413, detail=f"mtlx: {name!r} makes a material of more than {MAX_JSON_BYTES - _JSON_ROOM} bytes "
                                        f"of JSON ({len(found['channels'])} channels, each with the document): too large to send")
    return MtlxOut(name=found["material"]["name"], file=name, **found)
