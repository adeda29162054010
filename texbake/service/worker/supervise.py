"""``texbake serve``'s embedded worker: started, watched, restarted when it dies, and
stopped with everything it started.

The API process becomes a child subreaper (``PR_SET_CHILD_SUBREAPER``), so the bake
processes of a worker that dies (``kill -9``, the OOM killer) are re-parented to it, not
to PID 1; it ends them before it starts the next worker. (They also end by themselves:
``texbake.workers`` bake processes die with their parent.) The worker dies with the API
process in the same way (``TEXBAKE_WORKER_PARENT``: :func:`texbake.workers.die_with_parent`),
so a ``kill -9`` of ``texbake serve`` leaves no worker baking from the queue on its own.

The worker is an isolated interpreter (:func:`texbake.workers.isolated`) in a working
folder of its own, the data folder: nothing in the folder ``texbake serve`` was started
from is imported or read by it. Its settings are the API's, passed in its environment
(:func:`worker_environment`), so a ``.env`` file or a relative path that the API read
means the same to it.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import psutil

from texbake.workers import child_env, isolated

from ..core.config import Settings

logger = logging.getLogger("texbake.service")

RESTART_DELAYS = (1.0, 2.0, 5.0, 10.0, 30.0)  # a worker that keeps dying is restarted ever more slowly
HEALTHY_SECONDS = 60.0  # a worker that ran this long starts the delays again from the first


def become_subreaper() -> bool:
    """Make orphaned descendants this process's children (Linux); False where not possible."""
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0) == 0  # PR_SET_CHILD_SUBREAPER
    except (OSError, AttributeError):
        return False


def end_orphans() -> list[int]:
    """Kill and reap this process's children (called when it has no worker: they are the
    re-parented orphans of one); their pids."""
    ended = []
    for child in psutil.Process().children():
        try:
            child.kill()
            child.wait(10)
            ended.append(child.pid)
        except psutil.NoSuchProcess:
            pass
        except psutil.TimeoutExpired:
            logger.error("process %d did not end after SIGKILL", child.pid)
    return ended


def worker_environment(settings: Settings) -> dict[str, str]:
    """This process's environment with every setting it runs with as a ``BAKE_*`` variable
    (what came from a ``.env`` file too), paths made absolute: the worker, started in
    another folder, then runs with the same settings."""
    env = dict(os.environ)
    for name in Settings.model_fields:
        value = getattr(settings, name)
        if value is None:
            continue
        if name == "data_dir":
            value = Path(value).resolve()
        elif name == "database_url":
            value = _absolute_sqlite(value)
        env[f"BAKE_{name.upper()}"] = json.dumps(value) if isinstance(value, list) else str(value)
    return env


def _absolute_sqlite(url: str) -> str:
    """A SQLite URL whose file is given relative to the working folder, made absolute."""
    from sqlalchemy.engine import make_url

    parsed = make_url(url)
    name = parsed.database
    if not parsed.drivername.startswith("sqlite") or not name or name == ":memory:" or name.startswith("file:") or os.path.isabs(name):
        return url
    return parsed.set(database=os.path.abspath(name)).render_as_string(hide_password=False)


class Supervisor:
    """Runs ``command`` (``[sys.executable, "-m", "texbake.cli", "worker", ...]``, started
    isolated in ``folder`` with ``env``) and keeps it running until :meth:`stop`."""

    def __init__(self, command: Sequence[str], stop_seconds: float, *, folder: Path | None = None, env: Mapping[str, str] | None = None):
        self.command, self.stop_seconds = list(command), stop_seconds
        self.folder, self.env = folder, dict(os.environ if env is None else env)
        self.process: subprocess.Popen | None = None
        self.restarts = 0
        self._stopping = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._watch, name="worker-supervisor", daemon=True)

    def start(self) -> None:
        become_subreaper()
        self._spawn()
        self._thread.start()

    def _spawn(self) -> None:
        with self._lock:
            if not self._stopping.is_set():
                # the worker dies with this process (child_env); Linux signals it when the
                # thread that started it ends: the main thread or the watching one, which
                # both outlive it
                self.process = subprocess.Popen(isolated(self.command), cwd=self.folder, env=child_env(self.env))

    def _watch(self) -> None:
        failures = 0
        while not self._stopping.is_set():
            process = self.process
            assert process is not None  # started by start()
            began = time.monotonic()
            code = process.wait()
            if self._stopping.is_set():
                return
            failures = 1 if time.monotonic() - began > HEALTHY_SECONDS else failures + 1  # deaths in a row
            delay = RESTART_DELAYS[min(failures, len(RESTART_DELAYS)) - 1]
            orphans = end_orphans()
            logger.error("the worker (pid %d) ended with exit code %s; %d of its processes ended; restarting it in %g s",
                         process.pid, code, len(orphans), delay)
            if self._stopping.wait(delay):
                return
            self.restarts += 1
            self._spawn()

    def stop(self) -> None:
        """The worker's graceful stop (SIGTERM: running bakes finish within BAKE_STOP_SECONDS
        or go back to the queue), then SIGKILL for what is left, orphans included."""
        with self._lock:
            self._stopping.set()
            process = self.process
        if process is not None and process.poll() is None:
            process.terminate()
            try:
                process.wait(self.stop_seconds + 10)
            except subprocess.TimeoutExpired:
                logger.error("the worker (pid %d) did not stop in %g s: killed", process.pid, self.stop_seconds + 10)
                process.kill()
                process.wait()
        end_orphans()
        if self._thread.is_alive():
            self._thread.join(5)
