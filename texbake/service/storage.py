"""Where uploads and outputs live: the data folder (:class:`LocalStorage`, the default) or
an S3-compatible object store (:class:`S3Storage`, ``BAKE_STORAGE_URL=s3://bucket/prefix``).
The routes, the bake task and retention use only :class:`Storage`'s methods.

A job's objects, under ``jobs/ID/`` of the data folder or of the store's prefix: the
upload (the mesh ``NAME`` and the files it refers to, each under its own name) and
``job.json`` (the mesh's name, the other files' names, the settings), stored by the API; the
outputs, published by the worker that holds the job's lease: in the data folder,
``out.tmp.LEASE`` renamed to ``out``; in a store, uploaded under ``out.LEASE/`` and made
visible by the jobs table (a reader looks only at a ``done`` job's ``out.LEASE/``, and the
row says ``done`` only after every file is there, with that lease). A worker on another
machine bakes in a copy of its own (``work/ID.LEASE/`` in its data folder), removed when
the bake ends.

Errors are typed: :class:`StorageUnavailable` (the store cannot be reached, or refuses:
the API answers 503, a worker tries again later) and :class:`StorageMissing` (no such
object).
"""

from __future__ import annotations

import functools
import json
import mimetypes
import shutil
import time
import zipfile
from collections.abc import Callable, Iterable, Iterator
from datetime import timedelta
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from fastapi.responses import FileResponse, StreamingResponse
from starlette.responses import Response

from .core.config import Settings, get_settings

if TYPE_CHECKING:
    from obstore.store import ClientConfig, RetryConfig

CHUNK = 1 << 20


class StorageError(Exception):
    """A storage operation that failed."""


class StorageUnavailable(StorageError):
    """The object store cannot be reached or refused the request: try again later."""


class StorageMissing(StorageError):
    """No such object (a job's upload deleted from under it)."""


class Storage(Protocol):
    def save_input(self, job_id: str, files: dict[str, Path], job: dict) -> None:
        """Store a job's upload (``files``: name -> file, the mesh and the files it refers to;
        the files may be moved away) and its ``job.json``."""

    def fetch_input(self, job_id: str, lease: int) -> Path:
        """A local folder holding the job's upload (every file) and ``job.json`` for a bake under
        ``lease`` (which writes ``out.tmp.LEASE`` there)."""

    def done_with(self, folder: Path) -> None:
        """The bake that had ``folder`` from :meth:`fetch_input` has ended."""

    def publish(self, job_id: str, lease: int, outputs: Path) -> None:
        """Publish the files in ``outputs`` (a bake's ``out.tmp.LEASE``) as the job's,
        under ``lease``; the caller holds the lease and marks the job done after."""

    def outputs(self, job_id: str, lease: int) -> dict[str, int]:
        """The published outputs of the job done under ``lease``: name -> size in bytes."""

    def read(self, job_id: str, lease: int, name: str) -> Iterator[bytes]:
        """One output's bytes, in chunks."""

    def file_response(self, job_id: str, lease: int, name: str, size: int) -> Response:
        """One output as an HTTP response, streamed (constant memory)."""

    def delete(self, job_id: str) -> None:
        """Remove everything of the job."""

    def sweep(self, jobs: dict[str, int | None], older_than: float) -> list[str]:
        """Remove left-overs older than ``older_than`` (a time.time()): the objects of a
        job not in ``jobs`` (id -> lease of a finished job, None for an unfinished one), a
        finished job's unpublished bake outputs. Returns what was removed."""

    def check(self) -> None:
        """Raise :class:`StorageUnavailable` when the store cannot be used."""


class LocalStorage:
    """The data folder: ``jobs/ID/`` holds the upload, ``out.tmp.LEASE`` while baking, ``out``."""

    def __init__(self, data_dir: Path):
        self.jobs = data_dir / "jobs"

    def _dir(self, job_id: str) -> Path:
        return self.jobs / job_id

    def save_input(self, job_id: str, files: dict[str, Path], job: dict) -> None:
        folder = self._dir(job_id)
        folder.mkdir(parents=True)
        for name, path in files.items():
            shutil.move(path, folder / name)
        (folder / "job.json").write_text(json.dumps(job))

    def fetch_input(self, job_id: str, lease: int) -> Path:
        return self._dir(job_id)

    def done_with(self, folder: Path) -> None:
        pass  # the job's own folder: it stays

    def publish(self, job_id: str, lease: int, outputs: Path) -> None:
        final = self._dir(job_id) / "out"
        shutil.rmtree(final, ignore_errors=True)
        outputs.rename(final)  # all files at once

    def outputs(self, job_id: str, lease: int) -> dict[str, int]:
        out = self._dir(job_id) / "out"
        return {p.name: p.stat().st_size for p in out.iterdir() if p.is_file()} if out.is_dir() else {}

    def read(self, job_id: str, lease: int, name: str) -> Iterator[bytes]:
        with open(self._dir(job_id) / "out" / name, "rb") as f:
            while chunk := f.read(CHUNK):
                yield chunk

    def file_response(self, job_id: str, lease: int, name: str, size: int) -> Response:
        return FileResponse(self._dir(job_id) / "out" / name, filename=name)

    def delete(self, job_id: str) -> None:
        shutil.rmtree(self._dir(job_id), ignore_errors=True)

    def sweep(self, jobs: dict[str, int | None], older_than: float) -> list[str]:
        removed = []
        for folder in sorted(p for p in self.jobs.iterdir() if p.is_dir()) if self.jobs.is_dir() else []:
            if folder.name not in jobs:
                if folder.stat().st_mtime < older_than:
                    removed.append(f"jobs/{folder.name}")
                    shutil.rmtree(folder, ignore_errors=True)
            elif jobs[folder.name] is not None:  # finished: a bake that died left its folder
                for tmp in folder.glob("out.tmp.*"):
                    if tmp.stat().st_mtime < older_than:
                        removed.append(f"jobs/{folder.name}/{tmp.name}")
                        shutil.rmtree(tmp, ignore_errors=True)
        return removed

    def check(self) -> None:
        pass  # /readyz reports the data folder's free space


# S3 client settings: a store that does not answer fails a request within seconds (the
# API answers 503 rather than hold the client for object_store's default of 3 minutes of
# retries); a long download is not cut short (the overall timeout), a stalled one is.
S3_RETRY: RetryConfig = {"max_retries": 3, "retry_timeout": timedelta(seconds=10)}
S3_CLIENT: ClientConfig = {"connect_timeout": "5s", "read_timeout": "60s", "timeout": "3600s"}


class S3Storage:
    """An S3-compatible store (obstore): ``jobs/ID/NAME`` (the mesh and each file it refers
    to), ``jobs/ID/job.json``, ``jobs/ID/out.LEASE/``.

    The endpoint, when not AWS's, is ``endpoint`` (plain http is allowed for an
    ``http://`` one: MinIO, moto); credentials and region come from the standard
    ``AWS_*`` environment variables (``AWS_ACCESS_KEY_ID``, ``AWS_SECRET_ACCESS_KEY``,
    ``AWS_SESSION_TOKEN``, ``AWS_REGION``, ``AWS_ENDPOINT_URL``...), read by obstore.
    """

    def __init__(self, url: str, data_dir: Path, endpoint: str | None = None):
        from obstore.store import S3Store  # the service extra's

        # client options replace the environment's, AWS_ALLOW_HTTP included: say it here
        client: ClientConfig = {**S3_CLIENT, "allow_http": bool(endpoint and endpoint.startswith("http://"))}
        self.url, self.work = url, data_dir / "work"
        self.store = S3Store.from_url(url, config={"endpoint": endpoint} if endpoint else None, client_options=client, retry_config=S3_RETRY)

    def _call(self, what: str, call: Callable[[], Any], missing_is_unavailable: bool = False) -> Any:
        """``call()`` with obstore's errors as ours (it raises a missing object as the built-in
        FileNotFoundError, an OSError: it must not pass for a local disk's)."""
        from obstore.exceptions import BaseError, NotFoundError

        try:
            return call()
        except (NotFoundError, FileNotFoundError) as exc:
            if missing_is_unavailable:  # a write or a listing: the bucket is missing
                raise StorageUnavailable(f"{what}: {self.url}: the bucket or prefix does not exist") from exc
            raise StorageMissing(f"{what}: not in {self.url}") from exc
        except (BaseError, OSError) as exc:
            raise StorageUnavailable(f"{what}: {self.url}: {type(exc).__name__}: {str(exc).splitlines()[0]}") from exc

    def _put(self, key: str, data: bytes | Path) -> None:
        import obstore

        self._call(f"storing {key}", lambda: obstore.put(self.store, key, data), missing_is_unavailable=True)

    def _list(self, prefix: str) -> list[dict]:
        import obstore

        # a listing finds nothing rather than fail: its 404 is the bucket's
        return self._call(f"listing {prefix}", lambda: [m for batch in obstore.list(self.store, prefix) for m in batch],
                          missing_is_unavailable=True)

    def _delete(self, keys: list[str]) -> None:
        import obstore

        for at in range(0, len(keys), 1000):  # S3's DeleteObjects takes 1000 keys at a time
            batch = keys[at:at + 1000]
            self._call(f"deleting {len(batch)} objects", functools.partial(obstore.delete, self.store, batch))

    def _open(self, key: str) -> Iterator[bytes]:
        """The object's chunks; asked for now (a store that fails fails here), read as iterated."""
        import obstore

        stream = self._call(f"reading {key}", lambda: obstore.get(self.store, key)).stream(CHUNK)

        def chunks() -> Iterator[bytes]:
            while (chunk := self._call(f"reading {key}", lambda: next(stream, None))) is not None:
                yield chunk

        return chunks()

    def save_input(self, job_id: str, files: dict[str, Path], job: dict) -> None:
        for name, path in files.items():
            self._put(f"jobs/{job_id}/{name}", path)  # from the file: multipart, constant memory
        self._put(f"jobs/{job_id}/job.json", json.dumps(job).encode())

    def fetch_input(self, job_id: str, lease: int) -> Path:
        folder = self.work / f"{job_id}.{lease}"
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        try:
            job = json.loads(b"".join(self._open(f"jobs/{job_id}/job.json")))
            # (the API's own names: never a path out of the folder, never job.json)
            mesh, files = _plain(job["mesh"]), [_plain(name) for name in job.get("files", [])]
            for name in [mesh, *files]:
                with open(folder / name, "wb") as f:
                    for chunk in self._open(f"jobs/{job_id}/{name}"):
                        f.write(chunk)
            (folder / "job.json").write_text(json.dumps({**job, "mesh": mesh, "files": files}))
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        return folder

    def done_with(self, folder: Path) -> None:
        shutil.rmtree(folder, ignore_errors=True)

    def publish(self, job_id: str, lease: int, outputs: Path) -> None:
        for p in sorted(outputs.iterdir()):
            self._put(f"jobs/{job_id}/out.{lease}/{p.name}", p)

    def outputs(self, job_id: str, lease: int) -> dict[str, int]:
        prefix = f"jobs/{job_id}/out.{lease}/"
        return {m["path"].removeprefix(prefix): m["size"] for m in self._list(prefix)}

    def read(self, job_id: str, lease: int, name: str) -> Iterator[bytes]:
        return self._open(f"jobs/{job_id}/out.{lease}/{name}")

    def file_response(self, job_id: str, lease: int, name: str, size: int) -> Response:
        chunks = self._open(f"jobs/{job_id}/out.{lease}/{name}")  # now: a store that fails is a 503, not a cut stream
        media = mimetypes.guess_type(name)[0] or "application/octet-stream"
        return StreamingResponse(chunks, media_type=media,
                                 headers={"Content-Length": str(size), "Content-Disposition": f'attachment; filename="{name}"'})

    def delete(self, job_id: str) -> None:
        self._delete([m["path"] for m in self._list(f"jobs/{job_id}/")])

    def sweep(self, jobs: dict[str, int | None], older_than: float) -> list[str]:
        objects: dict[str, list[dict]] = {}
        for m in self._list("jobs/"):
            objects.setdefault(m["path"].split("/")[1], []).append(m)
        gone: list[str] = []
        for job_id, found in sorted(objects.items()):
            if job_id not in jobs:  # every object of a job without a row, once its newest is old
                if max(m["last_modified"].timestamp() for m in found) < older_than:
                    gone += [m["path"] for m in found]
            elif jobs[job_id] is not None:  # a finished job's outputs of another lease than the one it published
                keep = f"jobs/{job_id}/out.{jobs[job_id]}/"
                gone += [m["path"] for m in found if m["path"].split("/")[2].startswith("out.") and not m["path"].startswith(keep)
                         and m["last_modified"].timestamp() < older_than]
        self._delete(gone)
        if self.work.is_dir():  # a bake's copy that its worker did not live to remove
            for folder in sorted(self.work.iterdir()):
                if folder.stat().st_mtime < older_than:
                    gone.append(f"work/{folder.name}")
                    shutil.rmtree(folder, ignore_errors=True)
        return gone

    def check(self) -> None:
        import obstore

        # a prefix that holds nothing: a cheap answer, and a missing bucket's 404 tells
        self._call("listing", lambda: obstore.list_with_delimiter(self.store, "readyz/"), missing_is_unavailable=True)


def _plain(name: str) -> str:
    """A stored file's name from ``job.json``, as a name in the job's folder."""
    plain = Path(name).name
    if plain in ("", ".", "..", "job.json"):
        raise StorageMissing(f"job.json names {name!r}: not an upload's file")
    return plain


@functools.lru_cache
def _make(data_dir: Path, url: str | None, endpoint: str | None) -> Storage:
    return LocalStorage(data_dir) if url is None else S3Storage(url, data_dir, endpoint)


def get_storage(settings: Settings | None = None) -> Storage:
    """The storage the settings name (one per configuration, made on first use)."""
    s = settings or get_settings()
    return _make(s.data_dir, s.storage_url, s.s3_endpoint)


# --- result.zip ---------------------------------------------------------------------------

# already compressed: stored as they are (deflating them again takes seconds per 100 MB and saves nothing)
STORED = {".png", ".jpg", ".jpeg", ".exr", ".zip", ".gz", ".ktx2"}


class _Sink:
    """Where zipfile writes: kept until taken. No ``tell``/``seek``, so zipfile writes a
    stream (sizes and CRCs after each member's data)."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []

    def write(self, data: bytes, /) -> int:
        self.parts.append(bytes(data))
        return len(data)

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass

    def take(self) -> bytes:
        data, self.parts = b"".join(self.parts), []
        return data


def zip_stream(members: Iterable[tuple[str, int, Callable[[], Iterator[bytes]]]]) -> Iterator[bytes]:
    """A zip of ``members`` (name, size, a callable that gives its chunks), written as it
    is sent: constant memory, any size (ZIP64 where a member needs it)."""
    sink = _Sink()
    with zipfile.ZipFile(sink, "w") as z:
        for name, size, chunks in members:
            info = zipfile.ZipInfo(name, time.localtime()[:6])
            info.external_attr = 0o644 << 16
            info.file_size = size  # ZIP64 headers when it needs them
            if Path(name).suffix.lower() in STORED:
                info.compress_type = zipfile.ZIP_STORED
            else:
                info.compress_type, info._compresslevel = zipfile.ZIP_DEFLATED, 1  # type: ignore[attr-defined]  # compress_level from 3.13 on
            with z.open(info, "w") as f:
                for chunk in chunks():
                    f.write(chunk)
                    if data := sink.take():
                        yield data
    yield sink.take()
