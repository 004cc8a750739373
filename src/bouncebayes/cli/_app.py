"""The ``bouncebayes`` program: one parser, one error policy, one exit-status convention.

Exit statuses: 0 success; 1 ``kinematics`` skipped some files; 2 any failure (one line on
stderr naming the option, file, line or key, what was received and what is allowed; ``--traceback``
shows the full traceback instead); 130 stopped by Ctrl-C (SIGINT), 143 stopped by SIGTERM
(earlier results are intact: every output is staged and put in place only when complete).

Only the chosen sub-command's options are built: ``bouncebayes --help`` imports no stage.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

from ._common import Formatter, Parser, UserError, flag_names

EXIT_FAILURE, EXIT_SIGINT, EXIT_SIGTERM = 2, 130, 143


class _Command(NamedTuple):
    name: str
    module: str
    add: str = "add_arguments"
    run: str = "run"
    prefix: str = ""  # of the HELP and DESCRIPTION constants


COMMANDS = (
    _Command("simulate", "._simulate"), _Command("synth", "._synth"),
    _Command("track", "._track"), _Command("kinematics", "._kinematics"),
    _Command("infer", "._infer"), _Command("run", "._run"), _Command("report", "._report"),
    _Command("demo", "._run", "add_demo_arguments", "run_demo", "DEMO_"),
    _Command("warmup", "._warmup"),
)


class _Version(argparse.Action):
    """``--version``, reading the installed version only when asked (it costs 0.2 s)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from .._version import __version__

        parser.exit(0, f"bouncebayes {__version__}\n")


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived: stop like Ctrl-C does (the staged outputs are discarded)."""


def build_parser(commands: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The argument parser; only ``commands`` (all if None) get their options built, the
    others are listed with their one-line help."""
    parser = Parser(prog="bouncebayes", formatter_class=Formatter,
                    description="Contact parameters (friction, viscous damping) of a ball from "
                                "how it bounces. Units are SI, angles in degrees.")
    parser.add_argument("--version", action=_Version, nargs=0,
                        help="print the version and exit")
    parser.add_argument("--traceback", action="store_true",
                        help="show the full traceback of an error (for bug reports)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=Parser)
    for command in COMMANDS:
        module = importlib.import_module(command.module, __package__)
        p = sub.add_parser(command.name, formatter_class=Formatter,
                           help=getattr(module, command.prefix + "HELP"),
                           description=getattr(module, command.prefix + "DESCRIPTION"))
        if commands is None or command.name in commands:
            getattr(module, command.add)(p)
            p.set_defaults(run=getattr(module, command.run))
    return parser


def _chosen(argv: Sequence[str]) -> list[str]:
    """The sub-command named on the command line (the first word that is not an option)."""
    return [next((a for a in argv if not a.startswith("-")), "")]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``bouncebayes`` command; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    # numba's threads beside a multi-threaded BLAS oversubscribe the cores (10x slowdown
    # measured); set before NumPy loads its BLAS, and limited below where it already has
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    args = build_parser(_chosen(argv)).parse_args(argv)
    args.argv = ["bouncebayes", *argv]
    from threadpoolctl import threadpool_limits

    with _stop_signals() as stop, _one_line_warnings(args.command), \
            threadpool_limits(limits=1, user_api="blas"):
        try:
            return args.run(args)
        except SystemExit:
            raise
        except BaseException as exc:
            if args.traceback:
                raise
            return _failure(args, exc, stop)


def _failure(args: argparse.Namespace, exc: BaseException, stop: dict) -> int:
    """Print the one line a failure deserves; return the exit status."""
    if stop["signal"] is not None or isinstance(exc, KeyboardInterrupt):
        out = _output_of(args)
        where = f"; earlier results in {out} are intact" if out else "; nothing was written"
        print(f"bouncebayes {args.command}: stopped{where}", file=sys.stderr)
        term = stop["signal"] == signal.SIGTERM or isinstance(exc, Terminated)
        return EXIT_SIGTERM if term else EXIT_SIGINT
    print(f"bouncebayes {args.command}: error: {one_line(describe(exc))}", file=sys.stderr)
    return EXIT_FAILURE


def describe(exc: BaseException) -> str:
    """What went wrong, in words: the message of an input error, the file of an OS error."""
    if isinstance(exc, UserError | ValueError | TypeError):
        return flag_names(str(exc))
    if isinstance(exc, OSError):
        where = " -> ".join(str(f) for f in (exc.filename, exc.filename2) if f is not None)
        reason = exc.strerror or str(exc) or type(exc).__name__
        return f"{where}: {reason}" if where else reason
    if isinstance(exc, MemoryError):
        return ("out of memory; ask for less (fewer draws or grid points, a smaller table) or "
                "free memory" + (f" ({exc})" if str(exc) else ""))
    return (f"unexpected {type(exc).__name__}: {exc}; this is a bug: please report it with "
            f"the output of the same command with --traceback")


def one_line(text: str) -> str:
    """Messages are one line: line breaks become spaces."""
    return " ".join(part.strip() for part in str(text).splitlines() if part.strip())


def _output_of(args: argparse.Namespace) -> Path | None:
    out = getattr(args, "out", None) or getattr(args, "plot", None)
    if out is None and args.command == "report":
        out = args.folder
    return out


@contextmanager
def _stop_signals() -> Iterator[dict]:
    """SIGTERM stops like Ctrl-C; remember which signal arrived (an interrupted C extension
    may turn the KeyboardInterrupt into another exception)."""
    stop: dict = {"signal": None}
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def handler(signum, frame):
        stop["signal"] = signum
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


@contextmanager
def _one_line_warnings(command: str) -> Iterator[None]:
    """Warnings reach the user as one line each, without the source line."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"bouncebayes {command}: warning: {one_line(flag_names(str(message)))}",
              file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield
