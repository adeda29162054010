"""The HTTP API: ``create_app()`` wires the routers; ``texbake serve`` runs it."""

from __future__ import annotations

import errno
import logging
import threading
import time
from contextlib import asynccontextmanager

from fastapi import FastAPI, HTTPException, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi_offline import FastAPIOffline
from redis.exceptions import RedisError
from sqlalchemy.exc import DataError, DBAPIError
from sqlalchemy.exc import TimeoutError as PoolTimeout

from texbake.errors import BakeError
from texbake.version import __version__

from .api import jsondepth
from .api.problems import request_problems
from .api.routes import inspect, jobs, meta, mtlx, swatch
from .api.routes.page import add_page
from .api.schemas import Problem
from .core.config import get_settings
from .storage import StorageError, StorageMissing
from .worker.tasks import reap_forever

logger = logging.getLogger("texbake.service")
access_log = logging.getLogger("texbake.access")


class BodyLimit:
    """Stop request bodies at ``limit`` bytes while they arrive: 413 with a JSON reason.

    Starlette spools a whole multipart upload to disk before the route runs, so the
    route's own limit comes too late for a huge body. A declared Content-Length over the
    limit is refused before anything is read; a chunked body is stopped where it passes
    the limit (an HTTPException, which the route's error handling turns into JSON).
    Starlette's own ``max_body_size`` answers in plain text, hence this.
    """

    def __init__(self, app, limit: int):
        self.app, self.limit = app, limit

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        too_large = HTTPException(413, detail=f"request body: larger than the limit of {self.limit} bytes")
        declared = dict(scope["headers"]).get(b"content-length", b"")
        if declared.isdigit() and int(declared) > self.limit:
            return await JSONResponse({"detail": too_large.detail}, status_code=413)(scope, receive, send)
        total = 0

        async def limited():
            nonlocal total
            message = await receive()
            total += len(message.get("body", b""))
            if total > self.limit:
                raise too_large
            return message

        await self.app(scope, limited, send)


class JsonLimit:
    """Refuse a JSON request body (``application/json`` or ``application/*+json``: what
    FastAPI parses as JSON) over ``jsondepth.MAX_BYTES`` (413) or nested deeper than
    ``jsondepth.MAX_DEPTH`` (422), before FastAPI parses it; both with a JSON reason."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or not _json_body(dict(scope["headers"]).get(b"content-type", b"")):
            return await self.app(scope, receive, send)
        chunks, size, more = [], 0, True
        try:
            while more:
                message = await receive()
                if message["type"] != "http.request":  # the client went away: let the app see it
                    return await self.app(scope, _replay([message], receive), send)
                chunks.append(message.get("body", b""))
                size += len(chunks[-1])
                more = message.get("more_body", False)
                if size > jsondepth.MAX_BYTES:
                    raise HTTPException(413, detail=f"request body: JSON larger than the limit of {jsondepth.MAX_BYTES} bytes")
            body = b"".join(chunks)
            if why := jsondepth.too_deep(body):
                raise HTTPException(422, detail=f"request body: {why}")
        except HTTPException as exc:  # (BodyLimit's too: raised from receive)
            return await JSONResponse({"detail": exc.detail}, status_code=exc.status_code)(scope, receive, send)
        await self.app(scope, _replay([{"type": "http.request", "body": body, "more_body": False}], receive), send)


def _json_body(content_type: bytes) -> bool:
    media = content_type.split(b";")[0].strip().lower()
    return media == b"application/json" or (media.startswith(b"application/") and media.endswith(b"+json"))


def _replay(messages: list, receive):
    """``receive`` that gives ``messages`` first, then what ``receive`` gives."""
    async def replayed():
        return messages.pop(0) if messages else await receive()

    return replayed


# Sent with every answer: no content sniffing (a PNG or a zip is never run as a script or
# a page), no framing by other sites, no Referer carrying a job's URL elsewhere. The page's
# own Content-Security-Policy is set by its route.
SECURITY_HEADERS = {"X-Content-Type-Options": "nosniff", "X-Frame-Options": "DENY", "Referrer-Policy": "no-referrer"}


class SecurityHeaders:
    """Add :data:`SECURITY_HEADERS` to every response (those a route set itself stay)."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)

        async def sending(message):
            if message["type"] == "http.response.start":
                present = {name.lower() for name, _ in message.get("headers", [])}
                extra = [(k.lower().encode(), v.encode()) for k, v in SECURITY_HEADERS.items() if k.lower().encode() not in present]
                message = {**message, "headers": [*message.get("headers", []), *extra]}
            await send(message)

        await self.app(scope, receive, sending)


RETRY_AFTER_SECONDS = 10


def unavailable(what: str, state: str = "unavailable") -> JSONResponse:
    """503 with ``Retry-After``: a dependency is down (or busy), the request may be sent again."""
    return JSONResponse(status_code=503, headers={"Retry-After": str(RETRY_AFTER_SECONDS)},
                        content={"detail": f"{what} is {state}: try again in {RETRY_AFTER_SECONDS} s"})


class AccessLog:
    """One line per request on ``texbake.access``: client, method, path, status, seconds."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        began, status = time.perf_counter(), 500  # what the client gets if nothing is sent

        async def sending(message):
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
            await send(message)

        try:
            await self.app(scope, receive, sending)
        finally:
            client = scope.get("client") or ("-", 0)
            seconds = round(time.perf_counter() - began, 3)
            access_log.info("%s %s %s %d %.3f", client[0], scope["method"], scope["path"], status, seconds,
                            extra={"client": client[0], "method": scope["method"], "path": scope["path"], "status": status, "seconds": seconds})


@asynccontextmanager
async def lifespan(app: FastAPI):
    """The reaper, every half BAKE_STALE_SECONDS while the API runs: jobs whose worker died
    go back to the queue, and queued jobs the queue lost are enqueued again. Stopping, it
    ends the mesh reader's child too (``/v1/inspect``)."""
    stop = threading.Event()
    reaper = threading.Thread(target=reap_forever, args=(stop,), name="reaper", daemon=True)
    reaper.start()
    try:
        yield
    finally:
        stop.set()
        inspect.stop_inspectors()
        reaper.join(10)


def create_app() -> FastAPI:
    # /docs and /redoc with their scripts served from the package (no CDN: they work offline)
    app = FastAPIOffline(title="texbake", version=__version__, lifespan=lifespan,
                         description="Upload a mesh and a texture spec; get baked maps and a textured GLB.",
                         responses={"4XX": {"model": Problem, "description": "what is wrong, naming the field or the file"}})
    app.add_middleware(JsonLimit)  # inside BodyLimit: a declared length over the limit is refused unread
    app.add_middleware(BodyLimit, limit=get_settings().max_upload_bytes + 1024 * 1024)  # room for the form
    app.add_middleware(SecurityHeaders)
    app.add_middleware(AccessLog)  # outermost: sees the 413s too
    app.include_router(jobs.router)
    app.include_router(inspect.router)
    app.include_router(meta.router)
    app.include_router(swatch.router)
    app.include_router(mtlx.router)
    add_page(app)  # the web page at /

    @app.exception_handler(BakeError)
    async def bake_error(request: Request, exc: BakeError):
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    @app.exception_handler(DBAPIError)
    async def database_error(request: Request, exc: DBAPIError):
        """The jobs table out of reach: 503, try again; a value the database refuses: 422."""
        if isinstance(exc, DataError):  # e.g. a string too long for its column that validation let through
            return JSONResponse(status_code=422, content={"detail": "a value in the request is not valid for the jobs table"})
        logger.warning("%s %s: the jobs table is unavailable: %s", request.method, request.url.path, type(exc.orig).__name__)
        return unavailable("the jobs database")

    @app.exception_handler(PoolTimeout)
    async def database_busy(request: Request, exc: PoolTimeout):
        """No pooled connection within BAKE_DATABASE_WAIT_SECONDS: 503, try again (never a request left waiting)."""
        logger.warning("%s %s: no database connection free in time", request.method, request.url.path)
        return unavailable("the jobs database", "busy")

    @app.exception_handler(RedisError)
    async def queue_error(request: Request, exc: RedisError):
        logger.warning("%s %s: the queue is unavailable: %s", request.method, request.url.path, type(exc).__name__)
        return unavailable("the queue")

    @app.exception_handler(StorageError)
    async def storage_error(request: Request, exc: StorageError):
        """The object store out of reach (or its bucket missing): 503, try again; an object gone: 404."""
        if isinstance(exc, StorageMissing):
            return JSONResponse(status_code=404, content={"detail": "the file is gone (its job expired?)"})
        logger.warning("%s %s: the object store is unavailable: %s", request.method, request.url.path, exc)
        return unavailable("the object store")

    @app.exception_handler(OSError)
    async def disk_error(request: Request, exc: OSError):
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            logger.error("%s %s: the data folder's disk is full", request.method, request.url.path)
            return unavailable("the server's disk (full)")
        return await server_error(request, exc)

    @app.exception_handler(Exception)
    async def server_error(request: Request, exc: Exception):
        """A bug: JSON like every other answer; the trace goes to the log."""
        logger.error("%s %s: internal error", request.method, request.url.path, exc_info=exc)
        # (answered outside every middleware, SecurityHeaders' included: its headers are set here)
        return JSONResponse(status_code=500, headers=SECURITY_HEADERS,
                            content={"detail": f"internal error ({type(exc).__name__}); the server's log has the details"})

    @app.exception_handler(RequestValidationError)
    async def invalid_request(request: Request, exc: RequestValidationError):
        """422 naming each bad field (``settings.size: ...``), the list under ``errors``."""
        detail, errors = request_problems(list(exc.errors()))
        return JSONResponse(status_code=422, content={"detail": detail, "errors": errors})

    return app
