"""Bayesian calibration: likelihoods, samplers, diagnostics and the posterior summary."""

from ._forward import Forward as Forward
from ._infer import InferenceResult as InferenceResult
from ._infer import format_table as format_table
from ._infer import infer as infer
from ._infer import inference_data as inference_data
from ._infer import write_outputs as write_outputs
from ._likelihood import LIKELIHOODS as LIKELIHOODS
from ._likelihood import MEANINGS as MEANINGS
from ._posterior import SAMPLERS as SAMPLERS
from ._posterior import LogPosterior as LogPosterior
from ._posterior import SamplerConfig as SamplerConfig

__all__ = ["Forward", "InferenceResult", "LIKELIHOODS", "LogPosterior", "MEANINGS", "SAMPLERS",
           "SamplerConfig", "format_table", "infer", "inference_data", "write_outputs"]
