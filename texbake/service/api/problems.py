"""A request that failed validation, written for a person: each bad field named with the
value given and what is allowed, the bake settings in the same words as the library's and
the command line's (``texbake.settings.describe_errors``)."""

from __future__ import annotations

from texbake.settings import describe_errors
from texbake.validation import describe


def request_problems(errors: list[dict]) -> tuple[str, list[dict]]:
    """``(detail, errors)`` of the 422 answer to FastAPI's validation ``errors``: the
    detail ``settings.size: expected ..., got 'abc'; view: ...``, and each problem as
    ``{"loc": [...], "msg": ...}`` (its location without where it came from: body, query)."""
    settings = [{**e, "loc": tuple(e["loc"][2:])} for e in errors if tuple(e["loc"][:2]) == ("body", "settings")]
    others = [{**e, "loc": tuple(e["loc"][1:])} for e in errors if tuple(e["loc"][:2]) != ("body", "settings")]
    found = [("settings." + name if name else "settings", problem) for name, problem in describe_errors(settings)] if settings else []
    found += describe(others, {}) if others else []
    detail = "; ".join(f"{name}: {problem}" if name else problem for name, problem in found)
    return detail, [{"loc": name.split(".") if name else [], "msg": problem} for name, problem in found]
