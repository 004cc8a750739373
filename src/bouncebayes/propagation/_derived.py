"""DEM-ready output: the posterior of the quantities simulation users set in their codes.

:func:`derive` pushes a seeded subset of the posterior draws through
:func:`bouncebayes.model.derived_quantities` (docs/model.md §4.7): the normal restitution and
contact time over impact speeds of 0.5-10 m/s, the tangential restitution, rebound spin and
rebound angle over incidence angles at the campaign's speed, the equivalent linear
spring-dashpot and the friction coefficient, each with its definition and where it transfers.
:func:`write_derived` writes ``derived.json``; :func:`load_derived` reads it back (the report's
table and figure).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import InputFileError
from .._io import write_json
from ._propagate import draw_subset

N_DERIVED = 300  #: posterior draws behind the derived quantities
DERIVED_FILE = "derived.json"
LEVELS = (0.05, 0.5, 0.95)  #: the quantiles of every curve and number


def _stats(v: np.ndarray) -> dict[str, Any]:
    """Median, mean, sd and the 90 % interval of a number over the draws (NaN: unsolved)."""
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"median": None, "mean": None, "sd": None, "ci90": None, "n_draws": 0}
    q = np.quantile(v, LEVELS)
    return {"median": float(q[1]), "mean": float(np.mean(v)), "sd": float(np.std(v)),
            "ci90": [float(q[0]), float(q[2])], "n_draws": int(v.size)}


def _band(v: np.ndarray) -> dict[str, Any]:
    """5 %, 50 % and 95 % quantiles of a curve at each grid point, over the solved draws."""
    ok = np.isfinite(v)
    q = np.full((len(LEVELS), v.shape[1]), np.nan)
    for j in range(v.shape[1]):
        if ok[:, j].any():
            q[:, j] = np.quantile(v[ok[:, j], j], LEVELS)
    return {"q05": _list(q[0]), "median": _list(q[1]), "q95": _list(q[2])}


def _list(x: np.ndarray) -> list[float | None]:
    return [float(a) if np.isfinite(a) else None for a in x]


def derive(result, *, n_draws: int = N_DERIVED, seed: int | None = None) -> dict[str, Any]:
    """The content of ``derived.json`` for an inference result (seeded subset of its draws;
    seed: the inference's by default)."""
    from ..model import derived_quantities

    seed = result.seed if seed is None else int(seed)
    e, t = result.experiment, result.trials
    theta = draw_subset(result, n_draws, np.random.default_rng([seed, 2]))
    values = {k: v for k, v in theta.items() if k in e.model_parameters and k != "spin"}
    speeds = np.asarray(t.incidence_speed, dtype=float)
    v_ref = float(np.median(speeds))
    normal = speeds * np.cos(np.radians(np.asarray(t.incidence_angle, dtype=float)))
    found = derived_quantities(e.ball, values, reference_speed=v_ref, normal_law=e.normal_law,
                               tangential=e.tangential,
                               measured_speeds=(float(normal.min()), float(normal.max())))
    quantities = {}
    for name, q in found.items():
        record: dict[str, Any] = {"unit": q.unit, "definition": q.definition,
                                  "transfer": q.transfer}
        if q.grid is None:
            record |= _stats(np.asarray(q.values, dtype=float))
        else:
            record |= {"grid_name": q.grid_name, "grid_unit": q.grid_unit,
                       "grid": _list(q.grid)} | _band(np.asarray(q.values, dtype=float))
        quantities[name] = record
    return {"reference_speed_m_s": v_ref,
            "measured_speeds_m_s": [float(speeds.min()), float(speeds.max())],
            "measured_normal_speeds_m_s": [float(normal.min()), float(normal.max())],
            "measured_angles_deg": [float(np.min(t.incidence_angle)),
                                    float(np.max(t.incidence_angle))],
            "normal_law": e.normal_law, "tangential": e.tangential, "seed": seed,
            "n_draws": int(next(iter(values.values())).size) if values else 0,
            "conditions": "no incident spin, no gravity, a horizontal plane (material "
                          "responses, as DEM codes define them)",
            "cautions": _cautions(result), "quantities": quantities}


def _cautions(result) -> list[str]:
    """What the numbers do not say: a misfitting model, a friction only bounded."""
    out = []
    a = result.adequacy
    if a is not None and not a.adequate and result.discrepancy == "none":
        out.append("the model does not reproduce the data (see the adequacy verdict): these "
                   "are the misfitting model's numbers, not measurements")
    for p in result.parameters:
        spread_at_zero = p.name.endswith("_sd") and (p.bound or {}).get("side") == "upper"
        if not p.identifiable and not spread_at_zero:  # no spread is an answer, not a gap
            out.append(f"{p.name} is not identified by the data ({p.paper_form()}): the "
                       f"quantities that depend on it spread over what its prior allows")
    return out


def write_derived(derived: dict[str, Any], out: str | Path) -> Path:
    """``derived.json`` in the folder ``out``."""
    return write_json(Path(out) / DERIVED_FILE, derived)


def load_derived(folder: str | Path) -> dict[str, Any] | None:
    """``derived.json`` of a run folder, or None where it has none.

    Raises:
        InputFileError: the file is damaged (named, with what to do).
    """
    path = Path(folder) / DERIVED_FILE
    if not path.is_file():
        return None
    remedy = "delete it and run `bouncebayes report` again to compute it"
    try:
        obj = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputFileError(path, f"damaged: cannot be read ({exc}); {remedy}") from None
    if not (isinstance(obj, dict) and isinstance(obj.get("quantities"), dict)
            and isinstance(obj.get("reference_speed_m_s"), int | float)):
        raise InputFileError(path, f"damaged: no quantities or reference speed; {remedy}")
    return obj
