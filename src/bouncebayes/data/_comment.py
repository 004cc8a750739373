"""Provenance as a leading comment line of a CSV file: ``# provenance: {...}`` (one line of JSON).

Both CSV formats of the package (trial tables and trajectories) carry it the same way, so a
file says where it came from (package version, inputs, settings, seed) and every reader skips
it as a comment.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

PROVENANCE_PREFIX = "# provenance: "


def provenance_comment(provenance: Mapping[str, Any]) -> str:
    """The comment line (without a newline) holding ``provenance`` as compact JSON.

    Raises:
        TypeError: ``provenance`` is not a mapping, or holds something JSON cannot write.
    """
    if not isinstance(provenance, Mapping):
        raise TypeError(f"`provenance` must be a dict; got {type(provenance).__name__}")
    try:
        text = json.dumps(dict(provenance), separators=(",", ":"), ensure_ascii=False,
                          allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"`provenance` must be JSON-serialisable (strings, numbers, lists, "
                        f"dicts; finite numbers); {exc}") from None
    return PROVENANCE_PREFIX + text


def parse_provenance(line: str) -> dict | None:
    """The dict of a provenance comment line; None if the line is not one or is not valid JSON."""
    text = line.strip()
    if not text.startswith(PROVENANCE_PREFIX.strip()):
        return None
    try:
        value = json.loads(text[len(PROVENANCE_PREFIX.strip()):].strip())
    except ValueError:
        return None
    return value if isinstance(value, dict) else None
