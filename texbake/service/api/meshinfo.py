"""What an uploaded mesh holds before it is baked (``POST /v1/inspect``): its materials with
their faces, UVs and UDIM tiles, read by the bake's own loader and texture sets
(:func:`texbake.mesh.load_mesh`, :func:`texbake.sets.texture_sets`), so the names are
exactly those ``materials`` takes: an unnamed glTF material's ``material_N``, a name's
whitespace collapsed, a material left without faces gone.

The mesh is read in a child process (``python -m texbake.service.api.meshinfo MEMORY_MB``,
a :mod:`texbake.workers` worker), never in the API's: an upload may be as large as the
upload limit, and parsing it can take seconds and gigabytes. The child's address space is
capped at ``BAKE_JOB_MEMORY_MB``, as a bake's (at least :data:`MIN_MEMORY_MB`), and it is killed after
:data:`INSPECT_SECONDS`. One child per API process, kept warm (its imports take 1.5-3 s),
owned by one thread of its own (Linux ends a worker with the thread that started it, and
request threads come and go); it reads one mesh at a time, and a request that cannot have
its turn within :data:`WAIT_SECONDS` is answered 503.
"""

from __future__ import annotations

import os
import queue
import sys
import threading
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from pathlib import Path

INSPECT_SECONDS = 60.0  # the longest one mesh may take to read
WAIT_SECONDS = 30.0  # the longest a request waits for its turn
MAX_WAITING = 8  # requests waiting at once; more are answered 503 at once
MIN_MEMORY_MB = 1024  # measured: reading a 0.5 MB GLB takes 430 MB of address space (Python, numpy, scipy, trimesh mapped)


class Busy(Exception):
    """No turn for this mesh within :data:`WAIT_SECONDS` (or too many waiting): try again."""


def describe(folder: str, mesh: str, max_faces: int) -> dict:
    """The child's job: ``{"info": ...}`` (:class:`texbake.service.api.schemas.MeshInfo`'s
    fields but ``mesh``) of the mesh file ``mesh`` in ``folder``, or ``{"problem": why}``
    (a reason naming no server folder)."""
    from texbake.atlas import udim_tiles
    from texbake.errors import BakeError, MeshError
    from texbake.mesh import load_mesh
    from texbake.sets import texture_sets
    from texbake.settings import BakeSettings

    os.chdir(folder)  # errors name the mesh as uploaded, not the server's folders
    try:
        loaded = load_mesh(Path(mesh), max_faces=max_faces)
        sets = texture_sets(loaded, BakeSettings())  # one per material, as a bake of the default settings
    except BakeError as exc:
        return {"problem": exc.problem if isinstance(exc, MeshError) else str(exc)}
    except MemoryError:
        return {"problem": "reading it needs more memory than this server gives a bake"}
    materials = []
    for s in sets:
        m = s.mesh
        uv = "none" if m.uv is None else "some" if m.has_uv is not None else "all"
        tiles = udim_tiles(m.uv, m.faces) if m.uv is not None and m.has_uv is None else None
        numbers = [] if tiles is None else sorted(set(tiles.tolist()))
        materials.append({"name": s.name, "faces": len(s.faces), "uv": uv, "tiles": [] if numbers == [1001] else numbers})
    return {"info": {"faces": len(loaded.faces), "vertices": len(loaded.vertices), "parts": list(loaded.part_names),
                     "materials": materials, "warnings": list(loaded.warnings)}}


class Inspector:
    """The API's reader of meshes: one warm child process (:func:`describe`), one mesh at
    a time, owned by a thread of its own."""

    def __init__(self, memory_mb: int, folder: Path):
        self.memory_mb, self.folder = memory_mb, folder
        self._jobs: queue.Queue = queue.Queue()
        self._waiting = threading.BoundedSemaphore(MAX_WAITING)
        self._thread: threading.Thread | None = None
        self._start = threading.Lock()

    def inspect(self, folder: Path, mesh: str, max_faces: int) -> dict:
        """:func:`describe` of ``folder / mesh`` in the child; :class:`Busy` when it had no turn."""
        if not self._waiting.acquire(blocking=False):
            raise Busy
        try:
            with self._start:
                if self._thread is None:
                    self._thread = threading.Thread(target=self._serve, name="inspector", daemon=True)
                    self._thread.start()
            future: Future = Future()
            self._jobs.put((str(folder), mesh, max_faces, future))
            try:
                return future.result(WAIT_SECONDS + INSPECT_SECONDS)
            except FutureTimeout:
                future.cancel()  # not started yet: the thread skips it
                raise Busy from None
        finally:
            self._waiting.release()

    def stop(self) -> None:
        """End the thread and its child (the API is stopping)."""
        if self._thread is not None:
            self._jobs.put(None)
            self._thread.join(10)

    def _serve(self) -> None:
        from texbake.workers import Worker

        self.folder.mkdir(parents=True, exist_ok=True)
        worker = None
        while (job := self._jobs.get()) is not None:
            folder, mesh, max_faces, future = job
            if not future.set_running_or_notify_cancel():
                continue
            if worker is None:
                worker = Worker([sys.executable, "-m", __name__, str(self.memory_mb)], str(self.folder))
            reply = worker.result(INSPECT_SECONDS) if worker.send("inspect", (folder, mesh, max_faces)) else (False, worker.exit_reason())
            if reply is None or not reply[0]:  # too slow, or died (out of memory, a crash): a fresh child next time
                worker.end()
                worker = None
                future.set_result({"problem": f"it could not be read within {INSPECT_SECONDS:g} s" if reply is None
                                   else f"reading it failed ({reply[1]}): it is too large or not a mesh this server can read"})
            else:
                future.set_result(reply[1])
        if worker is not None:
            worker.end(polite=True)


def main(memory_mb: int) -> None:
    """The child: its address space capped at ``memory_mb``, serving :func:`describe`."""
    import resource

    from texbake.workers import serve

    limit = max(memory_mb, MIN_MEMORY_MB) * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    serve({"inspect": describe})


if __name__ == "__main__":
    main(int(sys.argv[1]))
