"""Worker processes: the one supervisor of every child process texbake runs work in
(the xatlas unwrap here, the service's bakes).

A worker is a fresh interpreter running a module of the package as ``__main__``: not a
fork and not multiprocessing, so the caller's ``__main__`` is never re-imported, it works
from pool processes too, and a hang or a crash in native code (xatlas, a bake) takes down
only the worker, which the parent then sees die or kills at its deadline. A worker dies
with its parent (:func:`die_with_parent`): Linux kills it when the parent thread that
started it ends, and it watches its parent's pid besides, which covers a parent that died
while the worker started and a parent thread that is not the one that lives longest.

Every such interpreter is isolated (:func:`isolated`: ``python -I``), so nothing in the
working directory, the user's site-packages or ``PYTHON*`` variables is imported or obeyed
in place of the package: a ``texbake.py`` beside the command line would otherwise be the
worker. The package's own folder is put first on its path explicitly, so a source
checkout works as an installed package does.

Protocol: the parent writes one line per job to the worker's stdin, the path of a file
holding a pickled ``(kind, args)``; the worker answers on stdout with an 8-byte
little-endian length and a pickled ``("ok", result)`` or ``("error", message)``. An empty
line or EOF ends it. The worker's side is :func:`serve`; the parent's, :class:`Worker`
(one worker, one job at a time) and :class:`Pool` (several, one deadline for a list of jobs).
"""

from __future__ import annotations

import os
import pickle
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

_ROOT = str(Path(__file__).resolve().parents[1])  # the folder that holds the package
_PARENTS_SIGNALS = {signal.SIGINT, signal.SIGTERM}  # a worker leaves them to its parent


PARENT_ENV = "TEXBAKE_WORKER_PARENT"  # the pid of the process that started this worker
PARENT_POLL_SECONDS = 0.5

# Run by ``python -I -c``: argv is PATHS MODULE ARG...; the PATHS (os.pathsep-separated)
# not on sys.path already go first on it (one that is, site-packages say, stays behind the
# standard library), then MODULE runs as ``__main__`` as ``-m`` would run it.
_BOOTSTRAP = ("import os, runpy, sys; _, paths, module, *args = sys.argv; "
              "sys.path[:0] = [p for p in paths.split(os.pathsep) if p and p not in sys.path]; sys.argv = [module, *args]; "
              "runpy.run_module(module, run_name='__main__', alter_sys=True)")


def isolated(command: Sequence[str]) -> list[str]:
    """``command`` as a child process is started with it: ``[PYTHON, "-m", MODULE, ARG...]``
    becomes ``PYTHON -I -c BOOTSTRAP PATHS MODULE ARG...``; any other command is left as it is.

    ``-I`` keeps the working directory, the user's site-packages and every ``PYTHON*``
    variable out of the child. ``PATHS`` puts back what it needs: the folder holding this
    package (a source checkout, not installed), the absolute entries of this process's
    ``PYTHONPATH`` (a relative one would name the working directory), and the user's
    site-packages where this process uses them (``pip install --user``).
    """
    import site

    command = list(command)
    if len(command) < 3 or command[1] != "-m":
        return command
    extra = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if os.path.isabs(p)]
    user = [p for p in [site.getusersitepackages()] if p in sys.path]
    paths = os.pathsep.join(dict.fromkeys([_ROOT, *extra, *user]))
    return [command[0], "-I", "-c", _BOOTSTRAP, paths, *command[2:]]


def child_env(env: dict[str, str] | None = None) -> dict[str, str]:
    """The environment for a child that is to die with this process (``env`` or this
    process's own, plus ``TEXBAKE_WORKER_PARENT``: see :func:`die_with_parent`)."""
    return {**(os.environ if env is None else env), PARENT_ENV: str(os.getpid())}


def die_with_parent() -> None:
    """End this process when its parent dies (a hung job never returns, and an orphaned
    bake must not keep baking): ``PR_SET_PDEATHSIG``, then a thread that checks every
    ``PARENT_POLL_SECONDS`` that the parent is still the one named in ``TEXBAKE_WORKER_PARENT``
    (set by :func:`child_env`)."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the poll below, and the parent kills it at the deadline
        pass
    parent = int(os.environ.get(PARENT_ENV) or 0)
    if not parent:
        return

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_SECONDS)
        os._exit(70)  # re-parented: the parent is gone

    if os.getppid() != parent:
        os._exit(70)  # it died while this process started
    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def serve(jobs: dict[str, Callable[..., object]]) -> None:
    """The worker's side: answer jobs ``kind -> function`` until an empty line or EOF.

    SIGINT and SIGTERM are ignored: sent to the whole process group (Ctrl-C, systemd's
    stop), they are the parent's to act on; it kills its workers, or they die with it.
    """
    die_with_parent()
    for signum in _PARENTS_SIGNALS:
        signal.signal(signum, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _PARENTS_SIGNALS)  # blocked since the start: see Worker
    out = sys.stdout.buffer
    sys.stdout = sys.stderr  # whatever a job prints must not corrupt the replies
    for line in sys.stdin:
        path = line.strip()
        if not path:
            break
        try:
            with open(path, "rb") as f:
                kind, args = pickle.load(f)
            os.unlink(path)
            reply = ("ok", jobs[kind](*args))
        except Exception as exc:  # reported to the parent, which decides
            reply = ("error", f"{type(exc).__name__}: {exc}")
        data = pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL)
        out.write(len(data).to_bytes(8, "little") + data)
        out.flush()


class Worker:
    """One worker process running ``command`` (``[sys.executable, "-m", MODULE, ...]``,
    started :func:`isolated`); jobs one at a time. ``folder``: where job files go (and the
    worker's working folder)."""

    def __init__(self, command: Sequence[str], folder: str, *, stderr=subprocess.DEVNULL):
        env = child_env()
        self.folder = folder
        # The child starts with SIGINT and SIGTERM blocked (a thread's signal mask survives
        # fork and exec) until serve() ignores them: a group signal during its imports waits
        # and is then dropped, instead of killing it. The parent thread's mask is restored.
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, _PARENTS_SIGNALS)
        try:
            self.process = subprocess.Popen(isolated(command), stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr,
                                            bufsize=0, env=env, cwd=folder)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        self.jobs = 0  # sent so far
        self._buffer: bytearray | None = None  # the reply being read; None: idle

    @property
    def pid(self) -> int:
        return self.process.pid

    @property
    def busy(self) -> bool:
        return self._buffer is not None

    def fileno(self) -> int:
        assert self.process.stdout is not None  # started with pipes
        return self.process.stdout.fileno()

    def send(self, kind: str, args: tuple) -> bool:
        """Start a job; False if the worker is dead (then :meth:`exit_reason` says why)."""
        path = os.path.join(self.folder, f"job-{self.pid}-{self.jobs}.pickle")
        self.jobs += 1
        with open(path, "wb") as f:
            pickle.dump((kind, args), f, protocol=pickle.HIGHEST_PROTOCOL)
        try:
            assert self.process.stdin is not None
            self.process.stdin.write(path.encode() + b"\n")  # a short line: never blocks
            self.process.stdin.flush()
        except OSError:
            return False
        self._buffer = bytearray()
        return True

    def read(self) -> tuple[bool, object] | None:
        """Read what the worker has sent (call when :meth:`fileno` is readable): the job's
        ``(ok, result or message)`` once complete, ``(False, "exit code N")`` if the worker
        died, None while the reply is still coming."""
        assert self._buffer is not None  # a job was sent
        data = os.read(self.fileno(), 1 << 22)
        if not data:  # died (a segfault: a negative exit code)
            self._buffer = None
            return False, self.exit_reason()
        buf = self._buffer
        buf += data
        if len(buf) >= 8 and len(buf) >= 8 + int.from_bytes(buf[:8], "little"):
            self._buffer = None
            status, value = pickle.loads(bytes(buf[8:]))
            return status == "ok", value
        return None

    def result(self, timeout: float) -> tuple[bool, object] | None:
        """The running job's ``(ok, value)``, waiting at most ``timeout`` seconds (None: not yet)."""
        end = time.monotonic() + timeout
        while True:
            left = end - time.monotonic()
            if left <= 0 or not select.select([self], [], [], left)[0]:
                return None
            reply = self.read()
            if reply is not None:
                return reply

    def exit_reason(self) -> str:
        try:
            self.process.wait(1.0)
        except subprocess.TimeoutExpired:
            pass
        return f"exit code {self.end()}"

    def ask_to_quit(self) -> None:
        """Ask an idle worker to exit (an empty line), without waiting."""
        p = self.process
        if p.poll() is None and p.stdin and not p.stdin.closed:
            try:
                p.stdin.write(b"\n")
                p.stdin.flush()
            except OSError:
                pass

    def end(self, *, polite: bool = False) -> int | None:
        """Stop the worker (``polite``: ask it first, for an idle one); returns its exit code."""
        p = self.process
        if polite:
            self.ask_to_quit()
            try:
                p.wait(0.2)
            except subprocess.TimeoutExpired:
                pass
        if p.poll() is None:
            p.kill()
            p.wait()
        for stream in (p.stdin, p.stdout):
            try:
                if stream is not None:
                    stream.close()
            except OSError:
                pass
        return p.returncode


def cpu_seconds(pid: int) -> float | None:
    """CPU time (user and system, all threads) process ``pid`` has used, or None where it
    cannot be read (not Linux, or the process is gone)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            fields = f.read().rsplit(b")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return None


def resident_bytes(pid: int) -> int:
    """Memory process ``pid`` holds (Linux: VmRSS), 0 where that cannot be read."""
    try:
        with open(f"/proc/{pid}/status", "rb") as f:
            for line in f:
                if line.startswith(b"VmRSS:"):
                    return int(line.split()[1]) * 1024
    except (OSError, IndexError, ValueError):
        pass
    return 0


def runnable(pid: int) -> bool:
    """Whether a thread of process ``pid`` is running or waiting for a core (Linux: state
    R); True where that cannot be read."""
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return True
    for tid in tasks:
        try:
            with open(f"/proc/{pid}/task/{tid}/stat", "rb") as f:
                if f.read().rsplit(b")", 1)[1].split()[0] == b"R":
                    return True
        except (OSError, IndexError):
            continue
    return False


class Pool:
    """Up to ``n`` workers of ``command`` sharing one deadline of ``seconds``, counted in
    each worker's own CPU time (a busy machine slows the jobs without changing what they
    do), from the pool's start or the latest :meth:`restart`.

    A job is ended as timed out when its worker has used more than ``cap`` (at first all
    the ``seconds``) of CPU time since then; or, where a worker's CPU time cannot be read,
    when as much wall time has passed; or when as much wall time has passed, the job has
    run ``STALL_SECONDS`` at least, with under ``STALL_SHARE`` of that on a core, and none of its threads is
    runnable (a deadlock or a sleep, which CPU time alone would never end); or after
    ``WALL_FACTOR`` times the ``seconds`` in any case.

    Started lazily, reused for every job (across restarts: a warm pool), and replaced
    when one dies or is ended. Use as a context manager: leaving it ends them all.
    """

    WALL_FACTOR = 4.0
    STALL_SHARE = 0.05
    STALL_SECONDS = 1.0  # a job is not taken as stalled before this (its start may wait on a read)
    POLL_SECONDS = 0.05

    def __init__(self, command: Sequence[str], n: int, seconds: float):
        self.command, self.n = list(command), max(1, n)
        self.folder = tempfile.mkdtemp(prefix="texbake-workers-")
        self.idle: list[Worker] = []
        self.all: list[Worker] = []
        self.restart(seconds)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def restart(self, seconds: float) -> None:
        """A new deadline of ``seconds`` from now (each worker's CPU time counted from here)."""
        self.seconds = self.cap = float(seconds)
        self.began = time.monotonic()
        self._base: dict[Worker, float] = {}
        self._spent: dict[Worker, float] = {}  # CPU seconds since the start, as last read
        for w in self.all:
            self._base[w] = cpu_seconds(w.pid) or 0.0

    def spent(self) -> float:
        """Seconds of the deadline used: the most CPU time one worker has used since the
        start (wall time where that cannot be read)."""
        for w in self.all:
            used = cpu_seconds(w.pid)
            if used is not None:
                self._spent[w] = used - self._base.get(w, 0.0)
            elif w.process.poll() is None:  # alive, but its CPU time unknown: wall time
                self._spent[w] = time.monotonic() - self.began
        return max(self._spent.values(), default=0.0)

    def left(self) -> float:
        """Seconds of the deadline not used yet (:meth:`spent`; negative once passed)."""
        return self.seconds - self.spent()

    def close(self) -> None:
        for w in self.all:  # all asked at once, then each waited for
            if not w.busy:
                w.ask_to_quit()
        for w in self.all:
            w.end(polite=not w.busy)
        self.all.clear()
        self.idle.clear()
        shutil.rmtree(self.folder, ignore_errors=True)

    def run(self, jobs: list[tuple[str, tuple]], *, job_seconds: float | None = None,
            retries: int = 0) -> list[tuple[bool, object]]:
        """Run ``(kind, args)`` jobs; per job ``(True, result)`` or ``(False, why)``.

        ``why`` is "timeout" for jobs not done by the deadline (then every busy worker is
        ended), "exit code N" for a worker that died, or the job's exception message.

        ``job_seconds``: what one job may take, for jobs far smaller than the deadline (the
        patches of a parallel unwrap). A job that has run that long and either used that
        much CPU time or sits idle (a livelock or a deadlock in native code; both were seen
        once in hundreds of unwraps and do not come back on a fresh process) is ended and
        sent to a fresh worker, up to ``retries`` times; then it is "timeout".
        """
        results: list = [None] * len(jobs)
        pending = list(range(len(jobs)))[::-1]
        tries = [0] * len(jobs)
        busy: dict[Worker, tuple[int, float, float]] = {}  # worker -> (job, its wall start, its CPU start)
        while pending or busy:
            while pending and (self.idle or len(self._alive()) < self.n):
                w, i = self._idle_or_new(), pending.pop()
                if w.send(*jobs[i]):
                    busy[w] = (i, time.monotonic(), cpu_seconds(w.pid) or 0.0)
                else:
                    results[i] = (False, w.exit_reason())
            if not busy:
                continue
            ready = select.select(list(busy), [], [], self.POLL_SECONDS)[0]
            if not ready and self._late(busy):
                for w, (i, _, _) in busy.items():
                    w.end()
                    results[i] = (False, "timeout")
                for i in pending:
                    results[i] = (False, "timeout")
                self._forget_dead()
                return results
            for w in ready:
                reply = w.read()
                if reply is None:
                    continue
                results[busy.pop(w)[0]] = reply
                if w.process.poll() is None:  # alive: ready for the next job
                    self.idle.append(w)
            stuck = self._stuck(busy, job_seconds) if job_seconds is not None and not ready else []
            for w in stuck:
                i = busy.pop(w)[0]
                w.end()
                if tries[i] < retries:
                    tries[i] += 1
                    pending.append(i)
                else:
                    results[i] = (False, "timeout")
            if stuck:
                self._forget_dead()
        self._forget_dead()
        return results

    def _stuck(self, busy: dict, job_seconds: float) -> list[Worker]:
        """The workers of ``busy`` whose job has run ``job_seconds`` of wall time and used as
        much CPU time, or under ``STALL_SHARE`` of it with no thread runnable."""
        stuck = []
        for w, (_, started, cpu) in busy.items():
            job_wall = time.monotonic() - started
            if job_wall < job_seconds:
                continue
            used = cpu_seconds(w.pid)
            if used is None:
                continue  # gone: its read reports the exit
            if used - cpu >= job_seconds or (used - cpu < self.STALL_SHARE * job_wall and not runnable(w.pid)):
                stuck.append(w)
        return stuck

    def _late(self, busy: dict) -> bool:
        """Whether the jobs ``busy`` runs are past the deadline (see the class)."""
        wall = time.monotonic() - self.began
        if wall >= self.WALL_FACTOR * self.seconds or self.spent() >= self.cap:
            return True
        if wall < self.cap:
            return False
        for w, (_, started, cpu) in busy.items():
            used = cpu_seconds(w.pid)
            job_wall = time.monotonic() - started
            if used is None or (job_wall >= self.STALL_SECONDS and used - cpu < self.STALL_SHARE * job_wall
                                and not runnable(w.pid)):
                return True
        return False

    def end_larger_than(self, rss: int) -> None:
        """End the idle workers holding more than ``rss`` bytes of memory (a large job's heap
        stays mapped after it: a warm pool would keep it between bakes)."""
        for w in list(self.idle):
            if resident_bytes(w.pid) > rss:
                self.idle.remove(w)
                w.end(polite=True)
        self._forget_dead()

    def _alive(self) -> list[Worker]:
        return [w for w in self.all if w.process.poll() is None]

    def _idle_or_new(self) -> Worker:
        """An idle worker that is still alive (one started by a thread that has ended since
        died with it: see :func:`die_with_parent`), else a new one."""
        while self.idle:
            w = self.idle.pop()
            if w.process.poll() is None:
                return w
            w.end()
        w = Worker(self.command, self.folder)
        self.all.append(w)
        self._base[w] = 0.0
        return w

    def _forget_dead(self) -> None:
        """Ended workers out of the lists (their last CPU reading stays in :meth:`spent`)."""
        dead = [w for w in self.all if w.process.poll() is not None]
        for w in dead:
            w.end()
            self.all.remove(w)
            if w in self.idle:
                self.idle.remove(w)
