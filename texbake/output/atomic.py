"""Writing files atomically: under a temporary name beside the final one, renamed into
place only when complete, removed on any failure. Nothing half-written is ever left
under a final name."""

from __future__ import annotations

import os
import re
import uuid
from contextlib import contextmanager
from pathlib import Path

from ..errors import OutputError


def _remove(path: Path) -> None:
    try:
        path.unlink(missing_ok=True)
    except OSError:
        pass


_TEMPORARY = re.compile(r"\..+\.tmp-(\d+)-[0-9a-f]{8}")  # replacing()'s names: .NAME.tmp-PID-HEX[SUFFIX]


def remove_stale(folder) -> list[str]:
    """Remove from ``folder`` the temporary files of :func:`replacing` whose process is
    gone (killed mid-write: ``kill -9`` leaves them); returns their names. Those of a
    live process, another bake writing there, are kept."""
    removed: list[str] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = _TEMPORARY.match(entry.name)
        if match is None or not entry.is_file(follow_symlinks=False) or _alive(int(match.group(1))):
            continue
        _remove(Path(entry.path))
        removed.append(entry.name)
    return removed


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # someone else's, or not a pid we can judge: keep it
    return True


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
