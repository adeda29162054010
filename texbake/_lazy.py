"""Names a package lends from its modules, imported on first use.

A stage folder's ``__init__`` names what the rest of texbake may use. Importing those
names eagerly would load every module of the folder (trimesh, OpenImageIO, SciPy) for
any one of them: the unwrap's worker process, ``--help`` and the service's API process
import light modules of folders whose other modules are heavy.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable


def lazy_names(package: str, homes: dict[str, str]) -> Callable[[str], object]:
    """A module ``__getattr__`` for ``package`` that imports each name of ``homes``
    (name -> module of ``package``) from its module when it is first asked for."""

    def __getattr__(name: str) -> object:
        home = homes.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{home}"), name)

    return __getattr__
