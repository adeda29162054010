"""xatlas worker process: ``python -m bake._unwrap_worker`` serves jobs until stdin closes.

It is started by :mod:`bake.atlas` as a fresh interpreter (not a fork, and not through
multiprocessing, so the caller's ``__main__`` is never re-imported and it works from
daemonic pool workers too). xatlas can hang or crash on bad input; here that only takes
down this process, which the parent kills at its deadline or sees die.

Protocol: the parent writes one line per job to stdin, the path of a file holding a
pickled ``(kind, args)``; the worker answers on stdout with an 8-byte little-endian
length and a pickled ``("ok", result)`` or ``("error", message)``. An empty line or EOF
ends it. Only numpy and xatlas are imported.
"""

from __future__ import annotations

import os
import pickle
import sys

import numpy as np


def _die_with_parent() -> None:
    """Ask Linux to kill this process when the parent dies (a hung xatlas never returns)."""
    try:
        import ctypes
        import signal

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except Exception:  # not Linux: the parent still kills it at the deadline
        pass


def _square(atlas, uv: np.ndarray) -> np.ndarray:
    """xatlas' UVs are divided by the atlas width and height: make them one square scale."""
    w, h = atlas.width, atlas.height
    return (uv.astype(np.float64) * [w, h] / max(w, h, 1)).astype(np.float64)


def chart(positions: np.ndarray, faces: np.ndarray, max_iterations: int):
    """Cut one patch into charts and parametrise them.

    Returns ``(vmapping, indices, uv)``: xatlas' packing here is only a cheap way to get
    the charts' UVs (all at one scale); the caller rescales and packs all patches again.
    """
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(positions, faces)
    co = xatlas.ChartOptions()
    co.max_iterations = max_iterations
    po = xatlas.PackOptions()
    po.resolution = 256
    po.padding = 1
    po.bilinear = False
    po.blockAlign = False
    po.bruteForce = False
    atlas.generate(co, po)
    vmapping, indices, uv = atlas[0]
    return vmapping, indices, _square(atlas, uv)


def pack(uv: np.ndarray, faces: np.ndarray, size: int, padding: int):
    """Pack the charts of a UV mesh into one square atlas of ``size`` texels.

    Returns ``(vmapping, indices, uv, info)``; ``uv`` is in the unit square (v up).
    """
    import xatlas

    def run(resolution: int, texels_per_unit: float):
        atlas = xatlas.Atlas()
        atlas.add_uv_mesh(uv, faces)
        po = xatlas.PackOptions()
        po.resolution = resolution
        po.texels_per_unit = texels_per_unit
        po.padding = padding
        po.bilinear = True
        po.blockAlign = False
        po.bruteForce = False
        co = xatlas.ChartOptions()
        co.max_iterations = 1
        atlas.generate(co, po)
        return atlas

    atlas = run(size, 0.0)
    if atlas.atlas_count != 1:  # did not fit one page: one page that grows, same density
        atlas = run(0, float(atlas.texels_per_unit))
    vmapping, indices, out = atlas[0]
    info = {"atlas_count": int(atlas.atlas_count), "width": int(atlas.width), "height": int(atlas.height)}
    return vmapping, indices, _square(atlas, out), info


JOBS = {"chart": chart, "pack": pack}


def main() -> None:
    _die_with_parent()
    out = sys.stdout.buffer
    for line in sys.stdin:
        path = line.strip()
        if not path:
            break
        try:
            with open(path, "rb") as f:
                kind, args = pickle.load(f)
            os.unlink(path)
            reply = ("ok", JOBS[kind](*args))
        except Exception as exc:  # reported to the parent, which decides
            reply = ("error", f"{type(exc).__name__}: {exc}")
        data = pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL)
        out.write(len(data).to_bytes(8, "little") + data)
        out.flush()


if __name__ == "__main__":
    main()
