"""Typed errors of the baking core.

Every error a user can cause derives from :class:`BakeError`; its message names the
file or the parameter and the problem, in one line, so that the command line can print
it as it is and exit with code 2.
"""

from __future__ import annotations


class BakeError(Exception):
    """A bake could not be done because of its input or its settings.

    The base of every error here: catch it to catch any of them. ``str(error)`` is one
    line that names the file or the parameter and the problem.
    """


class MeshError(BakeError):
    """A mesh file is unreadable, unsafe or unusable.

    Parameters
    ----------
    path : str or os.PathLike
        The file, or ``"<mesh>"`` for an in-memory mesh; kept as ``str`` in ``path``.
    problem : str
        What is wrong with it, in one line; kept in ``problem``.

    The message is ``"{path}: {problem}"``. Picklable, so it crosses process
    boundaries (batch and service workers) unchanged.
    """

    def __init__(self, path: str, problem: str):
        self.path = str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")

    def __reduce__(self):  # picklable across processes (batch workers)
        return (type(self), (self.path, self.problem))


class ParameterError(BakeError, ValueError):
    """A bake parameter is out of range, of the wrong type or unknown.

    Parameters
    ----------
    name : str
        The parameter as the caller spelt it (``"size"``, ``"uv"``); kept in ``name``.
    problem : str
        What is wrong with its value, in one line; kept in ``problem``.

    The message is ``"{name}: {problem}"`` (``size: expected a whole number from 1 to
    65536, got 0``). A ``ValueError`` too; picklable.
    """

    def __init__(self, name: str, problem: str):
        self.name = name
        self.problem = problem
        super().__init__(f"{name}: {problem}")

    def __reduce__(self):
        return (type(self), (self.name, self.problem))


class AtlasError(BakeError):
    """No usable UV atlas could be made (or kept) for the mesh.

    Raised for arrays that are not ``(n, 3)`` vertices and ``(m, 3)`` faces, a mesh
    without faces, faces that index missing vertices or vertices that are not finite;
    for ``uv="keep"`` on a mesh whose UVs are not usable (the message says why); and
    when not even the fallback grid is usable. The message is the reason, in one line.
    """


class TextureError(BakeError, ValueError):
    """A texture spec is invalid: an unknown texture, or an unknown or out-of-range parameter.

    The message names the texture and the parameter (``"texture 'marble': frequency:
    Input should be greater than 0"``); every string that is neither a texture name
    nor a JSON object gets the same message, so it never tells whether a file exists.
    A ``ValueError`` too.
    """


class OutputError(BakeError):
    """An output file could not be written or read back whole (a full disk, a missing or
    read-only folder, a file cut short).

    The message names the file. Nothing half-written is left under its name: a writer
    that raises this has removed its temporary file, and an older file of that name is
    as it was.
    """


class MaterialError(BakeError, ValueError):
    """A material is invalid: a bad channel, an unknown op or node, a cycle, a colour
    where a scalar is taken, or a bad texture or parameter inside a node.

    Parameters
    ----------
    node : str
        The node (a named node, a channel, or the path of an inline node such as
        ``base_color.mask``), or ``""`` for the material as a whole; kept in ``node``.
    problem : str
        What is wrong, in one line; kept in ``problem``.

    The message is ``"node 'mask': {problem}"`` (or the problem alone). A ``ValueError``
    too; picklable. Given as a bake's ``material`` setting it reads
    ``material: node 'mask': ...`` (a :class:`ParameterError`).
    """

    def __init__(self, node: str, problem: str):
        self.node = node
        self.problem = problem
        super().__init__(f"node {node!r}: {problem}" if node else problem)

    def __reduce__(self):
        return (type(self), (self.node, self.problem))


class MtlxError(BakeError, ValueError):
    """A MaterialX document texbake cannot bake: unreadable or invalid, no surface shader,
    or a node it does not evaluate (an image without its file, a shading node).

    Parameters
    ----------
    path : str
        The ``.mtlx`` file (or ``"<mtlx>"`` for a document given as text); kept in ``path``.
    node : str
        The node's name path in the document, or ``""`` for the document as a whole.
    problem : str
        What is wrong, in one line (for a node: its category and what is supported).

    The message is ``"{path}: node {node!r}: {problem}"`` (or ``"{path}: {problem}"``).
    A ``ValueError`` too; picklable.
    """

    def __init__(self, path: str, node: str, problem: str):
        self.path, self.node, self.problem = str(path), node, problem
        super().__init__(f"{self.path}: node {node!r}: {problem}" if node else f"{self.path}: {problem}")

    def __reduce__(self):
        return (type(self), (self.path, self.node, self.problem))
