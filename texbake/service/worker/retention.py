"""Retention: finished jobs expire, with their folders (or their objects in the object
store); nothing in the data folder or the store grows without bound. ``texbake gc`` runs
:func:`collect` once; the API's reaper every ``GC_SECONDS``.

Done jobs are kept ``BAKE_KEEP_HOURS``, failed and cancelled ones ``BAKE_KEEP_FAILED_HOURS``
(counted from their last change); an expired job's row goes first (deduplication stops
returning it), then its files. Left-overs of processes that died are removed too, once
older than ``LEFTOVER_SECONDS`` (and twice ``BAKE_JOB_SECONDS``, what a bake may take): a
job folder or a store's job prefix without a row, an upload never turned into a job, a
finished job's unpublished bake outputs (``out.tmp.LEASE``, a store's ``out.LEASE/``), a
worker's copy of a job (``work/``, with a store) that it did not live to remove.
"""

from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field
from datetime import timedelta
from pathlib import Path

from ..core import crud, db, models
from ..core.config import Settings
from ..storage import get_storage

GC_SECONDS = 600.0  # how often the API collects
LEFTOVER_SECONDS = 3600.0  # a folder or upload older than this without its job is a left-over


@dataclass
class Collected:
    jobs: list[str] = field(default_factory=list)  # expired: rows and folders removed
    leftovers: list[str] = field(default_factory=list)  # paths removed (relative to the data folder)


def collect(settings: Settings) -> Collected:
    out = Collected()
    now = models.now()
    storage = get_storage(settings)
    rules = ((("done",), settings.keep_hours), (("failed", "cancelled"), settings.keep_failed_hours))
    with db.sessions(settings.database)() as session:
        for states, hours in rules:
            out.jobs += crud.expire(session, states, now - timedelta(hours=hours))
        jobs = crud.leases(session, models.FINISHED)
    for job_id in out.jobs:
        storage.delete(job_id)
    old = time.time() - LEFTOVER_SECONDS
    out.leftovers += storage.sweep(jobs, older_than=min(old, time.time() - 2 * settings.job_seconds))
    uploads = settings.data_dir / "uploads"
    for upload in sorted(uploads.iterdir()) if uploads.is_dir() else []:
        if _newest(upload) < old:
            out.leftovers.append(str(upload.relative_to(settings.data_dir)))
            if upload.is_dir():
                shutil.rmtree(upload, ignore_errors=True)
            else:
                upload.unlink(missing_ok=True)
    return out


def _newest(upload: Path) -> float:
    """When an upload (a folder of one request's parts, or an older version's file) was last
    written: its newest part's time, as a part may still be arriving; now if it is gone
    (its request has ended meanwhile)."""
    try:
        return max(p.stat().st_mtime for p in [upload, *(upload.iterdir() if upload.is_dir() else [])])
    except FileNotFoundError:
        return time.time()
