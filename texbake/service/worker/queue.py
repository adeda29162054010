"""The task queue (huey): SQLite in the data folder by default, Redis when
``BAKE_REDIS_URL`` is set. The queue only carries job ids; the jobs table is the truth.

Messages are JSON, not pickle (huey's default): whoever can write to the queue can make a
worker bake a job id, never run code in it. A message that is not ours is refused when
read (huey logs it and goes on; the reaper enqueues its job again if it was one). Results
are not stored: the jobs table holds every outcome, and nothing accumulates in the queue.
"""

from __future__ import annotations

import json
from datetime import datetime
from typing import Any

from huey import RedisHuey, SqliteHuey
from huey.registry import Message
from huey.serializer import Serializer

from ..core.config import Settings


class BadMessage(ValueError):
    """Queue data that is not a JSON message of ours."""


def _encode(value: Any) -> Any:
    if isinstance(value, Message):
        return {"message": [_encode(v) for v in value]}
    if isinstance(value, datetime):
        return {"datetime": value.isoformat()}
    if isinstance(value, (list, tuple)):
        return [_encode(v) for v in value]
    if isinstance(value, dict):
        if any(not isinstance(k, str) for k in value):
            raise TypeError(f"queue data: dict keys must be strings, got {list(value)!r}")
        return {"dict": {k: _encode(v) for k, v in value.items()}}
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    raise TypeError(f"queue data: {type(value).__name__} cannot go through JSON")


def _decode(value: Any) -> Any:
    if isinstance(value, list):
        return tuple(_decode(v) for v in value)
    if isinstance(value, dict):
        (kind, inner), = value.items()
        if kind == "message":
            return Message(*(_decode(v) for v in inner))
        if kind == "datetime":
            return datetime.fromisoformat(inner)
        if kind == "dict":
            return {k: _decode(v) for k, v in inner.items()}
        raise BadMessage(f"unknown tag {kind!r}")
    return value


class JsonSerializer(Serializer):
    """Huey's messages (and its few other values: revocations, locks) as tagged JSON."""

    def _serialize(self, data: Any) -> bytes:
        return json.dumps(_encode(data), separators=(",", ":")).encode()

    def _deserialize(self, data: bytes) -> Any:
        try:
            return _decode(json.loads(data))
        except (ValueError, TypeError, UnicodeDecodeError) as exc:
            raise BadMessage(f"not a texbake queue message ({exc}): {bytes(data[:40])!r}") from None


def make_huey(settings: Settings):
    options: dict[str, Any] = {"results": False, "serializer": JsonSerializer()}
    if settings.redis_url:
        return RedisHuey("texbake", url=settings.redis_url, **options)
    return SqliteHuey("texbake", filename=str(settings.data_dir / "queue.db"), **options)
