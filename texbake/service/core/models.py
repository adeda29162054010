"""The tables: ``jobs``, the source of truth for every bake (the queue only carries job
ids), and ``workers``, each worker process's last sign of life.

States: queued -> running -> done | failed | cancelled. A live (queued, running) or done
job holds its deduplication key in ``live_key``, which is unique; a failed or cancelled
one lets go of it. ``lease`` counts the job's claims and is the token a bake holds it by
(see :mod:`texbake.service.core.crud`).

A change here needs a migration beside it (``texbake/service/migrations/versions``).
"""

from __future__ import annotations

import json
from datetime import datetime, timezone

from sqlalchemy import DateTime, Integer, String, Text
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

STATES = ("queued", "running", "done", "failed", "cancelled")
FINISHED = ("done", "failed", "cancelled")
UNFINISHED = ("queued", "running")  # what the per-client limit counts
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


class WorkerSeen(Base):
    """A worker process's last sign of life (``/readyz`` counts the live ones)."""

    __tablename__ = "workers"

    id: Mapped[str] = mapped_column(String(128), primary_key=True)  # host:pid
    slots: Mapped[int] = mapped_column(Integer, default=1)
    seen: Mapped[datetime] = mapped_column(DateTime(timezone=True), default=now)
