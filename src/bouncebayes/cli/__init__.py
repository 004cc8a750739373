"""The ``bouncebayes`` command line: a thin shell that parses flags, calls the library with
arguments, and writes files (staged, then put in place at once, each stamped with provenance).

One module per sub-command (``_simulate``, ``_synth``, ``_track``, ``_kinematics``, ``_infer``,
``_run`` for ``run`` and ``demo``, ``_report``, ``_warmup``), each with ``HELP``,
``DESCRIPTION``, ``add_arguments(parser)`` and ``run(args) -> exit status``; ``_common`` holds
what they share. Call :func:`main` with a list of words to run a command in-process.
"""

from ._app import build_parser, main

__all__ = ["build_parser", "main"]
