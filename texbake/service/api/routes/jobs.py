"""/v1/jobs: upload a mesh with bake settings, follow the job, download its outputs."""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
import shutil
import uuid
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, File, Form, HTTPException, Query, Request, Response, UploadFile
from fastapi.responses import StreamingResponse
from pydantic import Json
from sqlalchemy import func, select, true

from texbake.errors import MeshError
from texbake.memory import check_fits
from texbake.mesh.load import FORMATS, check_file

from ...core import db
from ...core.config import get_settings
from ...storage import Storage, StorageMissing, get_storage, zip_stream
from ...worker.tasks import enqueue_bake, state_changed
from ..deps import ClientDep, JobDep, SessionDep, SettingsDep, StorageDep
from ..schemas import BakeSettings, JobOut, JobPage

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])
logger = logging.getLogger("texbake.service")
_CHUNK = 1 << 20
UPLOAD_FORMATS = tuple(suffix for suffix in FORMATS if suffix != ".gltf")  # a glTF's buffers would be separate files


def job_url(job_id: str, request: Request) -> str:
    """The job's URL: under ``BAKE_BASE_URL`` when set (what a client should see behind a
    proxy, never what its Host header claims), else the request's own address."""
    base = get_settings().base_url
    return f"{base.rstrip('/')}/v1/jobs/{job_id}" if base else str(request.url_for("get_job", job_id=job_id))


def _out(job: db.Job, request: Request) -> JobOut:
    files = sorted(get_storage().outputs(job.id, job.lease)) if job.state == "done" else []
    data = job.as_dict()
    warnings = (data["report"] or {}).get("warnings", [])
    return JobOut(url=job_url(job.id, request), files=files, warnings=warnings, **data)


def _safe_stem(filename: str | None) -> str:
    """The upload's name without folders or odd characters (it names the outputs)."""
    stem = Path((filename or "mesh").replace("\\", "/")).stem
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in stem)[:64] or "mesh"


def _bake_options(parsed: BakeSettings | None, settings) -> dict:
    """The job's settings within this server's limits (which only tighten the bake's own),
    as set by the client: what is left out comes from the preset or the defaults."""
    parsed = parsed or BakeSettings()
    limits = {"size": (max(parsed.width_height), settings.max_size), "samples": (parsed.quality_settings().samples, settings.max_samples),
              "max_faces": (parsed.max_faces if "max_faces" in parsed.model_fields_set else 0, settings.max_faces),
              "frames": (len(parsed.frames or ()), settings.max_frames)}
    for name, (value, limit) in limits.items():
        if value > limit:
            raise HTTPException(422, detail=f"settings.{name}: {value} is over this server's limit of {limit}")
    check_fits(parsed, 0, workers=1, limit=settings.job_memory_mb << 20)  # the maps' memory: the faces are not counted yet
    out = parsed.model_dump(mode="json", exclude_unset=True)
    out.setdefault("max_faces", settings.max_faces)
    return out


def _receive(mesh: UploadFile, suffix: str, settings) -> tuple[Path, hashlib._Hash]:
    """Stream the upload to a temporary file, stopped at the limit, and check what can be
    told without parsing (the bake's process parses it). Returns the file and its sha256."""
    uploads = settings.data_dir / "uploads"
    uploads.mkdir(parents=True, exist_ok=True)
    tmp = uploads / f"{uuid.uuid4().hex}{suffix}"
    digest, size = hashlib.sha256(), 0
    try:
        with open(tmp, "wb") as f:
            while chunk := mesh.file.read(_CHUNK):
                size += len(chunk)
                if size > settings.max_upload_bytes:
                    raise HTTPException(413, detail=f"mesh: larger than the limit of {settings.max_upload_bytes} bytes")
                digest.update(chunk)
                f.write(chunk)
        check_file(tmp)
    except MeshError as exc:
        tmp.unlink(missing_ok=True)
        raise HTTPException(422, detail=f"mesh {mesh.filename!r}: {exc.problem}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp, digest


def _resolved(options: dict) -> dict:
    """Every setting of the bake, quality preset resolved: two uploads that bake the same
    are the same job, however their settings were written."""
    settings = BakeSettings.build(options)
    return {**settings.model_dump(mode="json"), **dataclasses.asdict(settings.quality_settings())}


def _check_unfinished(session, client: str, settings) -> None:
    unfinished = session.scalar(select(func.count()).select_from(db.Job).where(db.Job.client == client, db.Job.state.in_(("queued", "running")))) or 0
    if unfinished >= settings.jobs_per_client:
        raise HTTPException(429, detail=f"{unfinished} unfinished jobs: the limit per client is {settings.jobs_per_client}")


def _make_job(request: Request, response: Response, session, settings, storage: Storage, client: str, *,
              upload: Path, name: str, mesh_name: str, options: dict, key: str) -> JobOut:
    """The job of the mesh in ``upload`` (stored as ``name``) with bake ``options``, queued;
    or the queued, running or done job with the same ``key`` (the answer's status then 200)."""
    # the upload first, the row second: a job in the table always has its upload
    job_id = uuid.uuid4().hex
    storage.save_input(job_id, upload, name, {"mesh": name, "settings": options})  # outputs are named after it
    try:
        job, created = db.create_job(session, job_id=job_id, key=key, client=client, mesh_name=mesh_name, settings=options)
    except BaseException:
        storage.delete(job_id)
        raise
    if created:
        state_changed(job.id, "queued", f"{name}, client {client}")
        try:
            enqueue_bake(job.id)
        except Exception as exc:  # the job is in the table: the reaper enqueues it once the queue answers
            logger.warning("job %s: the queue write failed (%s: %s): the reaper enqueues it within %g s",
                           job.id, type(exc).__name__, exc, settings.requeue_seconds)
    else:  # the same upload's job exists already
        storage.delete(job_id)
        response.status_code = 200
    response.headers["Location"] = job_url(job.id, request)
    return _out(job, request)


@router.post("", status_code=202, response_model=JobOut)
def create_job(
    request: Request, response: Response, session: SessionDep, settings: SettingsDep, client: ClientDep, storage: StorageDep,
    mesh: Annotated[UploadFile, File(description="OBJ, PLY, STL, OFF, glTF or GLB")],
    bake_settings: Annotated[Json[BakeSettings] | None, Form(alias="settings", description="BakeSettings as JSON (default: all defaults)")] = None,
):
    """Upload a mesh and its bake settings; the bake is queued (202). The same upload with
    the same settings returns the existing job (200) instead of baking twice.

    A plain function: FastAPI runs it in its thread pool, so the copying, hashing and
    database work of one upload never holds up the event loop (or ``/healthz``)."""
    if mesh.filename and (len(mesh.filename) > 255 or "\x00" in mesh.filename):
        raise HTTPException(422, detail=f"mesh: the file name must be at most 255 characters, without NUL (got {len(mesh.filename)}: {mesh.filename[:40]!r}...)")
    suffix = Path(mesh.filename or "").suffix.lower()
    if suffix not in UPLOAD_FORMATS:
        raise HTTPException(422, detail=f"mesh: {mesh.filename!r} is not a single-file mesh ({' '.join(UPLOAD_FORMATS)})")
    options = _bake_options(bake_settings, settings)
    _check_unfinished(session, client, settings)
    tmp, digest = _receive(mesh, suffix, settings)
    try:
        digest.update(json.dumps(_resolved(options), sort_keys=True).encode())
        if settings.api_keys:  # with keys, each client has its own jobs
            digest.update(client.encode())
        return _make_job(request, response, session, settings, storage, client, upload=tmp, name=_safe_stem(mesh.filename) + suffix,
                         mesh_name=mesh.filename or "mesh", options=options, key=digest.hexdigest())
    finally:
        tmp.unlink(missing_ok=True)


@router.post("/{job_id}/retry", status_code=202, response_model=JobOut)
def retry_job(job: JobDep, request: Request, response: Response, session: SessionDep, settings: SettingsDep, client: ClientDep,
              storage: StorageDep):
    """Bake a failed or cancelled job again: a new job from its upload and settings (202),
    or the queued, running or done job that has them already (200)."""
    if job.state not in ("failed", "cancelled"):
        raise HTTPException(409, detail=f"job {job.id} is {job.state}: only a failed or cancelled job is retried")
    _check_unfinished(session, client, settings)
    uploads = settings.data_dir / "uploads"
    uploads.mkdir(parents=True, exist_ok=True)
    try:
        folder = storage.fetch_input(job.id, job.lease)  # (from an object store: a copy of its own)
        try:
            name = json.loads((folder / "job.json").read_text())["mesh"]
            tmp = uploads / f"{uuid.uuid4().hex}{Path(name).suffix}"
            shutil.copyfile(folder / name, tmp)
        finally:
            storage.done_with(folder)
    except (StorageMissing, FileNotFoundError):  # deleted by retention, or from the store
        raise HTTPException(409, detail=f"job {job.id}: its upload is no longer kept; upload the mesh again") from None
    try:
        return _make_job(request, response, session, settings, storage, client, upload=tmp, name=name, mesh_name=job.mesh_name,
                         options=json.loads(job.settings), key=job.key)
    finally:
        tmp.unlink(missing_ok=True)


@router.get("", response_model=JobPage)
def list_jobs(request: Request, session: SessionDep, settings: SettingsDep, client: ClientDep,
              offset: Annotated[int, Query(ge=0, le=2**31 - 1)] = 0, limit: Annotated[int, Query(ge=1, le=200)] = 50):
    """A page of jobs, newest first (with API keys: the caller's own)."""
    mine = db.Job.client == client if settings.api_keys else true()
    total = session.scalar(select(func.count()).select_from(db.Job).where(mine))
    jobs = session.scalars(select(db.Job).where(mine).order_by(db.Job.created.desc()).offset(offset).limit(limit)).all()
    return JobPage(jobs=[_out(j, request) for j in jobs], total=total, offset=offset, limit=limit)


@router.get("/{job_id}", response_model=JobOut, name="get_job")
def get_job(job: JobDep, request: Request):
    return _out(job, request)


@router.delete("/{job_id}", response_model=JobOut)
def cancel_job(job: JobDep, session: SessionDep, request: Request):
    """Cancel a queued or running job (a running bake is stopped within a heartbeat)."""
    if not db.cancel(session, job.id):
        raise HTTPException(409, detail=f"job {job.id} is {job.state}: nothing to cancel")
    session.refresh(job)
    return _out(job, request)


def _outputs(job: db.Job, storage: Storage) -> dict[str, int]:
    files = storage.outputs(job.id, job.lease) if job.state == "done" else {}
    if not files:
        raise HTTPException(409, detail=f"job {job.id} is {job.state}: no outputs yet")
    return files


@router.get("/{job_id}/files/{name}")
def get_file(job: JobDep, name: str, storage: StorageDep):
    files = _outputs(job, storage)
    if name not in files:  # names are matched, never joined: no path traversal
        raise HTTPException(404, detail=f"job {job.id} has no file {name!r} (has: {', '.join(sorted(files))})")
    return storage.file_response(job.id, job.lease, name, files[name])


@router.get("/{job_id}/result.zip")
def get_zip(job: JobDep, storage: StorageDep):
    """Every output in one zip, written as it is sent (constant memory, any size)."""
    members = [(name, size, functools.partial(storage.read, job.id, job.lease, name)) for name, size in sorted(_outputs(job, storage).items())]
    return StreamingResponse(zip_stream(members), media_type="application/zip",
                             headers={"Content-Disposition": f'attachment; filename="{job.id}.zip"'})
