"""Every query of the jobs database, one function each (the routes, the worker and
retention call these; none of them writes SQL).

Each function is one transaction, committed before it returns: a session holds a pooled
connection only while a function runs, never while its caller copies an upload or waits
for a client, so a burst of requests shares the pool in turns of milliseconds.

Deduplication: :func:`create_job` inserts, and on a clash of the unique ``live_key``
returns the job that holds the key, so identical concurrent uploads make one job on any
database. A failed or cancelled job lets go of its key: the same upload then makes a new
job.

The per-client limit is counted in the transaction that inserts, under the client's lock
(:func:`texbake.service.core.db.write_lock`): concurrent uploads of one client are counted
one after another, so the limit is exact.

Fencing: :func:`claim` takes a new lease (``lease`` counts every claim, never goes back:
the lease's token); heartbeats and :func:`finish` of a bake count only while the job is
running under that token, so a bake whose job was taken from it (its heartbeat went
stale, the reaper re-queued it, another worker claimed it) can neither mark it done nor
publish its outputs.
"""

from __future__ import annotations

import json
import uuid
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from datetime import datetime, timedelta
from typing import Any, cast

from sqlalchemy import CursorResult, Result, delete, func, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from .db import write_lock
from .models import UNFINISHED, Job, WorkerSeen, now


class LimitReached(Exception):
    """A client has ``unfinished`` queued or running jobs, its ``limit``: no new one."""

    def __init__(self, client: str, unfinished: int, limit: int):
        super().__init__(f"client {client}: {unfinished} unfinished jobs, the limit is {limit}")
        self.client, self.unfinished, self.limit = client, unfinished, limit


@contextmanager
def _transaction(session: Session) -> Iterator[Session]:
    """One transaction of its own: committed at the end (the connection goes back to the
    pool), rolled back on an error (the session is usable again, e.g. for a retry)."""
    if session.in_transaction():
        session.commit()  # what the caller left open ends first: a lock must begin its transaction
    try:
        yield session
        session.commit()
    except BaseException:
        session.rollback()
        raise


def _rowcount(result: Result[Any]) -> int:
    """Rows an UPDATE matched: the session returns a CursorResult for DML without RETURNING."""
    return cast("CursorResult[Any]", result).rowcount


# --- the API's ------------------------------------------------------------------------

def get_job(session: Session, job_id: str) -> Job | None:
    """The job as the database has it now (None: no such job)."""
    with _transaction(session):
        return session.get(Job, job_id, populate_existing=True)


def list_jobs(session: Session, client: str | None, offset: int, limit: int) -> tuple[int, list[Job]]:
    """(how many jobs, a page of them newest first): every job, or ``client``'s own."""
    mine = [Job.client == client] if client is not None else []
    with _transaction(session):
        total = session.scalar(select(func.count()).select_from(Job).where(*mine)) or 0
        jobs = list(session.scalars(select(Job).where(*mine).order_by(Job.created.desc()).offset(offset).limit(limit)))
    return total, jobs


def unfinished(session: Session, client: str) -> int:
    """How many of ``client``'s jobs are queued or running."""
    with _transaction(session):
        return _unfinished(session, client)


def _unfinished(session: Session, client: str) -> int:
    return session.scalar(select(func.count()).select_from(Job).where(Job.client == client, Job.state.in_(UNFINISHED))) or 0


def live_job(session: Session, key: str) -> Job | None:
    """The queued, running or done job that holds ``key``, if any."""
    with _transaction(session):
        return session.scalars(select(Job).where(Job.live_key == key)).first()


def create_job(session: Session, *, key: str, client: str, mesh_name: str, settings: dict, job_id: str | None = None,
               limit: int | None = None) -> tuple[Job, bool]:
    """The queued, running or done job with this key, or a new queued one. Returns (job, created).

    With ``limit``, a client with that many unfinished jobs gets :class:`LimitReached`,
    counted under the client's lock in the transaction that inserts. Insert first, look
    up on a clash: of identical concurrent calls, one inserts and the others get its job
    (the unique ``live_key`` decides, not a check before the insert).
    """
    job_id = job_id or uuid.uuid4().hex
    for _ in range(10):  # the holder may let go of the key between the clash and the look-up
        try:
            with _transaction(session):
                write_lock(session, f"client:{client}")
                if limit is not None and (count := _unfinished(session, client)) >= limit:
                    raise LimitReached(client, count, limit)
                job = Job(id=job_id, key=key, live_key=key, client=client, mesh_name=mesh_name, settings=json.dumps(settings))
                session.add(job)
            return job, True
        except IntegrityError:
            pass
        existing = live_job(session, key)
        if existing is not None:
            return existing, False
    raise RuntimeError(f"job key {key}: neither inserted nor found after 10 tries")


def cancel(session: Session, job_id: str) -> bool:
    """Cancel a queued or running job; False if it had finished already."""
    with _transaction(session):
        done = session.execute(update(Job).where(Job.id == job_id, Job.state.in_(UNFINISHED)).values(state="cancelled", live_key=None))
    return _rowcount(done) == 1


# --- the worker's -----------------------------------------------------------------------

def claim(session: Session, job_id: str) -> Job | None:
    """Move a queued job to running (atomically); None if it is not queued any more. The
    job's ``lease`` is this bake's token (see the module's notes on fencing)."""
    with _transaction(session):
        done = session.execute(
            update(Job).where(Job.id == job_id, Job.state == "queued")
            .values(state="running", heartbeat=now(), attempts=Job.attempts + 1, lease=Job.lease + 1, progress=0.0)
        )
        return session.get(Job, job_id, populate_existing=True) if _rowcount(done) == 1 else None


def beat(session: Session, job_id: str, token: int, progress: float | None = None) -> str:
    """Refresh a running job's heartbeat; returns its state (a cancel shows here), or
    "taken" when it runs under another token (re-queued and claimed again), or "gone"."""
    values = {"heartbeat": now()} if progress is None else {"heartbeat": now(), "progress": progress}
    with _transaction(session):
        session.execute(update(Job).where(Job.id == job_id, Job.state == "running", Job.lease == token).values(**values))
        row = session.execute(select(Job.state, Job.lease).where(Job.id == job_id)).first()
    if row is None:
        return "gone"  # deleted (expired) meanwhile
    if row.state == "queued" or (row.state == "running" and row.lease != token):
        return "taken"
    return row.state


def holds(session: Session, job_id: str, token: int) -> bool:
    """Whether the job is running under ``token`` (checked before a bake publishes its outputs)."""
    with _transaction(session):
        return session.scalar(select(Job.id).where(Job.id == job_id, Job.state == "running", Job.lease == token)) is not None


def finish(session: Session, job_id: str, token: int, state: str, *, error: str | None = None, report: dict | None = None) -> bool:
    """End a job running under ``token`` (done or failed); a job cancelled or taken
    meanwhile is left as it is. Returns whether it was ended here."""
    values: dict[str, Any] = {"state": state, "error": error}
    if state == "done":
        values["progress"] = 1.0
    else:
        values["live_key"] = None
    if report is not None:
        values["report"] = json.dumps(report)
    with _transaction(session):
        done = session.execute(update(Job).where(Job.id == job_id, Job.state == "running", Job.lease == token).values(**values))
    return _rowcount(done) == 1


def lose_outputs(session: Session, job_id: str, token: int, error: str) -> bool:
    """Fail a job done under ``token`` whose outputs the store no longer holds (``error``
    says so); it lets go of its key. False if it was not done so any more."""
    with _transaction(session):
        done = session.execute(update(Job).where(Job.id == job_id, Job.state == "done", Job.lease == token)
                               .values(state="failed", error=error, live_key=None))
    return _rowcount(done) == 1


def release(session: Session, job_id: str, token: int) -> bool:
    """Put a job running under ``token`` back in the queue uncounted (its worker is
    stopping); False if it was not running so any more."""
    with _transaction(session):
        done = session.execute(update(Job).where(Job.id == job_id, Job.state == "running", Job.lease == token)
                               .values(state="queued", heartbeat=None, progress=0.0, attempts=Job.attempts - 1))
    return _rowcount(done) == 1


def reap(session: Session, stale_seconds: float, max_attempts: int) -> tuple[list[str], list[str]]:
    """Re-queue running jobs whose heartbeat is stale, or fail them after ``max_attempts``.

    Returns (re-queued ids, failed ids): the caller enqueues the re-queued ones.
    """
    cutoff = now() - timedelta(seconds=stale_seconds)
    requeued: list[str] = []
    failed: list[str] = []
    with _transaction(session):
        for job in session.scalars(select(Job).where(Job.state == "running", Job.heartbeat < cutoff)).all():
            if job.attempts >= max_attempts:
                assert job.heartbeat is not None  # selected by heartbeat < cutoff, so not NULL
                reason = f"the worker stopped answering {job.attempts} times (last heartbeat {job.heartbeat.isoformat()})"
                values: dict[str, Any] = {"state": "failed", "error": reason, "live_key": None}
            else:
                values = {"state": "queued", "heartbeat": None}
            moved = session.execute(update(Job).where(Job.id == job.id, Job.state == "running", Job.heartbeat < cutoff)
                                    .values(**values).execution_options(synchronize_session=False))
            if _rowcount(moved):
                (failed if values["state"] == "failed" else requeued).append(job.id)
    return requeued, failed


def stranded(session: Session, grace_seconds: float) -> list[str]:
    """Queued jobs unchanged for ``grace_seconds``: the candidates for a lost queue entry
    (the caller re-enqueues those the queue does not hold)."""
    cutoff = now() - timedelta(seconds=grace_seconds)
    with _transaction(session):
        return list(session.scalars(select(Job.id).where(Job.state == "queued", Job.updated < cutoff).order_by(Job.created)))


def worker_seen(session: Session, worker_id: str, slots: int) -> None:
    """Record that a worker is alive (and forget workers not seen for a day)."""
    with _transaction(session):
        if _rowcount(session.execute(update(WorkerSeen).where(WorkerSeen.id == worker_id).values(seen=now(), slots=slots))) == 0:
            session.add(WorkerSeen(id=worker_id, slots=slots))
        session.execute(delete(WorkerSeen).where(WorkerSeen.seen < now() - timedelta(days=1)))


def live_workers(session: Session, within_seconds: float) -> tuple[int, int]:
    """(workers, bake slots) seen in the last ``within_seconds``."""
    cutoff = now() - timedelta(seconds=within_seconds)
    with _transaction(session):
        rows = session.execute(select(WorkerSeen.slots).where(WorkerSeen.seen >= cutoff)).all()
    return len(rows), sum(r.slots for r in rows)


# --- retention's ------------------------------------------------------------------------

def expire(session: Session, states: Sequence[str], cutoff: datetime) -> list[str]:
    """Delete the jobs in ``states`` unchanged since ``cutoff``; their ids."""
    with _transaction(session):
        expired = list(session.scalars(select(Job.id).where(Job.state.in_(states), Job.updated < cutoff)))
        if expired:  # the same conditions again: a job re-queued meanwhile is not deleted
            session.execute(delete(Job).where(Job.id.in_(expired), Job.state.in_(states), Job.updated < cutoff))
    return expired


def leases(session: Session, finished: Sequence[str]) -> dict[str, int | None]:
    """Every job's id -> its lease when in ``finished`` states, else None (a bake may still write)."""
    with _transaction(session):
        rows = session.execute(select(Job.id, Job.state, Job.lease)).all()
    return {row.id: row.lease if row.state in finished else None for row in rows}
