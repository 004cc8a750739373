"""bouncebayes: contact parameters of a ball from how it bounces.

The public API, stage by stage (see the README):

- :mod:`bouncebayes.model`: the forward model (:func:`simulate`, :class:`Ball`, ...);
- :mod:`bouncebayes.data`: experiment files, priors, trial tables, synthetic campaigns;
- :mod:`bouncebayes.tracking`: ball tracking in high-speed video;
- :mod:`bouncebayes.kinematics`: tracked trajectories to incidence and rebound kinematics;
- :mod:`bouncebayes.density`: kernel density estimates and the data summary;
- :mod:`bouncebayes.inference`: the posterior (:func:`infer`);
- :mod:`bouncebayes.propagation`, :mod:`bouncebayes.plots`, :mod:`bouncebayes.report`,
  :mod:`bouncebayes.pipeline` (``run``, the whole job), :mod:`bouncebayes.cli`.

Importing the package is light: each name below is imported from its stage on first use
(PEP 562), so ``import bouncebayes`` loads neither numba nor SciPy until a stage needs them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# public name -> the sub-module that defines it
_LAZY = {
    "Ball": "model", "PAPER_BALL": "model", "Bounces": "model", "SimulationWarning": "model",
    "SolverConfig": "model", "Status": "model", "hertz_elastic_impact": "model",
    "rigid_body_rebound": "model", "simulate": "model", "simulate_history": "model",
    "Experiment": "data", "Trials": "data", "load_experiment": "data", "load_trials": "data",
    "synthesize": "data",
    "rebound_density": "density", "summarize": "density",
    "fit_kinematics": "kinematics", "kinematics_from_folder": "kinematics",
    "read_trajectory": "kinematics",
    "InferenceResult": "inference", "MHConfig": "inference", "EnsembleConfig": "inference",
    "GridConfig": "inference", "infer": "inference", "BounceModel": "model",
}
_SUBMODULES = ("model", "data", "tracking", "kinematics", "density", "inference",
               "propagation", "plots", "report", "pipeline", "cli")

__all__ = ["__version__", "Ball", "BounceModel", "Bounces", "EnsembleConfig", "Experiment",
           "GridConfig", "InferenceResult", "MHConfig", "PAPER_BALL", "SimulationWarning", "SolverConfig", "Status", "Trials",
           "fit_kinematics", "hertz_elastic_impact", "infer", "kinematics_from_folder",
           "load_experiment", "load_trials", "read_trajectory", "rebound_density",
           "rigid_body_rebound", "simulate", "simulate_history", "summarize", "synthesize"]


def __getattr__(name: str) -> Any:
    if name == "__version__":  # importlib.metadata costs a quarter of a second: on demand
        from ._version import __version__

        return __version__
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value  # later look-ups do not come back here
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'bouncebayes' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY, *_SUBMODULES})


if TYPE_CHECKING:  # what static checkers and IDEs see
    from ._version import __version__
    from .data import Experiment, Trials, load_experiment, load_trials, synthesize
    from .density import rebound_density, summarize
    from .inference import EnsembleConfig, GridConfig, InferenceResult, MHConfig, infer
    from .kinematics import fit_kinematics, kinematics_from_folder, read_trajectory
    from .model import (PAPER_BALL, Ball, BounceModel, Bounces, SimulationWarning, SolverConfig,
                        Status,
                        hertz_elastic_impact, rigid_body_rebound, simulate, simulate_history)
