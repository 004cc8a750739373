"""Exceptions that carry where the problem is, so the CLI can print one clear line."""

from __future__ import annotations

import os


def _rebuilt(cls: type, args: tuple, state: dict) -> BaseException:
    """An exception of ``cls`` with ``args`` and attributes ``state``, its ``__init__`` not
    called (:meth:`Rebuilt.__reduce__`)."""
    error = cls.__new__(cls, *args)
    error.args = args
    error.__dict__.update(state)
    return error


class Rebuilt:
    """A mixin for exceptions whose ``__init__`` takes other arguments than their message:
    pickled (to and from a process pool's or Dask's workers) as their message and attributes.
    Python's default rebuilds an exception by calling its class with ``args`` alone, which for
    these raised a TypeError in the parent process instead of the error."""

    def __reduce__(self):
        return _rebuilt, (type(self), self.args, dict(self.__dict__))  # type: ignore[attr-defined]


class InputFileError(Rebuilt, ValueError):
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
