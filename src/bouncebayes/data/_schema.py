"""The experiment file's schema: every key, its type, unit, range and default, in one table.

The table drives the parser, its error messages and the reference in docs/experiment-file.md,
so the three cannot disagree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..model import NORMAL_LAWS, STANDARD_GRAVITY, TANGENTIAL_LAWS


@dataclass(frozen=True)
class Key:
    """One key of the experiment file."""

    kind: type  # float, int or str
    doc: str
    unit: str = ""
    default: Any = None  # None: required unless the section's rules say otherwise
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple[str, ...] = ()


def _pos(doc: str, unit: str, default: Any = None) -> Key:
    return Key(float, doc, unit, default, low=0.0, low_open=True)


def _nonneg(doc: str, unit: str, default: Any = 0.0) -> Key:
    return Key(float, doc, unit, default, low=0.0)


OPTIONAL = object()  # default marker: may be absent, no value

# The choices of the [inference] table, which the inference's arguments share.
INFERENCE_CHOICES: dict[str, tuple[str, ...]] = {
    "likelihood": ("kde", "gaussian", "consistent", "population"),
    "noise": ("auto", "given", "inferred"),
    "discrepancy": ("auto", "none", "normal", "student-t"),
    "population": ("normal", "lognormal"),
}

SECTIONS: dict[str, dict[str, Key]] = {
    "experiment": {
        "name": Key(str, "a short name shown in reports", default="experiment"),
        "description": Key(str, "free text shown in reports (beside the count of trials fitted)", default=""),
    },
    "ball": {
        "diameter_m": _pos("ball diameter (give this or radius_m)", "m", OPTIONAL),
        "radius_m": _pos("ball radius (give this or diameter_m)", "m", OPTIONAL),
        "mass_kg": _pos("ball mass (give this or density_kg_m3)", "kg", OPTIONAL),
        "density_kg_m3": _pos("mean density (give this or mass_kg)", "kg/m^3", OPTIONAL),
        "youngs_modulus_Pa": _pos("Young's modulus E", "Pa"),
        "poisson_ratio": Key(float, "Poisson ratio", "", None, low=-1.0, high=0.5,
                             low_open=True),
        "inertia_factor": Key(float, "kappa in I = kappa m r^2: 0.4 solid, 2/3 thin shell", "",
                              0.4, low=0.0, high=1.0, low_open=True),
    },
    "surface": {
        "inclination_deg": Key(float, "inclination of the plane to the horizontal; positive "
                                      "when the ball travels down-slope", "deg", 0.0,
                               low=-90.0, high=90.0, low_open=True, high_open=True),
    },
    "incidence": {
        "speed_m_s": _pos("nominal incident speed at first contact", "m/s"),
        "angle_deg": Key(float, "nominal incident angle from the plane normal", "deg", None,
                         low=0.0, high=90.0, high_open=True),
        "spin_rad_s": Key(float, "nominal incident spin, counter-clockwise positive", "rad/s",
                          0.0),
        "speed_sd_m_s": _nonneg("bounce-to-bounce standard deviation of the speed", "m/s"),
        "angle_sd_deg": _nonneg("bounce-to-bounce standard deviation of the angle", "deg"),
        "spin_sd_rad_s": _nonneg("bounce-to-bounce standard deviation of the spin", "rad/s"),
    },
    "model": {
        "normal": Key(str, "normal-force law (docs/model.md §4): the paper's Hertz + linear "
                           "dashpot, Hunt-Crossley, the DEM linear spring-dashpot, or Hertz "
                           "with Tsuji's dashpot", "", "kelvin-voigt", choices=NORMAL_LAWS),
        "tangential": Key(str, "tangential compliance (docs/model.md §5.2): none (rigid "
                               "tangential contact, the paper's), a Mindlin spring (stiffness "
                               "proportional to the contact radius) or a linear "
                               "Cundall-Strack spring, both capped by Coulomb friction", "",
                          "none", choices=TANGENTIAL_LAWS),
        "gravity_m_s2": _nonneg("gravitational acceleration", "m/s^2", STANDARD_GRAVITY),
    },
    "contact": {
        "mu": _nonneg("Coulomb friction coefficient: its value where it is not inferred, and "
                      "the truth of synthetic campaigns", "", OPTIONAL),
        "eta": _nonneg("damping coefficient of kelvin-voigt (kg/s) and hunt-crossley (s/m): "
                       "its value where it is not inferred, and the truth of synthetic "
                       "campaigns", "kg/s or s/m", OPTIONAL),
        "restitution": Key(float, "restitution coefficient that sets the damping of the DEM "
                                  "laws linear-dashpot and hertz-tsuji, as DEM codes take it "
                                  "(value where not inferred, and synthetic truth)", "",
                           OPTIONAL, low=0.0, high=1.0, low_open=True),
        "normal_stiffness": _pos("normal stiffness k_n of linear-dashpot (value where not "
                                 "inferred, and synthetic truth)", "N/m", OPTIONAL),
        "tangential_stiffness_ratio": _pos("tangential to normal stiffness (docs/model.md "
                                           "§5.2; value where not inferred, and synthetic "
                                           "truth); default Mindlin's 2(1-nu)/(2-nu)", "",
                                           OPTIONAL),
    },
    "inference": {
        "likelihood": Key(str, "how the bounces inform the parameters (docs/likelihoods.md): "
                               "the paper's kde, the gaussian measurement model, "
                               "data-consistent inversion, or the hierarchical population "
                               "model; `--likelihood` overrides it", "",
                          "gaussian", choices=INFERENCE_CHOICES["likelihood"]),
        "noise": Key(str, "gaussian: the table's standard errors (given), noise levels "
                          "inferred, or auto (given when every trial has them); `--noise` "
                          "overrides it", "", "auto", choices=INFERENCE_CHOICES["noise"]),
        "discrepancy": Key(str, "gaussian with given noise: an inferred model error per "
                                "observable in quadrature to the standard errors (normal, or "
                                "student-t for outliers), none, or auto (added when the "
                                "adequacy check fails without it); `--discrepancy` overrides "
                                "it", "", "auto", choices=INFERENCE_CHOICES["discrepancy"]),
        "population": Key(str, "population: the family of each parameter's bounce-to-bounce "
                               "population, truncated to the prior's domain (lognormal for "
                               "positive parameters); `--population` overrides it", "",
                          "normal", choices=INFERENCE_CHOICES["population"]),
    },
    "trajectories": {
        "rotation_deg": Key(float, "rotation from the camera frame to the plane-aligned frame "
                                   "(counter-clockwise positive)", "deg", 0.0,
                            low=-180.0, high=180.0),
        "length_unit": Key(str, "unit of the positions in trajectory files", "", "m",
                           choices=("m", "cm", "mm")),
        "drag": Key(str, "air drag in the free-flight fits", "", "none",
                    choices=("none", "quadratic")),
        "scale": Key(str, "length scale of the trial table: `tracked` keeps the trajectories' "
                          "own and checks it against the free flights' fall (a warning where "
                          "they disagree); `gravity` also corrects every length and speed by "
                          "the fall (combined with the tracker's stated scale uncertainty "
                          "where the two agree), which then sets `scale_rel_sd`", "",
                     "tracked", choices=("tracked", "gravity")),
    },
    "synth": {
        "n": Key(int, "number of bounces of a synthetic campaign", "", 55, low=1.0),
        "mu_sd": _nonneg("bounce-to-bounce standard deviation of mu", ""),
        "eta_sd": _nonneg("bounce-to-bounce standard deviation of eta", "kg/s or s/m"),
        "rebound_speed_noise_m_s": _nonneg("measurement noise (sd) of the rebound speed in the "
                                           "trial table", "m/s", 0.01),
        "rebound_angle_noise_deg": _nonneg("measurement noise (sd) of the rebound angle in the "
                                           "trial table", "deg", 0.3),
        "incidence_speed_noise_m_s": _nonneg("measurement noise (sd) of the incident speed in "
                                             "the trial table", "m/s", 0.01),
        "incidence_angle_noise_deg": _nonneg("measurement noise (sd) of the incident angle in "
                                             "the trial table", "deg", 0.3),
        "camera_rate_hz": Key(float, "sample rate of synthetic trajectories", "Hz", 1000.0,
                              low=10.0, high=1e6),
        "position_noise_m": _nonneg("position noise (sd) of synthetic trajectories", "m",
                                    2e-4),
        "flight_time_s": _pos("free flight recorded before and after the impact", "s", 0.04),
    },
}
REQUIRED_SECTIONS = ("ball", "incidence")

# ---------------------------------------------------------------- [models.NAME] (compare)
#: The keys of a candidate model's table [models.NAME] (``bouncebayes compare``), besides the
#: [model] keys it overrides and its sub-tables [models.NAME.contact] and
#: [models.NAME.parameters.X].
CANDIDATE_KEYS: dict[str, Key] = {
    "description": Key(str, "what the candidate stands for, shown in the comparison", "",
                       default=""),
}
#: ``fixed``: an array of names of parameters that [parameters] infers and the candidate keeps
#: at their [contact] (or [models.NAME.contact]) values.
CANDIDATE_FIXED = "fixed"
CANDIDATE_TABLES = ("contact", "parameters")

# The inferable parameters: unit, and the physical domain a prior must stay inside.
PARAMETERS: dict[str, tuple[str, float]] = {
    "mu": ("", 0.0),
    "eta": ("kg/s or s/m", 0.0),
    "youngs_modulus": ("Pa", 0.0),
    "spin": ("rad/s", -math.inf),
    "restitution": ("", 0.0),
    "normal_stiffness": ("N/m", 0.0),
    "tangential_stiffness_ratio": ("", 0.0),
}
PRIOR_KEYS: dict[str, dict[str, Key]] = {
    "uniform": {"low": Key(float, "lower bound"), "high": Key(float, "upper bound")},
    "normal": {"mean": Key(float, "mean"), "sd": _pos("standard deviation", ""),
               "low": Key(float, "truncation below", default=-math.inf),
               "high": Key(float, "truncation above", default=math.inf)},
    "lognormal": {"median": _pos("median", ""), "sd_log": _pos("sd of the natural log", "")},
}


_PARAMETERS_TEXT = (
    ". The unit of `eta` is kg/s under `kelvin-voigt` and s/m under `hunt-crossley`. Each "
    "contact law has its own parameters (`bouncebayes.model.model_parameters`): `eta` for "
    "`kelvin-voigt` and `hunt-crossley`, `restitution` for `linear-dashpot` and `hertz-tsuji`, "
    "`normal_stiffness` for `linear-dashpot` (which has no `youngs_modulus`), "
    "`tangential_stiffness_ratio` when `tangential` is not `none`; a prior for a parameter the "
    "law does not have is refused. A parameter not listed is fixed: `mu`, `eta`, "
    "`restitution`, `normal_stiffness` at their [contact] values, `tangential_stiffness_ratio` "
    "at its [contact] value or Mindlin's 2(1-nu)/(2-nu), `youngs_modulus` at "
    "`ball.youngs_modulus_Pa`, `spin` at `incidence.spin_rad_s`. A prior must stay inside the "
    "physical domain (`mu`, `eta` >= 0; `youngs_modulus`, `normal_stiffness`, "
    "`tangential_stiffness_ratio` > 0; `restitution` in (0, 1]).")


def reference_markdown() -> str:
    """docs/experiment-file.md, generated from the tables above (a test keeps them equal)."""
    from .._validate import range_text

    lines = ["# The experiment file", "",
             "An experiment is described by one TOML file; keys carry their unit in the name, "
             "angles are in degrees. `examples/paper.toml` is a commented example. Sections "
             f"[{'] and ['.join(REQUIRED_SECTIONS)}] are required; every other section and "
             "key is optional unless marked *required*. A mistake (missing or unknown key, "
             "wrong type, impossible value, reversed prior bounds) stops with the key's path "
             "and what is allowed. This page is generated from `bouncebayes/data/_schema.py`.",
             ""]
    for section, keys in SECTIONS.items():
        lines += [f"## [{section}]", "", "| key | meaning | unit | allowed | default |",
                  "|---|---|---|---|---|"]
        for name, k in keys.items():
            if k.kind is str:
                allowed = ", ".join(f"`{c}`" for c in k.choices) or "text"
            else:
                allowed = range_text(k.low, k.high, k.low_open, k.high_open).replace(
                    "a finite number", "integer" if k.kind is int else "number")
            default = ("*required*" if k.default is None else "" if k.default is OPTIONAL
                       else f"`{k.default!r}`")
            lines.append(f"| `{name}` | {k.doc} | {k.unit or '-'} | {allowed} | {default} |")
        lines.append("")
    lines += ["In [ball], give exactly one of `diameter_m`/`radius_m` and exactly one of "
              "`mass_kg`/`density_kg_m3`.", "", "## [parameters.NAME]", "",
              "One table per inferred parameter; NAME is one of "
              + ", ".join(f"`{n}` ({u or 'dimensionless'})" for n, (u, _) in
                          PARAMETERS.items()) + _PARAMETERS_TEXT, "",
              "| prior | keys |", "|---|---|"]
    for kind, keys in PRIOR_KEYS.items():
        described = ", ".join(f"`{n}` ({k.doc}"
                              + (", default " + repr(k.default) if k.default is not None
                                 else "") + ")" for n, k in keys.items())
        lines.append(f"| `prior = \"{kind}\"`{' (default)' if kind == 'uniform' else ''} | "
                     f"{described} |")
    return "\n".join(lines + _candidates_markdown()) + "\n"


_CANDIDATES_TEXT = (
    "Candidate models for `bouncebayes compare` (docs/comparison.md), one table per model; "
    "NAME is letters, digits, `-` and `_`. Each candidate is the experiment above with its "
    "own contact law and priors: its keys override [model] (`normal`, `tangential`, "
    "`gravity_m_s2`), [models.NAME.contact] overrides [contact] values, and "
    "[models.NAME.parameters.X] adds a prior or replaces the one of [parameters.X]. A prior of "
    "[parameters] for a parameter the candidate's law does not have is left out for it, and "
    "`fixed` keeps inferred parameters fixed. `bouncebayes run` and `infer` use [model] and "
    "[parameters] and ignore [models] (after checking it).")


def _candidates_markdown() -> list[str]:
    rows = [f"| `{k}` | {SECTIONS['model'][k].doc} |" for k in SECTIONS["model"]]
    rows += [f"| `{k}` | {v.doc} |" for k, v in CANDIDATE_KEYS.items()]
    rows += [f"| `{CANDIDATE_FIXED}` | an array of parameter names inferred in [parameters] "
             f"that this candidate keeps fixed at its [contact] value (or Mindlin's ratio), "
             f"e.g. `[\"tangential_stiffness_ratio\"]` |",
             "| [models.NAME.contact] | values of [contact] keys for this candidate |",
             "| [models.NAME.parameters.X] | a prior of this candidate (as [parameters.X]) |"]
    return ["", "## [models.NAME]", "", _CANDIDATES_TEXT, "", "| key | meaning |", "|---|---|",
            *rows]
