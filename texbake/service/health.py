"""Health checks for containers and orchestrators: ``python -m texbake.service.health api|worker``.

``api`` asks the API's ``/healthz`` (on ``BAKE_PORT``, 8000 by default); ``worker`` checks
that the jobs table, the queue and the object store (if any) answer. Exit code 0 when healthy, else 1 with the reason
on one line. :func:`ready` is ``/readyz``'s answer.
"""

from __future__ import annotations

import logging
import os
import shutil
import sys
import urllib.request

logger = logging.getLogger("texbake.service")


def ready() -> dict:
    """What ``/readyz`` reports: each dependency (``database``, ``queue``, ``storage``: the
    object store; always ``ok`` for the data folder) ``ok`` or ``unavailable`` (the reason goes
    to the log, never to the client), the queue's length, live workers and their bake
    slots, free disk in the data folder; ``ok`` when all are up, a worker is alive and the
    disk has ``BAKE_MIN_FREE_MB``."""
    from .core import crud, db
    from .core.config import get_settings
    from .storage import get_storage
    from .worker.tasks import queue

    s = get_settings()
    answer: dict = {"database": "ok", "queue": "ok", "storage": "ok", "queued": None, "workers": None, "slots": None}
    try:
        with db.sessions(s.database)() as session:
            answer["workers"], answer["slots"] = crud.live_workers(session, s.stale_seconds)
    except Exception as exc:  # any reason: the check's answer
        logger.warning("readiness: the jobs database: %s: %s", type(exc).__name__, exc)
        answer["database"] = "unavailable"
    try:
        answer["queued"] = queue().huey.pending_count()
    except Exception as exc:
        logger.warning("readiness: the queue: %s: %s", type(exc).__name__, exc)
        answer["queue"] = "unavailable"
    try:
        get_storage(s).check()
    except Exception as exc:
        logger.warning("readiness: the object store: %s: %s", type(exc).__name__, exc)
        answer["storage"] = "unavailable"
    answer["disk_free_mb"] = shutil.disk_usage(s.data_dir).free >> 20
    answer["ok"] = (answer["database"] == answer["queue"] == answer["storage"] == "ok" and bool(answer["workers"])
                    and answer["disk_free_mb"] >= s.min_free_mb)
    return answer


def main(argv: list[str]) -> int:
    what = argv[0] if argv else "api"
    try:
        if what == "api":
            port = int(os.environ.get("BAKE_PORT", "8000"))
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=5) as answer:
                answer.read()
        elif what == "worker":
            answer = ready()
            down = [name for name in ("database", "queue", "storage") if answer[name] != "ok"]
            if down:
                print(f"unhealthy: {' and '.join(down)} unavailable", file=sys.stderr)
                return 1
        else:
            print(f"usage: python -m texbake.service.health api|worker (got {what!r})", file=sys.stderr)
            return 2
    except Exception as exc:  # the check's answer is the failure itself
        print(f"unhealthy: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
