"""The ``bouncebayes`` program: one parser, one error policy, one exit-status convention.

Exit statuses: 0 success; 1 ``kinematics`` skipped some files; 2 any failure (one line on
stderr naming the option, file, line or key, what was received and what is allowed; ``--traceback``
shows the full traceback instead); 130 stopped by Ctrl-C (SIGINT), 143 stopped by SIGTERM
(earlier results are intact: every output is staged and put in place only when complete).

Only the chosen sub-command's options are built: ``bouncebayes --help`` imports no stage.
"""

from __future__ import annotations

import argparse
import atexit
import contextlib
import gc
import importlib
import os
import signal
import sys
import threading
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple, NoReturn

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
    _Command("predict", "._predict"), _Command("compare", "._compare"),
    _Command("demo", "._run", "add_demo_arguments", "run_demo", "DEMO_"),
    _Command("warmup", "._warmup"), _Command("design", "._design"),
    _Command("sbc", "._sbc"), _Command("batch", "._batch"),
)


class _Version(argparse.Action):
    """``--version``, reading the installed version only when asked (it costs 0.2 s)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from .._version import __version__

        print(f"bouncebayes {__version__}")
        parser.exit(0)


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
            # argparse has no public accessor for a parser's options
            flags = frozenset(s for a in p._actions for s in a.option_strings)
            p.set_defaults(run=getattr(module, command.run), flags=flags)
    return parser


def _chosen(argv: Sequence[str]) -> list[str]:
    """The sub-command named on the command line (the first word that is not an option)."""
    return [next((a for a in argv if not a.startswith("-")), "")]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``bouncebayes`` command; returns the exit status.

    Called without ``argv`` it is the program (it reads ``sys.argv``): Ctrl-C or SIGTERM then
    discard the staged outputs, print one line and end the process at once, so that no
    exception unwinds through compiled code that was interrupted half-way (numba's compiler,
    HDF5, matplotlib); and the process ends without Python's teardown (:func:`_end_program`).
    Called with a list of words (in-process, as the tests do) they raise KeyboardInterrupt
    instead and the same line is printed, and nothing else of the process is changed.
    """
    stop = _Stop(program=argv is None)
    if not stop.program:
        return _main(list(argv or ()), stop)
    # A run allocates a great many long-lived objects (the modules of NumPy, SciPy, numba,
    # matplotlib, ArviZ: 2,000 of them) and few short-lived cycles; with Python's defaults
    # (a young collection every 700 allocations) `bouncebayes demo` spent 0.75 s in 750
    # collections that freed almost nothing (measured on the 2-core development machine;
    # 0.25 s with these settings). The program owns its process: the library called from
    # another program leaves that program's collector alone.
    gc.set_threshold(10_000, 10, 10)
    _end_program(_main(sys.argv[1:], stop))


def _main(argv: list[str], stop: _Stop) -> int:
    # numba's threads beside a multi-threaded BLAS oversubscribe the cores (10x slowdown
    # measured); set before NumPy loads its BLAS, and limited below where it already has
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    # FFmpeg (under OpenCV) writes its own lines to stderr for a file it cannot read ("moov
    # atom not found"); the tool's one-line error names the file and says what it accepts
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    with stop.handling():
        args = build_parser(_chosen(argv)).parse_args(argv)
        if stop.program:
            gc.freeze()  # the modules imported so far: never garbage, not scanned again
        args.argv = ["bouncebayes", *argv]
        stop.args = args
        from threadpoolctl import threadpool_limits

        with _one_line_warnings(args.command), threadpool_limits(limits=1, user_api="blas"):
            try:
                return args.run(args)
            except SystemExit:
                raise
            except BaseException as exc:
                if args.traceback:
                    raise
                return _failure(args, exc, stop)


def _end_program(status: int) -> NoReturn:
    """End the program with ``status``, skipping the interpreter's teardown.

    Python's finalisation frees the objects of every imported module one by one: 1.2-1.7 s
    after `bouncebayes demo` on the 2-core development machine, more than any stage but the
    figures, for nothing (the process is ending). What finalisation does that matters is done
    here first, in its order: wait for the other (non-daemon) threads, run the exit handlers
    (``atexit``: removal of temporary folders, logging's flush), flush the standard streams.
    Every output file was closed by the command before this point.
    """
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and not thread.daemon:
            thread.join()
    atexit._run_exitfuncs()  # what the interpreter runs at exit (no public name in CPython)
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a closed pipe (`bouncebayes ... | head`)
            stream.flush()
    os._exit(status)


class _Stop:
    """What Ctrl-C (SIGINT) and SIGTERM do: stop, say whether earlier results are intact."""

    def __init__(self, program: bool) -> None:
        from .._io import INSTALLED

        self.program = program
        self.signal: int | None = None
        self.args: argparse.Namespace | None = None
        self.installed = len(INSTALLED)

    def status(self, exc: BaseException | None = None) -> int:
        term = self.signal == signal.SIGTERM or isinstance(exc, Terminated)
        return EXIT_SIGTERM if term else EXIT_SIGINT

    def message(self) -> str:
        from .._io import INSTALLED

        args = self.args
        if args is None:
            return "bouncebayes: stopped; nothing was written"
        out = _output_of(args)
        if len(INSTALLED) > self.installed:
            where = f" after the results were put in {out}: they are complete"
        else:
            where = f"; earlier results in {out} are intact" if out else "; nothing was written"
        return f"bouncebayes {args.command}: stopped{where}"

    def handler(self, signum: int, frame) -> None:
        self.signal = signum
        if not self.program:
            raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
        from .._io import discard_staged

        for s in (signal.SIGINT, signal.SIGTERM):  # a second Ctrl-C must not cut this short
            signal.signal(s, signal.SIG_IGN)
        discard_staged()
        with contextlib.suppress(Exception):
            sys.stdout.flush()
        print(self.message(), file=sys.stderr, flush=True)
        os._exit(self.status())

    @contextmanager
    def handling(self) -> Iterator[None]:
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        previous = {s: signal.signal(s, self.handler) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield
        finally:
            for s, h in previous.items():
                signal.signal(s, h)


def _failure(args: argparse.Namespace, exc: BaseException, stop: _Stop) -> int:
    """Print the one line a failure deserves; return the exit status."""
    if stop.signal is not None or isinstance(exc, KeyboardInterrupt):
        print(stop.message(), file=sys.stderr)
        return stop.status(exc)
    message = one_line(describe(exc, getattr(args, "flags", frozenset())))
    print(f"bouncebayes {args.command}: error: {message}", file=sys.stderr)
    return EXIT_FAILURE


def describe(exc: BaseException, flags: frozenset[str] = frozenset()) -> str:
    """What went wrong, in words: the message of an input error (naming the command's flags
    where the library names its arguments), the file of an OS error."""
    if isinstance(exc, UserError | ValueError | TypeError):
        return flag_names(str(exc), flags)
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
def _one_line_warnings(command: str) -> Iterator[None]:
    """Warnings reach the user as one line each, without the source line."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"bouncebayes {command}: warning: {one_line(flag_names(str(message)))}",
              file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield
