"""The texture catalogue, health and readiness."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException

from bake.textures.spec import catalogue, json_schema

from ..health import ready

router = APIRouter(tags=["meta"])


@router.get("/v1/textures")
def textures():
    return {"textures": catalogue(), "schema": json_schema()}


@router.get("/healthz")
async def healthz():
    """Liveness: answered on the event loop, never queued behind uploads in the thread pool."""
    return {"ok": True}


@router.get("/readyz")
def readyz():
    """Readiness: the jobs table and the queue answer."""
    try:
        queued = ready()
    except Exception as exc:  # the answer is the check's result
        raise HTTPException(503, detail=f"not ready: {type(exc).__name__}: {exc}") from None
    return {"ok": True, "queue": queued}
