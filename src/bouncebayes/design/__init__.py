"""Experiment design: what a campaign will tell before it is filmed.

For candidate incidence angles and speeds, numbers of bounces and camera settings (frame rate,
position noise; or the trial table's standard errors), :func:`run_design` simulates campaigns
with truths from the experiment's priors and computes their exact grid posteriors: the expected
posterior standard deviation of every inferred parameter, the probability that ``mu`` is
identified (every bounce slides throughout) and the expected information gain; it recommends
the cheapest design reaching target widths. Campaigns are independent tasks run through
:func:`bouncebayes.studies.run_tasks` (serially or on a dask.distributed cluster).
"""

from ._campaign import design_campaign as design_campaign
from ._campaign import information_gain as information_gain
from ._errors import kinematics_errors as kinematics_errors
from ._plot import design_figure as design_figure
from ._space import DEFAULT_ANGLES as DEFAULT_ANGLES
from ._space import DEFAULT_BOUNCES as DEFAULT_BOUNCES
from ._space import DesignSpace as DesignSpace
from ._space import cost as cost
from ._study import METHOD as METHOD
from ._study import describe as describe
from ._study import p_mu_identified as p_mu_identified
from ._study import run_design as run_design
from ._study import sliding_boundary as sliding_boundary
from ._study import study_key as study_key

__all__ = ["DEFAULT_ANGLES", "DEFAULT_BOUNCES", "METHOD", "DesignSpace", "cost",
           "describe", "design_campaign", "design_figure", "information_gain",
           "kinematics_errors", "p_mu_identified", "run_design", "sliding_boundary",
           "study_key"]
