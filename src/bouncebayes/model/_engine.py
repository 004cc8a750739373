"""The one way into the forward model: :class:`BounceModel`.

Everything that needs batched bounces goes through it: :func:`simulate` (full results for
broadcast arguments), the likelihoods of ``bouncebayes.inference`` (rebounds for many parameter
rows under fixed incidence conditions, called thousands of times), the (mu, eta) grid of the
Gaussian likelihood, and the propagation of posteriors. Each element is solved by the closed
form where it is exact and by the ODE solver elsewhere; both write into the same output
layout (``_outputs``), where velocities become speed and angle in one function.
"""

from __future__ import annotations

import warnings
from typing import Literal

import numpy as np

from .._validate import check_choice
from . import _fast
from ._arrays import (I_E, I_ETA, I_KT, I_MU, I_SPIN, LAW_CODES, Inputs, ball_constants,
                      explain_invalid, input_bounds, prepare, slot_damping, slot_names,
                      valid_mask)
from ._config import (PAPER_BALL, STANDARD_GRAVITY, Ball, SolverConfig, check_normal_law,
                      check_tangential, mindlin_stiffness_ratio, model_parameters)
from ._ode import solve_rows
from ._outputs import N_OUT, N_REBOUND, store_ode, store_ode_rebound
from ._results import Bounces, Rebounds, SimulationWarning, Status

Errors = Literal["raise", "flag"]
Method = Literal["auto", "ode"]
#: Inputs that may vary per parameter row, and their input slot (``eta`` and ``restitution``
#: share the damping slot, ``youngs_modulus`` and ``normal_stiffness`` the stiffness slot: each
#: normal law uses one of each, ``model_parameters``).
VARYING = {"mu": I_MU, "eta": I_ETA, "youngs_modulus": I_E, "spin": I_SPIN,
           "restitution": I_ETA, "normal_stiffness": I_E, "tangential_stiffness_ratio": I_KT}
#: Values of varying parameters in the prepared conditions (inside their domains; each row
#: replaces them).
_PLACEHOLDERS = {"restitution": 0.5, "normal_stiffness": 1.0, "tangential_stiffness_ratio": 1.0}
#: The law-dependent parameters and what takes their place in a law that does not use them.
_ALTERNATIVES = {"eta": "restitution", "restitution": "eta",
                 "youngs_modulus": "normal_stiffness", "normal_stiffness": "youngs_modulus"}


class BounceModel:
    """Bounces of ``ball`` under a batch of conditions (all arguments broadcast together).

    Arguments are those of :func:`simulate`; a parameter may be left out when it is in
    ``varying``: the names of the parameters (of :func:`model_parameters` for the contact law:
    ``mu``, ``eta`` or ``restitution``, ``youngs_modulus`` or ``normal_stiffness``, ``spin``,
    ``tangential_stiffness_ratio``) that calls give per parameter row, in the column order of
    ``theta``.

    - ``model(theta)``: rebounds (speed, angle, spin, contact time, rolling, status) of every
      parameter row of ``theta`` (shape (n, len(varying))) under every condition, arrays of
      shape (n, *conditions); built for samplers (one compiled call, the normal impact of each
      condition prepared once). Parameter values outside their domain get ``INVALID_INPUT``.
    - ``model.bounces(theta=None)``: every result (:class:`Bounces`) of the conditions, or of
      every row of ``theta`` under every condition.
    - ``model.gaussian_grid(...)``: summed Gaussian misfits of the rebounds on a (mu, damping)
      grid.

    With tangential compliance every bounce is solved by the ODE path (``closed_form`` False).
    """

    def __init__(self, ball: Ball = PAPER_BALL, *, speed, angle, mu=None, eta=None, spin=0.0,
                 inclination=0.0, youngs_modulus=None, gravity=STANDARD_GRAVITY,
                 normal_law: str = "kelvin-voigt", tangential: str = "none",
                 restitution=None, normal_stiffness=None, tangential_stiffness_ratio=None,
                 solver: SolverConfig | None = None, errors: Errors = "raise",
                 varying: tuple[str, ...] = ()):
        self.errors = check_choice("errors", errors, ("raise", "flag"))
        self.normal_law = check_normal_law(normal_law)
        self.tangential = check_tangential(tangential)
        self.parameters = model_parameters(self.normal_law, self.tangential)
        self.varying = _check_varying(varying, self.parameters)
        self.ball = ball
        self.solver = SolverConfig() if solver is None else solver
        given = {"mu": mu, "eta": eta, "restitution": restitution,
                 "youngs_modulus": youngs_modulus, "normal_stiffness": normal_stiffness,
                 "tangential_stiffness_ratio": tangential_stiffness_ratio, "spin": spin}
        self.values = self._parameter_values(given) | {
            "speed": speed, "angle": angle, "inclination": inclination, "gravity": gravity}
        self.bounds = input_bounds(self.normal_law)
        self.inputs = prepare(ball_constants(ball, self.normal_law), self.values,
                              self.normal_law, self.bounds, self.solver.max_contact_time_factor,
                              self.tangential)
        self.shape = self.inputs.shape
        self.n_conditions = self.inputs.size
        names = slot_names(self.normal_law)
        self._cols = np.array([self.varying.index(names[i]) if names[i] in self.varying else -1
                               for i in (I_MU, I_ETA, I_E, I_SPIN)], dtype=np.int64)
        self._tables = _tables(self.normal_law)
        self._conditions: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def compliant(self) -> bool:
        """Whether the contact has a tangential spring (then every bounce takes the ODE)."""
        return self.tangential != "none"

    def _parameter_values(self, given: dict) -> dict:
        """The law's parameters from the arguments: unused ones refused, missing ones required
        unless varying, defaults (the ball's modulus, Mindlin's stiffness ratio) filled in."""
        used = set(self.parameters)
        for name, value in given.items():
            if value is not None and name not in used:
                other = _ALTERNATIVES.get(name)
                hint = (f"its parameter is `{other}`" if other in used else
                        "it has no tangential spring (set `tangential`)")
                raise ValueError(f"`{name}` is not a parameter of the contact law "
                                 f"({self.normal_law}, tangential {self.tangential}): {hint}")
        defaults = {"youngs_modulus": self.ball.youngs_modulus,
                    "tangential_stiffness_ratio": mindlin_stiffness_ratio(
                        self.ball.poisson_ratio)}
        out = {}
        for name in slot_names(self.normal_law):
            if name not in given:
                continue
            value = given[name] if given[name] is not None else defaults.get(name)
            if name not in used:  # the unused spring slot: any value inside its bounds
                value = 1.0
            elif value is None:
                if name not in self.varying:
                    raise ValueError(f"`{name}` is required (or name it in `varying`): a "
                                     f"parameter of the contact law {self.normal_law}")
                value = _PLACEHOLDERS.get(name, 0.0)  # replaced by each row
            out[name] = value
        return out

    # -- full results --------------------------------------------------------------------------

    def bounces(self, theta=None, *, method: Method = "auto") -> Bounces:
        """Every result of the conditions (``theta`` None) or of each parameter row of
        ``theta`` under each condition (shape (n, *conditions))."""
        check_choice("method", method, ("auto", "ode"))
        values = self.values if theta is None else self._product(theta)
        inputs = self.inputs if theta is None else prepare(
            self.inputs.ball, values, self.normal_law, self.bounds,
            self.solver.max_contact_time_factor, self.tangential)
        n = inputs.size
        out, status = np.empty((N_OUT, n)), np.empty(n, dtype=np.int8)
        rolling, flags = np.empty(n, dtype=bool), np.empty((2, n), dtype=bool)
        fallback = np.empty(n, dtype=np.int8)
        n_invalid, n_fallback = _fast.bounces(
            inputs.values, inputs.ball, inputs.bounds, method == "auto" and _tabled(self),
            self._tables, out, status, rolling, flags, fallback)
        if n_invalid and self.errors == "raise":
            explain_invalid(values, self.normal_law)
        if n_fallback:
            rows = np.flatnonzero(fallback)
            res, res_status = solve_rows(inputs, rows, self.solver)
            store_ode(res, res_status, rows, self.ball.radius, out, status, rolling, flags)
        result = Bounces.from_block(out, status, rolling, flags, inputs.shape)
        if self.errors == "raise" and result.n_failed:
            warnings.warn(f"{result.n_failed} of {n} bounces could not be solved: "
                          f"{result.failure_summary()}", SimulationWarning, stacklevel=3)
        return result

    def _product(self, theta) -> dict:
        """The inputs of every parameter row under every condition, as broadcastable arrays."""
        theta = self._theta(theta)
        lead = (theta.shape[0],) + (1,) * len(self.shape)
        return {k: np.asarray(v, dtype=float)[None, ...] if k not in self.varying
                else theta[:, self.varying.index(k)].reshape(lead)
                for k, v in self.values.items()}

    def _theta(self, theta) -> np.ndarray:
        theta = np.ascontiguousarray(theta, dtype=np.float64)
        if theta.ndim == 1:
            theta = theta[None, :]
        if theta.ndim != 2 or theta.shape[1] != len(self.varying) or not theta.flags.writeable:
            if theta.ndim == 2 and theta.shape[1] == len(self.varying):
                return theta.copy()  # a read-only array would compile another specialisation
            raise ValueError(f"`theta` must have shape (n, {len(self.varying)}) for the "
                             f"parameters {self.varying}; got {theta.shape}")
        return theta

    # -- rebounds for samplers -----------------------------------------------------------------

    def __call__(self, theta) -> Rebounds:
        """Rebounds of each parameter row of ``theta`` under each condition."""
        theta = self._slots(self._theta(theta))
        cond, cond_rows = self._conditions or self._prepared_conditions()
        n = theta.shape[0]
        dims = (n, self.n_conditions)
        out, status = np.empty((N_REBOUND,) + dims), np.empty(dims, dtype=np.int8)
        rolling, ok = np.empty(dims, dtype=bool), np.empty(dims, dtype=bool)
        fallback = np.empty(dims, dtype=bool)
        main, _, x_max, gamma_max, kv = self._tables
        if self.compliant:  # no closed form: every element to the ODE
            self._rebound_fallback(theta, np.arange(n * self.n_conditions),
                                   out.reshape(N_REBOUND, -1), status.reshape(-1),
                                   rolling.reshape(-1), ok.reshape(-1))
        elif n * self.n_conditions <= _fast.SERIAL_MAX:
            n_fallback = _fast.rebound_range(theta, self._cols, cond, cond_rows, self.inputs.ball,
                                             self.bounds, main, x_max, gamma_max, kv, 0, n, out,
                                             status, rolling, ok, fallback)
        else:
            n_fallback = _fast.rebound_parallel(theta, self._cols, cond, cond_rows,
                                                self.inputs.ball, self.bounds, main, x_max,
                                                gamma_max, kv, out, status, rolling, ok,
                                                fallback)
        if not self.compliant and n_fallback:
            self._rebound_fallback(theta, np.flatnonzero(fallback), out.reshape(N_REBOUND, -1),
                                   status.reshape(-1), rolling.reshape(-1), ok.reshape(-1))
        if len(self.shape) != 1:
            shape = (n,) + self.shape
            out, status = out.reshape((N_REBOUND,) + shape), status.reshape(shape)
            rolling, ok = rolling.reshape(shape), ok.reshape(shape)
        return Rebounds(out[0], out[1], out[2], out[3], rolling, ok, status)

    def _slots(self, theta: np.ndarray) -> np.ndarray:
        """``theta`` with a ``restitution`` column turned into the damping slot's value."""
        if "restitution" not in self.varying:
            return theta
        theta = theta.copy()
        col = self.varying.index("restitution")
        theta[:, col] = slot_damping(self.normal_law, theta[:, col])
        return theta

    def rebound_kernel(self) -> tuple | None:
        """The arguments of :func:`rebound_rows` after ``theta`` (the prepared conditions and
        tables), for samplers that evaluate rows from their own compiled loops with ``theta``
        as :meth:`__call__` takes it; ``None`` where calls do more than that kernel (a law
        without closed-form tables, a compliant contact, parameter columns transformed before
        the kernel): such samplers then call the model."""
        if (not _tabled(self) or getattr(self, "compliant", False)
                or "restitution" in self.varying):
            return None
        cond, cond_rows = self._prepared_conditions()
        main, _, x_max, gamma_max, kv = self._tables
        return (self._cols, cond, cond_rows, self.inputs.ball, self.bounds, main, x_max,
                gamma_max, kv)

    def prepare(self) -> BounceModel:
        """Check the conditions (raising in ``errors="raise"`` mode) and prepare their normal
        impacts for calls now rather than at the first call; returns the model."""
        self._prepared_conditions()
        return self

    def _prepared_conditions(self) -> tuple[np.ndarray, np.ndarray]:
        if self._conditions is None:
            if self.errors == "raise":
                explain_invalid(self.values, self.normal_law)
            main, _, _, gamma_max, kv = self._tables
            nc = self.n_conditions
            cond = np.empty((_fast.N_COND, nc))
            pieces = _fast.MAIN_PIECES  # none where that would take too much memory
            if nc * pieces * 2 * _fast.NX * 8 > _fast.PRECONTRACT_BYTES:
                pieces = 0
            cond_rows = np.empty((nc, pieces, 2 * _fast.NX))
            _fast.prepare_conditions(self.inputs.values, self.inputs.ball, self.bounds, main,
                                     gamma_max, kv, cond, cond_rows)
            self._conditions = cond, cond_rows
        return self._conditions

    def _rebound_fallback(self, theta, idx, out, status, rolling, ok) -> None:
        """The ODE for the elements at flat indices ``idx`` (``theta`` in slot values): those
        the closed form handed back, or every element of a compliant model (checked against
        the domains first: the closed form has not looked at them)."""
        r, c = np.divmod(idx, self.n_conditions)
        values = [v if v.size == 1 else np.ascontiguousarray(v[c]) for v in self.inputs.values]
        for name, column in zip(self.varying, range(len(self.varying)), strict=True):
            values[VARYING[name]] = np.ascontiguousarray(theta[r, column])
        sub = Inputs(tuple(values), self.inputs.ball, self.inputs.law, (idx.size,), self.bounds,
                     self.inputs.max_contact_time_factor, self.inputs.tangential)
        good = np.empty(idx.size, dtype=bool)
        valid_mask(sub.values, self.bounds, good)
        rows = np.flatnonzero(good)
        res, res_status = solve_rows(sub, rows, self.solver)
        store_ode_rebound(res, res_status, idx[rows], out, status, rolling, ok)
        if rows.size < idx.size:
            bad = idx[~good]
            out[:, bad], status[bad], rolling[bad], ok[bad] = np.nan, Status.INVALID_INPUT, \
                False, False

    # -- the (mu, eta) grid of a Gaussian misfit ------------------------------------------------

    def gaussian_grid(self, mu, eta, *, speed, angle, inverse_covariance,
                      log_norm) -> tuple[np.ndarray, np.ndarray]:
        """Sum over the conditions of bivariate normal log densities of the rebound (speed,
        angle) misfits against ``speed``, ``angle`` (one per condition), on the grid of ``mu``
        x ``eta`` (other inputs at the conditions' values): (log density (n_mu, n_eta), cells
        the closed form could not do, to be recomputed by a call of the model).

        ``inverse_covariance``: (n_conditions, 3) entries (ss, sa, aa) of each inverse
        covariance; ``log_norm``: each density's log normalising constant, subtracted.
        The normal impact is computed once per (eta, condition), the friction outcome per mu.
        """
        cond, cond_rows = self._prepared_conditions()
        mu = np.ascontiguousarray(mu, dtype=float)
        with np.errstate(all="ignore"):
            eta = np.ascontiguousarray(slot_damping(self.normal_law, eta), dtype=float)
        out = np.empty((mu.size, eta.size))
        bad = np.zeros((mu.size, eta.size), dtype=bool)
        if self.compliant:  # no closed form: the caller computes every cell
            out[:] = 0.0
            bad[:] = True
            return out, bad
        main, _, x_max, gamma_max, kv = self._tables
        nc = self.n_conditions
        speed, angle, log_norm = (np.ascontiguousarray(a, dtype=float).reshape(nc)
                                  for a in (speed, angle, log_norm))
        icov = np.ascontiguousarray(inverse_covariance, dtype=float).reshape(nc, 3)
        _fast.gaussian_grid(mu, eta, cond, cond_rows, self.inputs.ball, self.bounds, main,
                            x_max, gamma_max, kv, speed, angle, icov, log_norm, out, bad)
        return out, bad


def _check_varying(varying, parameters: tuple[str, ...]) -> tuple[str, ...]:
    varying = tuple(varying)
    unknown = [n for n in varying if n not in parameters]
    if unknown or len(set(varying)) != len(varying):
        raise ValueError(f"`varying` must name distinct inputs among the parameters of the "
                         f"contact law, {parameters}; got {varying}")
    return varying


#: Tabled laws whose full results (``bounces``) take the ODE path all the same: Tsuji's force
#: grows like t^(1/4) from first touch, which the compression table (in sqrt(t)) cannot follow
#: to 1e-7 (the peak friction of a contact that sticks before the force peak was off by up to
#: 7e-4); their rebounds (``__call__``, the grid) come from the main table, which is exact.
_REBOUNDS_ONLY = ("hertz-tsuji",)


def _tabled(model: BounceModel) -> bool:
    """Whether the closed form may take the model's full results: a tabled normal law (with a
    compression table that fits it) without tangential compliance."""
    return (model.normal_law in _fast.DOMAIN and model.normal_law not in _REBOUNDS_ONLY
            and not model.compliant)


def _tables(law: str):
    """The closed-form tables of ``law``, or empty stand-ins (of the same array types) for a
    law the closed form does not cover: every element then goes to the ODE solver."""
    if law in _fast.DOMAIN:
        return _fast.kernel_tables(law)
    return (np.zeros((1, _fast.NG, 2 * _fast.NX)), np.zeros((1, _fast.NG, 1)), -1.0, -1.0,
            LAW_CODES[law])


def ode_bounce(inputs: Inputs, res: np.ndarray, status: int, radius: float) -> Bounces:
    """The :class:`Bounces` of one element from one ODE result (for histories)."""
    out, st = np.empty((N_OUT, 1)), np.empty(1, dtype=np.int8)
    rolling, flags = np.empty(1, dtype=bool), np.empty((2, 1), dtype=bool)
    store_ode(res[None, :], np.array([status], dtype=np.int8), np.zeros(1, dtype=np.int64),
              radius, out, st, rolling, flags)
    return Bounces.from_block(out, st, rolling, flags, inputs.shape)
