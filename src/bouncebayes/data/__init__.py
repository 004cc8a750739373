"""Experiment description (TOML), priors, and trial tables (CSV)."""

from ._experiment import Experiment as Experiment
from ._experiment import Incidence as Incidence
from ._experiment import load_experiment as load_experiment
from ._experiment import parse_experiment as parse_experiment
from ._priors import LogNormal as LogNormal
from ._priors import LogUniform as LogUniform
from ._priors import Normal as Normal
from ._priors import Prior as Prior
from ._priors import Uniform as Uniform
from ._schema import PARAMETERS as PARAMETERS
from ._schema import SECTIONS as SECTIONS
from ._trials import Trials as Trials
from ._trials import load_trials as load_trials
from ._trials import make_trials as make_trials
from ._trials import write_trials as write_trials
from ._synth import Campaign as Campaign
from ._synth import SynthesisError as SynthesisError
from ._synth import synthesize as synthesize
from ._synth import write_campaign as write_campaign
from ._demo import DemoCampaign as DemoCampaign
from ._demo import demo_campaign as demo_campaign

__all__ = ["Campaign", "DemoCampaign", "Experiment", "Incidence", "LogNormal", "LogUniform",
           "Normal", "PARAMETERS", "Prior", "SECTIONS", "SynthesisError", "Trials", "Uniform",
           "demo_campaign", "load_experiment", "load_trials", "make_trials", "parse_experiment",
           "synthesize", "write_campaign", "write_trials"]
