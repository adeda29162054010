"""The texture catalogue, the built-in materials, the server's configuration, health and readiness."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from texbake.materials import BUILTINS, CHANNELS, DEFAULTS
from texbake.materials.nodes import VALUED
from texbake.textures.spec import catalogue, json_schema

from ...health import ready
from ..deps import SettingsDep
from ..schemas import BakeSettings, ServerConfig, ServerLimits
from ..uploads import COMPANION_FORMATS, MAX_COMPANIONS, UPLOAD_FORMATS
from .mtlx import MAX_BYTES as MTLX_MAX_BYTES

router = APIRouter(tags=["meta"])


@router.get("/v1/textures")
def textures():
    return {"textures": catalogue(), "schema": json_schema()}


@router.get("/v1/materials")
def materials():
    """The built-in materials, each as its JSON object (what the bake's ``material`` takes,
    by name or as the object); the channels, each ``scalar`` or ``colour``, and the value
    of one a material does not give; the textures that have a value (a scalar) as well as a
    colour: what the page's material editor starts from; the largest MaterialX document
    ``POST /v1/materials/mtlx`` reads (``mtlx_max_bytes``)."""
    return {"materials": list(BUILTINS.values()), "channels": CHANNELS, "defaults": DEFAULTS, "valued": list(VALUED),
            "mtlx_max_bytes": MTLX_MAX_BYTES}


@router.get("/v1/config", response_model=ServerConfig)
def config(settings: SettingsDep):
    """Whether this server needs an API key, its limits (a client can check a file's size
    before sending it), the mesh formats it takes, the files a mesh may bring beside it and
    the JSON Schema of the settings."""
    limits = ServerLimits(**{name: getattr(settings, name) for name in ServerLimits.model_fields})
    return ServerConfig(auth=bool(settings.api_keys), limits=limits, formats=list(UPLOAD_FORMATS),
                        companions=list(COMPANION_FORMATS), max_companions=MAX_COMPANIONS,
                        settings_schema=BakeSettings.model_json_schema())


@router.get("/healthz")
async def healthz():
    """Liveness: answered on the event loop, never queued behind uploads in the thread pool."""
    return {"ok": True}


@router.get("/readyz")
def readyz():
    """Readiness: the jobs table and the queue answer, a worker is alive, the disk has
    room (503 naming what is missing, without internals)."""
    answer = ready()
    if answer["ok"]:
        return answer
    names = {"database": "database", "queue": "queue", "storage": "object store"}
    missing = [f"the {said} is unavailable" for name, said in names.items() if answer[name] != "ok"]
    if answer["database"] == "ok" and not answer["workers"]:
        missing.append("no worker is alive")
    if not missing:
        missing.append(f"{answer['disk_free_mb']} MB free on the data folder's disk")
    return JSONResponse(status_code=503, headers={"Retry-After": "10"}, content={"detail": "not ready: " + "; ".join(missing), **answer})
