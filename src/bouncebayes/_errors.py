"""Exceptions that carry where the problem is, so the CLI can print one clear line."""

from __future__ import annotations

import os


class InputFileError(ValueError):
    """A problem in a user's file: names the file, and the line or field where known.

    Arguments:
        path: the file (or folder) concerned.
        message: what was received and what is allowed.
        line: 1-based line number, if the problem is on one line.
        field: key path (``ball.mass_kg``) or column name, if the problem is in one field.
    """

    def __init__(self, path: str | os.PathLike, message: str, *, line: int | None = None,
                 field: str | None = None):
        self.path = os.fspath(path)
        self.line = line
        self.field = field
        self.reason = message
        where = self.path
        if line is not None:
            where += f", line {line}"
        if field is not None:
            where += f", `{field}`"
        super().__init__(f"{where}: {message}")
