"""The run folder: reload a run, draw its figures, and write one self-contained report.html."""

from __future__ import annotations

import base64
import datetime as dt
import html
import json
import platform
from pathlib import Path

import numpy as np

from ._errors import InputFileError
from ._io import write_text
from ._version import __version__
from .data import load_experiment, load_trials
from .inference import InferenceResult, load_inference
from .inference._infer import SAMPLER_MEANINGS
from .inference._likelihood import MEANINGS

EXPERIMENT_FILE, TRIALS_FILE, TRUTH_FILE = "experiment.toml", "trials.csv", "truth.json"

CAPTIONS = {
    "data": "Measured rebound speed and angle: histograms and Gaussian kernel density "
            "estimates (paper Fig. 3). The bandwidths and the correlation test decide the "
            "experimental density used by the kde and consistent likelihoods.",
    "joint_posterior": "Joint posterior of the first two parameters as a surface and as "
                       "contours (paper Fig. 4).",
    "marginals": "Prior (dashed) and posterior (solid) marginal densities with the 90 % "
                 "credible interval shaded (paper Fig. 5).",
    "trajectories": "Trajectory of the centre of mass through the collision for posterior "
                    "draws, at the nominal incidence (paper Fig. 6).",
    "predictive": "Posterior predictive against measured distributions of the rebound speed "
                  "and angle (paper Fig. 7), with the two-sample Kolmogorov–Smirnov test and "
                  "the Hellinger distance.",
    "forces": "Normal and friction force histories of posterior draws (paper Fig. 8).",
    "contact_time": "Probability density of the contact time over the posterior (paper "
                    "Fig. 9); the modes are marked.",
    "diagnostics": "Sampler diagnostics: the trace of every chain and the histograms of the "
                   "ranks of each chain's draws among all draws (flat when the chains agree).",
}


def load_result(folder: str | Path) -> InferenceResult:
    """Rebuild the :class:`InferenceResult` of a run folder (without its likelihood object)."""
    folder = Path(folder)
    for name in ("posterior.nc", "summary.json", EXPERIMENT_FILE, TRIALS_FILE):
        if not (folder / name).is_file():
            raise InputFileError(folder, f"not a bouncebayes run folder: {name} is missing "
                                         f"(run `bouncebayes run` or `bouncebayes infer` first)")
    summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
    experiment = load_experiment(folder / EXPERIMENT_FILE)
    trials = load_trials(folder / TRIALS_FILE, experiment)
    return load_inference(folder / "posterior.nc", summary, experiment, trials)


def load_truth(folder: str | Path) -> dict | None:
    """Population values of a synthetic campaign, if the run folder holds its truth.json."""
    path = Path(folder) / TRUTH_FILE
    if not path.is_file():
        return None
    return json.loads(path.read_text(encoding="utf-8")).get("population")


def make_figures(result: InferenceResult, prop, folder: str | Path,
                 truth: dict | None = None) -> list[tuple[str, Path]]:
    """Draw every figure as PNG and SVG under ``folder/figures``; returns (key, png path)."""
    from . import plots
    from .density import summarize

    out = Path(folder) / "figures"
    t = result.trials
    grid = Path(folder) / "grid.npz"
    figures = {
        "data": lambda: plots.plot_data(t.rebound_speed, t.rebound_angle,
                                        summarize(t.rebound_speed, t.rebound_angle)),
        "joint_posterior": lambda: plots.plot_joint_posterior(
            result, grid if grid.is_file() else None, truth),
        "marginals": lambda: plots.plot_marginals(result, truth),
        "trajectories": lambda: plots.plot_trajectories(prop, result.experiment.ball.radius),
        "predictive": lambda: plots.plot_predictive(prop, t),
        "forces": lambda: plots.plot_forces(prop),
        "contact_time": lambda: plots.plot_contact_time(prop),
        "diagnostics": lambda: plots.plot_diagnostics(result),
    }
    written = []
    for key, draw in figures.items():
        fig = draw()
        if fig is None:
            continue
        plots.save_figure(fig, out / f"{key}.svg", close=False)
        written.append((key, plots.save_figure(fig, out / f"{key}.png")))
    return written


def _img(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<img src="data:image/png;base64,{data}" alt="{html.escape(alt)}">'


def _table(rows: list[list[str]], header: list[str] | None = None) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header or ())
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in r) + "</tr>"
                   for r in rows)
    thead = f"<thead><tr>{head}</tr></thead>" if head else ""
    return f"<table>{thead}<tbody>{body}</tbody></table>"


def render_report(result: InferenceResult, prop_summary: dict, figures, folder: str | Path,
                  truth: dict | None = None) -> Path:
    """Write ``folder/report.html``: one file, figures embedded, opens offline."""
    e, t = result.experiment, result.trials
    s = result.summary()
    params = [[p.name, p.unit or "-", f"{p.mean:.5g}", f"{p.sd:.3g}",
               f"[{p.ci90[0]:.5g}, {p.ci90[1]:.5g}]", p.paper_form(),
               "-" if p.r_hat is None else f"{p.r_hat:.3f}",
               "-" if p.ess_bulk is None else f"{p.ess_bulk:.0f}",
               "yes" if p.identifiable else "no"]
              + ([f"{truth[p.name]:g}" if truth and p.name in truth else "-"] if truth else [])
              for p in result.parameters]
    header = ["parameter", "unit", "mean", "sd", "90 % interval", "result", "R-hat",
              "ESS (bulk)", "identified"] + (["true value"] if truth else [])
    warns = "".join(f"<li>{html.escape(w)}</li>" for w in result.warnings) or \
        "<li>none: chains agree (R-hat &le; 1.01), enough effective draws (ESS &ge; 400), one " \
        "mode, nothing piled against a prior bound</li>"
    at = prop_summary["at_nominal_incidence"]
    pred_rows = [[k.replace("_", " "), v["unit"], f"{v['mean']:.4g}", f"{v['sd']:.3g}",
                  f"[{v['ci90'][0]:.4g}, {v['ci90'][1]:.4g}]"]
                 for k, v in at.items() if isinstance(v, dict)]
    match = prop_summary["posterior_predictive_match"]
    r = result.regimes
    sections = [
        f"<h1>bouncebayes report: {html.escape(e.name)}</h1>",
        f"<p class='meta'>{html.escape(e.description)}</p>",
        "<h2>Result</h2>", _table(params, header),
        f"<p>Friction regime of the posterior's simulated bounces: "
        f"{100 * (1 - r['share_rolling']):.0f} % slide throughout the contact, "
        f"{100 * r['share_rolling']:.0f} % leave rolling (where a bounce leaves rolling its "
        f"rebound does not depend on mu).</p>",
        "<h2>Diagnostics and warnings</h2>", f"<ul>{warns}</ul>",
        "<h2>The experiment</h2>",
        _table([["ball", f"diameter {1e3 * e.ball.diameter:.4g} mm, mass "
                         f"{1e3 * e.ball.mass:.4g} g, E = {e.ball.youngs_modulus:.4g} Pa, "
                         f"Poisson ratio {e.ball.poisson_ratio:g}, I = "
                         f"{e.ball.inertia_factor:g} m r^2"],
                ["surface", f"inclination {e.inclination:g} deg"],
                ["nominal incidence", f"{e.incidence.speed:g} m/s at {e.incidence.angle:g} deg "
                                      f"from the normal, spin {e.incidence.spin:g} rad/s"],
                ["normal force law", e.normal_law],
                ["priors", "; ".join(f"{n}: {p.describe()}" for n, p in e.priors.items())]]),
        "<h2>The data</h2>",
        f"<p>{t.n} bounces from <code>{html.escape(Path(t.source).name)}</code>; rebound "
        f"speed {np.mean(t.rebound_speed):.4g} &plusmn; {np.std(t.rebound_speed, ddof=1):.2g} "
        f"m/s, rebound angle {np.mean(t.rebound_angle):.4g} &plusmn; "
        f"{np.std(t.rebound_angle, ddof=1):.2g} deg (mean &plusmn; sd).</p>",
        "<h2>Method</h2>",
        f"<p><b>Likelihood {result.likelihood}</b>: {html.escape(MEANINGS[result.likelihood])}"
        f"</p><p><b>Sampler {result.sampler}</b>: "
        f"{html.escape(SAMPLER_MEANINGS[result.sampler])}; {s['n_draws']} draws.</p>",
        "<h2>What the posterior predicts</h2>",
        f"<p>{html.escape(match['verdict'])}</p>",
        _table(pred_rows, ["quantity (nominal incidence)", "unit", "mean", "sd",
                           "90 % interval"]),
        "<p>Contact time: "
        + (f"the distribution is multimodal ({len(prop_summary['contact_time_modes_s'])} "
           "modes)." if prop_summary["contact_time_multimodal"] else "one mode.")
        + f" Failed simulations: {prop_summary['n_failed']}.</p>",
        "<h2>Figures</h2>",
    ]
    for i, (key, path) in enumerate(figures, start=1):
        sections.append(f"<figure>{_img(path, CAPTIONS[key])}<figcaption>Figure {i}. "
                        f"{html.escape(CAPTIONS[key])}</figcaption></figure>")
    sections += ["<h2>Provenance</h2>", _table([
        ["bouncebayes", __version__], ["python", platform.python_version()],
        ["numpy", np.__version__], ["created (UTC)", dt.datetime.now(dt.UTC).isoformat(
            timespec="seconds")],
        ["seed", str(result.seed)], ["experiment file", f"{e.source} (sha256 {e.text_sha256})"],
        ["data file", f"{t.source} (sha256 {t.sha256})"],
        ["sampler settings", json.dumps(result.config.__dict__)]]),
        "<h3>Experiment file</h3>",
        f"<pre>{html.escape(Path(e.source).read_text(encoding='utf-8'))}</pre>"]
    page = (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>bouncebayes: "
            f"{html.escape(e.name)}</title><style>{CSS}</style></head><body>"
            + "\n".join(sections) + "</body></html>\n")
    return write_text(Path(folder) / "report.html", page)


CSS = ("body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;"
       "color:#222;line-height:1.45}table{border-collapse:collapse;margin:.8em 0}"
       "td,th{border:1px solid #ccc;padding:.3em .6em;text-align:left;vertical-align:top}"
       "th{background:#f3f3f3}img{max-width:100%}figure{margin:1.5em 0}"
       "figcaption{color:#444;font-size:.95em}pre{background:#f7f7f7;padding:1em;"
       "overflow-x:auto;font-size:.85em}.meta{color:#555}")
