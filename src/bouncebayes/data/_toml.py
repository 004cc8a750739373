"""A TOML writer for experiment documents (the standard library reads TOML but does not write
it): tables of strings, numbers, booleans and arrays of them, nested tables as
``[a.b]`` headers. That is all an experiment file holds, so no dependency is needed for it."""

from __future__ import annotations

import json
import math
import re
from typing import Any

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def _key(name: str) -> str:
    return name if _BARE.fullmatch(name) else json.dumps(name)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # TOML basic strings take JSON's escapes
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} {v!r} as a TOML value")


def dumps(doc: dict[str, Any], header: str = "") -> str:
    """TOML text of ``doc`` (a dict of tables), each table's plain keys before its sub-tables;
    ``header``: comment lines put first."""
    lines = [f"# {line}" for line in header.splitlines()]
    _table(doc, (), lines)
    return "\n".join(lines).lstrip("\n") + "\n"


def _table(table: dict[str, Any], path: tuple[str, ...], lines: list[str]) -> None:
    plain = {k: v for k, v in table.items() if not isinstance(v, dict)}
    if path and (plain or not any(isinstance(v, dict) for v in table.values())):
        lines += ["", "[" + ".".join(_key(p) for p in path) + "]"]
    lines += [f"{_key(k)} = {_value(v)}" for k, v in plain.items()]
    for k, v in table.items():
        if isinstance(v, dict):
            _table(v, (*path, k), lines)
