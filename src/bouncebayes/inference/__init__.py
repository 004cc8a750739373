"""Bayesian calibration: likelihoods, samplers, diagnostics and the posterior summary.

The entry point is :func:`infer`; each sampler has its own configuration (:class:`MHConfig`,
:class:`EnsembleConfig`, :class:`GridConfig`) and is also available as a pure ``(init, step)``
pair (``mh_init``/``mh_step``, ``ensemble_init``/``ensemble_step``) with typed state records.
"""

from ._adequacy import ALPHA as ADEQUACY_LEVEL
from ._adequacy import Adequacy as Adequacy
from ._adequacy import assess as assess_adequacy
from ._adequacy import distribution_check as distribution_check
from ._adequacy import failures as adequacy_failures
from ._adequacy import hellinger as hellinger
from ._config import CONFIGS as SAMPLER_CONFIGS
from ._config import SAMPLERS as SAMPLERS
from ._config import EnsembleConfig as EnsembleConfig
from ._config import GridConfig as GridConfig
from ._config import MHConfig as MHConfig
from ._config import default_sampler as default_sampler
from ._config import sampler_config as sampler_config
from ._config import resolve_sampler as resolve_sampler
from ._draws import Draws as Draws
from ._ensemble import EnsembleInfo as EnsembleInfo
from ._ensemble import EnsembleRun as EnsembleRun
from ._ensemble import EnsembleState as EnsembleState
from ._ensemble import init as ensemble_init
from ._ensemble import step as ensemble_step
from ._forward import Forward as Forward
from ._grid import GridDensity as GridDensity
from ._grid import GridRun as GridRun
from ._infer import SAMPLER_MEANINGS as SAMPLER_MEANINGS
from ._infer import InferenceResult as InferenceResult
from ._infer import format_table as format_table
from ._infer import infer as infer
from ._infer import load_inference as load_inference
from ._infer import plan_memory as plan_memory
from ._likelihood import DISCREPANCIES as DISCREPANCIES
from ._likelihood import DISCREPANCY_MEANINGS as DISCREPANCY_MEANINGS
from ._likelihood import LIKELIHOODS as LIKELIHOODS
from ._likelihood import STUDENT_T_DOF as STUDENT_T_DOF
from ._likelihood import incidence_variance as incidence_variance
from ._likelihood import MEANINGS as MEANINGS
from ._likelihood import noise_priors as noise_priors
from ._memory import BYTES_PER_BOUNCE as BYTES_PER_BOUNCE
from ._memory import DEFAULT_MEMORY_BUDGET as DEFAULT_MEMORY_BUDGET
from ._memory import MemoryBudgetError as MemoryBudgetError
from ._mh import MHInfo as MHInfo
from ._mh import MHRun as MHRun
from ._mh import MHState as MHState
from ._mh import init as mh_init
from ._mh import step as mh_step
from ._outputs import inference_data as inference_data
from ._outputs import write_outputs as write_outputs
from ._pass import Replicates as Replicates
from ._population import FAMILIES as POPULATION_FAMILIES
from ._population import binned_density as population_density
from ._population import hyper_names as population_hyper_names
from ._posterior import LogPosterior as LogPosterior
from ._summary import ParameterSummary as ParameterSummary
from ._summary import marginal_modes as marginal_modes

__all__ = [
    "ADEQUACY_LEVEL", "Adequacy", "DISCREPANCIES", "STUDENT_T_DOF", "DISCREPANCY_MEANINGS", "adequacy_failures", "assess_adequacy",
    "distribution_check", "hellinger", "incidence_variance",
    "BYTES_PER_BOUNCE", "DEFAULT_MEMORY_BUDGET", "LIKELIHOODS", "MEANINGS", "SAMPLERS", "SAMPLER_CONFIGS", "SAMPLER_MEANINGS", "Draws",
    "EnsembleConfig", "EnsembleInfo", "EnsembleRun", "EnsembleState", "Forward", "GridConfig",
    "GridDensity", "GridRun", "InferenceResult", "LogPosterior", "MHConfig", "MHInfo", "MHRun",
    "MHState", "MemoryBudgetError", "POPULATION_FAMILIES", "population_density",
    "population_hyper_names", "ParameterSummary", "Replicates",
    "default_sampler", "ensemble_init", "ensemble_step", "format_table", "infer", "inference_data",
    "load_inference", "marginal_modes", "plan_memory", "mh_init", "mh_step", "noise_priors",
    "resolve_sampler", "sampler_config", "write_outputs",
]
