"""/v1/swatch: a texture evaluated without a mesh, as a small PNG (``texbake.swatch``), for the
page's live preview.

``GET`` takes the spec in the query (a name or JSON: cacheable by the browser), ``POST``
as a JSON body; both answer the same PNG. Swatches are cached by the hash of the resolved
spec, size and view (the ETag: an unchanged one is a 304), and at most ``RENDERERS`` are
rendered at once, so a page typing fast cannot take over the API's CPU.

With ``material`` (a built-in's name or a material object) and ``channel`` in place of
``texture``, the swatch is that channel of the material on the same sphere, unlit
(``texbake.swatch.material_swatch``): colour channels sRGB, data channels (roughness,
metallic, height, occlusion, opacity, the normal's encoding) stored as they are, so the
page's PBR-lit sphere reads them as a bake's maps. A bad material is a 422 naming the node.
"""

from __future__ import annotations

import functools
import hashlib
import json
import threading
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, Header, Query, Response
from pydantic import BaseModel, ConfigDict, Field

from texbake.errors import MaterialError, ParameterError, TextureError
from texbake.materials import CHANNELS, parse_material
from texbake.materials.nodes import COLOUR
from texbake.output import encode_png_bytes
from texbake.settings import Texture
from texbake.swatch import material_swatch, swatch
from texbake.textures import parse_spec
from texbake.version import __version__

from ..deps import client_id

router = APIRouter(prefix="/v1/swatch", tags=["textures"], dependencies=[Depends(client_id)])  # with API keys, a key is needed
SIZE = 256
MAX_SIZE = 512
RENDERERS = threading.BoundedSemaphore(2)
View = Literal["sphere", "slice"]
Channel = Literal["base_color", "roughness", "metallic", "normal", "height", "occlusion", "emissive", "opacity"]
_PNG: dict[int | str, dict[str, Any]] = {200: {"content": {"image/png": {}}, "description": "the swatch, sRGB with alpha (0 off the sphere)"}}


class SwatchIn(BaseModel):
    model_config = ConfigDict(extra="forbid")

    texture: Texture | None = Field(None, description="a texture name or spec object, as in the bake settings")
    material: Any = Field(None, description="in place of texture: a built-in material's name or a material object, as the "
                                            "bake's material setting takes")
    channel: Channel = Field("base_color", description="with material: the channel shown")
    size: int = Field(SIZE, ge=16, le=MAX_SIZE, description="width and height in pixels")
    view: View = Field("sphere", description="sphere: the texture on a lit sphere filling the unit texture space; slice: the plane z = 0.5")


@functools.lru_cache(maxsize=256)
def _png(spec_json: str, size: int, view: str) -> bytes:
    with RENDERERS:
        return encode_png_bytes(swatch(json.loads(spec_json), size, view))


@functools.lru_cache(maxsize=256)
def _material_png(material_json: str, channel: str, size: int, view: str) -> bytes:
    with RENDERERS:
        image = material_swatch(json.loads(material_json), channel, size, view)
    return encode_png_bytes(image, colorspace="linear" if CHANNELS[channel] == COLOUR and channel != "normal" else "data")


def _answer(spec, size: int, view: str, if_none_match: str | None, material=None, channel: str = "base_color") -> Response:
    if material is not None:
        if spec is not None:
            raise ParameterError("texture", "give a texture or a material, not both")
        try:
            parsed_material = parse_material(material)
        except MaterialError as exc:  # named as the settings name it: "material: node 'x': ..."
            raise ParameterError("material", str(exc)) from None
        key = json.dumps(parsed_material.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
        render = functools.partial(_material_png, key, channel, size, view)
        key = f"material|{channel}|{key}"
    else:
        if spec is None:
            raise ParameterError("texture", "required (or a material and its channel)")
        try:
            parsed = parse_spec(spec)
        except TextureError as exc:  # named as the settings name it: the field, then the problem
            raise TextureError(f"texture: {exc}") from None
        key = json.dumps(parsed.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
        render = functools.partial(_png, key, size, view)
    etag = '"' + hashlib.sha256(f"{__version__}|{size}|{view}|{key}".encode()).hexdigest()[:32] + '"'
    headers = {"ETag": etag, "Cache-Control": "private, max-age=3600"}
    if if_none_match and etag in (tag.strip() for tag in if_none_match.split(",")):
        return Response(status_code=304, headers=headers)
    return Response(render(), media_type="image/png", headers=headers)


@router.get("", response_class=Response, responses=_PNG)
def get_swatch(texture: Annotated[str | None, Query(min_length=1, max_length=8192, description="a texture name or a JSON spec object")] = None,
               size: Annotated[int, Query(ge=16, le=MAX_SIZE)] = SIZE, view: View = "sphere",
               material: Annotated[str | None, Query(min_length=1, max_length=8192, description="in place of texture: a built-in "
                                                     "material's name or a JSON material object")] = None,
               channel: Channel = "base_color", if_none_match: Annotated[str | None, Header(max_length=1024)] = None):
    """The texture on a sphere (or a slice through it) as a PNG, without a mesh: the bake's
    own evaluation, filtered by each pixel's footprint; or a material's channel."""
    return _answer(texture, size, view, if_none_match, material, channel)


@router.post("", response_class=Response, responses=_PNG)
def post_swatch(body: SwatchIn, if_none_match: Annotated[str | None, Header(max_length=1024)] = None):
    """As ``GET``, with the spec in a JSON body."""
    return _answer(body.texture, body.size, body.view, if_none_match, body.material, body.channel)
