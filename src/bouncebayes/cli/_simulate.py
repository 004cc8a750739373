"""``bouncebayes simulate``: one bounce, its rebound, forces and contact time."""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from ._common import UserError, check_out_file, real, record

HELP = "simulate one bounce and print its rebound, forces, contact time"
DESCRIPTION = ("Simulate one oblique bounce of a ball on a rigid plane (Hertz contact, viscous "
               "damping, Coulomb friction, optionally a tangential spring) and print the "
               "rebound, the contact time and the peak forces. Incident values are those at "
               "first contact; rebound values those at separation.")
FIGURE_SUFFIXES = (".png", ".svg", ".pdf")

# Quantities printed, with units.
_ROWS = (
    ("rebound_speed", "rebound speed", "m/s", "{:.6g}"),
    ("rebound_angle", "rebound angle (from the normal)", "deg", "{:.6g}"),
    ("rebound_spin", "rebound spin (CCW +)", "rad/s", "{:.6g}"),
    ("contact_time", "contact time", "ms", "{:.6g}"),
    ("peak_normal_force", "peak normal force", "N", "{:.6g}"),
    ("peak_friction_force", "peak friction force", "N", "{:.6g}"),
    ("max_overlap", "maximum overlap", "mm", "{:.6g}"),
    ("regime", "contact point at separation", "", "{}"),
    ("path", "solved by", "", "{}"),
)
_JSON_KEYS = ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
              "peak_normal_force", "peak_friction_force", "regime")


def add_ball_arguments(parser: argparse.ArgumentParser) -> None:
    """Ball and surface options shared by the commands that simulate."""
    from ..model import NORMAL_LAWS, PAPER_BALL, STANDARD_GRAVITY, TANGENTIAL_LAWS

    g = parser.add_argument_group("ball and surface (SI units; defaults: the paper's 25.6 mm "
                                  "polybutadiene ball, see README 'Default ball')")
    g.add_argument("--diameter", type=real, default=PAPER_BALL.diameter, metavar="M",
                   help="ball diameter in m")
    g.add_argument("--mass", type=real, default=PAPER_BALL.mass, metavar="KG",
                   help="ball mass in kg")
    g.add_argument("--modulus", type=real, default=PAPER_BALL.youngs_modulus, metavar="PA",
                   help="Young's modulus E in Pa")
    g.add_argument("--poisson", type=real, default=PAPER_BALL.poisson_ratio, metavar="NU",
                   help="Poisson ratio, in (-1, 0.5]")
    g.add_argument("--inertia-factor", type=real, default=PAPER_BALL.inertia_factor,
                   metavar="K", help="I = K m r^2: 0.4 solid sphere, 0.667 thin shell")
    g.add_argument("--inclination", type=real, default=0.0, metavar="DEG",
                   help="plane inclination to the horizontal in degrees, in (-90, 90); "
                        "positive when the ball travels down-slope")
    g.add_argument("--gravity", type=real, default=STANDARD_GRAVITY, metavar="M/S2",
                   help="gravitational acceleration in m/s^2")
    g.add_argument("--normal-law", choices=NORMAL_LAWS, default="kelvin-voigt",
                   help="normal force (docs/model.md §4): Hertz + linear viscous "
                        "(kelvin-voigt, the paper's; --eta in kg/s), Hunt-Crossley (--eta in "
                        "s/m), the DEM linear spring-dashpot (--normal-stiffness, "
                        "--restitution) or Hertz with Tsuji's dashpot (--restitution)")
    g.add_argument("--tangential", choices=TANGENTIAL_LAWS, default="none",
                   help="tangential compliance (docs/model.md §5.2): none (rigid, the "
                        "paper's), mindlin (spring stiffness proportional to the contact "
                        "radius) or linear (constant spring), capped by Coulomb friction")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``simulate``."""
    p.add_argument("--mu", type=real, default=0.16, help="Coulomb friction coefficient (-)")
    p.add_argument("--eta", type=real, default=None,
                   help="damping coefficient: kg/s (kelvin-voigt) or s/m (hunt-crossley); "
                        "default 1.35 kg/s or 0.1 s/m")
    p.add_argument("--restitution", type=real, default=None, metavar="E",
                   help="restitution coefficient in (0, 1] that sets the damping of "
                        "linear-dashpot and hertz-tsuji, as DEM codes take it")
    p.add_argument("--normal-stiffness", type=real, default=None, metavar="N/M",
                   help="normal stiffness k_n of linear-dashpot in N/m")
    p.add_argument("--tangential-stiffness-ratio", type=real, default=None, metavar="R",
                   help="tangential to normal stiffness (docs/model.md §5.2); default "
                        "Mindlin's 2(1-nu)/(2-nu)")
    p.add_argument("--speed", type=real, default=3.0, metavar="M/S",
                   help="incident speed in m/s")
    p.add_argument("--angle", type=real, default=60.0, metavar="DEG",
                   help="incident angle from the plane normal in degrees, in [0, 90)")
    p.add_argument("--spin", type=real, default=0.0, metavar="RAD/S",
                   help="incident spin in rad/s, counter-clockwise positive with x along the "
                        "direction of travel and y the outward normal")
    add_ball_arguments(p)
    p.add_argument("--json", action="store_true",
                   help="print one JSON object instead of the table")
    p.add_argument("--plot", metavar="FILE", type=Path,
                   help="write a figure of the trajectory near contact and the force histories "
                        "(.png, .svg or .pdf)")


def run(args: argparse.Namespace) -> int:
    """Simulate, print, and draw the figure if asked."""
    from ..model import HERTZ_OVERLAP_LIMIT, Ball, SimulationWarning, simulate

    if args.plot is not None:
        check_out_file("--plot", args.plot, FIGURE_SUFFIXES)
    ball = Ball.from_diameter(args.diameter, mass=args.mass, youngs_modulus=args.modulus,
                              poisson_ratio=args.poisson, inertia_factor=args.inertia_factor)
    kwargs = dict(mu=args.mu, speed=args.speed, angle=args.angle, spin=args.spin,
                  inclination=args.inclination, normal_law=args.normal_law,
                  tangential=args.tangential, gravity=args.gravity, **_law_options(args))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimulationWarning)  # reported below as an error
        result = simulate(ball, **kwargs)
    if result.n_failed:
        raise UserError(f"the bounce could not be solved: {result.failure_summary()}")
    row = result.item()
    row["path"] = "closed form" if row["closed_form"] else "ODE"
    if not row["hertz_valid"]:
        print(f"bouncebayes simulate: warning: the maximum overlap, "
              f"{float(row['max_overlap']) * 1e3:.4g} mm, exceeds {HERTZ_OVERLAP_LIMIT:.0%} of the ball's "
              f"radius ({ball.radius * 1e3:.4g} mm): beyond the small strains of Hertz's contact, "
              f"so these numbers are the model's, not a real ball's", file=sys.stderr)
    if args.json:
        print(json.dumps({k: row[k] for k in _JSON_KEYS}))
    else:
        print(format_bounce_table(row, args))
    if args.plot:
        path = _plot(ball, kwargs, args)
        print(f"figure written to {path}", file=sys.stderr)
    return 0


# The options of each law's parameters, and the defaults of the damping coefficient.
_LAW_OPTIONS = {"eta": "--eta", "restitution": "--restitution",
                "normal_stiffness": "--normal-stiffness",
                "tangential_stiffness_ratio": "--tangential-stiffness-ratio"}
_ETA_DEFAULTS = {"kelvin-voigt": 1.35, "hunt-crossley": 0.1}


def _law_options(args: argparse.Namespace) -> dict:
    """The contact law's parameters from the options: each one it has, required where it has
    no default; an option of a parameter it does not have is refused."""
    from ..model import model_parameters

    used = model_parameters(args.normal_law, args.tangential)
    out = {}
    for name, flag in _LAW_OPTIONS.items():
        value = getattr(args, name)
        if name not in used:
            if value is not None:
                raise UserError(f"{flag} is not a parameter of --normal-law {args.normal_law} "
                                f"with --tangential {args.tangential} (its parameters: "
                                f"{', '.join(used)})")
            continue
        if value is None and name == "eta":
            value = _ETA_DEFAULTS[args.normal_law]
        if value is None and name != "tangential_stiffness_ratio":
            raise UserError(f"{flag} is required with --normal-law {args.normal_law}")
        out[name] = value
    return out


def _law_text(kwargs: dict) -> str:
    """The contact law's parameters in a title: ``eta = 1.35`` or ``e = 0.9, k_n = 1e+05``."""
    short = {"eta": "eta", "restitution": "e", "normal_stiffness": "k_n",
             "tangential_stiffness_ratio": "k_t/k_n"}
    return ", ".join(f"{short[k]} = {kwargs[k]:g}" for k in short if kwargs.get(k) is not None)


def _plot(ball, kwargs: dict, args: argparse.Namespace) -> Path:
    from .._io import staged_output
    from .._provenance import stamp
    from ..model import simulate_history
    from ..plots import plot_bounce, save_figure

    history = simulate_history(ball, **kwargs)
    title = (f"mu = {args.mu:g}, {_law_text(kwargs)}, V = {args.speed:g} m/s, "
             f"angle = {args.angle:g} deg, spin = {args.spin:g} rad/s")
    with staged_output(args.plot, "file") as stage:
        path = save_figure(plot_bounce(history, title=title), stage / args.plot.name)
        stamp(path, record(args, {}))
    return args.plot


def format_bounce_table(row: dict, args: argparse.Namespace) -> str:
    """The printed table of one bounce."""
    scale = {"contact_time": 1e3, "max_overlap": 1e3}
    law = args.normal_law + ("" if args.tangential == "none" else f", {args.tangential} spring")
    lines = [f"bounce: mu = {args.mu:g}, {_law_text(_law_options(args))}, incident "
             f"{args.speed:g} m/s at {args.angle:g} deg, spin {args.spin:g} rad/s ({law})"]
    for key, label, unit, fmt in _ROWS:
        value = row[key] * scale[key] if key in scale else row[key]
        lines.append(f"  {label:<34} {fmt.format(value):>12} {unit}")
    return "\n".join(lines)
