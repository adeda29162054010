"""Validation errors written for a person: the field, the value given and what is allowed.

pydantic's own messages name its internals (``size.constrained-int``, "Input should be a
valid tuple", "Extra inputs are not permitted"). :func:`describe` turns its errors into
``(field, problem)`` pairs instead, reading what is allowed from the model's JSON Schema:
``("size", "expected a whole number from 1 to 65536 (or width,height), got 'abc'")``. The
settings (``texbake.settings.parameter_error``), the texture specs
(``texbake.textures.spec``) and the service's 422 answers all use it.
"""

from __future__ import annotations

import difflib
import json
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["allowed", "describe", "did_you_mean", "json_error_text", "shown"]

# the types pydantic names a union's branches by in an error's location
_TYPE_TAGS = {"int", "float", "str", "bool", "bytes", "list", "dict", "tuple", "none", "set"}


def shown(value: Any, limit: int = 60) -> str:
    """A value as it appears in a message: its repr, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def did_you_mean(name: str, names: list[str]) -> str:
    """``"did you mean 'marble'? "`` when ``name`` is close to one of ``names``, else ``""``."""
    close = difflib.get_close_matches(str(name), names, n=1, cutoff=0.6)
    return f"did you mean {close[0]!r}? " if close else ""


def _number(x: float) -> str:
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


def _limit(schema: dict, inclusive: str, exclusive: str, short: tuple[str, str]) -> tuple[str, float] | None:
    """``("ge", 1)``-like: a bound under its JSON Schema name, or under pydantic's own (a
    constraint on a type pydantic cannot write as JSON Schema keeps its own name)."""
    for key, kind in ((inclusive, short[0]), (short[0], short[0]), (exclusive, short[1]), (short[1], short[1])):
        if key in schema:
            return kind, schema[key]
    return None


def _bounds(schema: dict) -> str:
    lo = _limit(schema, "minimum", "exclusiveMinimum", ("ge", "gt"))
    hi = _limit(schema, "maximum", "exclusiveMaximum", ("le", "lt"))
    if lo and hi and lo[0] == "ge" and hi[0] == "le":
        return f" from {_number(lo[1])} to {_number(hi[1])}"
    parts = [] if lo is None else [f"{'of at least' if lo[0] == 'ge' else 'above'} {_number(lo[1])}"]
    parts += [] if hi is None else [f"{'at most' if hi[0] == 'le' else 'below'} {_number(hi[1])}"]
    return "".join(" " + part for part in [" and ".join(parts)] if part)


def allowed(schema: dict, defs: dict | None = None, plural: bool = False) -> str:
    """What a JSON Schema allows, in words: ``"a whole number from 1 to 30"``, ``"one of
    'auto', 'unwrap', 'keep'"``, ``"3 numbers"`` (``plural``: ``"whole numbers ..."``)."""
    defs = defs or {}
    if "$ref" in schema:
        schema = defs.get(schema["$ref"].rsplit("/", 1)[-1], {})
    if "anyOf" in schema:
        options = [s for s in schema["anyOf"] if s.get("type") != "null"]
        text = " or ".join(allowed(s, defs, plural) for s in options)
        return text + " (or none)" if len(options) < len(schema["anyOf"]) else text
    if "enum" in schema or "const" in schema:
        values = schema.get("enum", [schema.get("const")])
        return repr(values[0]) if len(values) == 1 else "one of " + ", ".join(map(repr, values))
    kind = schema.get("type")
    article = "" if plural else "a "
    if kind in ("integer", "number"):
        noun = "whole number" if kind == "integer" else "number"
        return f"{article}{noun}{'s' if plural else ''}{_bounds(schema)}"
    if kind == "boolean":
        return "true or false"
    if kind == "string":
        return f"{article}string{'s' if plural else ''}"
    if kind == "array":
        items = schema.get("prefixItems")
        if items:
            phrases = [allowed(s, defs) for s in items]
            if len(set(phrases)) == 1:
                return f"{len(items)} {allowed(items[0], defs, plural=True)}"
            return "[" + ", ".join(phrases) + "]"
        counts = (schema.get("minItems"), schema.get("maxItems"))
        many = "" if counts == (None, None) else f" of {counts[0] or 0} to {counts[1]}" if counts[1] else f" of at least {counts[0]}"
        each = allowed(schema.get("items", {}), defs, plural=True) if schema.get("items") else "values"
        return f"{'' if plural else 'a '}list{'s' if plural else ''}{many} {each}"
    if kind == "object" or "properties" in schema:
        names = ", ".join(schema.get("properties", {}))
        return f"{article}group{'s' if plural else ''} of parameters" + (f" ({names})" if names else "")
    return "a value"


def _resolved(schema: dict, defs: dict) -> dict:
    """``schema`` with its references followed and an optional's ``null`` dropped."""
    while True:
        if "$ref" in schema:
            schema = defs.get(schema["$ref"].rsplit("/", 1)[-1], {})
            continue
        options = [s for s in schema.get("anyOf", []) if s.get("type") != "null"]
        if len(options) != 1:
            return schema
        schema = options[0]


def _at(schema: dict, defs: dict, path: tuple) -> dict | None:
    """The sub-schema at ``path`` (field names and item indices), or None."""
    found: dict | None = schema
    for part in path:
        here = _resolved(found or {}, defs)
        if isinstance(part, int):
            items = here.get("prefixItems")
            found = items[part] if items and part < len(items) else here.get("items")
        else:
            found = here.get("properties", {}).get(part)
        if found is None:
            return None
    return _resolved(found, defs) if found is not None and "$ref" in found else found


def _suggest(name: str, group: dict, defs: dict) -> str:
    """A name close to ``name`` among a group's parameters, or the same name one group
    down (``octaves`` given to marble: ``turbulence.octaves``)."""
    names = [n for n in group.get("properties", {}) if n != "name"]
    close = did_you_mean(name, names)
    if close:
        return close
    for sub_name in names:
        sub = _at(group, defs, (sub_name,)) or {}
        if name in sub.get("properties", {}):
            return f"did you mean {sub_name + '.' + name!r}? "
    return ""


def _tag_index(loc: tuple) -> int | None:
    """Where a union branch's name starts in an error's location (None: no union)."""
    for i, part in enumerate(loc):
        if isinstance(part, str) and (part in _TYPE_TAGS or not part.isidentifier()):
            return i
    return None


def _dotted(path: tuple) -> str:
    return ".".join(str(part) for part in path)


def describe(errors: Sequence[Mapping[str, Any]], schema: dict, *, hints: dict[str, str] | None = None,
             subject: str | None = None) -> list[tuple[str, str]]:
    """``(field, problem)`` for each bad field of a failed validation, in order.

    ``errors``: pydantic's ``ValidationError.errors()`` (locations from the model's top);
    ``schema``: the model's JSON Schema (``$defs`` included); ``hints``: what a field
    allows, where the schema's words would be clumsy (``{"size": "a whole number ..."}``);
    ``subject``: the model's name in the messages about a parameter it lacks ("marble has
    no parameter 'octaves'"; without one a field it lacks is "not a setting"). A union's
    branches that all failed are one problem: the field, what any branch allows and the
    value. The field is ``""`` where the problem is the model's as a whole.
    """
    defs, hints = schema.get("$defs", {}), hints or {}
    out: list[tuple[str, str]] = []
    done: set[tuple] = set()
    for error in errors:
        loc = tuple(error["loc"])
        tag = _tag_index(loc)
        if tag is not None:
            loc = loc[:tag]
            if loc in done:
                continue
            done.add(loc)
            value = min((e for e in errors if tuple(e["loc"][:tag]) == loc), key=lambda e: len(e["loc"]))["input"]
            out.append(_expected(loc, value, schema, defs, hints))
            continue
        out.append(_problem(error, loc, schema, defs, hints, subject))
    return out


def _expected(loc: tuple, value, schema: dict, defs: dict, hints: dict[str, str]) -> tuple[str, str]:
    where = _dotted(loc)
    sub = _at(schema, defs, loc)
    what = hints.get(where) or (allowed(sub, defs) if sub is not None else "another value")
    return where, f"expected {what}, got {shown(value)}"


def _problem(error: Mapping[str, Any], loc: tuple, schema: dict, defs: dict, hints: dict[str, str], subject: str | None) -> tuple[str, str]:
    kind, ctx = error["type"], error.get("ctx") or {}
    if kind == "extra_forbidden":
        parent, name = loc[:-1], str(loc[-1])
        group = _at(schema, defs, parent) or {}
        if not group.get("properties"):
            return _dotted(loc), "not a known field"
        names, hint = [n for n in group.get("properties", {}) if n != "name"], _suggest(name, group, defs)
        if subject is None and not parent:
            return name, f"not a setting ({hint.strip() or 'the settings are: ' + ', '.join(names)})"
        owner = f"{subject}'s {_dotted(parent)}" if subject and parent else subject or _dotted(parent)
        return "", f"{owner} has no parameter {name!r} ({hint}it has: {', '.join(names)})"
    if kind == "missing" and loc and isinstance(loc[-1], int):  # a short tuple: the whole of it is wrong
        return _expected(loc[:-1], error["input"], schema, defs, hints)
    if kind == "missing":
        sub = _at(schema, defs, loc)
        return _dotted(loc), "required" + (f" ({allowed(sub, defs)})" if sub is not None else "")
    if kind == "json_invalid":
        return _dotted(loc), f"not valid JSON: {ctx.get('error', error['msg'])}"
    if kind in ("value_error", "assertion_error"):
        message = str(ctx.get("error", error["msg"])).removeprefix("Value error, ").removeprefix("Assertion failed, ")
        if not loc:  # the model's own check, its message starting with the field it names
            name, sep, rest = message.partition(": ")
            return (name, rest) if sep and name.isidentifier() else ("", message)
        return _dotted(loc), message
    if kind == "model_type" or kind == "dict_type":
        return _expected(loc, error["input"], schema, defs, hints)
    if _at(schema, defs, loc) is not None or _dotted(loc) in hints:
        return _expected(loc, error["input"], schema, defs, hints)
    return _dotted(loc), _from_context(kind, ctx, error)


_CONTEXT = {"greater_than_equal": "at least {ge}", "greater_than": "more than {gt}", "less_than_equal": "at most {le}",
            "less_than": "less than {lt}", "literal_error": "{expected}", "string_too_long": "at most {max_length} characters",
            "string_too_short": "at least {min_length} characters", "too_long": "at most {max_length} items",
            "too_short": "at least {min_length} items", "int_parsing": "a whole number", "int_type": "a whole number",
            "int_from_float": "a whole number", "float_parsing": "a number", "float_type": "a number",
            "bool_parsing": "true or false", "bool_type": "true or false", "string_type": "a string"}


def _from_context(kind: str, ctx: dict, error: Mapping[str, Any]) -> str:
    """A problem from the error alone (no schema: a query parameter), its limit from ``ctx``."""
    template = _CONTEXT.get(kind)
    if template is None:
        return f"{error['msg'][:1].lower()}{error['msg'][1:]}, got {shown(error['input'])}"
    value = error["input"]
    if kind.startswith("string_too"):
        got = f"{len(value)} characters"
    elif kind.startswith("too_"):
        got = f"{len(value)} items"
    else:  # a number in a query string came as text: shown as sent
        got = value if isinstance(value, str) and kind.startswith(("greater", "less")) else shown(value)
    return f"expected {template.format(**{k: _number(v) if isinstance(v, float) else v for k, v in ctx.items()})}, got {got}"


def json_error_text(exc: json.JSONDecodeError) -> str:
    """``"not valid JSON at line 1 column 9: expecting ',' delimiter"``."""
    return f"not valid JSON at line {exc.lineno} column {exc.colno}: {exc.msg[:1].lower()}{exc.msg[1:]}"
