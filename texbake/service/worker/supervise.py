"""``texbake serve``'s embedded worker: started, watched, restarted when it dies, and
stopped with everything it started.

The API process becomes a child subreaper (``PR_SET_CHILD_SUBREAPER``), so the bake
processes of a worker that dies (``kill -9``, the OOM killer) are re-parented to it, not
to PID 1; it ends them before it starts the next worker. (They also end by themselves:
``texbake.workers`` bake processes die with their parent.)
"""

from __future__ import annotations

import logging
import subprocess
import threading
import time
from collections.abc import Sequence

import psutil

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


class Supervisor:
    """Runs ``command`` (``texbake worker``) and keeps it running until :meth:`stop`."""

    def __init__(self, command: Sequence[str], stop_seconds: float):
        self.command, self.stop_seconds = list(command), stop_seconds
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
                self.process = subprocess.Popen(self.command)

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
