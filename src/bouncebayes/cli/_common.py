"""What the sub-commands share: the parser and help formatter, option types, output checks,
sampler flags, progress and provenance at the command-line boundary.

Nothing here imports a pipeline stage at module level: ``bouncebayes --help`` must stay fast.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
import tempfile
from pathlib import Path
from typing import Any, NoReturn


class UserError(Exception):
    """An error in what the user asked for; printed as one line without a traceback."""


class Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (exit status 2)."""

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE`` and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message} (see `{self.prog} --help`)\n")


class Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help with every default shown (none for options whose default is 'not given')."""

    def __init__(self, prog: str) -> None:
        super().__init__(prog, max_help_position=34, width=100)

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None or action.default is False:
            return action.help
        return super()._get_help_string(action)


# ------------------------------------------------------------------------- option types

def integer(low: int | None = None):
    """An argparse type: an integer, at least ``low``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer; got {text!r}") from None
        if low is not None and value < low:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}; got {text!r}")
        return value
    parse.__name__ = "integer"
    return parse


def real(text: str) -> float:
    """An argparse type: a finite real number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number; got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number; got {text!r}")
    return value


_SIZE = re.compile(r"\s*([0-9]*\.?[0-9]+(?:e[+-]?[0-9]+)?)\s*(|b|k|kb|kib|m|mb|mib|g|gb|gib|t|tb|tib)\s*",
                   re.IGNORECASE)
_SIZE_UNITS = {"": 1, "b": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}


def byte_size(text: str) -> int:
    """An argparse type: a memory size in bytes, ``4G``, ``512MiB``, ``2.5gb`` (binary units)."""
    m = _SIZE.fullmatch(text)
    if m is None:
        raise argparse.ArgumentTypeError(f"must be a size such as 4G, 512M or 2GiB; got {text!r}")
    return int(float(m[1]) * _SIZE_UNITS[m[2][:1].lower()])


FIGURE_FORMAT_CHOICES = ("png", "svg", "pdf")


def figure_format_list(text: str) -> tuple[str, ...]:
    """An argparse type: comma-separated figure formats (PNG is always written)."""
    names = tuple(t.strip().lower().lstrip(".") for t in text.split(",") if t.strip())
    bad = [n for n in names if n not in FIGURE_FORMAT_CHOICES]
    if bad or not names:
        raise argparse.ArgumentTypeError(f"must be a comma-separated list of "
                                         f"{', '.join(FIGURE_FORMAT_CHOICES)}; got {text!r}")
    return names


def add_figure_formats(p: argparse.ArgumentParser) -> None:
    """``--figure-formats``: which files each figure is written as."""
    p.add_argument("--figure-formats", type=figure_format_list, default=("png",),
                   metavar="LIST",
                   help="figure files to write, comma-separated from png, svg, pdf (PNG is "
                        "always written: the report embeds it; default png)")


# ------------------------------------------------------------------------- outputs

def _nearest_existing(path: Path) -> Path:
    return next(p for p in (path, *path.parents) if os.path.lexists(p))


def _check_creatable(option: str, folder: Path) -> None:
    """``folder`` exists or can be made, and files can be written in it: probed by making (and
    removing) an empty hidden file, which also catches what permission bits do not (read-only
    file systems, and a user who may write anywhere)."""
    anchor = _nearest_existing(folder)
    if not anchor.is_dir():
        raise UserError(f"`{option}` {folder}: {anchor} is a file, so no folder can be made "
                        f"there; give another path")
    try:
        fd, probe = tempfile.mkstemp(prefix=".bouncebayes-probe-", dir=anchor)
    except OSError as exc:
        raise UserError(f"`{option}` {folder}: cannot write in {anchor} "
                        f"({exc.strerror or exc}); give a folder you can write to") from None
    os.close(fd)
    os.unlink(probe)


def check_out_folder(option: str, path: Path) -> Path:
    """``path`` can be a command's output folder (it exists as a folder, or can be made)."""
    if path.exists() and not path.is_dir():
        raise UserError(f"`{option}` {path}: is a file; expected a folder (made if missing)")
    _check_creatable(option, path)
    return path


def check_out_file(option: str, path: Path, suffixes: tuple[str, ...] = ()) -> Path:
    """``path`` can be written as one output file (with one of ``suffixes``, if given)."""
    if path.is_dir():
        raise UserError(f"`{option}` {path}: is a folder; expected a file name, e.g. "
                        f"{path / ('out' + (suffixes[0] if suffixes else ''))}")
    if suffixes and path.suffix.lower() not in suffixes:
        raise UserError(f"`{option}` {path}: must end in one of {', '.join(suffixes)}; got "
                        f"{path.suffix or 'no suffix'!r}")
    _check_creatable(option, path.parent)
    return path


def add_out_folder(p: argparse.ArgumentParser, help: str = "output folder") -> None:
    """``--out DIR`` (required)."""
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help=help)


def tone_curve(text: str) -> str | float | None:
    """An argparse type: a camera tone curve (``bouncebayes.tracking.TrackerConfig.tone_curve``)."""
    from ..tracking import TrackerConfig

    try:
        return TrackerConfig(tone_curve=text).tone_curve
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("`tone_curve` ")) from None


def add_tone_curve(p: argparse.ArgumentParser) -> None:
    """``--tone-curve``: how the camera stored light as grey levels."""
    p.add_argument("--tone-curve", type=tone_curve, default=None, metavar="CURVE",
                   help="how the camera stored light as grey levels: linear (raw frames, most "
                        "machine-vision cameras), srgb, rec709 (the BT.709 curve of consumer "
                        "video) or a gamma from 1 to 4 (stored = light^(1/gamma)); the frames "
                        "are decoded to light before tracking. Not given: taken as linear (a "
                        "curve taken for linear puts the --ball-diameter scale 1-8 %% off, up to "
                        "15 %% for a 5 px ball; "
                        "lossy-coded files then get a warning)")


def add_readout(p: argparse.ArgumentParser) -> None:
    """``--readout``: a rolling shutter's readout time."""
    p.add_argument("--readout", type=real, default=0.0, metavar="SECONDS",
                   help="a rolling shutter (most consumer CMOS cameras): the time the camera "
                        "takes to read a frame from its top row to its bottom, at most the frame "
                        "interval; each ball centre is then timed by its row. 0: a global "
                        "shutter")


def add_quiet(p: argparse.ArgumentParser) -> None:
    """``--quiet``: no progress bar."""
    p.add_argument("--quiet", action="store_true",
                   help="no progress bars (they are shown only on a terminal anyway)")


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars on a terminal only: never in pipes, logs or CI."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def record(args: argparse.Namespace, inputs: dict[str, Any], *, seed: int | None = None,
           config: Any = None) -> dict:
    """The provenance record of this command (its options are the settings by default)."""
    from .._provenance import provenance

    if config is None:
        config = {k: v for k, v in vars(args).items()
                  if k not in ("run", "argv", "traceback", "command", "flags")}
    return provenance(inputs=inputs, seed=seed, config=config, argv=getattr(args, "argv", None))


def log(message: str) -> None:
    """Progress messages go to stderr; results to stdout."""
    print(message, file=sys.stderr, flush=True)


# ------------------------------------------------------------------------- sampler flags

# library argument -> the flag that sets it
SAMPLER_FLAGS = {"draws": "--draws", "chains": "--chains", "burn_in": "--burn-in",
                 "thin": "--thin", "walkers": "--walkers", "points": "--grid-points"}
_FLAG_NAME = re.compile(r"`(" + "|".join(sorted(SAMPLER_FLAGS, key=len, reverse=True)) + r")`")


def flag_names(text: str, flags: frozenset[str] = frozenset()) -> str:
    """Library messages name arguments (`` `burn_in` ``); the command line names flags: the
    sampler settings, and any ``a_b`` (or ``a``) whose flag ``--a-b`` is among ``flags``."""
    text = _FLAG_NAME.sub(lambda m: f"`{SAMPLER_FLAGS[m[1]]}`", text)
    text = _CONFIG_NAME.sub("", text)  # "raise `--draws` of MHConfig": the flag says it

    def flag(m: re.Match) -> str:
        option = "--" + m[1].replace("_", "-")
        return f"`{option}`" if option in flags else m[0]

    return _SNAKE_NAME.sub(flag, text)


_CONFIG_NAME = re.compile(r" of (?:MH|Ensemble|Grid)Config\b")
_SNAKE_NAME = re.compile(r"`([a-z]+(?:_[a-z]+)*)`")


def add_sampler_arguments(p: argparse.ArgumentParser) -> None:
    """The flags of every command that samples a posterior (infer, run, demo)."""
    from ..inference import DISCREPANCIES, LIKELIHOODS, SAMPLERS, EnsembleConfig, MHConfig

    d, e = MHConfig(), EnsembleConfig()
    g = p.add_argument_group("inference")
    g.add_argument("--likelihood", choices=LIKELIHOODS, default=None,
                   help="gaussian: every bounce = model + measurement noise (the uncertainty "
                        "of one true value); kde: the paper's (density of the measured "
                        "rebounds at the simulated one); consistent: data-consistent inversion "
                        "(the parameters' bounce-to-bounce distribution); population: each "
                        "bounce its own parameters from an inferred population (<p>_mean, "
                        "<p>_sd) plus measurement noise (default: the experiment's "
                        "[inference] likelihood, else gaussian)")
    g.add_argument("--sampler", choices=SAMPLERS, default=None,
                   help="mh: the paper's Metropolis-Hastings; ensemble: emcee; grid: exact "
                        "quadrature (up to 3 parameters) (default: mh; ensemble for the "
                        "population likelihood, whose mean and spread mh explores slowly)")
    g.add_argument("--seed", type=integer(0), default=0,
                   help="random seed (recorded in the outputs)")
    g.add_argument("--noise", choices=("auto", "given", "inferred"), default=None,
                   help="gaussian likelihood: the table's standard errors (given), noise levels "
                        "inferred as extra parameters, or given when every trial has them "
                        "(auto) (default: the experiment's [inference] noise, else auto)")
    g.add_argument("--discrepancy", choices=DISCREPANCIES, default=None,
                   help="gaussian likelihood with given noise: an inferred model error per "
                        "observable (discrepancy_speed m/s, discrepancy_angle deg) in "
                        "quadrature to the standard errors, normal or student-t (outliers "
                        "count less); none; or auto: added when the adequacy check fails "
                        "without it (default: the experiment's [inference] discrepancy, else "
                        "auto)")
    add_population(g)
    g.add_argument("--draws", type=integer(), metavar="N",
                   help=f"posterior draws kept in all (default {d.draws})")
    g.add_argument("--chains", type=integer(), metavar="N",
                   help=f"mh chains (default {d.chains})")
    g.add_argument("--burn-in", type=integer(), metavar="N",
                   help=f"iterations (mh, default {d.burn_in}) or steps (ensemble, default "
                        f"{e.burn_in}) discarded at the start; the mh proposal is "
                        f"tuned meanwhile")
    g.add_argument("--thin", type=integer(), metavar="N",
                   help=f"keep every N-th iteration (mh, default {d.thin}) or step (ensemble, "
                        f"default {e.thin})")
    g.add_argument("--walkers", type=integer(), metavar="N",
                   help=f"ensemble walkers (default {e.walkers})")
    g.add_argument("--grid-points", type=integer(), metavar="N",
                   help="grid points per parameter (default 2048 / 512 / 96 for 1 / 2 / 3 "
                        "parameters)")
    add_memory_budget(g)
    add_quiet(p)


def add_population(g) -> None:
    """``--population FAMILY`` (the population likelihood's family)."""
    from ..data import INFERENCE_CHOICES

    g.add_argument("--population", choices=INFERENCE_CHOICES["population"], default=None,
                   help="population likelihood: the family of each parameter's population, "
                        "truncated to the prior's domain (default: the experiment's "
                        "[inference] population, else normal)")


def add_memory_budget(g) -> None:
    """``--memory-budget SIZE`` (bytes; suffixes K, M, G)."""
    g.add_argument("--memory-budget", type=byte_size, default=None, metavar="SIZE",
                   help="memory an inference may hold at once, e.g. 4G or 512M (default 2G); "
                        "a request that needs more is refused before it starts")


def inference_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of :func:`bouncebayes.inference.infer` the flags set besides the
    sampler and its configuration: likelihood, noise, discrepancy (``None``: the experiment's),
    and the memory budget."""
    budget = getattr(args, "memory_budget", None)
    out = {"likelihood": args.likelihood, "noise": args.noise, "discrepancy": args.discrepancy}
    if getattr(args, "population", None) is not None:
        out["population"] = args.population
    return out | ({} if budget is None else {"memory_budget": budget})


def sampler_config(args: argparse.Namespace, experiment=None):
    """The chosen sampler's configuration from the flags (library defaults for the others); a
    flag that does not apply to the chosen sampler is refused, naming the samplers it does.

    Without ``--sampler``, ``args.sampler`` is set to the likelihood's default sampler
    (:func:`bouncebayes.inference.default_sampler`), the likelihood being ``--likelihood`` or
    the experiment's (``experiment``: a loaded experiment or the path of its file)."""
    from dataclasses import fields

    from ..inference import SAMPLER_CONFIGS, default_sampler
    from ..inference import sampler_config as make_config

    uses = "`--sampler {}`"
    if args.sampler is None:
        uses = ("the {} sampler (the likelihood's default; choose another with `--sampler`)")
        likelihood = getattr(args, "likelihood", None)
        if likelihood is None and experiment is not None:
            if not hasattr(experiment, "inference"):
                from ..data import load_experiment

                experiment = load_experiment(experiment)
            likelihood = experiment.inference["likelihood"]
        args.sampler = default_sampler(likelihood)

    given = {"draws": args.draws, "chains": args.chains, "burn_in": args.burn_in,
             "thin": args.thin, "walkers": args.walkers, "points": args.grid_points}
    given = {k: v for k, v in given.items() if v is not None}
    for name in given:
        users = [s for s, cls in SAMPLER_CONFIGS.items() if name in {f.name for f in fields(cls)}]
        if args.sampler not in users:
            raise UserError(f"`{SAMPLER_FLAGS[name]}` applies to the {' and '.join(users)} "
                            f"sampler{'s' if len(users) > 1 else ''}; this command uses "
                            + uses.format(args.sampler))
    return make_config(args.sampler, **given)
