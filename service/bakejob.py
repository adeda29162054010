"""A service bake process: ``python -m service.bakejob MEMORY_MB`` serves bakes, one job
after another (``bake.workers`` protocol), with the baking core imported once.

:func:`setup` caps the process's address space; :func:`run` reads ``JOB_DIR/job.json``
(mesh file name and bake settings), bakes into ``JOB_DIR/out.tmp.LEASE`` (the lease's
own folder) and returns None, or the reason the bake failed.
"""

from __future__ import annotations

import json
import os
import resource
import sys
import threading
import traceback
from pathlib import Path

from bake import BakeError, bake_mesh
from bake.settings import BakeSettings
from bake.workers import serve

_memory_mb = 0  # this process's address-space limit, set by setup()
_progress_file = "progress"  # of the running bake, set by run()


def setup(memory_mb: int) -> None:
    """Cap the address space at ``memory_mb``."""
    global _memory_mb
    _memory_mb = memory_mb
    limit = memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def _write_progress(fraction: float) -> None:
    """Leave the bake's progress in ``JOB_DIR/progress.LEASE`` for the worker's heartbeat."""
    tmp = Path(f"{_progress_file}.{threading.get_ident()}.tmp")  # tiles report from their threads
    tmp.write_text(f"{0.95 * fraction:.3f}")  # the last 5 %: saving the files
    tmp.replace(_progress_file)


def run(job_dir: str, lease: int) -> str | None:
    """Bake the job in ``job_dir`` under ``lease``: None when its files are in
    ``out.tmp.LEASE``, else why not."""
    global _progress_file
    os.chdir(job_dir)  # errors name the mesh as uploaded, not the server's folders
    _progress_file = f"progress.{lease}"
    job = json.loads(Path("job.json").read_text())
    try:
        settings = BakeSettings.build(job["settings"])
        # one core per bake: the service runs as many bakes at a time as it has workers
        result = bake_mesh(Path(job["mesh"]), settings, workers=1, progress=_write_progress)
        result.save(Path(f"out.tmp.{lease}"))
    except BakeError as exc:
        return str(exc)
    except MemoryError:
        return f"the bake ran out of its {_memory_mb} MB memory limit"
    except Exception as exc:  # a bug: keep the trace in the worker's log, the reason in the job
        traceback.print_exc()
        return f"internal error: {type(exc).__name__}: {exc}"
    return None


if __name__ == "__main__":
    setup(int(sys.argv[1]))
    serve({"bake": run})
