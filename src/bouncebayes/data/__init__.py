"""Experiment description (TOML), priors, and the file formats: trial tables and trajectories
(CSV), each with one schema, one writer and one reader."""

from ._experiment import Candidate as Candidate
from ._experiment import Experiment as Experiment
from ._experiment import Incidence as Incidence
from ._experiment import load_experiment as load_experiment
from ._experiment import parse_experiment as parse_experiment
from ._priors import LogNormal as LogNormal
from ._priors import LogUniform as LogUniform
from ._priors import Normal as Normal
from ._priors import Prior as Prior
from ._priors import Uniform as Uniform
from ._schema import INFERENCE_CHOICES as INFERENCE_CHOICES
from ._schema import PARAMETERS as PARAMETERS
from ._schema import SECTIONS as SECTIONS
from ._trials import LABEL_COLUMNS as LABEL_COLUMNS
from ._trials import MEASURED as MEASURED
from ._trials import SYSTEMATIC as SYSTEMATIC
from ._trials import Trials as Trials
from ._trials import load_trials as load_trials
from ._trials import make_trials as make_trials
from ._trials import trial_table_reference as trial_table_reference
from ._trials import write_trials as write_trials
from ._trajectory import QUALITY_COLUMNS as QUALITY_COLUMNS
from ._trajectory import TrackSidecar as TrackSidecar
from ._trajectory import TrajectoryTable as TrajectoryTable
from ._trajectory import read_track_sidecar as read_track_sidecar
from ._trajectory import read_trajectory_table as read_trajectory_table
from ._trajectory import sidecar_path as sidecar_path
from ._trajectory import write_trajectory as write_trajectory
from ._synth import Campaign as Campaign
from ._synth import SynthesisError as SynthesisError
from ._synth import synthesize as synthesize
from ._synth import write_campaign as write_campaign
from ._demo import CAMPAIGNS as CAMPAIGNS
from ._demo import DemoCampaign as DemoCampaign
from ._demo import demo_campaign as demo_campaign

__all__ = [
    "CAMPAIGNS",
    "Campaign",
    "Candidate",
    "demo_campaign",
    "DemoCampaign",
    "Experiment",
    "Incidence",
    "INFERENCE_CHOICES",
    "LABEL_COLUMNS",
    "load_experiment",
    "load_trials",
    "LogNormal",
    "LogUniform",
    "make_trials",
    "MEASURED",
    "Normal",
    "PARAMETERS",
    "parse_experiment",
    "Prior",
    "QUALITY_COLUMNS",
    "read_track_sidecar",
    "read_trajectory_table",
    "SECTIONS",
    "sidecar_path",
    "SynthesisError",
    "synthesize",
    "SYSTEMATIC",
    "TrackSidecar",
    "TrajectoryTable",
    "trial_table_reference",
    "Trials",
    "Uniform",
    "write_campaign",
    "write_trajectory",
    "write_trials",
]
