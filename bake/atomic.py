"""Writing files atomically: under a temporary name beside the final one, renamed into
place only when complete, removed on any failure. Nothing half-written is ever left
under a final name."""

from __future__ import annotations

import os
import uuid
from contextlib import contextmanager
from pathlib import Path

from .errors import OutputError


def _remove(path: Path) -> None:
    try:
        path.unlink(missing_ok=True)
    except OSError:
        pass


@contextmanager
def replacing(path, suffix: str = ""):
    """Yield a temporary path beside ``path``; rename it to ``path`` if the block succeeds.

    ``suffix`` ends the temporary name (writers that pick a format by extension need it).
    An ``OSError`` becomes an :class:`OutputError` naming ``path``.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}-{uuid.uuid4().hex[:8]}{suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OutputError as exc:
        _remove(tmp)
        if str(path) not in str(exc):
            raise OutputError(f"{path}: {exc}") from None
        raise
    except OSError as exc:
        _remove(tmp)
        raise OutputError(f"{path}: {exc.strerror or exc}") from None
    except BaseException:
        _remove(tmp)
        raise


def sync(path) -> None:
    """Flush a written file to the disk: a full disk may only show here (delayed allocation)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically, flushed and size-checked."""
    with replacing(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if tmp.stat().st_size != len(data):
            raise OutputError(f"{path}: short write (disk full?)")
