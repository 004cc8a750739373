"""Rebounds for batches of parameter vectors: the forward model h(Theta) of the likelihoods.

A thin adapter of :class:`bouncebayes.model.BounceModel` to an experiment: the incidence
conditions are prepared once, and each call evaluates every parameter row under every condition
in one compiled call (the ODE only for the elements the closed form hands back).
"""

from __future__ import annotations

import numpy as np

from ..data import Experiment
from ..model import VARYING, BounceModel, Rebounds, SolverConfig

PARAMETER_ORDER = tuple(VARYING)

__all__ = ["PARAMETER_ORDER", "Forward", "Rebounds"]


class Forward:
    """h(Theta): rebound speed, angle, spin, contact time (and regime, status) for parameter
    rows ``theta`` (n, d) under each of the incidence conditions (``speed``, ``angle``,
    ``spin`` arrays of one length): arrays of shape (n, n_conditions)."""

    def __init__(self, experiment: Experiment, names: tuple[str, ...], *, speed, angle,
                 spin=None, solver: SolverConfig | None = None):
        unknown = [n for n in names if n not in PARAMETER_ORDER]
        if unknown:
            raise ValueError(f"cannot infer {unknown}; inferable parameters: {PARAMETER_ORDER}")
        self.experiment = experiment
        self.names = tuple(names)
        # no wall-clock limit per call: a posterior pass hands the model every draw at once, and
        # a compliant contact (every bounce on the ODE, ~25x the closed form's cost) can outlast
        # any fixed limit on a loaded machine, losing the batch's last rows (status TIMEOUT);
        # the solver's step cap still bounds every bounce
        self.solver = solver or SolverConfig(time_limit=None)
        e = experiment
        spin = e.incidence.spin if spin is None else spin
        speed, angle, spin = (np.array(a, dtype=float).ravel()
                              for a in np.broadcast_arrays(speed, angle, spin))
        # the experiment's contact law, its fixed parameters, the inferred ones per row
        self.model: BounceModel = e.bounce_model(speed=speed, angle=angle, spin=spin,
                                                 varying=self.names, solver=self.solver).prepare()
        self.n_conditions = self.model.n_conditions

    def __call__(self, theta: np.ndarray) -> Rebounds:
        """Rebounds of every row of ``theta`` (columns in the order of ``names``)."""
        return self.model(theta)
