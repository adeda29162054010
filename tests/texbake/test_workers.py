"""The worker-process supervisor (texbake.workers), with a small real worker script."""

import os
import signal
import sys
import time
from pathlib import Path

import pytest

from texbake.workers import Pool, Worker

SCRIPT = """
import os, signal, sys, time
time.sleep(float(sys.argv[1]))  # a slow start, like the imports of a real worker
from texbake.workers import serve


def crash():
    os.kill(os.getpid(), signal.SIGSEGV)


HELD = []


def hold(megabytes):
    HELD.append(bytearray(megabytes << 20))
    return "held"


def spin(seconds):
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass
    return "spun"


def once(marker, how):
    # stuck the first time (asleep, or spinning), answers the next
    if not os.path.exists(marker):
        open(marker, "w").close()
        if how == "sleep":
            time.sleep(600)
        while True:
            pass
    return "again"


serve({"once": once, "add": lambda a, b: a + b, "fail": lambda: 1 / 0, "crash": crash, "sleep": time.sleep,
       "print": lambda: print("not a reply") or "ok", "spin": spin, "hold": hold})
"""


@pytest.fixture
def command(tmp_path):
    script = tmp_path / "worker.py"
    script.write_text(SCRIPT)
    return lambda start=0.0: [sys.executable, str(script), str(start)]


def test_a_worker_answers_fails_and_dies_with_the_reason(command, tmp_path):
    w = Worker(command(), str(tmp_path))
    try:
        assert w.send("add", (2, 3)) and w.result(30) == (True, 5)
        assert w.send("print", ()) and w.result(30) == (True, "ok")  # what a job prints is not a reply
        assert w.send("fail", ()) and w.result(30) == (False, "ZeroDivisionError: division by zero")
        assert w.send("add", ([1], [2])) and w.result(30) == (True, [1, 2])  # still serving
        assert w.send("crash", ()) and w.result(30) == (False, f"exit code {-signal.SIGSEGV}")
    finally:
        w.end()


def test_a_worker_leaves_group_signals_to_its_parent(command, tmp_path):
    """SIGTERM or SIGINT sent while it starts (blocked) or serves (ignored) does not kill it."""
    w = Worker(command(start=1.0), str(tmp_path))
    try:
        os.kill(w.pid, signal.SIGTERM)  # during its start
        os.kill(w.pid, signal.SIGINT)
        assert w.send("add", (1, 1)) and w.result(30) == (True, 2)
        os.kill(w.pid, signal.SIGTERM)  # while it serves
        assert w.send("add", (2, 2)) and w.result(30) == (True, 4)
        assert signal.pthread_sigmask(signal.SIG_BLOCK, set()) == set()  # the parent's mask is as it was
    finally:
        assert w.end(polite=True) == 0


def test_a_pool_runs_jobs_and_stops_at_its_deadline(command):
    with Pool(command(), 2, 20) as pool:
        assert pool.run([("add", (i, i)) for i in range(5)]) == [(True, 2 * i) for i in range(5)]
        assert pool.run([("crash", ()), ("add", (1, 2))]) == [(False, f"exit code {-signal.SIGSEGV}"), (True, 3)]
    with Pool(command(), 2, 2) as pool:
        began = time.monotonic()
        # two workers: the first sleeps, the second adds, then sleeps too; the last job never starts
        assert pool.run([("sleep", (60,)), ("add", (1, 1)), ("sleep", (60,)), ("add", (2, 2))]) == [
            (False, "timeout"), (True, 2), (False, "timeout"), (False, "timeout")]
        assert time.monotonic() - began < 6


def test_a_pools_deadline_is_its_workers_cpu_time(command):
    with Pool(command(), 1, 3) as pool:
        assert pool.run([("spin", (0.5,))]) == [(True, "spun")]
        assert 0.5 <= pool.spent() < 3 and pool.left() == pytest.approx(3 - pool.spent())
        pool.restart(1.0)  # the warm worker's CPU time is counted from here
        assert pool.spent() < 0.1
        began = time.monotonic()
        assert pool.run([("spin", (60,))]) == [(False, "timeout")]
        took = time.monotonic() - began
        assert took < Pool.WALL_FACTOR * 1.0 + 1
        # ended at 1 s of its CPU time, or where it got less than a quarter of a core (a
        # loaded machine), at the wall-clock backstop
        assert (pool.spent() >= 1.0 and pool.left() <= 0) or took >= Pool.WALL_FACTOR * 1.0
        pool.restart(5.0)
        assert pool.run([("add", (1, 2))]) == [(True, 3)]  # a fresh worker in place of the ended one


@pytest.mark.parametrize("how", ["sleep", "spin"])
def test_a_pool_sends_a_stuck_job_to_a_fresh_worker(command, tmp_path, how):
    """A job past ``job_seconds`` that sleeps (a deadlock) or spins (a livelock) is ended
    and run again once, long before the pool's deadline; the others are not touched."""
    with Pool(command(), 2, 60) as pool:
        began = time.monotonic()
        jobs = [("once", (str(tmp_path / "first"), how)), ("add", (1, 1))]
        assert pool.run(jobs, job_seconds=1.0, retries=1) == [(True, "again"), (True, 2)]
        assert time.monotonic() - began < 15  # not the 60 s deadline, nor its wall backstop
        began = time.monotonic()
        jobs = [("once", (str(tmp_path / "second"), how)), ("add", (2, 2))]
        assert pool.run(jobs, job_seconds=1.0) == [(False, "timeout"), (True, 4)]  # no retry asked for
        assert time.monotonic() - began < 15
        assert pool.run([("add", (3, 3))]) == [(True, 6)]  # the pool works on


def test_a_pool_ends_the_idle_workers_that_hold_much_memory(command):
    from texbake.workers import resident_bytes

    with Pool(command(), 2, 30) as pool:
        assert pool.run([("hold", (64,)), ("add", (1, 1))]) == [(True, "held"), (True, 2)]
        sizes = {w.pid: resident_bytes(w.pid) for w in pool.all}
        assert sorted(sizes.values())[1] > 64 << 20 > sorted(sizes.values())[0] > 0
        pool.end_larger_than(48 << 20)
        assert [w.pid for w in pool.all] == [pid for pid, size in sizes.items() if size < 48 << 20]


def test_a_worker_dies_with_its_parent_even_while_it_starts(command, tmp_path):
    """kill -9 of the parent while its worker is still importing (before the worker could
    ask Linux for a signal on the parent's death): the worker ends by itself."""
    import subprocess

    import psutil

    parent = subprocess.Popen([sys.executable, "-c", f"""
import sys, time
from texbake.workers import Worker
w = Worker({command(start=2.0)!r}, {str(tmp_path)!r})
print(w.pid, flush=True)
time.sleep(60)
"""], stdout=subprocess.PIPE, text=True)
    pid = int(parent.stdout.readline())
    parent.kill()
    parent.wait()
    parent.stdout.close()
    child = psutil.Process(pid)
    assert child.ppid() != parent.pid  # re-parented
    child.wait(10)  # raises TimeoutExpired if it outlives its parent by 10 s (2 s start + 0.5 s poll)
    assert not psutil.pid_exists(pid) or child.status() == psutil.STATUS_ZOMBIE


def test_a_module_worker_is_isolated_from_the_working_directory(tmp_path, monkeypatch):
    """``[python, -m, MODULE]`` runs isolated: a ``texbake.py`` in its working folder and a
    relative PYTHONPATH entry (naming that folder) are ignored; the package still imports
    from this source tree, and an absolute PYTHONPATH entry still counts."""
    import subprocess

    from texbake.workers import isolated

    (tmp_path / "texbake.py").write_text("raise SystemExit('the working folder was imported')")
    (tmp_path / "extra").mkdir()
    (tmp_path / "extra" / "texbake_extra.py").write_text("")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([".", str(tmp_path / "extra")]))
    code = "import sys, texbake, texbake_extra; print(texbake.__file__, sys.flags.isolated, sys.argv[1:])"
    probe = tmp_path / "extra" / "probe.py"
    probe.write_text(code)
    command = isolated([sys.executable, "-m", "probe", "a", "b"])
    assert command[1:3] == ["-I", "-c"] and command[-3:] == ["probe", "a", "b"]
    out = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == [str(Path(__file__).resolve().parents[2] / "texbake" / "__init__.py"), "1", "['a',", "'b']"]
    assert isolated([sys.executable, "worker.py"]) == [sys.executable, "worker.py"]  # a script: as it is
