"""The jobs table: the source of truth for every bake (the queue only carries job ids).

SQLite by default, PostgreSQL (or any SQLAlchemy URL) when ``BAKE_DATABASE_URL`` is set.
States: queued -> running -> done | failed | cancelled; a running job whose heartbeat goes
stale is re-queued (a bounded number of times) by :func:`reap`.
"""

from __future__ import annotations

import json
import time
import uuid
from datetime import datetime, timedelta, timezone
from functools import lru_cache
from typing import Any, cast

from sqlalchemy import CursorResult, DateTime, Integer, Result, String, Text, create_engine, event, select, update
from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import DeclarativeBase, Mapped, Session, mapped_column, sessionmaker

STATES = ("queued", "running", "done", "failed", "cancelled")
FINISHED = ("done", "failed", "cancelled")


def now() -> datetime:
    return datetime.now(timezone.utc)


class Base(DeclarativeBase):
    pass


class Job(Base):
    __tablename__ = "jobs"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    key: Mapped[str] = mapped_column(String(64), index=True)  # upload + settings hash
    client: Mapped[str] = mapped_column(String(128), default="")
    state: Mapped[str] = mapped_column(String(16), index=True, default="queued")
    mesh_name: Mapped[str] = mapped_column(String(255))
    settings: Mapped[str] = mapped_column(Text)  # JSON
    progress: Mapped[float] = mapped_column(default=0.0)
    error: Mapped[str | None] = mapped_column(Text, default=None)
    report: Mapped[str | None] = mapped_column(Text, default=None)  # JSON
    attempts: Mapped[int] = mapped_column(Integer, default=0)
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


@lru_cache
def sessions(url: str) -> sessionmaker:
    """A session factory for the database at ``url`` (tables created on first use)."""
    engine = create_engine(url, pool_pre_ping=True)
    if url.startswith("sqlite"):
        @event.listens_for(engine, "connect")
        def _sqlite(conn, _):  # many readers, one writer, waiting rather than failing
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA busy_timeout=10000")
    for attempt in range(5):  # the API and workers start together: another may create them first
        try:
            Base.metadata.create_all(engine)
            break
        except DBAPIError:
            if attempt == 4:
                raise
            time.sleep(0.2 * (attempt + 1))
    return sessionmaker(engine, expire_on_commit=False)


def create_job(db: Session, *, key: str, client: str, mesh_name: str, settings: dict) -> tuple[Job, bool]:
    """The unfinished or done job with this key, or a new queued one. Returns (job, created)."""
    existing = db.scalars(
        select(Job).where(Job.key == key, Job.state.in_(("queued", "running", "done"))).order_by(Job.created.desc())
    ).first()
    if existing is not None:
        return existing, False
    job = Job(id=uuid.uuid4().hex, key=key, client=client, mesh_name=mesh_name, settings=json.dumps(settings))
    db.add(job)
    db.commit()
    return job, True


def _rowcount(result: Result[Any]) -> int:
    """Rows an UPDATE matched: the session returns a CursorResult for DML without RETURNING."""
    return cast("CursorResult[Any]", result).rowcount


def claim(db: Session, job_id: str) -> Job | None:
    """Move a queued job to running (atomically); None if it is not queued any more."""
    done = db.execute(
        update(Job).where(Job.id == job_id, Job.state == "queued")
        .values(state="running", heartbeat=now(), attempts=Job.attempts + 1, progress=0.0)
    )
    db.commit()
    return db.get(Job, job_id) if _rowcount(done) == 1 else None


def beat(db: Session, job_id: str, progress: float | None = None) -> str:
    """Refresh a running job's heartbeat; returns its state (a cancel shows here)."""
    values = {"heartbeat": now()} if progress is None else {"heartbeat": now(), "progress": progress}
    db.execute(update(Job).where(Job.id == job_id, Job.state == "running").values(**values))
    db.commit()
    state = db.scalar(select(Job.state).where(Job.id == job_id))
    assert state is not None  # jobs are never deleted, and this one was claimed
    return state


def finish(db: Session, job_id: str, state: str, *, error: str | None = None, report: dict | None = None) -> None:
    """End a running job (done or failed); a job cancelled meanwhile stays cancelled."""
    values = {"state": state, "error": error, "progress": 1.0 if state == "done" else None}
    if report is not None:
        values["report"] = json.dumps(report)
    values = {k: v for k, v in values.items() if v is not None or k == "error"}
    db.execute(update(Job).where(Job.id == job_id, Job.state == "running").values(**values))
    db.commit()


def release(db: Session, job_id: str) -> bool:
    """Put a running job back in the queue uncounted (its worker is stopping); False if it
    was not running any more."""
    done = db.execute(update(Job).where(Job.id == job_id, Job.state == "running")
                      .values(state="queued", heartbeat=None, progress=0.0, attempts=Job.attempts - 1))
    db.commit()
    return _rowcount(done) == 1


def cancel(db: Session, job_id: str) -> bool:
    """Cancel a queued or running job; False if it had finished already."""
    done = db.execute(update(Job).where(Job.id == job_id, Job.state.in_(("queued", "running"))).values(state="cancelled"))
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
                               .values(state="failed", error=reason).execution_options(synchronize_session=False))
            (failed if _rowcount(moved) else []).append(job.id)
        else:
            moved = db.execute(update(Job).where(Job.id == job.id, Job.state == "running", Job.heartbeat < cutoff)
                               .values(state="queued", heartbeat=None).execution_options(synchronize_session=False))
            (requeued if _rowcount(moved) else []).append(job.id)
    db.commit()
    return requeued, failed
