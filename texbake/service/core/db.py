"""The jobs table: the source of truth for every bake (the queue only carries job ids).

SQLite by default, PostgreSQL (or any SQLAlchemy URL) when ``BAKE_DATABASE_URL`` is set.
States: queued -> running -> done | failed | cancelled; a running job whose heartbeat goes
stale is re-queued (a bounded number of times) by :func:`reap`; a done job whose outputs
the store lost is failed (:func:`lose_outputs`).

Deduplication: a live (queued, running) or done job holds its key in ``live_key``, which
is unique; :func:`create_job` inserts, and on a clash returns the job that holds the key,
so identical concurrent uploads make one job on any database. A failed or cancelled job
lets go of its key: the same upload then makes a new job.

Fencing: :func:`claim` takes a new lease (``lease`` counts every claim, never goes back:
the lease's token); heartbeats and
:func:`finish` of a bake count only while the job is running under that token, so a bake
whose job was taken from it (its heartbeat went stale, the reaper re-queued it, another
worker claimed it) can neither mark it done nor publish its outputs.
"""

from __future__ import annotations

import json
import threading
import time
import uuid
from datetime import datetime, timedelta, timezone
from functools import lru_cache
from typing import Any, cast

from sqlalchemy import CursorResult, DateTime, Integer, Result, String, Text, create_engine, delete, event, inspect, select, text, update
from sqlalchemy.engine import Engine
from sqlalchemy.exc import IntegrityError, OperationalError, ProgrammingError
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column, sessionmaker

STATES = ("queued", "running", "done", "failed", "cancelled")
FINISHED = ("done", "failed", "cancelled")
LIVE = ("queued", "running", "done")  # the states that hold a job's key (deduplication)


def now() -> datetime:
    return datetime.now(timezone.utc)


class Base(DeclarativeBase):
    pass


class Job(Base):
    __tablename__ = "jobs"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    key: Mapped[str] = mapped_column(String(64), index=True)  # upload + settings hash
    live_key: Mapped[str | None] = mapped_column(String(64), unique=True, default=None)  # = key while LIVE, else NULL
    client: Mapped[str] = mapped_column(String(128), default="")
    state: Mapped[str] = mapped_column(String(16), index=True, default="queued")
    mesh_name: Mapped[str] = mapped_column(String(255))
    settings: Mapped[str] = mapped_column(Text)  # JSON
    progress: Mapped[float] = mapped_column(default=0.0)
    error: Mapped[str | None] = mapped_column(Text, default=None)
    report: Mapped[str | None] = mapped_column(Text, default=None)  # JSON
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    lease: Mapped[int] = mapped_column(Integer, default=0)  # the token of the latest claim
    created: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=now)
    updated: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=now, onupdate=now)
    heartbeat: Mapped[datetime | None] = mapped_column(DateTime(timezone=True), default=None)

    def as_dict(self) -> dict:
        return {
            "id": self.id, "state": self.state, "progress": self.progress, "error": self.error,
            "mesh": self.mesh_name, "settings": json.loads(self.settings), "attempts": self.attempts,
            "created": self.created.isoformat(), "updated": self.updated.isoformat(),
            "report": json.loads(self.report) if self.report else None,
        }


_creating = threading.Lock()


class WorkerSeen(Base):
    """A worker process's last sign of life (``/readyz`` counts the live ones)."""

    __tablename__ = "workers"

    id: Mapped[str] = mapped_column(String(128), primary_key=True)  # host:pid
    slots: Mapped[int] = mapped_column(Integer, default=1)
    seen: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=now)


@lru_cache
def sessions(url: str) -> sessionmaker:
    """A session factory for the database at ``url`` (tables created on first use)."""
    engine = create_engine(url, pool_pre_ping=True)
    if url.startswith("sqlite"):
        @event.listens_for(engine, "connect")
        def _sqlite(conn, _):  # many readers, one writer, waiting rather than failing
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA busy_timeout=10000")
    # The API and workers start together: another process may create the tables first
    # (SQLite says so with an OperationalError); a database out of reach raises at once.
    created_meanwhile = (IntegrityError, ProgrammingError, OperationalError) if url.startswith("sqlite") else (IntegrityError, ProgrammingError)
    with _creating:  # and threads of this process one at a time
        for attempt in range(5):
            try:
                Base.metadata.create_all(engine)
                _upgrade(engine)
                break
            except created_meanwhile:
                if attempt == 4:
                    raise
                time.sleep(0.2 * (attempt + 1))
    return sessionmaker(engine, expire_on_commit=False)


def _upgrade(engine: Engine) -> None:
    """Upgrade a jobs table made before ``lease`` and ``live_key``: add the columns, give
    each key's newest live job its key (older duplicates, from before the constraint, keep
    none), index it."""
    columns = {c["name"] for c in inspect(engine).get_columns("jobs")}
    if "lease" not in columns:
        with engine.begin() as conn:
            conn.execute(text("ALTER TABLE jobs ADD COLUMN lease INTEGER NOT NULL DEFAULT 0"))
    if "live_key" in columns:
        return
    live = ", ".join(f"'{state}'" for state in LIVE)
    with engine.begin() as conn:
        conn.execute(text("ALTER TABLE jobs ADD COLUMN live_key VARCHAR(64)"))
        conn.execute(text(f"UPDATE jobs SET live_key = key WHERE state IN ({live}) AND id = "
                          f"(SELECT j.id FROM jobs j WHERE j.key = jobs.key AND j.state IN ({live}) ORDER BY j.created DESC LIMIT 1)"))
        conn.execute(text("CREATE UNIQUE INDEX ix_jobs_live_key ON jobs (live_key)"))


def create_job(db: Session, *, key: str, client: str, mesh_name: str, settings: dict, job_id: str | None = None) -> tuple[Job, bool]:
    """The queued, running or done job with this key, or a new queued one. Returns (job, created).

    Insert first, look up on a clash: of identical concurrent calls, one inserts and the
    others get its job (the unique ``live_key`` decides, not a check before the insert).
    """
    job_id = job_id or uuid.uuid4().hex
    for _ in range(10):  # the holder may let go of the key between the clash and the look-up
        job = Job(id=job_id, key=key, live_key=key, client=client, mesh_name=mesh_name, settings=json.dumps(settings))
        db.add(job)
        try:
            db.commit()
            return job, True
        except IntegrityError:
            db.rollback()
        existing = db.scalars(select(Job).where(Job.live_key == key)).first()
        if existing is not None:
            return existing, False
    raise RuntimeError(f"job key {key}: neither inserted nor found after 10 tries")


def _rowcount(result: Result[Any]) -> int:
    """Rows an UPDATE matched: the session returns a CursorResult for DML without RETURNING."""
    return cast("CursorResult[Any]", result).rowcount


def claim(db: Session, job_id: str) -> Job | None:
    """Move a queued job to running (atomically); None if it is not queued any more. The
    job's ``lease`` is this bake's token (see the module's notes on fencing)."""
    done = db.execute(
        update(Job).where(Job.id == job_id, Job.state == "queued")
        .values(state="running", heartbeat=now(), attempts=Job.attempts + 1, lease=Job.lease + 1, progress=0.0)
    )
    db.commit()
    return db.get(Job, job_id, populate_existing=True) if _rowcount(done) == 1 else None


def beat(db: Session, job_id: str, token: int, progress: float | None = None) -> str:
    """Refresh a running job's heartbeat; returns its state (a cancel shows here), or
    "taken" when it runs under another token (re-queued and claimed again), or "gone"."""
    values = {"heartbeat": now()} if progress is None else {"heartbeat": now(), "progress": progress}
    db.execute(update(Job).where(Job.id == job_id, Job.state == "running", Job.lease == token).values(**values))
    db.commit()
    row = db.execute(select(Job.state, Job.lease).where(Job.id == job_id)).first()
    if row is None:
        return "gone"  # deleted (expired) meanwhile
    if row.state == "queued" or (row.state == "running" and row.lease != token):
        return "taken"
    return row.state


def holds(db: Session, job_id: str, token: int) -> bool:
    """Whether the job is running under ``token`` (checked before a bake publishes its outputs)."""
    return db.scalar(select(Job.id).where(Job.id == job_id, Job.state == "running", Job.lease == token)) is not None


def finish(db: Session, job_id: str, token: int, state: str, *, error: str | None = None, report: dict | None = None) -> bool:
    """End a job running under ``token`` (done or failed); a job cancelled or taken
    meanwhile is left as it is. Returns whether it was ended here."""
    values: dict[str, Any] = {"state": state, "error": error}
    if state == "done":
        values["progress"] = 1.0
    else:
        values["live_key"] = None
    if report is not None:
        values["report"] = json.dumps(report)
    done = db.execute(update(Job).where(Job.id == job_id, Job.state == "running", Job.lease == token).values(**values))
    db.commit()
    return _rowcount(done) == 1


def lose_outputs(db: Session, job_id: str, token: int, error: str) -> bool:
    """Fail a job done under ``token`` whose outputs the store no longer holds (``error``
    says so); it lets go of its key. False if it was not done so any more."""
    done = db.execute(update(Job).where(Job.id == job_id, Job.state == "done", Job.lease == token)
                      .values(state="failed", error=error, live_key=None))
    db.commit()
    return _rowcount(done) == 1


def release(db: Session, job_id: str, token: int) -> bool:
    """Put a job running under ``token`` back in the queue uncounted (its worker is
    stopping); False if it was not running so any more."""
    done = db.execute(update(Job).where(Job.id == job_id, Job.state == "running", Job.lease == token)
                      .values(state="queued", heartbeat=None, progress=0.0, attempts=Job.attempts - 1))
    db.commit()
    return _rowcount(done) == 1


def cancel(db: Session, job_id: str) -> bool:
    """Cancel a queued or running job; False if it had finished already."""
    done = db.execute(update(Job).where(Job.id == job_id, Job.state.in_(("queued", "running"))).values(state="cancelled", live_key=None))
    db.commit()
    return _rowcount(done) == 1


def reap(db: Session, stale_seconds: float, max_attempts: int) -> tuple[list[str], list[str]]:
    """Re-queue running jobs whose heartbeat is stale, or fail them after ``max_attempts``.

    Returns (re-queued ids, failed ids): the caller enqueues the re-queued ones.
    """
    cutoff = now() - timedelta(seconds=stale_seconds)
    stale = db.scalars(select(Job).where(Job.state == "running", Job.heartbeat < cutoff)).all()
    requeued: list[str] = []
    failed: list[str] = []
    for job in stale:
        if job.attempts >= max_attempts:
            assert job.heartbeat is not None  # selected by heartbeat < cutoff, so not NULL
            reason = f"the worker stopped answering {job.attempts} times (last heartbeat {job.heartbeat.isoformat()})"
            moved = db.execute(update(Job).where(Job.id == job.id, Job.state == "running", Job.heartbeat < cutoff)
                               .values(state="failed", error=reason, live_key=None).execution_options(synchronize_session=False))
            (failed if _rowcount(moved) else []).append(job.id)
        else:
            moved = db.execute(update(Job).where(Job.id == job.id, Job.state == "running", Job.heartbeat < cutoff)
                               .values(state="queued", heartbeat=None).execution_options(synchronize_session=False))
            (requeued if _rowcount(moved) else []).append(job.id)
    db.commit()
    return requeued, failed


def stranded(db: Session, grace_seconds: float) -> list[str]:
    """Queued jobs unchanged for ``grace_seconds``: the candidates for a lost queue entry
    (the caller re-enqueues those the queue does not hold)."""
    cutoff = now() - timedelta(seconds=grace_seconds)
    return list(db.scalars(select(Job.id).where(Job.state == "queued", Job.updated < cutoff).order_by(Job.created)))


def worker_seen(db: Session, worker_id: str, slots: int) -> None:
    """Record that a worker is alive (and forget workers not seen for a day)."""
    if _rowcount(db.execute(update(WorkerSeen).where(WorkerSeen.id == worker_id).values(seen=now(), slots=slots))) == 0:
        db.add(WorkerSeen(id=worker_id, slots=slots))
    db.execute(delete(WorkerSeen).where(WorkerSeen.seen < now() - timedelta(days=1)))
    db.commit()


def live_workers(db: Session, within_seconds: float) -> tuple[int, int]:
    """(workers, bake slots) seen in the last ``within_seconds``."""
    cutoff = now() - timedelta(seconds=within_seconds)
    rows = db.execute(select(WorkerSeen.slots).where(WorkerSeen.seen >= cutoff)).all()
    return len(rows), sum(r.slots for r in rows)
