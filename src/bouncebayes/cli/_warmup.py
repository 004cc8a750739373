"""``bouncebayes warmup``: compile and cache the numerical kernels once, after installing."""

from __future__ import annotations

import argparse

from ._common import log

HELP = "compile the numerical kernels once (after installing; later runs start fast)"
DESCRIPTION = ("Run every stage once on a tiny problem so that the compiled kernels (numba) are "
               "cached on disk: the first real run then starts as fast as any later one. "
               "`make install` runs it. Writes nothing else.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """``warmup`` has no options."""


def run(args: argparse.Namespace) -> int:
    """Compile, and say how long it took."""
    from ..pipeline import warmup

    seconds = warmup(log=log)
    print(f"compiled kernels cached ({seconds:.1f} s)")
    return 0
