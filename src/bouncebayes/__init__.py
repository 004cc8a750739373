"""bouncebayes: contact parameters of a ball from how it bounces.

The public API, stage by stage (see the README):

- :mod:`bouncebayes.model`: the forward model (:func:`simulate`, :class:`Ball`, ...).
"""

from importlib.metadata import version as _version

from .model import PAPER_BALL as PAPER_BALL
from .model import Ball as Ball
from .model import Bounces as Bounces
from .model import SimulationWarning as SimulationWarning
from .model import SolverConfig as SolverConfig
from .model import Status as Status
from .model import hertz_elastic_impact as hertz_elastic_impact
from .model import rigid_body_rebound as rigid_body_rebound
from .model import simulate as simulate

__version__ = _version("bouncebayes")
