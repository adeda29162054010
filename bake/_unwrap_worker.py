"""xatlas worker process: ``python -m bake._unwrap_worker`` serves jobs until stdin closes.

It is started by :mod:`bake.atlas` as a fresh interpreter (not a fork, and not through
multiprocessing, so the caller's ``__main__`` is never re-imported and it works from
daemonic pool workers too). xatlas can hang or crash on bad input; here that only takes
down this process, which the parent kills at its deadline or sees die.

Protocol: the parent writes one line per job to stdin, the path of a file holding a
pickled ``(kind, args)``; the worker answers on stdout with an 8-byte little-endian
length and a pickled ``("ok", result)`` or ``("error", message)``. An empty line or EOF
ends it. Only numpy, xatlas and :mod:`bake.uvgeometry` (numpy only) are imported.
"""

from __future__ import annotations

import os
import pickle
import sys
from collections.abc import Callable

import numpy as np

from .uvgeometry import uv_areas


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


def pack(meshes: list, size: int, padding: int):
    """Pack the charts of UV meshes (``(uv, faces)`` pairs, one texel density) together.

    Each UV mesh is added on its own (``add_uv_mesh`` merges charts of one mesh that
    touch or overlap, so charts of different patches must not share one). The atlas is
    packed at an explicit texel density, lowered until it fits ``size`` texels, so that
    ``padding`` is at least that many texels of the texture. Returns per mesh
    ``(vmapping, indices, uv)`` with ``uv`` in the unit square, and an info dict.
    """
    import xatlas

    def run(texels_per_unit: float):
        atlas = xatlas.Atlas()
        for uv, faces in meshes:
            atlas.add_uv_mesh(uv, faces)
        po = xatlas.PackOptions()
        po.resolution = 0  # one atlas, as large as the density needs
        po.texels_per_unit = texels_per_unit
        po.padding = padding
        po.bilinear = True
        po.blockAlign = False
        po.bruteForce = False
        co = xatlas.ChartOptions()
        co.max_iterations = 1
        atlas.generate(co, po)
        return atlas

    area = sum(float(uv_areas(uv, faces).sum()) for uv, faces in meshes)
    tpu = size * np.sqrt(0.7 / max(area, 1e-30))
    for _ in range(4):
        atlas = run(tpu)
        side = max(atlas.width, atlas.height)
        if side <= size:
            break
        tpu *= 0.99 * size / side
    if atlas.atlas_count != 1:
        raise RuntimeError(f"xatlas made {atlas.atlas_count} atlases, expected 1")
    out = []
    for i in range(len(meshes)):
        vmapping, indices, uv = atlas[i]
        out.append((vmapping, indices, _square(atlas, uv)))
    info = {"width": int(atlas.width), "height": int(atlas.height), "texels_per_unit": float(tpu)}
    return out, info


JOBS: dict[str, Callable[..., object]] = {"chart": chart, "pack": pack}


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
