"""The run folder: reload a run, draw its figures, and write one self-contained report.html."""

from __future__ import annotations

import base64
import html
import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from ._errors import InputFileError
from ._io import write_text
from ._provenance import provenance as make_provenance
from ._provenance import provenance_rows
from .data import load_experiment, load_trials
from .inference import InferenceResult, load_inference
from .inference import MEANINGS, SAMPLER_MEANINGS, ParameterSummary
from .pipeline import EXPERIMENT_FILE, RUN_FILES, TRIALS_FILE, TRUTH_FILE


CAPTIONS = {
    "population": "Population likelihood: the density of each parameter over the bounces "
                  "(normal or lognormal, truncated to the prior), its median and 90 % band "
                  "over the posterior of the population's mean and spread, and the predictive "
                  "density of a new bounce (what a DEM simulation samples from), against the "
                  "prior; ticks: each measured bounce's estimate on its own (grey) and with "
                  "the population (black), which pulls poorly measured bounces towards the "
                  "population mean.",
    "data": "Measured rebound speed and angle: histograms and the Gaussian kernel density "
            "estimate of the measured rebounds that the kde likelihood evaluates (MATLAB "
            "ksdensity's normal-reference bandwidth; paper Fig. 3). The same density is the "
            "experimental curve of the predictive figure. The correlation test decides "
            "whether it is a product of the two marginals or a joint 2-D estimate.",
    "joint_posterior": "Joint posterior of the first two parameters as a surface and as "
                       "contours (paper Fig. 4).",
    "marginals": "Prior (dashed) and posterior (solid) marginal densities with the 90 % "
                 "credible interval shaded (paper Fig. 5).",
    "trajectories": "Trajectory of the centre of mass through the collision for posterior "
                    "draws, at the nominal incidence (paper Fig. 6).",
    "predictive": "Posterior predictive against measured distributions of the rebound speed "
                  "and angle (paper Fig. 7), with the two-sample Kolmogorov–Smirnov test and "
                  "the Hellinger distance. The measured curve is the density of the data "
                  "figure.",
    "forces": "Normal and friction force histories of posterior draws (paper Fig. 8).",
    "contact_time": "Probability density of the contact time over the posterior (paper "
                    "Fig. 9); the modes are marked.",
    "residuals": "Standardised residuals of the adequacy check (measured minus modelled "
                 "rebound, divided by its standard deviation: for the measurement model the "
                 "likelihood's own, stated errors, incidence uncertainty, inferred noise or "
                 "discrepancy, at the best-fitting posterior draw; for kde and consistent the "
                 "posterior predictive distribution's) of every trial: in table order and "
                 "against the incidence angle and speed. A model that fits leaves about 95 % "
                 "of the trials inside the darker ±2 band and nearly all inside ±3, with no "
                 "trend against the incidence; trends or many trials outside point to a "
                 "misfit.",
    "derived": "DEM-ready quantities (derived.json): the posterior median and 90 % band of the "
               "normal restitution and the contact time of head-on impacts against the impact "
               "speed, and of the tangential restitution and rebound spin against the incidence "
               "angle at the campaign's speed (no incident spin, no gravity); shaded: the range "
               "the data measured. Outside it the curves are the contact law's extrapolation.",
    "diagnostics": "Sampler diagnostics: the trace of every chain and the histograms of the "
                   "ranks of each chain's draws among all draws (flat when the chains agree).",
}
FIGURES_NOTE = ("Axis limits hold the bulk of the values (Tukey's outer fences); a value beyond "
                "them is not dropped but drawn as an arrowhead or cross at the edge of the axes "
                "and counted in the legend.")
DEFAULT_FORMATS = ("png",)


_SUMMARY_KEYS: dict[str, type | tuple[type, ...]] = {
    "parameters": dict, "likelihood": str, "sampler": str, "seed": int,
    "sampler_settings": dict, "regimes": dict, "warnings": list, "likelihood_details": dict,
    "seconds": (int, float)}
_RERUN = "run `bouncebayes infer` or `bouncebayes run` again to make it"


def load_result(folder: str | Path) -> InferenceResult:
    """Rebuild the :class:`InferenceResult` of a run folder (without its likelihood object).

    Raises:
        InputFileError: a file is missing or damaged; the message names it.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputFileError(folder, "no such run folder" if not folder.exists() else
                             "is a file; expected a run folder")
    for name in RUN_FILES:
        if not (folder / name).is_file():
            raise InputFileError(folder, f"not a bouncebayes run folder: {name} is missing "
                                         f"(run `bouncebayes run` or `bouncebayes infer` first)")
    summary = load_summary(folder / "summary.json")
    experiment = load_experiment(folder / EXPERIMENT_FILE)
    trials = load_trials(folder / TRIALS_FILE, experiment)
    _parameter_summaries(folder / "summary.json", summary["parameters"])
    _check_grid(folder / "grid.npz")
    return _load_inference(folder, summary, experiment, trials)


def _load_inference(folder: Path, summary: dict, experiment, trials) -> InferenceResult:
    """:func:`bouncebayes.inference.load_inference`, a damaged file named."""
    path = folder / "posterior.nc"
    try:
        return load_inference(path, summary, experiment, trials)
    except InputFileError:
        raise
    except KeyError as exc:
        raise InputFileError(path, f"damaged: no variable {exc} in the posterior (the summary "
                                   f"lists {', '.join(summary['parameters'])}); {_RERUN}") \
            from None
    except (TypeError, ValueError) as exc:
        raise InputFileError(folder / "summary.json", f"damaged: {_short(exc)}; {_RERUN}",
                             field="sampler_settings") from None
    except Exception as exc:  # any reader failure means a damaged file; name it
        raise InputFileError(path, f"damaged: cannot be read as NetCDF ({_short(exc)}); the "
                                   f"file may be empty or truncated; {_RERUN}") from None


def load_summary(path: Path) -> dict:
    """``summary.json``, checked for the keys a report needs."""
    obj = _load_json(path)
    for key, kind in _SUMMARY_KEYS.items():
        if key not in obj:
            raise InputFileError(path, f"damaged: the key is missing; {_RERUN}", field=key)
        if not isinstance(obj[key], kind) or isinstance(obj[key], bool):
            raise InputFileError(path, f"damaged: expected {_kind_name(kind)}, got "
                                       f"{type(obj[key]).__name__}; {_RERUN}", field=key)
    if not obj["parameters"]:
        raise InputFileError(path, f"damaged: no parameters; {_RERUN}", field="parameters")
    return obj


def _kind_name(kind) -> str:
    names = {dict: "an object", str: "a string", int: "an integer", list: "a list"}
    return "a number" if isinstance(kind, tuple) else names[kind]


def _load_json(path: Path) -> dict:
    """A JSON object from a file; a damaged file is named with the line where it breaks."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputFileError(path, f"cannot be read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise InputFileError(path, "damaged: not UTF-8 text") from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        what = "empty" if not text.strip() else f"not valid JSON ({exc.msg})"
        raise InputFileError(path, f"damaged: {what}; the file may be truncated",
                             line=exc.lineno if text.strip() else None) from None
    if not isinstance(obj, dict):
        raise InputFileError(path, f"damaged: expected a JSON object, got "
                                   f"{type(obj).__name__}")
    return obj


def _parameter_summaries(path: Path, parameters: dict) -> tuple[ParameterSummary, ...]:
    out = []
    for name, p in parameters.items():
        try:
            fields: dict[str, Any] = {k: (tuple(v) if k in ("ci90", "modes") else v)
                                      for k, v in p.items() if k != "paper_form"}
            out.append(ParameterSummary(**fields))
        except (TypeError, AttributeError) as exc:
            raise InputFileError(path, f"damaged: {exc}; {_RERUN}",
                                 field=f"parameters.{name}") from None
    return tuple(out)


def _check_grid(path: Path) -> None:
    if not path.exists():
        return
    try:
        with open(path, "rb") as fh, np.load(fh) as z:  # our handle: closed even on failure
            missing = {"density", "centres_0"} - set(z.files)
    except Exception as exc:  # any reader failure means a damaged file; name it
        raise InputFileError(path, f"damaged: cannot be read ({_short(exc)}); {_RERUN}") \
            from None
    if missing:
        raise InputFileError(path, f"damaged: no {', '.join(sorted(missing))}; {_RERUN}")


def _short(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 160 else text[:157] + "..."


def load_run_propagation(folder: str | Path):
    """The propagation saved in a run folder, or None if it has none (either file missing:
    the caller computes it again).

    Raises:
        InputFileError: one of the two files is damaged; the message names it.
    """
    from .propagation import load_propagation

    folder = Path(folder)
    files = [folder / "propagation.json", folder / "propagation.npz"]
    if not all(p.is_file() for p in files):
        return None
    remedy = ("delete propagation.json and propagation.npz and run `bouncebayes report` again "
              "to compute them")
    keys = ("posterior_predictive_match", "contact_time_modes_s", "n_failed", "failures",
            "seed", "notes")
    summary = _load_json(files[0])
    for key in keys:
        if key not in summary:
            raise InputFileError(files[0], f"damaged: the key is missing; {remedy}", field=key)
    if not zipfile.is_zipfile(files[1]):
        raise InputFileError(files[1], f"damaged: not a NumPy archive (truncated?); {remedy}")
    try:
        return load_propagation(folder)
    except Exception as exc:  # any reader failure means a damaged file; name it
        raise InputFileError(files[1], f"damaged: cannot be read ({_short(exc)}); {remedy}") \
            from None


def load_truth(folder: str | Path) -> dict | None:
    """Population values of a synthetic campaign, if the run folder holds its truth.json."""
    path = Path(folder) / TRUTH_FILE
    if not path.is_file():
        return None
    population = _load_json(path).get("population")
    if population is not None and not (isinstance(population, dict) and all(
            isinstance(v, int | float) for v in population.values())):
        raise InputFileError(path, "damaged: expected numbers by parameter name",
                             field="population")
    return population


def figure_formats(formats) -> tuple[str, ...]:
    """The figure file formats to write: PNG always (the report embeds it), then the others
    requested, each once; raises ValueError for a format that cannot be written."""
    from .plots import FIGURE_FORMATS

    allowed = tuple(f[1:] for f in FIGURE_FORMATS)
    if isinstance(formats, str):
        formats = (formats,)
    out = ["png"]
    for f in formats:
        name = str(f).lower().lstrip(".")
        if name not in allowed:
            raise ValueError(f"figure format {f!r} is not one of {', '.join(allowed)}")
        if name not in out:
            out.append(name)
    return tuple(out)


def figure_makers(result: InferenceResult, prop, folder: str | Path,
                  truth: dict | None = None) -> dict:
    """The function drawing each figure of the run, by key (a function may return None)."""
    from . import plots

    grid = Path(folder) / "grid.npz"
    density = plots.measured_density(result)
    population = {"population": lambda: plots.plot_population(result, truth)} \
        if result.population is not None else {}
    return {
        "data": lambda: plots.plot_data(density),
        "joint_posterior": lambda: plots.plot_joint_posterior(
            result, grid if grid.is_file() else None, truth),
        "marginals": lambda: plots.plot_marginals(result, truth),
        **population,
        "trajectories": lambda: plots.plot_trajectories(prop, result.experiment.ball.radius),
        "predictive": lambda: plots.plot_predictive(prop, density),
        "forces": lambda: plots.plot_forces(prop),
        "contact_time": lambda: plots.plot_contact_time(prop),
        "residuals": lambda: _residual_figure(result),
        "derived": lambda: _derived_figure(folder),
        "diagnostics": lambda: plots.plot_diagnostics(result),
    }


def _derived_figure(folder: str | Path):
    """The DEM-ready quantities' bands, where the run folder has derived.json."""
    from . import plots
    from .propagation import load_derived

    derived = load_derived(folder)
    return None if derived is None else plots.plot_derived(derived)


def _derived_section(folder: str | Path) -> list[str]:
    """The DEM-ready numbers with their definitions and where they transfer (derived.json)."""
    from .propagation import load_derived

    d = load_derived(folder)
    if d is None:
        return []
    rows = [[name.replace("_", " "), q["unit"] or "-", f"{q['median']:.4g}",
             f"[{q['ci90'][0]:.4g}, {q['ci90'][1]:.4g}]" if q["ci90"][0] < q["ci90"][1]
             else "none: set by fixed values of the experiment file", q["definition"]]
            for name, q in d["quantities"].items()
            if "grid" not in q and q.get("median") is not None]
    curves = ", ".join(f"{n.replace('_', ' ')} against {q['grid_name'].replace('_', ' ')}"
                       for n, q in d["quantities"].items() if "grid" in q)
    transfer = next(iter(d["quantities"].values()))["transfer"]
    cautions = "".join(f"<p><b>Caution:</b> {html.escape(c)}.</p>" for c in d["cautions"])
    return ["<h2>DEM-ready quantities</h2>",
            f"<p>What a simulation code takes, from {d['n_draws']} posterior draws "
            f"(<code>derived.json</code>; {html.escape(d['conditions'])}; reference speed "
            f"{d['reference_speed_m_s']:.3g} m/s). Curves in <code>derived.json</code> and the "
            f"figure: {html.escape(curves)}.</p>", cautions,
            _table(rows, ["quantity", "unit", "median", "90 % interval", "definition"]),
            f"<p><b>Where these transfer.</b> Every number {html.escape(transfer)}. The "
            f"friction coefficient holds for this pair of materials and their finish.</p>"]


def _residual_figure(result: InferenceResult):
    """The adequacy check's residuals, where the run has one."""
    from . import plots

    res = plots.posterior_residuals(result)
    return None if res is None else plots.plot_residuals(res)


def make_figures(result: InferenceResult, prop, folder: str | Path,
                 truth: dict | None = None, *,
                 formats=DEFAULT_FORMATS, progress: bool = False,
                 workers: int | None = None) -> list[tuple[str, Path]]:
    """Draw every figure under ``folder/figures`` as PNG and the other ``formats`` asked for
    (``"svg"``, ``"pdf"``); returns (key, PNG path) in report order. Files of a figure in
    formats not asked for this time are removed, so that none is left from an earlier run.
    ``progress``: a progress bar over the figures. ``workers``: processes that render the
    figures (:func:`bouncebayes.plots.save_figures`; default: one per core, up to four)."""
    from tqdm.auto import tqdm

    from .plots import FIGURE_FORMATS, save_figures

    fmts = figure_formats(formats)
    out = Path(folder) / "figures"
    written, files = [], []
    makers = figure_makers(result, prop, folder, truth)
    for key, draw in tqdm(makers.items(), total=len(makers), desc="figures",
                          disable=not progress, leave=False, unit="figure"):
        fig = draw()
        if fig is None:
            continue
        files.append((fig, [out / f"{key}.{fmt}" for fmt in fmts]))
        for stale in (out / f"{key}{s}" for s in FIGURE_FORMATS if s[1:] not in fmts):
            stale.unlink(missing_ok=True)
        written.append((key, out / f"{key}.png"))
    save_figures(files, workers)
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


def _result_section(result: InferenceResult, truth: dict | None) -> list[str]:
    params = [[p.name, p.unit or "-", f"{p.mean:.5g}",
               "-" if p.misfit else f"{p.sd:.3g}",
               "none (misfit)" if p.misfit else f"[{p.ci90[0]:.5g}, {p.ci90[1]:.5g}]",
               p.paper_form(),
               "-" if p.r_hat is None else f"{p.r_hat:.3f}",
               "-" if p.ess_bulk is None else f"{p.ess_bulk:.0f}",
               "yes" if p.identifiable else "no"]
              + ([f"{truth[p.name]:g}" if truth and p.name in truth else "-"] if truth else [])
              for p in result.parameters]
    header = ["parameter", "unit", "mean", "sd", "90 % interval", "result", "R-hat",
              "ESS (bulk)", "identified"] + (["true value"] if truth else [])
    verdict = result.adequacy.verdict if result.adequacy is not None else None
    warns = "".join(f"<li>{html.escape(w)}</li>" for w in result.warnings
                    if w != verdict) or \
        "<li>none: chains agree (R-hat &le; 1.01), enough effective draws (ESS &ge; 400), one " \
        "mode, nothing piled against a prior bound</li>"
    r = result.regimes
    return ["<h2>Result</h2>", _table(params, header),
            f"<p>Friction regime of the posterior's simulated bounces: "
            f"{100 * (1 - r['share_rolling']):.0f} % slide throughout the contact, "
            f"{100 * r['share_rolling']:.0f} % leave rolling (where a bounce leaves rolling its "
            f"rebound does not depend on mu).</p>", *_adequacy_section(result),
            "<h2>Diagnostics and warnings</h2>", f"<ul>{warns}</ul>"]


def _population_section(result: InferenceResult) -> list[str]:
    """The population likelihood's answer in words: how each parameter varies from contact to
    contact (or only a bound), and how much the population moved each bounce's estimate."""
    pop = result.population
    if pop is None:
        return []
    rec = pop.record
    rows = []
    for name in pop.names:
        e, b = rec["predictive"][name], rec["bounces"][name]
        shrink = b["median_shrinkage"]
        rows.append([name, e["unit"] or "-",
                     "bound only" if "bound" in e else
                     f"[{e['quantiles']['5%']:.4g}, {e['quantiles']['95%']:.4g}]",
                     f"{b['median_sd_alone']:.3g}", f"{b['median_sd_with_population']:.3g}",
                     "-" if shrink is None else f"{shrink:.2f}"])
    items = "".join(f"<li>{html.escape(w)}</li>" for w in rec["statements"])
    return ["<h2>Population of the bounces</h2>",
            f"<p>Every bounce has its own parameters, drawn from a {html.escape(rec['family'])}"
            f" population truncated to the prior; the table above gives the posterior of its "
            f"means and spreads (<code>&lt;parameter&gt;_mean</code>, "
            f"<code>&lt;parameter&gt;_sd</code>).</p><ul>{items}</ul>",
            _table(rows, ["parameter", "unit", "90 % of new bounces",
                          "median sd of a bounce on its own",
                          "median sd with the population", "median shrinkage"]),
            "<p>Shrinkage: the share of the way from a bounce's own estimate to the population "
            "mean that the population moved it (0: not at all, 1: all the way). New bounces "
            "for a simulation are drawn from the population predictive "
            "(<code>posterior.nc</code>, group <code>population_predictive</code>).</p>"]


def _adequacy_section(result: InferenceResult) -> list[str]:
    """Does the model reproduce the data: the verdict, the checks' numbers, the discrepancy."""
    a = result.adequacy
    if a is None:
        return ["<h2>Does the model reproduce the data?</h2>", "<p>Not checked: this run "
                "folder was written before the adequacy check existed; rerun the inference."
                "</p>"]
    d = a.to_dict()
    rows = [["residuals: chi-square per degree of freedom",
             f"{d['chi2_per_dof']:.3g} over {a.dof} (p = {a.p_value:.2g})"
             if d["chi2_per_dof"] is not None else "-"],
            ["rms standardised residual (about 1 expected)",
             ", ".join(f"{k.replace('_', ' ')} {v:.3g}" for k, v in a.rms.items())],
            ["worst trial's predictive p-value, corrected for the trials",
             f"{a.worst_p_value:.2g}"]]
    rows += [[f"{k.replace('_', ' ')}: KS p-value, Hellinger distance",
              f"{v['ks_p_value']:.2g}, {v['hellinger']:.3f}"]
             for k, v in a.distribution.items() if v.get("ks_p_value") is not None]
    out = ["<h2>Does the model reproduce the data?</h2>",
           f"<p><b>{'Yes' if a.adequate else 'No'}.</b> {html.escape(a.verdict)}</p>",
           _table(rows, ["check (each at level 0.0033; docs/likelihoods.md §10)", "value"])]
    return out + _discrepancy_note(result)


def _discrepancy_note(result: InferenceResult) -> list[str]:
    """The inferred model discrepancy, and the fit without it where ``auto`` added it."""
    out = []
    if result.discrepancy != "none":
        sizes = [f"{p.name.replace('discrepancy_', 'rebound ')} {p.median:.3g} {p.unit}"
                 for p in result.parameters if p.name.startswith("discrepancy_")]
        out.append(f"<p>Inferred model discrepancy ({html.escape(result.discrepancy)}; "
                   f"posterior medians): {', '.join(sizes)}. The intervals above include it."
                   f"</p>")
    if result.first_fit is not None:
        first = result.first_fit["adequacy"]
        out.append(f"<p>Without a discrepancy term the fit failed the check: "
                   f"{html.escape(first['verdict'])}</p>")
    return out


def _experiment_section(result: InferenceResult) -> list[str]:
    e, t = result.experiment, result.trials
    s = result.summary()
    return [
        "<h2>The experiment</h2>",
        _table([["ball", f"diameter {1e3 * e.ball.diameter:.4g} mm, mass "
                         f"{1e3 * e.ball.mass:.4g} g, E = {e.ball.youngs_modulus:.4g} Pa, "
                         f"Poisson ratio {e.ball.poisson_ratio:g}, I = "
                         f"{e.ball.inertia_factor:g} m r^2"],
                ["surface", f"inclination {e.inclination:g} deg"],
                ["nominal incidence", f"{e.incidence.speed:g} m/s at {e.incidence.angle:g} deg "
                                      f"from the normal, spin {e.incidence.spin:g} rad/s"],
                ["normal force law", e.normal_law],
                ["tangential contact", {"none": "rigid (Coulomb stick/slip, no spring)",
                                        "mindlin": "Mindlin spring capped by Coulomb friction",
                                        "linear": "linear spring capped by Coulomb friction"}[
                                            e.tangential]],
                ["priors", "; ".join(f"{n}: {p.describe()}" for n, p in e.priors.items())]]),
        "<h2>The data</h2>",
        f"<p>{t.n} bounces from <code>{html.escape(Path(t.source).name)}</code>; rebound "
        f"speed {np.mean(t.rebound_speed):.4g} &plusmn; {np.std(t.rebound_speed, ddof=1):.2g} "
        f"m/s, rebound angle {np.mean(t.rebound_angle):.4g} &plusmn; "
        f"{np.std(t.rebound_angle, ddof=1):.2g} deg (mean &plusmn; sd).</p>",
        *_scale_note(t),
        "<h2>Method</h2>",
        f"<p><b>Likelihood {result.likelihood}</b>: {html.escape(MEANINGS[result.likelihood])}"
        f"</p><p><b>Sampler {result.sampler}</b>: "
        f"{html.escape(SAMPLER_MEANINGS[result.sampler])}; {s['n_draws']} draws.</p>"]


def _scale_note(trials) -> list[str]:
    """The kinematics' check of the length scale against the flights' fall, where the trial
    table was made from trajectories (its provenance holds it)."""
    record = ((trials.provenance or {}).get("kinematics") or {}).get("gravity") or {}
    if "summary" not in record:
        return []
    text = html.escape(record["summary"].removeprefix("gravity: ")).replace(
        "\n  warning:", "<br><b>Warning:</b>").replace("+-", "&plusmn;")
    applied = ("" if "applied_words" not in record else
               f" The lengths were corrected by it: {html.escape(record['applied_words'])}.")
    return [f"<p><b>Length scale</b> (the free flights' fall against g): {text}.{applied}</p>"]


def _tracking_section(folder: str | Path) -> list[str]:
    """Where the run tracked videos: one row per video from its tracking record (frames, the
    ball's radius, the scale with its stated SD, what the flights' fall says, the record's
    warnings and notes in words: lost or repeated frames, a lens that bends lines, a faint
    surface edge, the camera's motion, the colour channel) and the first
    video's overlay image."""
    records = sorted((Path(folder) / "trajectories").glob("*.track.json"))
    if not records:
        return []
    rows = []
    for path in records:
        r = json.loads(path.read_text(encoding="utf-8"))
        cal, fall, q = r["calibration"], r.get("gravity"), r["quality"]
        sd = cal.get("relative_sd")
        moved = r["tracker"].get("camera_shift_max_px") or 0.0
        said = [w for w in (r["ball"].get("warning"), r.get("compression_warning"),
                            r.get("tone_curve_warning"), (r.get("timing") or {}).get("warning"),
                            (r.get("lens") or {}).get("warning"),
                            (r.get("surface") or {}).get("warning"), r["ball"].get("depth_warning"),
                            None if fall is None or fall["agrees"] else fall["summary"],
                            f"the camera moved by up to {moved:.2g} px (the frames moved back)"
                            if moved else None, r.get("channel_note"),
                            (r["ball"].get("cast_shadow") or {}).get("note")) if w]
        rows.append([path.name.removesuffix(".track.json"),
                     f"{q['found']} of {r['frames']} ({q['flagged']} flagged)",
                     f"{r['ball']['radius_px']:.3g}",
                     f"{1e3 * cal['metres_per_pixel']:.4g}"
                     + ("" if sd is None else f" ± {100 * sd:.2g} %") + f" ({cal['source']})",
                     "-" if fall is None else f"{100 * (fall['scale'] - 1):+.2f} ± "
                                              f"{100 * fall['scale_sd']:.2f} %",
                     "; ".join(said) or "none"])
    header = ["video", "frames with the ball", "radius (px)", "scale (mm/px)",
              "lengths off by (the fall)", "warnings and notes"]
    overlay = Path(folder) / "tracking" / f"{rows[0][0]}.overlay.png"
    figure = ([f"<figure>{_img(overlay, 'tracked positions over the frames')}<figcaption>"
               f"{html.escape(rows[0][0])}: every tracked centre over a superposition of the "
               "frames (flagged frames in magenta), the ball's edge, the surface line and a "
               "scale bar.</figcaption></figure>"] if overlay.is_file() else [])
    return ["<h2>Tracking</h2>",
            f"<p>{len(rows)} videos tracked (each record: <code>trajectories/"
            "&lt;video&gt;.track.json</code>); the scale from the ball's diameter and its "
            "edge, with its stated uncertainty; \"lengths off by\": what the video's own "
            "free flights' fall against standard gravity says of that scale "
            "(docs/tracking.md §5).</p>", _table(rows, header), *figure]


def _prediction_section(prop_summary: dict) -> list[str]:
    at = prop_summary["at_nominal_incidence"]
    pred_rows = [[k.replace("_", " "), v["unit"], f"{v['mean']:.4g}", f"{v['sd']:.3g}",
                  f"[{v['ci90'][0]:.4g}, {v['ci90'][1]:.4g}]"]
                 for k, v in at.items() if isinstance(v, dict)]
    match = prop_summary["posterior_predictive_match"]
    return ["<h2>What the posterior predicts</h2>",
            f"<p>{html.escape(match['verdict'])}</p>",
            _table(pred_rows, ["quantity (nominal incidence)", "unit", "mean", "sd",
                               "90 % interval"]),
            "<p>Contact time: "
            + (f"the distribution is multimodal ({len(prop_summary['contact_time_modes_s'])} "
               "modes)." if prop_summary["contact_time_multimodal"] else "one mode.")
            + f" Failed simulations: {prop_summary['n_failed']}.</p>"]


def _figures_section(figures) -> list[str]:
    out = ["<h2>Figures</h2>", f"<p>{html.escape(FIGURES_NOTE)}</p>"]
    for i, (key, path) in enumerate(figures, start=1):
        out.append(f"<figure>{_img(path, CAPTIONS[key])}<figcaption>Figure {i}. "
                   f"{html.escape(CAPTIONS[key])}</figcaption></figure>")
    return out


def _provenance_section(result: InferenceResult, provenance: dict | None) -> list[str]:
    e, t = result.experiment, result.trials
    if provenance is None:
        provenance = make_provenance(inputs={"experiment": e.source, "trials": t.source},
                                     seed=result.seed, config=result.config)
    return ["<h2>Provenance</h2>", _table(provenance_rows(provenance)),
        "<h3>Experiment file</h3>",
        f"<pre>{html.escape(Path(e.source).read_text(encoding='utf-8'))}</pre>"]


def _subtitle(result: InferenceResult) -> str:
    """The experiment file's description and what this report fitted: the experiment file's
    words are the same whatever trial table it is run on, so the count and table are said."""
    t = result.trials
    fitted = f"This report: {t.n} trial{'s' if t.n != 1 else ''} from {Path(t.source).name}."
    desc = result.experiment.description.strip()
    if desc and desc[-1] not in ".!?":
        desc += "."
    return f"{desc} {fitted}" if desc else fitted


def render_report(result: InferenceResult, prop_summary: dict, figures, folder: str | Path,
                  truth: dict | None = None, provenance: dict | None = None) -> Path:
    """Write ``folder/report.html``: one file, figures embedded, opens offline. ``provenance``:
    the run's record (:func:`bouncebayes._provenance.provenance`), made here if not given."""
    e = result.experiment
    sections = [f"<h1>bouncebayes report: {html.escape(e.name)}</h1>",
                f"<p class='meta'>{html.escape(_subtitle(result))}</p>",
                *_result_section(result, truth), *_population_section(result),
                *_experiment_section(result),
                *_tracking_section(folder),
                *_prediction_section(prop_summary), *_derived_section(folder),
                *_figures_section(figures),
                *_provenance_section(result, provenance)]
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
