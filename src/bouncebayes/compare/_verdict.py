"""Bayes factors in words (Kass & Raftery 1995) and the comparison's verdict."""

from __future__ import annotations

import math
from typing import Any

#: Kass & Raftery (1995) on 2 ln B: 0-2 "not worth more than a bare mention" (here: cannot
#: tell apart), 2-6 positive, 6-10 strong, above 10 very strong (here: decisive, as Jeffreys'
#: scale calls a factor above 100)
SCALE = ((2.0, "cannot tell apart"), (6.0, "positive"), (10.0, "strong"),
         (math.inf, "decisive"))
LOO_SMALL = 4.0  #: an elpd difference below this is small whatever its se (Sivula et al. 2020)


def evidence_words(two_ln_b: float) -> str:
    """The Kass & Raftery category of ``2 ln B`` (B >= 1: the better model over the other)."""
    return next(words for top, words in SCALE if abs(two_ln_b) < top)


def bayes_factors(models: dict[str, dict[str, Any]], best: str) -> dict[str, dict[str, Any]]:
    """The ln B of the best model over each other, with its numerical uncertainty and words; a
    difference within twice that uncertainty cannot be told apart whatever its size."""
    out = {}
    top = models[best]
    for name, m in models.items():
        if name == best:
            continue
        ln_b = top["log_evidence"] - m["log_evidence"]
        se = math.hypot(top["log_evidence_se"], m["log_evidence_se"])
        words = evidence_words(2 * ln_b)
        if words != SCALE[0][1] and not ln_b > 2 * se:
            words = f"{SCALE[0][1]} (within the evidence's numerical uncertainty)"
        out[name] = {"ln_bayes_factor": ln_b, "ln_bayes_factor_se": se, "two_ln_b": 2 * ln_b,
                     "words": words}
    return out


def verdict(models: dict[str, dict[str, Any]], loo: dict[str, dict[str, Any]]
            ) -> dict[str, Any]:
    """Which model the data prefer, how strongly, whether LOO agrees, and which models do not
    reproduce the data at all; ``text`` says it in words."""
    ranking = sorted(models, key=lambda n: -models[n]["log_evidence"])
    best = ranking[0]
    factors = bayes_factors(models, best)
    runner = ranking[1]
    clear = not factors[runner]["words"].startswith(SCALE[0][1])
    loo_best = min(loo, key=lambda n: loo[n]["rank"])
    loo_runner = next(n for n in sorted(loo, key=lambda n: loo[n]["rank"]) if n != loo_best)
    d, dse = loo[loo_runner]["elpd_diff"], loo[loo_runner]["elpd_diff_se"]
    loo_clear = d > LOO_SMALL and d > 2 * dse
    misfits = [n for n in ranking if not models[n]["adequate"]]
    parts = [_evidence_text(best, factors, clear), _loo_text(loo_best, loo_runner, d, dse,
                                                             loo_clear, best, clear)]
    parts += _adequacy_text(misfits, ranking, best)
    return {"preferred": best if clear else None, "ranking": ranking,
            "strength": factors[runner]["words"], "bayes_factors": factors,
            "loo_preferred": loo_best if loo_clear else None,
            "loo_elpd_diff": d, "loo_elpd_diff_se": dse,
            "misfitting": misfits, "text": " ".join(parts)}


def _evidence_text(best: str, factors: dict, clear: bool) -> str:
    others = "; ".join(f"over `{n}` 2 ln B = {f['two_ln_b']:.3g} ± {2 * f['ln_bayes_factor_se']:.2g}"
                       f" ({f['words']})" for n, f in factors.items())
    if not clear:
        runner = next(iter(factors))
        return (f"The evidence cannot tell `{best}` and `{runner}` apart ({others}): these "
                f"data do not choose between them.")
    return f"The evidence prefers `{best}` ({others}; Kass & Raftery's scale)."


def _loo_text(loo_best: str, runner: str, d: float, dse: float, clear: bool, best: str,
              evidence_clear: bool) -> str:
    size = f"elpd difference {d:.3g} ± {dse:.2g}"
    if not clear and d > LOO_SMALL:
        return (f"Leave-one-out cross-validation leans towards `{loo_best}` ({size} over "
                f"`{runner}`), but the difference comes from few trials and its standard error "
                f"is as large: on its own it does not decide.")
    if not clear:
        return (f"Leave-one-out cross-validation cannot tell `{loo_best}` and `{runner}` apart "
                f"({size}).")
    agree = ("agrees" if loo_best == best or not evidence_clear else
             f"disagrees: it prefers `{loo_best}`, which predicts left-out trials better, "
             f"while the evidence also weighs the priors")
    return f"Leave-one-out cross-validation {agree} ({size} over `{runner}`)."


def _adequacy_text(misfits: list[str], ranking: list[str], best: str) -> list[str]:
    if not misfits:
        return ["Every model reproduces the data within their stated errors."]
    names = ", ".join(f"`{n}`" for n in misfits)
    out = [f"{names} {'does' if len(misfits) == 1 else 'do'} not reproduce the data (the "
           f"adequacy check failed): a Bayes factor against a model that misfits says only "
           f"that it misfits more."]
    if len(misfits) == len(ranking):
        out.append("No candidate reproduces the data: the ranking is among wrong models; try "
                   "another contact law, or check the stated errors.")
    elif best in misfits:
        out.append(f"The best-supported model, `{best}`, is among them.")
    return out
