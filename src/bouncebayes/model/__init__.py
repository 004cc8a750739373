"""The forward model: a ball bouncing obliquely on a rigid plane (MODEL.md §1-3)."""

from ._closed_form import HertzImpact as HertzImpact
from ._closed_form import RigidBodyRebound as RigidBodyRebound
from ._closed_form import hertz_elastic_impact as hertz_elastic_impact
from ._closed_form import rigid_body_rebound as rigid_body_rebound
from ._config import NORMAL_LAWS as NORMAL_LAWS
from ._config import PAPER_BALL as PAPER_BALL
from ._config import STANDARD_GRAVITY as STANDARD_GRAVITY
from ._config import Ball as Ball
from ._config import SolverConfig as SolverConfig
from ._config import damping_unit as damping_unit
from ._domain import HERTZ_OVERLAP_LIMIT as HERTZ_OVERLAP_LIMIT
from ._domain import PARAMETER_DOMAINS as PARAMETER_DOMAINS
from ._domain import Domain as Domain
from ._domain import parameter_domain as parameter_domain
from ._simulate import Bounces as Bounces
from ._simulate import SimulationWarning as SimulationWarning
from ._simulate import Status as Status
from ._simulate import simulate as simulate
from ._history import BounceFailed as BounceFailed
from ._history import BounceHistory as BounceHistory
from ._history import simulate_history as simulate_history
