"""The task queue (huey): SQLite in the data folder by default, Redis when
``BAKE_REDIS_URL`` is set. The queue only carries job ids; the jobs table is the truth."""

from __future__ import annotations

from huey import RedisHuey, SqliteHuey

from .settings import Settings


def make_huey(settings: Settings):
    if settings.redis_url:
        return RedisHuey("texbake", url=settings.redis_url)
    return SqliteHuey("texbake", filename=str(settings.data_dir / "queue.db"))
