"""Rebounds for batches of parameter vectors: the forward model h(Theta) of the likelihoods.

Samplers call this thousands of times on small batches, so the incidence conditions are
prepared once (validation, arrays of the compiled kernels) and each call only fills the columns
that depend on Theta before running the closed-form path, with the ODE for its fallbacks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..data import Experiment
from ..model import _kernel as K
from ..model._config import SolverConfig
from ..model._fast import fast_arrays
from ..model._simulate import _Prepared, _prepare, solve_prepared

PARAMETER_ORDER = ("mu", "eta", "youngs_modulus", "spin")


@dataclass(frozen=True)
class Rebounds:
    """Simulated rebounds, arrays of shape (n_theta, n_conditions)."""

    speed: np.ndarray  #: m/s
    angle: np.ndarray  #: deg from the normal
    rolling: np.ndarray  #: bool
    ok: np.ndarray  #: bool: solved (False: see ``status``)
    status: np.ndarray


class Forward:
    """h(Theta): rebound speed and angle for parameter rows ``theta`` (n, d) under each of the
    incidence conditions (``speed``, ``angle``, ``spin`` arrays of one length)."""

    def __init__(self, experiment: Experiment, names: tuple[str, ...], *, speed, angle,
                 spin=None, solver: SolverConfig | None = None):
        unknown = [n for n in names if n not in PARAMETER_ORDER]
        if unknown:
            raise ValueError(f"cannot infer {unknown}; inferable parameters: {PARAMETER_ORDER}")
        self.experiment = experiment
        self.names = tuple(names)
        self.solver = solver or SolverConfig()
        e = experiment
        nominal = {n: (e.priors[n].ppf(0.5) if n in e.priors else e.fixed_value(n))
                   for n in ("mu", "eta", "youngs_modulus")}
        spin = np.full(np.shape(speed), e.incidence.spin) if spin is None else spin
        values = {"mu": nominal["mu"], "eta": nominal["eta"], "speed": speed, "angle": angle,
                  "spin": spin, "inclination": e.inclination,
                  "youngs_modulus": nominal["youngs_modulus"], "gravity": e.gravity}
        self.template = _prepare(e.ball, values, e.normal_law, self.solver, "raise")
        self.n_conditions = self.template.status.size
        self.modulus0 = float(nominal["youngs_modulus"])
        self.columns = {n: i for i, n in enumerate(self.names)}
        self._tiled: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def _tiles(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Fresh copies of the kernel arrays for ``n`` parameter rows (samplers call with the
        same ``n`` every iteration, so the tiled templates are kept)."""
        if n not in self._tiled:
            t = self.template
            self._tiled[n] = (np.tile(t.params, (n, 1)), np.tile(t.y0, (n, 1)),
                              np.tile(t.status, n))
        return tuple(a.copy() for a in self._tiled[n])

    def __call__(self, theta: np.ndarray) -> Rebounds:
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        n = theta.shape[0]
        params, y0, status = self._tiles(n)
        self._fill(theta, params, y0)
        res, status, fallback = fast_arrays(params, y0, status, self.experiment.normal_law,
                                            full=False)
        need = (fallback != 0) & (status == K.ST_OK)
        if need.any():
            prep = self._prepared(theta, params, y0, status)
            res_ode, status_ode = solve_prepared(prep, self.solver, mask=need)
            res[need] = res_ode[need]
            status[need] = status_ode[need]
        shape = (n, self.n_conditions)
        ok = (status == K.ST_OK).reshape(shape)
        u, vn = res[:, K.R_U].reshape(shape), res[:, K.R_V].reshape(shape)
        return Rebounds(np.hypot(u, vn), np.degrees(np.arctan2(u, vn)),
                        (res[:, K.R_PHASE] == 0).reshape(shape) & ok, ok, status.reshape(shape))

    def _column(self, theta: np.ndarray, name: str) -> np.ndarray:
        return np.repeat(theta[:, self.columns[name]], self.n_conditions)

    def _fill(self, theta: np.ndarray, params: np.ndarray, y0: np.ndarray) -> None:
        """Write the Theta-dependent entries of the kernel arrays."""
        if "mu" in self.columns:
            params[:, K.P_MU] = self._column(theta, "mu")
        if "eta" in self.columns:
            params[:, K.P_ETA] = self._column(theta, "eta")
        if "spin" in self.columns:
            y0[:, K.S_W] = self._column(theta, "spin")
        if "youngs_modulus" in self.columns:  # k is proportional to E
            params[:, K.P_K] *= self._column(theta, "youngs_modulus") / self.modulus0

    def _prepared(self, theta, params, y0, status) -> _Prepared:
        """The prepared elements, for the ODE fallback (it derives its own scales)."""
        return replace(self.template, params=params, y0=y0, status=status,
                       shape=(status.size,))
