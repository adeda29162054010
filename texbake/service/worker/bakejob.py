"""A service bake process: ``python -m texbake.service.worker.bakejob MEMORY_MB [CACHE]`` serves bakes, one
job after another (``texbake.workers`` protocol), with the baking core imported once.

:func:`setup` caps the process's address space and names the folder of the atlases kept
for later bakes of the same mesh (``DATA_DIR/cache``, bounded: ``texbake.atlas.cache``; the texel
lookups of its latest bakes stay in memory for its next jobs); :func:`run` reads ``JOB_DIR/job.json``
(mesh file name and bake settings; the files the mesh refers to lie beside it), bakes into ``JOB_DIR/out.tmp.LEASE`` (the lease's
own folder) and returns None, or the reason the bake failed.
"""

from __future__ import annotations

import ctypes
import json
import os
import resource
import sys
import threading
import traceback
from pathlib import Path

from texbake import BakeError, bake_mesh
from texbake.atlas import AtlasCache
from texbake.settings import BakeSettings
from texbake.workers import serve

_memory_mb = 0  # this process's address-space limit, set by setup()
_cache: AtlasCache | None = None  # the atlases of earlier bakes on this machine, the lookups of this process's (set by setup())
_progress_file = "progress"  # of the running bake, set by run()


def setup(memory_mb: int, cache: Path | None = None) -> None:
    """Cap the address space at ``memory_mb``; keep atlases in ``cache``; load every
    texture's kernels in the background (a job's first use of a texture otherwise pays
    for it: 0.3-1 s)."""
    global _memory_mb, _cache
    _memory_mb, _cache = memory_mb, None if cache is None else AtlasCache(cache)
    limit = memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    _few_arenas()
    threading.Thread(target=_warm, daemon=True).start()


def _few_arenas() -> None:
    """At most two malloc arenas (glibc's ``mallopt(M_ARENA_MAX, 2)``): each thread that
    allocates may otherwise reserve an arena of 64 MB of address space, which the limit
    counts (the tile threads, the kernels' pool, the warm-up), so a bake well inside the
    limit could fail for address space it never used."""
    try:
        ctypes.CDLL(None).mallopt(-8, 2)  # M_ARENA_MAX
    except (OSError, AttributeError):
        pass


def _warm() -> None:
    """Bake each texture (and a bump, shaded) into a square of two triangles with its own
    UVs, 8 texels a side: every kernel a job can use is loaded (no unwrap, nothing written)."""
    import numpy as np
    import trimesh

    from texbake.textures.spec import TEXTURES

    square = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]], process=False,
                             visual=trimesh.visual.TextureVisuals(uv=np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)))
    try:
        for name in TEXTURES:
            bake_mesh(square, name, size=8, workers=1)
        bake_mesh(square, "checker", size=8, workers=1, bump="noise", shading="full")
    except Exception:  # a warm-up only: a real job reports what is wrong
        traceback.print_exc()


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
        # one core per bake: the service runs as many bakes at a time as it has workers; every
        # texture set and tile counted against this process's limit before the atlas is made
        result = bake_mesh(Path(job["mesh"]), settings, workers=1, progress=_write_progress, cache=_cache,
                           memory_limit=_memory_mb << 20)
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
    setup(int(sys.argv[1]), Path(sys.argv[2]) if len(sys.argv) > 2 else None)
    serve({"bake": run})
