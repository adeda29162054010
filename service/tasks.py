"""The bake task, as the workers run it (``texbake worker`` loads this module).

A task claims its job in the jobs table, runs the bake in a child process with a
deadline and a memory limit (a hang or a crash in native code fails that job only), beats
the job's heartbeat meanwhile, stops the child when the job is cancelled, and moves the
outputs into place only when the bake is complete.
"""

from __future__ import annotations

import ctypes
import json
import logging
import resource
import signal
import shutil
import subprocess
import sys
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


def _child_setup(megabytes: int):
    """In the bake's child: cap its address space, and die with the worker (Linux)."""

    def apply():
        limit = megabytes * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        try:
            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:
            pass

    return apply


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
    child = subprocess.Popen(
        [sys.executable, "-m", "service.bakejob", str(folder)],
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        preexec_fn=_child_setup(s.job_memory_mb), start_new_session=True,
    )
    end = time.monotonic() + s.job_seconds
    state = "running"
    while child.poll() is None:
        time.sleep(min(s.heartbeat_seconds, 0.5))
        with Session() as session:
            state = db.beat(session, job_id)
        if state != "running" or time.monotonic() > end:
            child.kill()
            child.wait()
            break
    stderr = child.stderr.read().decode(errors="replace") if child.stderr else ""
    with Session() as session:
        if state == "cancelled":
            return "cancelled"
        if state != "running":
            return state
        if time.monotonic() > end and child.returncode != 0:
            db.finish(session, job_id, "failed", error=f"the bake took longer than {s.job_seconds:g} s")
            return "failed"
        outcome = folder / "outcome.json"
        result = json.loads(outcome.read_text()) if outcome.exists() else None
        if child.returncode == 0 and result and result.get("ok"):
            final = folder / "out"
            shutil.rmtree(final, ignore_errors=True)
            (folder / "out.tmp").rename(final)  # complete: all files at once
            report = json.loads((final / "report.json").read_text())
            db.finish(session, job_id, "done", report=report)
            return "done"
        if result and not result.get("ok"):
            error = result["error"]
        elif child.returncode and child.returncode < 0:
            error = f"the bake crashed (signal {-child.returncode})"
        else:
            last = [line for line in stderr.splitlines() if line.strip()]
            error = f"the bake failed (exit code {child.returncode}): {last[-1] if last else 'no message'}"
            if "MemoryError" in stderr:
                error = f"the bake ran out of its {s.job_memory_mb} MB memory limit"
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
