"""The forward model: a ball bouncing obliquely on a rigid plane (docs/model.md).

One way in: :class:`BounceModel` (batched bounces under fixed conditions; samplers call it with
parameter rows), :func:`simulate` (full results for broadcast arguments, through the same
model) and :func:`simulate_history` (time series of one bounce). Inputs are checked against
their physical domains (:data:`PARAMETER_DOMAINS`); statuses (:class:`Status`) say why a
bounce could not be solved.
"""

from ._closed_form import HertzImpact as HertzImpact
from ._closed_form import RigidBodyRebound as RigidBodyRebound
from ._closed_form import hertz_elastic_impact as hertz_elastic_impact
from ._closed_form import rigid_body_rebound as rigid_body_rebound
from ._config import NORMAL_LAWS as NORMAL_LAWS
from ._config import PAPER_BALL as PAPER_BALL
from ._config import STANDARD_GRAVITY as STANDARD_GRAVITY
from ._config import TANGENTIAL_LAWS as TANGENTIAL_LAWS
from ._config import Ball as Ball
from ._config import SolverConfig as SolverConfig
from ._config import damping_unit as damping_unit
from ._config import mindlin_stiffness_ratio as mindlin_stiffness_ratio
from ._config import model_parameters as model_parameters
from ._derived import DEFAULT_ANGLES as DEFAULT_ANGLES
from ._derived import DEFAULT_SPEEDS as DEFAULT_SPEEDS
from ._derived import DERIVED_QUANTITIES as DERIVED_QUANTITIES
from ._derived import DerivedQuantity as DerivedQuantity
from ._derived import ObliqueResponse as ObliqueResponse
from ._derived import derived_quantities as derived_quantities
from ._derived import equivalent_linear_dashpot as equivalent_linear_dashpot
from ._derived import normal_response as normal_response
from ._derived import oblique_response as oblique_response
from ._domain import HERTZ_OVERLAP_LIMIT as HERTZ_OVERLAP_LIMIT
from ._domain import PARAMETER_DOMAINS as PARAMETER_DOMAINS
from ._domain import Domain as Domain
from ._domain import parameter_domain as parameter_domain
from ._engine import VARYING as VARYING
from ._engine import BounceModel as BounceModel
from ._fast import rebound_range as rebound_rows
from ._history import BounceFailed as BounceFailed
from ._history import BounceHistory as BounceHistory
from ._history import simulate_history as simulate_history
from ._laws import damping_ratio_restitution as damping_ratio_restitution
from ._laws import restitution_damping_ratio as restitution_damping_ratio
from ._results import Bounces as Bounces
from ._results import Rebounds as Rebounds
from ._results import SimulationWarning as SimulationWarning
from ._results import Status as Status
from ._simulate import simulate as simulate

__all__ = [
    "DEFAULT_ANGLES", "DEFAULT_SPEEDS", "DERIVED_QUANTITIES", "HERTZ_OVERLAP_LIMIT", "NORMAL_LAWS", "PAPER_BALL", "PARAMETER_DOMAINS", "STANDARD_GRAVITY",
    "TANGENTIAL_LAWS", "VARYING", "Ball", "BounceFailed", "BounceHistory", "BounceModel",
    "Bounces", "DerivedQuantity", "Domain", "HertzImpact", "ObliqueResponse", "Rebounds", "RigidBodyRebound", "SimulationWarning",
    "SolverConfig", "Status", "damping_ratio_restitution", "damping_unit", "derived_quantities",
    "equivalent_linear_dashpot",
    "hertz_elastic_impact", "mindlin_stiffness_ratio", "model_parameters", "normal_response",
    "oblique_response", "parameter_domain", "rebound_rows",
    "restitution_damping_ratio", "rigid_body_rebound", "simulate", "simulate_history",
]
