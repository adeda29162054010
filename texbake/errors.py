"""Typed errors of the baking core.

Every error a user can cause derives from :class:`BakeError`; its message names the
file or the parameter and the problem, in one line, so that the command line can print
it as it is and exit with code 2.
"""

from __future__ import annotations


class BakeError(Exception):
    """A bake could not be done because of its input or its settings."""


class MeshError(BakeError):
    """A mesh file is unreadable, unsafe or unusable.

    ``path`` names the file (or ``"<mesh>"`` for an in-memory mesh), ``problem`` says
    what is wrong with it.
    """

    def __init__(self, path: str, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")

    def __reduce__(self):  # picklable across processes (batch workers)
        return (type(self), (self.path, self.problem))


class ParameterError(BakeError, ValueError):
    """A bake parameter is out of range or unknown: ``name`` and the problem, shown as
    ``name: problem`` (``size: expected a whole number from 1 to 65536, got 0``)."""

    def __init__(self, name: str, problem: str):
        self.name = name
        self.problem = problem
        super().__init__(f"{name}: {problem}")

    def __reduce__(self):
        return (type(self), (self.name, self.problem))


class AtlasError(BakeError):
    """No usable UV atlas could be made (or kept) for the mesh."""


class TextureError(BakeError, ValueError):
    """A texture spec is invalid: unknown texture, unknown or out-of-range parameter."""


class OutputError(BakeError):
    """An output file could not be written completely (disk full, bad folder)."""
