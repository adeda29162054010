"""/v1/jobs: upload a mesh with bake settings, follow the job, download its outputs."""

from __future__ import annotations

import functools
import json
import logging
import uuid
from typing import Annotated
from urllib.parse import quote

from fastapi import APIRouter, File, Form, HTTPException, Query, Request, Response, UploadFile
from fastapi.responses import StreamingResponse
from pydantic import BeforeValidator, Json

from texbake.errors import ParameterError
from texbake.memory import check_fits
from texbake.meshmaps.kinds import SOURCE_KINDS

from ...core import crud
from ...core.config import get_settings
from ...core.models import Job
from ...storage import Storage, StorageMissing, get_storage, zip_stream
from ...worker.tasks import enqueue_bake, state_changed
from ..deps import ClientDep, JobDep, SessionDep, SettingsDep, StorageDep
from ..jsondepth import shallow
from ..schemas import BakeSettings, JobOut, JobPage, SetOut
from ..uploads import FILES_DOC, MESH_DOC, Upload, check_names, copy_of, receive, safe_stem
from .inspect import read_upload

router = APIRouter(prefix="/v1/jobs", tags=["jobs"])
logger = logging.getLogger("texbake.service")
LIMIT_RETRY_SECONDS = 30  # a client at its limit waits for a bake to finish: seconds, not milliseconds


def job_url(job_id: str, request: Request) -> str:
    """The job's URL: under ``BAKE_BASE_URL`` when set (what a client should see behind a
    proxy, never what its Host header claims), else the request's own address."""
    base = get_settings().base_url
    return f"{base.rstrip('/')}/v1/jobs/{job_id}" if base else str(request.url_for("get_job", job_id=job_id))


OUTPUTS_LOST = "its outputs are gone from the store: retry the job to bake them again"


def _checked(session, job: Job, storage: Storage) -> dict[str, int]:
    """A done job's outputs as the store holds them (name -> size; {} for a job not done).

    A done job whose store lacks an output its report lists, or holds none (the store lost
    its objects), is failed here with :data:`OUTPUTS_LOST` first: it lets go of its key, so
    a retry or the same upload bakes it again, and no one is told to download what is gone.
    """
    if job.state != "done":
        return {}
    files = storage.outputs(job.id, job.lease)
    listed = {o.get("path") for o in ((job.as_dict()["report"] or {}).get("outputs") or {}).values() if isinstance(o, dict)} - {None}
    if files and listed <= set(files):
        return files
    if crud.lose_outputs(session, job.id, job.lease, OUTPUTS_LOST):
        state_changed(job.id, "failed", OUTPUTS_LOST)
    session.refresh(job)
    return {}


def _out(job: Job, request: Request, session) -> JobOut:
    files = sorted(_checked(session, job, get_storage()))
    data = job.as_dict()
    report = data["report"] or {}
    sets = SetOut.from_report(report) if files else []
    return JobOut(url=job_url(job.id, request), files=files, warnings=report.get("warnings", []), sets=sets, **data)


def _bake_settings(parsed: BakeSettings | None, settings) -> BakeSettings:
    """The job's settings within this server's limits (which only tighten the bake's own);
    the face limit, when the client sets none, is this server's."""
    parsed = parsed or BakeSettings()
    if wanted := [kind for kind in parsed.maps or () if kind in SOURCE_KINDS]:  # a job uploads one mesh (and its files)
        raise HTTPException(422, detail=f"settings.maps: {', '.join(wanted)} bake a source mesh onto the uploaded one, and a job "
                                        "takes no source mesh: bake them with `texbake bake --source` or the library")
    limits = {"size": (max(parsed.width_height), settings.max_size), "samples": (parsed.samples, settings.max_samples),
              "max_faces": (parsed.max_faces if "max_faces" in parsed.model_fields_set else 0, settings.max_faces),
              "frames": (len(parsed.frames or ()), settings.max_frames)}
    for name, (value, limit) in limits.items():
        if value > limit:
            raise HTTPException(422, detail=f"settings.{name}: {value} is over this server's limit of {limit}")
    try:  # the maps' memory, before the mesh is read: its faces, and the sets it has beyond those named, not yet
        check_fits(parsed, 0, workers=1, limit=settings.job_memory_mb << 20, sets=_named_sets(parsed))
    except ParameterError as exc:  # named as the other settings are
        raise HTTPException(422, detail=f"settings.{exc.name}: {exc.problem}") from None
    if "max_faces" in parsed.model_fields_set:
        return parsed
    return BakeSettings.build(parsed, max_faces=settings.max_faces)


def _named_sets(parsed: BakeSettings) -> list[tuple]:
    """The texture sets a bake has whatever its mesh, ``(settings, images)`` each
    (``texbake.memory.check_fits``): one per material ``materials`` names, each with its
    own settings (one image each at least: its UDIM tiles are known once the mesh is read);
    without ``materials``, one of the bake's settings. The bake's process counts every set
    and tile against the same limit where it reads the mesh."""
    return [(parsed.for_material(name), 1) for name in parsed.materials or {}] or [(parsed, 1)]


def _check_materials(info: dict, parsed: BakeSettings, filename: str | None, settings) -> None:
    """A 422 naming ``settings.materials`` for a material the mesh (``info``: what
    :func:`.inspect.read_upload` read) has not, and naming ``settings.size`` when its
    texture sets and UDIM tiles, each at its own settings, need more than a bake's memory."""
    have = [m["name"] for m in info["materials"]]
    unknown = sorted(set(parsed.materials or {}) - set(have))
    if unknown:
        raise HTTPException(422, detail=f"settings.materials: {filename!r} has no material {unknown[0]!r}; "
                                        f"its materials: {', '.join(map(repr, have))}")
    sets = []
    for m in info["materials"]:
        own = parsed.for_material(m["name"])
        sets.append((own, 1 if own.uv == "unwrap" or not m["tiles"] else len(m["tiles"])))  # as texbake.sets.images_of
    try:
        check_fits(parsed, info["faces"], workers=1, limit=settings.job_memory_mb << 20, sets=sets)
    except ParameterError as exc:
        raise HTTPException(422, detail=f"settings.{exc.name}: {exc.problem}") from None


def _too_many(unfinished: int, limit: int) -> HTTPException:
    return HTTPException(429, detail=f"{unfinished} unfinished jobs: the limit per client is {limit}",
                         headers={"Retry-After": str(LIMIT_RETRY_SECONDS)})


def _check_unfinished(session, client: str, settings) -> None:
    """Refuse a client at its limit before its upload is copied (the exact count is
    :func:`crud.create_job`'s, in the transaction that inserts)."""
    unfinished = crud.unfinished(session, client)
    if unfinished >= settings.jobs_per_client:
        raise _too_many(unfinished, settings.jobs_per_client)


def _make_job(request: Request, response: Response, session, settings, storage: Storage, client: str, *,
              upload: Upload, mesh_name: str, options: dict, key: str) -> JobOut:
    """The job of the mesh (and its companions) in ``upload`` with bake ``options``, queued;
    or the queued, running or done job with the same ``key`` (the answer's status then 200)."""
    job = crud.live_job(session, key)  # the same upload again: answered without storing it once more
    if job is not None and not (job.state == "done" and not _checked(session, job, storage)):
        response.status_code = 200
        response.headers["Location"] = job_url(job.id, request)
        return _out(job, request, session)
    # the upload first, the row second: a job in the table always has its upload
    job_id = uuid.uuid4().hex
    name = upload.mesh  # the outputs are named after it
    storage.save_input(job_id, upload.files(), {"mesh": name, "files": upload.companions, "settings": options})
    try:
        job, created = crud.create_job(session, job_id=job_id, key=key, client=client, mesh_name=mesh_name, settings=options,
                                       limit=settings.jobs_per_client)
        if not created and job.state == "done" and not _checked(session, job, storage):  # its outputs are gone: so is its key
            job, created = crud.create_job(session, job_id=job_id, key=key, client=client, mesh_name=mesh_name, settings=options,
                                           limit=settings.jobs_per_client)
    except crud.LimitReached as exc:
        storage.delete(job_id)
        raise _too_many(exc.unfinished, exc.limit) from None
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
    return _out(job, request, session)


@router.post("", status_code=202, response_model=JobOut)
def create_job(
    request: Request, response: Response, session: SessionDep, settings: SettingsDep, client: ClientDep, storage: StorageDep,
    mesh: Annotated[UploadFile, File(description=MESH_DOC)],
    files: Annotated[list[UploadFile], File(default_factory=list, description=FILES_DOC)],
    bake_settings: Annotated[Json[BakeSettings] | None, BeforeValidator(shallow),
                             Form(alias="settings", description="BakeSettings as JSON (default: all defaults)")] = None,
):
    """Upload a mesh, the files it refers to and its bake settings; the bake is queued (202).
    The same upload with the same settings returns the existing job (200) instead of baking
    twice.

    One mesh as ``mesh``; an OBJ's MTL and images, or a glTF's .bin buffers and images, as
    ``files`` beside it (the field repeated, once a file), each under the name the mesh
    uses: ``curl -F mesh=@capsule.obj -F files=@capsule.mtl -F files=@capsule0.jpg ...``.
    Every name is checked (a plain file name of a known kind, at most 255 bytes); the
    upload limit counts every part together; a buffer the mesh needs and that was not sent,
    or a file the mesh does not refer to, is a 422 naming it.

    A plain function: FastAPI runs it in its thread pool, so the copying, hashing and
    database work of one upload never holds up the event loop (or ``/healthz``)."""
    suffix, names = check_names(mesh, files)
    baked = _bake_settings(bake_settings, settings)
    options = baked.model_dump(mode="json")  # one serialisation of the resolved settings: the job's, the worker's and the dedup key's
    _check_unfinished(session, client, settings)
    upload = receive(mesh, files, names, safe_stem(mesh.filename) + suffix, settings.data_dir / "uploads", settings.max_upload_bytes)
    try:
        if baked.materials:  # names of the mesh's materials: checked against the mesh, read once it is here
            _check_materials(read_upload(upload, mesh.filename, settings), baked, mesh.filename, settings)
        key = upload.key(options, client if settings.api_keys else None)  # with keys, each client has its own jobs
        return _make_job(request, response, session, settings, storage, client, upload=upload, mesh_name=mesh.filename or "mesh",
                         options=options, key=key)
    finally:
        upload.discard()


@router.post("/{job_id}/retry", status_code=202, response_model=JobOut)
def retry_job(job: JobDep, request: Request, response: Response, session: SessionDep, settings: SettingsDep, client: ClientDep,
              storage: StorageDep):
    """Bake a failed or cancelled job again: a new job from its upload and settings (202),
    or the queued, running or done job that has them already (200)."""
    if job.state not in ("failed", "cancelled"):
        raise HTTPException(409, detail=f"job {job.id} is {job.state}: only a failed or cancelled job is retried")
    _check_unfinished(session, client, settings)
    try:
        folder = storage.fetch_input(job.id, job.lease)  # (from an object store: a copy of its own)
        try:
            upload = copy_of(folder, json.loads((folder / "job.json").read_text()), settings.data_dir / "uploads")
        finally:
            storage.done_with(folder)
    except (StorageMissing, FileNotFoundError):  # deleted by retention, or from the store
        raise HTTPException(409, detail=f"job {job.id}: its upload is no longer kept; upload the mesh again") from None
    try:
        return _make_job(request, response, session, settings, storage, client, upload=upload, mesh_name=job.mesh_name,
                         options=json.loads(job.settings), key=job.key)
    finally:
        upload.discard()


@router.get("", response_model=JobPage)
def list_jobs(request: Request, session: SessionDep, settings: SettingsDep, client: ClientDep,
              offset: Annotated[int, Query(ge=0, le=2**31 - 1)] = 0, limit: Annotated[int, Query(ge=1, le=200)] = 50):
    """A page of jobs, newest first (with API keys: the caller's own)."""
    total, jobs = crud.list_jobs(session, client if settings.api_keys else None, offset, limit)
    return JobPage(jobs=[_out(j, request, session) for j in jobs], total=total, offset=offset, limit=limit)


@router.get("/{job_id}", response_model=JobOut, name="get_job")
def get_job(job: JobDep, request: Request, session: SessionDep):
    return _out(job, request, session)


@router.delete("/{job_id}", response_model=JobOut)
def cancel_job(job: JobDep, session: SessionDep, request: Request):
    """Cancel a queued or running job (a running bake is stopped within a heartbeat)."""
    if not crud.cancel(session, job.id):
        raise HTTPException(409, detail=f"job {job.id} is {job.state}: nothing to cancel")
    return _out(crud.get_job(session, job.id) or job, request, session)


def _outputs(session, job: Job, storage: Storage) -> dict[str, int]:
    files = _checked(session, job, storage)
    if not files:
        raise HTTPException(409, detail=f"job {job.id} is {job.state}: " + (OUTPUTS_LOST if job.error == OUTPUTS_LOST else "no outputs yet"))
    return files


@router.get("/{job_id}/files/{name}")
def get_file(job: JobDep, name: str, storage: StorageDep, session: SessionDep):
    files = _outputs(session, job, storage)
    if name not in files:  # names are matched, never joined: no path traversal
        raise HTTPException(404, detail=f"job {job.id} has no file {name!r} (has: {', '.join(sorted(files))})")
    return storage.file_response(job.id, job.lease, name, files[name])


@router.get("/{job_id}/result.zip")
def get_zip(job: JobDep, storage: StorageDep, session: SessionDep):
    """Every output in one zip, written as it is sent (constant memory, any size)."""
    members = [(name, size, functools.partial(storage.read, job.id, job.lease, name)) for name, size in sorted(_outputs(session, job, storage).items())]
    return StreamingResponse(zip_stream(members), media_type="application/zip", headers={"Content-Disposition": _attachment(_zip_name(job))})


def _zip_name(job: Job) -> str:
    """``<mesh stem>-<texture>.zip``: results downloaded side by side are told apart by what they are."""
    settings = json.loads(job.settings)
    texture = settings.get("texture", BakeSettings.model_fields["texture"].default) or "maps"  # None: texture none, mesh maps only
    name = texture.get("name", "texture") if isinstance(texture, dict) else str(texture)
    return f"{safe_stem(job.mesh_name)}-{safe_stem(name)}.zip"


def _attachment(filename: str) -> str:
    """A Content-Disposition for ``filename``: an ASCII ``filename`` for old clients, the
    exact one as ``filename*`` (RFC 6266; header values are Latin-1, a name may not be)."""
    fallback = filename.encode("ascii", "replace").decode().replace("?", "_")
    return f"attachment; filename=\"{fallback}\"; filename*=UTF-8''{quote(filename)}"
