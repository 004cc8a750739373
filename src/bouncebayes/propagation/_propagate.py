"""Uncertainty propagation: push posterior draws back through the model.

For a seeded subset of draws this simulates the bounce at the nominal incidence (rebound,
contact time, peak forces, spin), time histories for a smaller subset (trajectories and force
realisations, the paper's Figs. 6 and 8). The posterior predictive distribution of the measured
rebounds is the one the inference replicated, compared with the data (two-sample
Kolmogorov–Smirnov and Hellinger distance) under the inference's adequacy verdict. Failed
simulations are counted, never fatal.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._io import write_json, write_with
from ..data import Experiment
from ..inference import InferenceResult, distribution_check, marginal_modes
from ..model import BounceFailed, Bounces, simulate_history

N_DRAWS = 2000  # draws propagated (bounce summaries)
N_HISTORIES = 100  # draws whose time histories are kept (figures)
PREDICTIVE_MAX = 200_000  # posterior predictive rebounds kept for the figures


@dataclass(frozen=True)
class Propagation:
    """What the posterior predicts. Arrays over the propagated draws unless stated."""

    theta: dict  #: parameter -> values of the propagated draws
    bounces: Bounces  #: at the nominal incidence
    predicted_speed: np.ndarray  #: posterior predictive rebound speed, m/s (failed: dropped)
    predicted_angle: np.ndarray  #: deg
    histories: dict  #: time (n, k) s, x, y (m), normal_force, friction_force (N)
    match: dict  #: KS and Hellinger per variable, verdict
    contact_time_modes: tuple[float, ...]  #: s
    n_failed: int
    failures: str
    seed: int
    notes: list = field(default_factory=list)

    def summary(self) -> dict:
        """JSON-ready summary (propagation.json)."""
        b = self.bounces
        ok = b.ok

        def stat(x, unit):
            x = x[ok]
            return {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)),
                    "ci90": [float(q) for q in np.quantile(x, [0.05, 0.95])], "unit": unit}

        modes = [float(m) for m in self.contact_time_modes]
        return {
            "n_draws": int(b.status.size), "n_failed": self.n_failed, "failures": self.failures,
            "seed": self.seed,
            "at_nominal_incidence": {
                "rebound_speed": stat(b.rebound_speed, "m/s"),
                "rebound_angle": stat(b.rebound_angle, "deg"),
                "rebound_spin": stat(b.rebound_spin, "rad/s"),
                "contact_time": stat(b.contact_time, "s"),
                "peak_normal_force": stat(b.peak_normal_force, "N"),
                "peak_friction_force": stat(b.peak_friction_force, "N"),
                "share_rolling": float(np.mean(b.rolling[ok])) if ok.any() else None},
            "contact_time_modes_s": modes,
            "contact_time_multimodal": len(modes) > 1,
            "posterior_predictive_match": self.match, "notes": self.notes}


def draw_subset(result: InferenceResult, n: int, rng) -> dict:
    """A seeded subset of ``n`` draws: every model parameter (inferred from the draws, the
    others at their fixed values) and every inferred parameter, arrays of one length."""
    samples, names = result.parameter_draws()  # with a population: a new bounce's
    flat = samples.reshape(-1, samples.shape[-1])
    pick = np.sort(rng.choice(flat.shape[0], size=min(n, flat.shape[0]), replace=False))
    theta = {}
    for name in result.experiment.model_parameters:
        if name in names:
            theta[name] = flat[pick, names.index(name)]
        else:
            theta[name] = np.full(pick.size, result.experiment.fixed_value(name))
    for name in names:
        theta.setdefault(name, flat[pick, names.index(name)])
    return theta


def _simulate(experiment: Experiment, theta: dict, **incidence) -> Bounces:
    # errors="flag": failures are counted through the statuses, not fatal
    return experiment.bounce_model(values=theta, errors="flag", **incidence).bounces()


def propagate(result: InferenceResult, *, seed: int | None = None, n_draws: int = N_DRAWS,
              n_histories: int = N_HISTORIES, progress: bool = False) -> Propagation:
    """Propagate a seeded subset of the posterior draws (seed: the inference's by default);
    ``progress``: a progress bar over the time histories (the long part)."""
    seed = result.seed if seed is None else int(seed)
    rng_pick, _ = np.random.default_rng([seed, 1]).spawn(2)  # the second: once the predictive's
    e = result.experiment
    theta = draw_subset(result, n_draws, rng_pick)
    inc = e.incidence
    bounces = _simulate(e, theta, speed=inc.speed, angle=inc.angle, spin=theta["spin"])
    speed, angle = predictive(result)
    histories, hist_failed = _histories(e, theta, n_histories, progress)
    n_failed = bounces.n_failed + hist_failed
    failures = "; ".join(x for x in (bounces.failure_summary(),
                                     f"{hist_failed} histories" if hist_failed else "") if x)
    tc = bounces.contact_time[bounces.ok]
    modes = marginal_modes(tc, float(tc.min()), float(tc.max())) if tc.size else ()
    match = predictive_match(result, speed, angle)
    notes = []
    if result.likelihood == "population":
        notes.append("the propagated draws are new bounces from the population predictive "
                     "(each a draw of the population's mean and spread, then of one bounce's "
                     "parameters); the predictive distribution of the measured rebounds is "
                     "each trial's: a new bounce at its own incidence, plus its noise")
    elif result.likelihood != "gaussian":
        notes.append("the predictive distribution is the rebound at the nominal incidence "
                     "pushed forward from the posterior, as in the paper's Fig. 7")
    return Propagation(theta, bounces, speed, angle, histories, match, modes, n_failed,
                       failures, seed, notes)


def predictive(result: InferenceResult, n_max: int = PREDICTIVE_MAX) -> tuple[np.ndarray,
                                                                               np.ndarray]:
    """The posterior predictive rebounds the inference replicated (posterior.nc's
    ``posterior_predictive`` group), pooled over draws and trials, evenly thinned to at most
    ``n_max`` values. Gaussian: each trial's rebound at its own incidence plus its measurement
    noise (and discrepancy); kde / consistent: the rebound at the nominal incidence (what those
    likelihoods compare with the data, as in the paper's Fig. 7)."""
    rep = result.replicates
    if rep is None:
        return np.empty(0), np.empty(0)
    speed, angle = rep.rebound_speed.ravel(), rep.rebound_angle.ravel()
    ok = np.isfinite(speed) & np.isfinite(angle)
    speed, angle = speed[ok], angle[ok]
    step = max(1, -(-speed.size // n_max))
    return speed[::step], angle[::step]


def predictive_match(result: InferenceResult, speed: np.ndarray, angle: np.ndarray) -> dict:
    """The distributions of the predicted and observed rebounds (KS, Hellinger), with the
    inference's adequacy verdict (which also judges the residuals, trial by trial)."""
    t = result.trials
    out = distribution_check({"rebound_speed": t.rebound_speed, "rebound_angle": t.rebound_angle},
                             {"rebound_speed": speed, "rebound_angle": angle})
    a = result.adequacy
    if a is None:
        out["verdict"] = ("The model's adequacy was not checked (a run folder written before "
                          "the check existed): rerun the inference to judge it.")
        out["reproduces_data"] = None
    else:
        out["verdict"], out["reproduces_data"] = a.verdict, a.adequate
    return out


def _histories(e: Experiment, theta: dict, n: int, progress: bool = False) -> tuple[dict, int]:
    from tqdm.auto import tqdm

    keys = ("time", "x", "y", "normal_force", "friction_force", "in_contact")
    out: dict[str, list] = {k: [] for k in keys}
    failed = 0
    inc = e.incidence
    for i in tqdm(range(min(n, theta["mu"].size)), desc="histories", disable=not progress,
                  leave=False, unit="draw", mininterval=0.2):
        try:
            values = e.model_values({k: float(theta[k][i]) for k in e.model_parameters})
            h = simulate_history(e.ball, speed=inc.speed, angle=inc.angle, n_contact=200,
                                 n_flight=60, flight_time=0.004, **values, **e.model_options)
        except BounceFailed:
            failed += 1
            continue
        for k in keys:
            out[k].append(getattr(h, k))
    return {k: np.array(v) for k, v in out.items()}, failed


def write_propagation(prop: Propagation, out: str | Path) -> dict[str, Path]:
    """``propagation.json`` (summary) and ``propagation.npz`` (arrays for the figures)."""
    out = Path(out)
    b = prop.bounces

    def save(tmp):
        with open(tmp, "wb") as fh:
            np.savez_compressed(
                fh, contact_time=b.contact_time, rebound_speed=b.rebound_speed,
                rebound_angle=b.rebound_angle, rebound_spin=b.rebound_spin,
                peak_normal_force=b.peak_normal_force, peak_friction_force=b.peak_friction_force,
                rolling=b.rolling, status=b.status, predicted_speed=prop.predicted_speed,
                predicted_angle=prop.predicted_angle,
                theta=json.dumps({k: v.tolist() for k, v in prop.theta.items()}),
                **{f"history_{k}": v for k, v in prop.histories.items()})

    return {"propagation_summary": write_json(out / "propagation.json", prop.summary()),
            "propagation_arrays": write_with(out / "propagation.npz", save)}


def load_propagation(folder: str | Path) -> Propagation:
    """Reload what :func:`write_propagation` saved (for redrawing figures)."""
    folder = Path(folder)
    summary = json.loads((folder / "propagation.json").read_text(encoding="utf-8"))
    with np.load(folder / "propagation.npz") as z:
        a = {k: z[k] for k in z.files}
    n = a["status"].size
    nan = np.full(n, np.nan)
    bounces = Bounces(rebound_speed=a["rebound_speed"], rebound_angle=a["rebound_angle"],
                      rebound_spin=a["rebound_spin"], rebound_tangential_velocity=nan,
                      rebound_normal_velocity=nan, contact_time=a["contact_time"],
                      peak_normal_force=a["peak_normal_force"],
                      peak_friction_force=a["peak_friction_force"], max_overlap=nan,
                      separation_overlap=nan, time_of_peak_normal_force=nan,
                      rolling=a["rolling"], hertz_valid=a["status"] == 0,
                      closed_form=np.zeros(n, bool), status=a["status"],
                      n_steps=np.zeros(n, np.int64))
    histories = {k[len("history_"):]: v for k, v in a.items() if k.startswith("history_")}
    theta = {k: np.array(v) for k, v in json.loads(str(a["theta"])).items()}
    return Propagation(theta, bounces, a["predicted_speed"], a["predicted_angle"], histories,
                       summary["posterior_predictive_match"],
                       tuple(summary["contact_time_modes_s"]), summary["n_failed"],
                       summary["failures"], summary["seed"], summary["notes"])
