"""Uncertainty propagation: the posterior pushed back through the model.

- :func:`propagate`: a seeded subset of draws at the nominal incidence (rebound, contact time,
  peak forces, spin), time histories (the paper's Figs. 6 and 8), and the posterior predictive
  distribution the inference replicated, with the adequacy verdict; written by
  :func:`write_propagation`, reloaded by :func:`load_propagation`.
- :func:`predict_bounces`: the calibrated model in use: for new incidences (a table of
  bounces), the posterior predictive distribution of rebound speed, angle and spin and contact
  time, with the measurement noise and model discrepancy the run inferred; written by
  :func:`write_predictions` (``bouncebayes predict``).
- :func:`derive`: DEM-ready quantities of the posterior (restitution against impact speed,
  tangential restitution and spin against incidence, contact time, the equivalent linear
  spring-dashpot, friction); written by :func:`write_derived` as ``derived.json``.
"""

from ._derived import DERIVED_FILE as DERIVED_FILE
from ._derived import N_DERIVED as N_DERIVED
from ._derived import derive as derive
from ._derived import load_derived as load_derived
from ._derived import write_derived as write_derived
from ._predict import PREDICTED as PREDICTED
from ._predict import Predictions as Predictions
from ._predict import predict_bounces as predict_bounces
from ._predict import write_predictions as write_predictions
from ._propagate import N_DRAWS as N_DRAWS
from ._propagate import N_HISTORIES as N_HISTORIES
from ._propagate import Propagation as Propagation
from ._propagate import draw_subset as draw_subset
from ._propagate import load_propagation as load_propagation
from ._propagate import predictive as predictive
from ._propagate import predictive_match as predictive_match
from ._propagate import propagate as propagate
from ._propagate import write_propagation as write_propagation

__all__ = ["DERIVED_FILE", "N_DERIVED", "derive", "load_derived", "write_derived", "N_DRAWS", "N_HISTORIES", "PREDICTED", "Predictions", "Propagation", "draw_subset",
           "load_propagation", "predict_bounces", "predictive", "predictive_match", "propagate",
           "write_predictions", "write_propagation"]
