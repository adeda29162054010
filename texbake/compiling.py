"""Say once per process when numba compiles one of texbake's kernels, so that the pause of
the first bake after an install is explained.

numba announces a compile (the ``numba:compile`` event) only when its on-disk cache has
none for the function: a cached kernel loads without one. Every texbake kernel counts, not
only the textures' (the margin's, the texel lookup's and the UV checks' take longer to
compile than the checker's), so :func:`watch_compiles` is called where a bake starts, and
by the texture kernels' module for a texture evaluated on its own.
"""

from __future__ import annotations

import logging

logger = logging.getLogger(__name__)
MESSAGE = "texbake: compiling the kernels (once after an install: several seconds); cached in %s"

_state = {"watching": False, "said": False}


def watch_compiles() -> None:
    """From now on, say once (a logging warning) when a texbake kernel is compiled.
    Imports numba; a second call does nothing."""
    if _state["watching"]:
        return
    from numba.core import event

    class _FirstCompile(event.Listener):
        def on_start(self, e):
            dispatcher = e.data["dispatcher"]
            if _state["said"] or not getattr(dispatcher.py_func, "__module__", "").startswith("texbake."):
                return
            _state["said"] = True
            where = getattr(getattr(dispatcher, "_cache", None), "_cache_path", "numba's cache")
            logger.warning(MESSAGE, where)

        def on_end(self, e):
            pass

    event.register("numba:compile", _FirstCompile())
    _state["watching"] = True
