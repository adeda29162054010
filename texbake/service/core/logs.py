"""The service's logging: text lines (the default) or, with ``BAKE_LOG_FORMAT=json``, one
JSON object per line: ``time``, ``level``, ``logger``, ``message`` and the record's own
fields (the access log's ``client``, ``method``, ``path``, ``status``, ``seconds``; a job
state change's ``job``, ``state``, ``detail``).
"""

from __future__ import annotations

import json
import logging
from datetime import datetime, timezone

TEXT = "%(asctime)s %(name)s %(levelname)s %(message)s"
_STANDARD = set(vars(logging.makeLogRecord({}))) | {"message", "asctime", "taskName", "color_message"}  # (uvicorn's, with ANSI codes)


class JsonFormatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        line = {"time": datetime.fromtimestamp(record.created, timezone.utc).isoformat(timespec="milliseconds"),
                "level": record.levelname, "logger": record.name, "message": record.getMessage()}
        line.update({k: v for k, v in vars(record).items() if k not in _STANDARD and not k.startswith("_")})
        if record.exc_info:
            line["exception"] = self.formatException(record.exc_info)
        return json.dumps(line, default=str)


def setup(log_format: str) -> None:
    """Log INFO and up to stderr, as text or JSON; every logger, uvicorn's and huey's too."""
    handler = logging.StreamHandler()
    handler.setFormatter(JsonFormatter() if log_format == "json" else logging.Formatter(TEXT))
    logging.basicConfig(level=logging.INFO, handlers=[handler], force=True)
    # Alembic's INFO lines are its set-up, repeated by every process at every start; what a
    # start migrated is logged by texbake.service itself
    logging.getLogger("alembic").setLevel(logging.WARNING)
