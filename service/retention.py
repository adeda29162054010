"""Retention: finished jobs expire, with their folders; nothing in the data folder grows
without bound. ``texbake gc`` runs :func:`collect` once; the API's reaper every
``GC_SECONDS``.

Done jobs are kept ``BAKE_KEEP_HOURS``, failed and cancelled ones ``BAKE_KEEP_FAILED_HOURS``
(counted from their last change); an expired job's row goes first (deduplication stops
returning it), then its folder. Left-overs of processes that died are removed too: a job
folder without a row, an upload never turned into a job, a bake's ``out.tmp.LEASE`` of a
finished job, older than ``LEFTOVER_SECONDS``.
"""

from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field
from datetime import timedelta

from sqlalchemy import delete, select

from . import db
from .settings import Settings

GC_SECONDS = 600.0  # how often the API collects
LEFTOVER_SECONDS = 3600.0  # a folder or upload older than this without its job is a left-over


@dataclass
class Collected:
    jobs: list[str] = field(default_factory=list)  # expired: rows and folders removed
    leftovers: list[str] = field(default_factory=list)  # paths removed (relative to the data folder)


def collect(settings: Settings) -> Collected:
    out = Collected()
    now = db.now()
    rules = ((("done",), settings.keep_hours), (("failed", "cancelled"), settings.keep_failed_hours))
    with db.sessions(settings.database)() as session:
        for states, hours in rules:
            cutoff = now - timedelta(hours=hours)
            expired = list(session.scalars(select(db.Job.id).where(db.Job.state.in_(states), db.Job.updated < cutoff)))
            if expired:  # the same conditions again: a job re-queued meanwhile is not deleted
                session.execute(delete(db.Job).where(db.Job.id.in_(expired), db.Job.state.in_(states), db.Job.updated < cutoff))
                session.commit()
            out.jobs += expired
        jobs = settings.data_dir / "jobs"
        folders = sorted(p for p in jobs.iterdir() if p.is_dir()) if jobs.is_dir() else []
        known = set(session.scalars(select(db.Job.id).where(db.Job.id.in_([p.name for p in folders]))))
        finished = set(session.scalars(select(db.Job.id).where(db.Job.id.in_(known), db.Job.state.in_(db.FINISHED))))
    old = time.time() - LEFTOVER_SECONDS
    for folder in folders:
        if folder.name in out.jobs:
            shutil.rmtree(folder, ignore_errors=True)
        elif folder.name not in known and folder.stat().st_mtime < old:
            out.leftovers.append(str(folder.relative_to(settings.data_dir)))
            shutil.rmtree(folder, ignore_errors=True)
        elif folder.name in finished:
            for tmp in folder.glob("out.tmp.*"):
                if tmp.stat().st_mtime < old:
                    out.leftovers.append(str(tmp.relative_to(settings.data_dir)))
                    shutil.rmtree(tmp, ignore_errors=True)
    uploads = settings.data_dir / "uploads"
    for upload in sorted(uploads.iterdir()) if uploads.is_dir() else []:
        if upload.stat().st_mtime < old:
            out.leftovers.append(str(upload.relative_to(settings.data_dir)))
            upload.unlink(missing_ok=True)
    return out
