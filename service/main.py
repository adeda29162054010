"""The HTTP API: ``create_app()`` wires the routers; ``texbake serve`` runs it."""

from __future__ import annotations

from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse

from bake.errors import BakeError

from .routes import jobs, meta


@asynccontextmanager
async def lifespan(app: FastAPI):
    from .tasks import reap_once

    reap_once()  # jobs whose worker died while the API was down go back to the queue
    yield


def create_app() -> FastAPI:
    app = FastAPI(title="texbake", version="0.1.0", lifespan=lifespan,
                  description="Upload a mesh and a texture spec; get baked maps and a textured GLB.")
    app.include_router(jobs.router)
    app.include_router(meta.router)

    @app.exception_handler(BakeError)
    async def bake_error(request: Request, exc: BakeError):
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    return app
