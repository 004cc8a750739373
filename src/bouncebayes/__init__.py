"""bouncebayes: contact parameters of a ball from how it bounces.

The public API, stage by stage (see the README):

- :mod:`bouncebayes.model`: the forward model (:func:`simulate`, :class:`Ball`, ...);
- :mod:`bouncebayes.data`: experiment files, priors, trial tables, synthetic campaigns;
- :mod:`bouncebayes.kinematics`: tracked trajectories to incidence and rebound kinematics;
- :mod:`bouncebayes.density`: kernel density estimates and the data summary.
"""

from ._version import __version__ as __version__
from .data import Experiment as Experiment
from .data import Trials as Trials
from .data import load_experiment as load_experiment
from .data import load_trials as load_trials
from .data import synthesize as synthesize
from .density import rebound_density as rebound_density
from .density import summarize as summarize
from .kinematics import fit_kinematics as fit_kinematics
from .kinematics import kinematics_from_folder as kinematics_from_folder
from .kinematics import read_trajectory as read_trajectory
from .model import PAPER_BALL as PAPER_BALL
from .model import Ball as Ball
from .model import Bounces as Bounces
from .model import SimulationWarning as SimulationWarning
from .model import SolverConfig as SolverConfig
from .model import Status as Status
from .model import hertz_elastic_impact as hertz_elastic_impact
from .model import rigid_body_rebound as rigid_body_rebound
from .model import simulate as simulate
from .model import simulate_history as simulate_history
