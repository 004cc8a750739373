"""The comparison's files: comparison.json, the figure, and one self-contained report.html."""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._io import write_json, write_text
from .._provenance import provenance_rows
from ._bands import prediction_bands

COMPARISON_FILE = "comparison.json"
FIGURE = "comparison"
CAPTION = ("Each candidate's rebound against the incidence angle: the median (line) and the 90 "
           "% band of its posterior (the uncertainty of its parameters, without measurement "
           "noise), simulated at the trials' median incident speed and spin; the measured "
           "trials with ±1 standard error. The tangential restitution u'/u of the trials is "
           "computed from their rebound speed and angle.")
SCALE_NOTE = ("Bayes factors B are read on Kass & Raftery's (1995) scale of 2 ln B: below 2 the "
              "data cannot tell the models apart, 2-6 positive, 6-10 strong, above 10 decisive "
              "(their 'very strong'). The evidence integrates each model's likelihood over its "
              "priors, so it also charges a model for prior volume the data do not use; "
              "PSIS-LOO (elpd_loo, the expected log predictive density of a left-out trial) "
              "judges predictions only. Pareto k above 0.7 marks trials where the LOO estimate "
              "is unreliable.")


def short_verdicts(models: dict[str, dict[str, Any]], verdict: dict[str, Any]) -> dict[str, str]:
    """A few words per model for the figure's legend."""
    best, out = verdict["ranking"][0], {}
    for name, m in models.items():
        bf = verdict["bayes_factors"].get(name)
        words = (("preferred" if verdict["preferred"] == name else "best, not decisively")
                 if bf is None else f"2 ln B = {bf['two_ln_b']:.3g} for {best} ({bf['words']})")
        out[name] = words + ("" if m["adequate"] else "; misfits")
    return out


def write_comparison(comparison, folder: str | Path, *, provenance: dict,
                     formats: Sequence[str] = ("png",), seed: int = 0,
                     run_reports: dict[str, str] | None = None) -> Path:
    """comparison.json, figures/comparison.png (and the other formats) and report.html in
    ``folder``; returns the report's path."""
    from ..plots import plot_comparison, save_figure
    from ..report import figure_formats

    folder = Path(folder)
    write_json(folder / COMPARISON_FILE, comparison.to_dict() | {"provenance": provenance})
    trials = next(iter(comparison.results.values())).trials
    bands = prediction_bands(comparison.results, seed=seed)
    fig = plot_comparison(bands, trials, short_verdicts(comparison.models, comparison.verdict))
    for fmt in figure_formats(formats):
        save_figure(fig, folder / "figures" / f"{FIGURE}.{fmt}")
    page = _page(comparison, folder / "figures" / f"{FIGURE}.png", provenance,
                 run_reports or {})
    return write_text(folder / "report.html", page)


def _table(rows: list[list[Any]], header: list[str]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _model_rows(comparison, run_reports: dict[str, str]) -> list[list[str]]:
    v, rows = comparison.verdict, []
    for name in v["ranking"]:
        m = comparison.models[name]
        bf = v["bayes_factors"].get(name)
        link = run_reports.get(name)
        rows.append([
            f"<b>{html.escape(name)}</b><br>{html.escape(m['description'])}",
            html.escape(f"{m['normal_law']}, tangential {m['tangential']}"),
            "<br>".join(html.escape(f"{p['result']} (prior {p['prior']})")
                        for p in m["parameters"].values()),
            html.escape(f"{m['log_evidence']:.4g} ± {m['log_evidence_se']:.2g}")
            + f"<br><small>{html.escape(m['evidence_method'])}</small>",
            "best" if bf is None else html.escape(f"{bf['two_ln_b']:.3g} ({bf['words']})"),
            html.escape(f"{m['elpd_loo']:.4g} ± {m['elpd_loo_se']:.2g} (p_loo "
                        f"{m['p_loo']:.2g}; max Pareto k {m['pareto_k_max']:.2f})"),
            "yes" if m["adequate"] else html.escape(
                f"no (chi-square per degree of freedom {m['chi2_per_dof']:.3g})"),
            f'<a href="{html.escape(link)}">report</a>' if link else "-"])
    return rows


def _page(comparison, figure: Path, provenance: dict, run_reports: dict[str, str]) -> str:
    from ..report import CSS

    v = comparison.verdict
    loo_rows = [[html.escape(n), str(r["rank"]), html.escape(f"{r['elpd_diff']:.3g}"),
                 html.escape(f"{r['elpd_diff_se']:.2g}"), html.escape(f"{r['weight']:.2f}")]
                for n, r in sorted(comparison.loo.items(), key=lambda kv: kv[1]["rank"])]
    trials = next(iter(comparison.results.values())).trials
    image = base64.b64encode(figure.read_bytes()).decode("ascii")
    s = comparison.settings
    sections = [
        "<h1>bouncebayes model comparison</h1>",
        f"<p class='meta'>{trials.n} trials from <code>{html.escape(Path(trials.source).name)}"
        f"</code>; {len(comparison.models)} candidate models.</p>",
        "<h2>Verdict</h2>", f"<p><b>{html.escape(v['text'])}</b></p>",
        "<h2>The candidates</h2>",
        _table(_model_rows(comparison, run_reports),
               ["model", "contact law", "parameters (90 %)", "log evidence (numerical se)",
                "2 ln B against the best", "elpd_loo (PSIS-LOO)", "reproduces the data?",
                "its run"]),
        f"<p>{html.escape(SCALE_NOTE)}</p>",
        "<h2>Leave-one-out comparison (ArviZ)</h2>",
        _table(loo_rows, ["model", "rank", "elpd difference to the best", "its se",
                          "stacking weight"]),
        "<h2>Settings</h2>",
        f"<p>Every model: likelihood {s['likelihood']}, model discrepancy {s['discrepancy']}, "
        f"seed {s['seed']}. Why: {html.escape(s['why'])}.</p>",
        "<h2>Figure</h2>",
        f"<figure><img src=\"data:image/png;base64,{image}\" alt=\"{html.escape(CAPTION)}\">"
        f"<figcaption>{html.escape(CAPTION)}</figcaption></figure>",
        "<h2>Provenance</h2>",
        "<table><tbody>" + "".join(f"<tr><td>{html.escape(str(a))}</td><td>"
                                   f"{html.escape(str(b))}</td></tr>"
                                   for a, b in provenance_rows(provenance)) + "</tbody></table>"]
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>bouncebayes: "
            f"model comparison</title><style>{CSS}</style></head><body>"
            + "\n".join(sections) + "</body></html>\n")
