"""Model comparison: candidate contact laws with their priors, judged on the same trials.

:func:`compare_models` infers every candidate of an experiment's [models] tables and compares
them (:class:`Comparison`: evidence by grid quadrature or nested sampling with its numerical
uncertainty, PSIS-LOO from ArviZ, the adequacy check, Bayes factors in words on Kass &
Raftery's scale, a verdict); :func:`compare_folder` is ``bouncebayes compare``: each candidate's
run folder, comparison.json, a figure and report.html (docs/comparison.md).
"""

from ._bands import prediction_bands as prediction_bands
from ._compare import EVIDENCE_METHODS as EVIDENCE_METHODS
from ._compare import FIXED_SETTINGS as FIXED_SETTINGS
from ._compare import GRID_POINTS as GRID_POINTS
from ._compare import Comparison as Comparison
from ._compare import Plan as Plan
from ._compare import compare_models as compare_models
from ._compare import compare_results as compare_results
from ._compare import plan_for as plan_for
from ._compare import select_candidates as select_candidates
from ._evidence import LIVE_POINTS as LIVE_POINTS
from ._evidence import Evidence as Evidence
from ._evidence import grid_evidence as grid_evidence
from ._evidence import nested_evidence as nested_evidence
from ._folder import CompareOutcome as CompareOutcome
from ._folder import compare_folder as compare_folder
from ._loo import loo_of as loo_of
from ._report import COMPARISON_FILE as COMPARISON_FILE
from ._report import write_comparison as write_comparison
from ._verdict import SCALE as KASS_RAFTERY_SCALE
from ._verdict import bayes_factors as bayes_factors
from ._verdict import evidence_words as evidence_words
from ._verdict import verdict as verdict

__all__ = ["COMPARISON_FILE", "EVIDENCE_METHODS", "FIXED_SETTINGS", "GRID_POINTS",
           "KASS_RAFTERY_SCALE", "LIVE_POINTS", "CompareOutcome", "Comparison", "Evidence",
           "Plan", "bayes_factors", "compare_folder", "compare_models", "compare_results",
           "evidence_words", "grid_evidence", "loo_of", "nested_evidence", "plan_for",
           "prediction_bands", "select_candidates", "verdict", "write_comparison"]
