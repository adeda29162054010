"""Health checks for containers and orchestrators: ``python -m service.health api|worker``.

``api`` asks the API's ``/healthz`` (on ``BAKE_PORT``, 8000 by default); ``worker`` checks
that the jobs table and the queue answer (what ``/readyz`` checks). Exit code 0 when
healthy, else 1 with the reason on one line.
"""

from __future__ import annotations

import os
import sys
import urllib.request


def ready() -> int:
    """Raise if the jobs table or the queue does not answer; else the queue's length."""
    from sqlalchemy import text

    from . import db
    from .settings import get_settings
    from .tasks import queue

    with db.sessions(get_settings().database)() as session:
        session.execute(text("SELECT 1"))
    return queue().huey.pending_count()


def main(argv: list[str]) -> int:
    what = argv[0] if argv else "api"
    try:
        if what == "api":
            port = int(os.environ.get("BAKE_PORT", "8000"))
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=5) as answer:
                answer.read()
        elif what == "worker":
            ready()
        else:
            print(f"usage: python -m service.health api|worker (got {what!r})", file=sys.stderr)
            return 2
    except Exception as exc:  # the check's answer is the failure itself
        print(f"unhealthy: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
