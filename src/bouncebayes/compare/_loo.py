"""PSIS-LOO (Vehtari, Gelman & Gabry 2017) of each model from ArviZ, and ArviZ's comparison."""

from __future__ import annotations

import warnings
from typing import Any

GOOD_K = 0.7  #: Pareto k above which an observation's importance sampling is unreliable


def loo_of(result):
    """ArviZ's PSIS-LOO (``arviz_stats.loo``) on the result's per-trial log-likelihood (the
    ``log_likelihood`` group of posterior.nc).

    Without a tangential spring a bounce that leaves rolling does so whatever ``mu``
    (docs/model.md §7.3), so a trial's log-likelihood can be the same in the many draws that
    roll: the largest importance ratios are then all equal, Pareto smoothing has no tail to fit
    and ArviZ stops ("All tail values are the same"). Such a trial has no heavy tail to smooth,
    and gets its raw self-normalised importance weights (Pareto k reported as 0); the others
    get ArviZ's own."""
    from ..inference import inference_data

    if result.likelihood not in ("gaussian", "population") or result.log_likelihood is None:
        raise ValueError(f"leave-one-out cross-validation needs a log-likelihood per trial "
                         f"(the gaussian or population likelihood); this result's is "
                         f"{result.likelihood}")
    tree = inference_data(result)
    try:
        return _loo(tree)
    except (ValueError, RuntimeWarning) as exc:
        if isinstance(exc, ValueError) and "tail values are the same" not in str(exc):
            raise
    weights, k = _weights(tree)
    return _loo(tree, log_weights=weights, pareto_k=k)


def _loo(tree, **weights):
    """``arviz_stats.loo``; its warning about large Pareto k is said in comparison.json and
    the report instead (``n_pareto_k_bad``), a flat tail's division by zero raised."""
    import arviz_stats

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Estimated shape parameter of Pareto")
        warnings.simplefilter("error", RuntimeWarning)
        return arviz_stats.loo(tree, pointwise=True, var_name="rebound", **weights)


def _weights(tree):
    """Per trial: ArviZ's Pareto-smoothed log weights, or the raw ones where the tail is
    flat (see :func:`loo_of`)."""
    from scipy.special import logsumexp

    ll = tree["log_likelihood"]["rebound"].transpose("trial", "chain", "draw")
    r_eff = _r_eff(tree, ll.sizes["chain"] * ll.sizes["draw"])
    weights, k = ll.copy(), ll.isel(chain=0, draw=0).copy()
    for i in range(ll.sizes["trial"]):
        one = ll.isel(trial=[i])
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", RuntimeWarning)
                w, ki = one.azstats.psislw(r_eff=r_eff, dim=["chain", "draw"])
            weights.values[i], k.values[i] = w.values[0], float(ki.values[0])
        except (ValueError, RuntimeWarning):
            raw = -one.values[0]
            weights.values[i], k.values[i] = raw - logsumexp(raw), 0.0
    return weights, k


def _r_eff(tree, n: int) -> float:
    """Relative efficiency of the draws, as ArviZ's loo takes it (1 for one chain)."""
    import numpy as np

    post = tree["posterior"]
    if post.sizes["chain"] == 1:
        return 1.0
    ess = post.to_dataset().azstats.ess(method="mean")
    return float(np.hstack([ess[v].values.ravel() for v in ess.data_vars]).mean() / n)


def loo_record(elpd) -> dict[str, Any]:
    """The numbers of comparison.json from an ``ELPDData``."""
    k = elpd.pareto_k.values.ravel()
    return {"elpd_loo": float(elpd.elpd), "elpd_loo_se": float(elpd.se), "p_loo": float(elpd.p),
            "pareto_k_max": float(k.max()), "n_pareto_k_bad": int((k > GOOD_K).sum()),
            "loo_reliable": bool((k <= GOOD_K).all())}


def loo_compare(elpds: dict) -> dict[str, dict[str, Any]]:
    """``arviz_stats.compare`` of the models' ``ELPDData``: rank, elpd difference to the best
    and its standard error, stacking weight."""
    import arviz_stats

    with warnings.catch_warnings():  # pandas deprecates an argument ArviZ passes
        warnings.filterwarnings("ignore", message="The inplace keyword")
        table = arviz_stats.compare(elpds)
    return {str(name): {"rank": int(row["rank"]), "elpd_diff": float(row["elpd_diff"]),
                        "elpd_diff_se": float(row["dse"]), "weight": float(row["weight"])}
            for name, row in table.iterrows()}
