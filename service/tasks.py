"""The bake task, as the workers run it (``texbake worker`` loads this module).

A task claims its job in the jobs table, runs the bake in a child process with a
deadline and a memory limit (a hang or a crash in native code fails that job only),
forked from a fork server that has the baking core loaded already (a fresh interpreter
would spend a second or more importing it for every job), beats
the job's heartbeat meanwhile, stops the child when the job is cancelled, and moves the
outputs into place only when the bake is complete.
"""

from __future__ import annotations

import json
import logging
import multiprocessing
import shutil
import time
from pathlib import Path

from . import db
from huey import crontab

from .queue import make_huey
from .settings import get_settings

logger = logging.getLogger("texbake.service")
settings = get_settings()
huey = make_huey(settings)  # huey registers tasks on the instance: made once, here


def job_dir(job_id: str) -> Path:
    return get_settings().data_dir / "jobs" / job_id


_forkserver = None


def _bakes():
    """The multiprocessing context whose fork server has the baking core loaded."""
    global _forkserver
    if _forkserver is None:
        _forkserver = multiprocessing.get_context("forkserver")
        _forkserver.set_forkserver_preload(["service.bakejob"])
    return _forkserver


def _progress(folder: Path) -> float | None:
    """The fraction the bake in ``folder`` last reported (None before its first report)."""
    try:
        return float((folder / "progress").read_text())
    except (OSError, ValueError):
        return None


@huey.task()
def run_bake(job_id: str) -> str:
    s = get_settings()
    Session = db.sessions(s.database)
    with Session() as session:
        job = db.claim(session, job_id)
        if job is None:
            return "not queued"
    folder = job_dir(job_id)
    shutil.rmtree(folder / "out.tmp", ignore_errors=True)
    (folder / "outcome.json").unlink(missing_ok=True)
    (folder / "progress").unlink(missing_ok=True)
    from . import bakejob  # the baking core: loaded by workers only, never by the API

    child = _bakes().Process(target=bakejob.run, args=(str(folder), s.job_memory_mb), daemon=True)
    child.start()
    end = time.monotonic() + s.job_seconds
    state = "running"
    while child.is_alive():
        child.join(min(s.heartbeat_seconds, 0.5))
        with Session() as session:
            state = db.beat(session, job_id, progress=_progress(folder))
        if child.is_alive() and (state != "running" or time.monotonic() > end):
            child.kill()
            child.join()
            break
    code = child.exitcode
    with Session() as session:
        if state != "running":
            return state  # cancelled (or taken from us by the reaper)
        if time.monotonic() > end and code != 0:
            db.finish(session, job_id, "failed", error=f"the bake took longer than {s.job_seconds:g} s")
            return "failed"
        outcome = folder / "outcome.json"
        result = json.loads(outcome.read_text()) if outcome.exists() else None
        if code == 0 and result and result.get("ok"):
            final = folder / "out"
            shutil.rmtree(final, ignore_errors=True)
            (folder / "out.tmp").rename(final)  # complete: all files at once
            report = json.loads((final / "report.json").read_text())
            db.finish(session, job_id, "done", report=report)
            return "done"
        if result and not result.get("ok"):
            error = result["error"]
        elif code is not None and code < 0:
            error = f"the bake crashed (signal {-code})"
        else:
            error = f"the bake stopped with exit code {code} and no outcome"
        db.finish(session, job_id, "failed", error=error)
        return "failed"


def reap_forever(stop) -> None:
    """Reap every half ``stale_seconds`` until ``stop`` (a threading.Event) is set."""
    interval = max(0.5, get_settings().stale_seconds / 2)
    while not stop.wait(interval):
        try:
            reap_once()
        except Exception:  # a database hiccup: say so, and try again next time
            logger.exception("reaping stale jobs failed")


def reap_once() -> tuple[list[str], list[str]]:
    """Re-queue jobs whose worker died (stale heartbeat), fail those out of attempts."""
    s = get_settings()
    with db.sessions(s.database)() as session:
        requeued, failed = db.reap(session, s.stale_seconds, s.max_attempts)
    for job_id in requeued:
        run_bake(job_id)
    return requeued, failed


@huey.periodic_task(crontab(minute="*"))
def reaper() -> None:
    reap_once()
