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
               "damping, Coulomb friction) and print the rebound, the contact time and the peak "
               "forces. Incident values are those at first contact; rebound values those at "
               "separation.")
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
)
_JSON_KEYS = ("rebound_speed", "rebound_angle", "rebound_spin", "contact_time",
              "peak_normal_force", "peak_friction_force", "regime")


def add_ball_arguments(parser: argparse.ArgumentParser) -> None:
    """Ball and surface options shared by the commands that simulate."""
    from ..model import NORMAL_LAWS, PAPER_BALL, STANDARD_GRAVITY

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
                   help="normal force: Hertz + linear viscous (kelvin-voigt, the paper's; "
                        "eta in kg/s) or Hunt-Crossley (eta in s/m)")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``simulate``."""
    p.add_argument("--mu", type=real, default=0.16, help="Coulomb friction coefficient (-)")
    p.add_argument("--eta", type=real, default=1.35,
                   help="damping coefficient: kg/s (kelvin-voigt) or s/m (hunt-crossley)")
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
    kwargs = dict(mu=args.mu, eta=args.eta, speed=args.speed, angle=args.angle, spin=args.spin,
                  inclination=args.inclination, normal_law=args.normal_law,
                  gravity=args.gravity)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimulationWarning)  # reported below as an error
        result = simulate(ball, **kwargs)
    if result.n_failed:
        raise UserError(f"the bounce could not be solved: {result.failure_summary()}")
    row = result.item()
    if not row["hertz_valid"]:
        print(f"bouncebayes simulate: warning: the maximum overlap, "
              f"{row['max_overlap'] * 1e3:.4g} mm, exceeds {HERTZ_OVERLAP_LIMIT:.0%} of the ball's "
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


def _plot(ball, kwargs: dict, args: argparse.Namespace) -> Path:
    from .._io import staged_output
    from .._provenance import stamp
    from ..model import simulate_history
    from ..plots import plot_bounce, save_figure

    history = simulate_history(ball, **kwargs)
    title = (f"mu = {args.mu:g}, eta = {args.eta:g}, V = {args.speed:g} m/s, "
             f"angle = {args.angle:g} deg, spin = {args.spin:g} rad/s")
    with staged_output(args.plot, "file") as stage:
        path = save_figure(plot_bounce(history, title=title), stage / args.plot.name)
        stamp(path, record(args, {}))
    return args.plot


def format_bounce_table(row: dict, args: argparse.Namespace) -> str:
    """The printed table of one bounce."""
    scale = {"contact_time": 1e3, "max_overlap": 1e3}
    lines = [f"bounce: mu = {args.mu:g}, eta = {args.eta:g}, incident {args.speed:g} m/s at "
             f"{args.angle:g} deg, spin {args.spin:g} rad/s ({args.normal_law})"]
    for key, label, unit, fmt in _ROWS:
        value = row[key] * scale[key] if key in scale else row[key]
        lines.append(f"  {label:<34} {fmt.format(value):>12} {unit}")
    return "\n".join(lines)
