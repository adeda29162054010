"""The bake task, as the workers run it (``texbake worker`` takes its queue from here).

Nothing happens at import: :func:`queue` makes the huey queue from the settings on first
use and registers the tasks on it (``run_bake`` and the ``reaper``); :func:`enqueue_bake`
puts a job id on it.

A task claims its job in the jobs table, fetches its upload (:mod:`texbake.service.storage`: the
data folder, or a copy from the object store), runs the bake in a child process with a
deadline and a memory limit (a hang or a crash in native code fails that job only), beats
the job's heartbeat meanwhile, stops the child when the job is cancelled, and publishes
the outputs only when the bake is complete and the job's lease still its own.

Bakes run in bake processes, ``texbake.workers.Worker``s running ``texbake.service.worker.bakejob``: started
when the worker starts (:func:`prestart`, one per worker thread), then reused from job to
job (a fresh interpreter spends about 1.5 s importing the baking core and loading the
compiled kernels). A bake that is cancelled, runs out of time or crashes takes its
process with it; the next job gets a new one. After ``JOBS_PER_PROCESS`` jobs the process
is replaced anyway.
"""

from __future__ import annotations

import functools
import json
import logging
import os
import shutil
import signal
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor, TimeoutError
from dataclasses import dataclass
from pathlib import Path

from huey import Huey, crontab
from huey.api import TaskWrapper
from huey.exceptions import RetryTask
from sqlalchemy.exc import DBAPIError

from texbake.workers import Worker

from ..core import crud, db
from ..core.config import Settings, get_settings
from ..storage import Storage, StorageMissing, StorageUnavailable, get_storage
from .queue import make_huey

logger = logging.getLogger("texbake.service")
jobs_log = logging.getLogger("texbake.jobs")


@dataclass(frozen=True)
class Queue:
    huey: Huey
    bake: TaskWrapper  # calling it with a job id enqueues that job


CLAIM_RETRY_SECONDS = 2.0  # a bake that cannot reach the jobs table to claim its job tries again this much later
STORE_RETRY_SECONDS = 5.0  # one that cannot fetch its upload from the object store, this much later


@functools.lru_cache
def queue() -> Queue:
    """The queue of this process, made from the settings on first use, with its tasks."""
    huey = make_huey(get_settings())
    huey.periodic_task(crontab(minute="*"), name="reaper")(reap_once)
    return Queue(huey, huey.task(name="run_bake")(run_bake))


def enqueue_bake(job_id: str) -> None:
    queue().bake(job_id)


def state_changed(job_id: str, state: str, detail: str = "") -> None:
    """The one log line of a job's change of state (``texbake.jobs``)."""
    jobs_log.info("job %s %s%s", job_id, state, f": {detail}" if detail else "", extra={"job": job_id, "state": state, "detail": detail})


def queued_ids() -> set[str]:
    """The job ids the queue holds: waiting, or scheduled to be tried again."""
    huey = queue().huey
    return {str(task.args[0]) for task in huey.pending() + huey.scheduled() if task.name == "run_bake" and task.args}


_idle: list[Worker] = []  # bake processes started and waiting for a job
_idle_lock = threading.Lock()
_running: dict[str, tuple[int, int]] = {}  # job id -> (pid of the bake process baking it, lease), this worker's
JOBS_PER_PROCESS = 50  # then a fresh process: no memory creeps from job to job
_handing_back = threading.Event()  # set by hand_back(): the bakes it kills are not failures


def _new_bake_process(s: Settings) -> Worker:
    folder = s.data_dir / "workers"
    folder.mkdir(parents=True, exist_ok=True)
    # its stderr is the worker's: tracebacks of bugs land in the worker's log
    return Worker([sys.executable, "-m", "texbake.service.worker.bakejob", str(s.job_memory_mb), str(s.data_dir / "cache")], str(folder),
                  stderr=None)


def prestart(count: int) -> None:
    """Start ``count`` bake processes now, so that the first jobs find them warm."""
    s = get_settings()
    started = [_new_bake_process(s) for _ in range(count)]
    with _idle_lock:
        _idle.extend(started)


def _take_bake_process(s: Settings) -> Worker:
    """A warm bake process (the baking core imported, the kernels loaded) from those
    waiting, or a new one; one that died or has done ``JOBS_PER_PROCESS`` jobs is ended."""
    while True:
        with _idle_lock:
            worker = _idle.pop() if _idle else None
        if worker is None:
            return _new_bake_process(s)
        if worker.process.poll() is None and worker.jobs < JOBS_PER_PROCESS:
            return worker
        worker.end(polite=True)


def _give_back(worker: Worker) -> None:
    """Keep a bake process that is still alive for the next job."""
    if worker.process.poll() is None:
        with _idle_lock:
            _idle.append(worker)


def _progress(file: Path) -> float | None:
    """The fraction the bake last reported in ``file`` (None before its first report)."""
    try:
        return float(file.read_text())
    except (OSError, ValueError):
        return None


def run_bake(job_id: str) -> str:
    """The task: bake one job (see the module's notes); returns the job's final state."""
    s = get_settings()
    Session = db.sessions(s.database)
    try:
        with Session() as session:
            job = crud.claim(session, job_id)
    except DBAPIError as exc:  # the jobs table is out of reach: try again later, never drop the job
        logger.warning("job %s: cannot claim it (%s): trying again in %g s", job_id, type(exc.orig).__name__, CLAIM_RETRY_SECONDS)
        raise RetryTask(delay=CLAIM_RETRY_SECONDS) from None
    if job is None:
        return "not queued"
    state_changed(job_id, "running", f"attempt {job.attempts}, lease {job.lease}")
    storage = get_storage(s)
    try:
        folder = _beating(job_id, job.lease, lambda: storage.fetch_input(job_id, job.lease))
    except StorageUnavailable as exc:  # hand the job back, uncounted, and try again later
        logger.warning("job %s: cannot fetch its upload (%s): trying again in %g s", job_id, exc, STORE_RETRY_SECONDS)
        with Session() as session:
            released = _patiently(f"job {job_id}", lambda: crud.release(session, job_id, job.lease), s.job_seconds)
        if released:
            state_changed(job_id, "queued", "handed back: its upload could not be fetched")
            raise RetryTask(delay=STORE_RETRY_SECONDS) from None
        return "taken"
    except StorageMissing as exc:
        reason = f"its upload is gone: {exc}"
        with Session() as session:
            if _patiently(f"job {job_id}", lambda: crud.finish(session, job_id, job.lease, "failed", error=reason), s.job_seconds):
                state_changed(job_id, "failed", reason)
        return "failed"
    tmp = f"out.tmp.{job.lease}"  # this lease's own: two bakes of one job never share a folder
    shutil.rmtree(folder / tmp, ignore_errors=True)
    worker = _take_bake_process(s)
    _running[job_id] = (worker.pid, job.lease)
    try:
        return _supervise(job_id, job.lease, folder, tmp, worker)
    finally:
        _running.pop(job_id, None)
        _give_back(worker)
        shutil.rmtree(folder / tmp, ignore_errors=True)
        (folder / f"progress.{job.lease}").unlink(missing_ok=True)
        storage.done_with(folder)


def _beating(job_id: str, token: int, call):
    """``call()`` (a transfer to or from the object store, which may take a while) in a
    thread, while this one beats the job's heartbeat: the reaper must not take the job
    from a bake that is only moving its files."""
    s = get_settings()
    with ThreadPoolExecutor(1, thread_name_prefix=f"transfer-{job_id[:8]}") as pool:
        done = pool.submit(call)
        while True:
            try:
                return done.result(timeout=s.heartbeat_seconds)
            except TimeoutError:
                try:
                    with db.sessions(s.database)() as session:
                        crud.beat(session, job_id, token)
                except DBAPIError:
                    pass  # the jobs table is out of reach: the bake's own loop says so


def _patiently(what: str, call, seconds: float):
    """``call()``, tried again for up to ``seconds`` while the jobs table or the object
    store is out of reach."""
    end, delay = time.monotonic() + seconds, 0.2
    while True:
        try:
            return call()
        except (DBAPIError, StorageUnavailable) as exc:
            if time.monotonic() + delay > end:
                raise
            reason = type(exc.orig).__name__ if isinstance(exc, DBAPIError) else str(exc)
            logger.warning("%s: %s is out of reach (%s): trying again in %.1f s", what,
                           "the jobs table" if isinstance(exc, DBAPIError) else "the object store", reason, delay)
            time.sleep(delay)
            delay = min(5.0, delay * 2)


def _supervise(job_id: str, token: int, folder: Path, tmp: str, worker: Worker) -> str:
    """Beat the job's heartbeat while its bake runs; stop it when cancelled, taken or late;
    publish its outputs only while holding the lease."""
    s = get_settings()
    Session = db.sessions(s.database)
    end = time.monotonic() + s.job_seconds
    state, error, unreachable = "running", None, False
    reply: tuple[bool, object] | None = None if worker.send("bake", (str(folder), token)) else (False, worker.exit_reason())
    while reply is None:
        reply = worker.result(timeout=min(s.heartbeat_seconds, 0.5))
        if reply is None:
            try:
                with Session() as session:
                    state = crud.beat(session, job_id, token, progress=_progress(folder / f"progress.{token}"))
                if unreachable:
                    logger.info("job %s: the jobs table answers again", job_id)
                unreachable = False
            except DBAPIError as exc:  # a database outage: keep baking, the heartbeat resumes with it
                if not unreachable:
                    logger.warning("job %s: heartbeat failed (%s): baking on", job_id, type(exc.orig).__name__)
                unreachable = True
            if state != "running" or time.monotonic() > end:
                error = f"the bake took longer than {s.job_seconds:g} s"
                worker.end()  # the bake is abandoned with its process
                break
    if reply is not None and not reply[0] and _handing_back.is_set():
        return "handed back"  # killed by hand_back(), which puts the job back in the queue
    if reply is not None:
        ok, value = reply
        if ok:  # the bake's own answer: None (done) or why it failed
            error = None if value is None else str(value)
        elif str(value).startswith("exit code"):  # the bake's process died: a crash in native code, or killed
            error = f"the bake's process died without a word (a crash in native code, or killed; {value})"
        else:
            error = f"internal error: {value}"
    if state != "running":
        return state  # cancelled, or taken from us (the reaper re-queued it; another bake holds it now)
    wait = s.job_seconds  # a finished bake waits out an outage as long as a bake may take
    if error is None:
        with Session() as session:
            if not _patiently(f"job {job_id}", lambda: crud.holds(session, job_id, token), wait):
                logger.info("job %s: lease %d lost before publishing: outputs discarded", job_id, token)
                return "taken"
            report = json.loads((folder / tmp / "report.json").read_text())
            try:
                error = _patiently(f"job {job_id}", lambda: _beating(job_id, token, lambda: _publish(get_storage(s), job_id, token, folder / tmp)), wait)
            except StorageUnavailable as exc:
                error = f"its outputs could not be stored: {exc}"
            if error is None:
                if _patiently(f"job {job_id}", lambda: crud.finish(session, job_id, token, "done", report=report), wait):
                    state_changed(job_id, "done")
                    return "done"
                return "taken"
    with Session() as session:
        if _patiently(f"job {job_id}", lambda: crud.finish(session, job_id, token, "failed", error=error), wait):
            state_changed(job_id, "failed", error or "")
            return "failed"
    return "taken"


def _publish(storage: Storage, job_id: str, token: int, outputs: Path) -> str | None:
    """Publish the bake's files in ``outputs``, then check that the store holds each of them
    at its size (the job reads done only then): None, or why the job fails."""
    files = {p.name: p.stat().st_size for p in outputs.iterdir() if p.is_file()}
    storage.publish(job_id, token, outputs)
    held = storage.outputs(job_id, token)
    missing = sorted(name for name, size in files.items() if held.get(name) != size)
    return f"its outputs could not be stored: the store does not hold {', '.join(missing)} as written" if missing else None


def hand_back() -> list[str]:
    """Give this worker's running jobs back to the queue and stop their bakes.

    For a worker that is stopping (``texbake worker`` on SIGTERM, once running bakes have
    had ``BAKE_STOP_SECONDS`` to finish): another worker takes them up at once, without
    waiting for the reaper, and the attempt is not counted against the job.
    """
    s = get_settings()
    returned = []
    _handing_back.set()  # before the kills: their bakes' threads must not fail the jobs first
    for job_id, (pid, token) in list(_running.items()):
        try:
            os.kill(pid, signal.SIGKILL)  # first: a bake that ends now cannot publish a released job
        except ProcessLookupError:
            pass
        with db.sessions(s.database)() as session:
            if crud.release(session, job_id, token):
                returned.append(job_id)
                state_changed(job_id, "queued", "handed back by a stopping worker")
    for job_id in returned:
        enqueue_bake(job_id)
    return returned


def reap_forever(stop, worker_slots: int | None = None) -> None:
    """Reap at once, then every half ``stale_seconds`` until ``stop`` (a threading.Event)
    is set; expire old jobs (:mod:`texbake.service.worker.retention`) every ``GC_SECONDS``. In a worker
    (``worker_slots``: its bakes at a time), also record that it is alive, for ``/readyz``."""
    import socket

    from .retention import GC_SECONDS, collect

    interval = max(0.5, min(get_settings().stale_seconds, get_settings().requeue_seconds) / 2)
    last_gc = -GC_SECONDS
    me = f"{socket.gethostname()}:{os.getpid()}"
    while True:
        try:
            if worker_slots is not None:
                with db.sessions(get_settings().database)() as session:
                    crud.worker_seen(session, me, worker_slots)
            reap_once()
            if time.monotonic() - last_gc >= GC_SECONDS:
                last_gc = time.monotonic()
                collected = collect(get_settings())
                if collected.jobs or collected.leftovers:
                    logger.info("expired %d jobs, removed %d left-overs", len(collected.jobs), len(collected.leftovers))
        except Exception as exc:  # the database or the queue out of reach: say so, and try again next time
            logger.warning("reaping stale jobs failed: %s: %s", type(exc).__name__, exc)
        if stop.wait(interval):
            return


def reap_once() -> tuple[list[str], list[str]]:
    """Re-queue jobs whose worker died (stale heartbeat), fail those out of attempts, and
    enqueue again queued jobs that the queue lost (not in it after ``requeue_seconds``:
    a queue write that failed, a flushed Redis, a task dropped). Returns (re-queued, failed)."""
    s = get_settings()
    with db.sessions(s.database)() as session:
        requeued, failed = crud.reap(session, s.stale_seconds, s.max_attempts)
        candidates = crud.stranded(session, s.requeue_seconds)
    for job_id in requeued:
        state_changed(job_id, "queued", "its worker stopped answering")
    for job_id in failed:
        state_changed(job_id, "failed", "its worker stopped answering too many times")
    lost = []
    if candidates:
        held = queued_ids()
        lost = [job_id for job_id in candidates if job_id not in held]
    for job_id in requeued + lost:
        enqueue_bake(job_id)
    for job_id in lost:
        logger.warning("job %s: queued but not in the queue: enqueued again", job_id)
    return requeued + lost, failed
