"""Batched forward model: validate inputs once, call the compiled solver, label the results."""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, fields
from enum import IntEnum
from typing import Literal

import numpy as np

from .._validate import (as_float_array, broadcast, check_array, check_choice, in_range_mask)
from . import _kernel as K
from ._closed_form import HERTZ_CONTACT_TIME_CONSTANT
from ._config import PAPER_BALL, STANDARD_GRAVITY, Ball, SolverConfig, check_normal_law
from ._domain import HERTZ_OVERLAP_LIMIT, PARAMETER_DOMAINS, parameter_domain

Errors = Literal["raise", "flag"]
Method = Literal["auto", "ode"]
_LAW_CODES = {"kelvin-voigt": K.LAW_KELVIN_VOIGT, "hunt-crossley": K.LAW_HUNT_CROSSLEY}


class Status(IntEnum):
    """Outcome of one bounce; ``Status(code).message`` says what happened and what to do."""

    OK = K.ST_OK
    INVALID_INPUT = K.ST_INVALID
    NO_SEPARATION = K.ST_NO_SEPARATION
    MAX_STEPS = K.ST_MAX_STEPS
    STEP_UNDERFLOW = K.ST_STEP_UNDERFLOW
    NON_FINITE = K.ST_NONFINITE
    TIMEOUT = K.ST_TIMEOUT

    @property
    def message(self) -> str:
        return _STATUS_MESSAGES[self]


_STATUS_MESSAGES = {
    Status.OK: "solved",
    Status.INVALID_INPUT: "input outside the physical domain (e.g. negative eta or speed); "
                          "the element was not simulated",
    Status.NO_SEPARATION: "the ball did not leave the surface within "
                          "SolverConfig.max_contact_time_factor Hertz contact times: damping "
                          "this strong stops it on the surface; raise the factor if a long "
                          "contact is expected",
    Status.MAX_STEPS: "the solver made SolverConfig.max_steps step attempts (accepted or "
                      "rejected) without finishing; raise max_steps or loosen rtol/atol",
    Status.STEP_UNDERFLOW: "the step size fell below 1e-12 of the contact time scale "
                           "(the equations are too stiff at these parameters)",
    Status.NON_FINITE: "a quantity of the solver overflowed or was not a number (inputs far "
                       "outside any real ball's range reached the solver); check the units of "
                       "the ball and of the incidence",
    Status.TIMEOUT: "not attempted: the batch used up SolverConfig.time_limit seconds in the "
                    "solver before reaching this bounce; raise time_limit (or None) or split "
                    "the batch",
}


class SimulationWarning(UserWarning):
    """Some bounces of a batch could not be solved; their results are NaN with a status."""


@dataclass(frozen=True)
class Bounces:
    """Per-bounce results of :func:`simulate`, arrays of the broadcast input shape.

    Velocities are in the plane-aligned frame at the moment of separation; the rebound angle is
    measured from the plane normal in degrees (positive: the ball keeps moving forward); spin is
    counter-clockwise positive. Failed elements hold NaN and a non-zero ``status``; bounces
    beyond the validity of Hertz's contact have ``hertz_valid`` False.
    """

    rebound_speed: np.ndarray  #: m/s
    rebound_angle: np.ndarray  #: deg from the normal
    rebound_spin: np.ndarray  #: rad/s
    rebound_tangential_velocity: np.ndarray  #: m/s
    rebound_normal_velocity: np.ndarray  #: m/s, outward
    contact_time: np.ndarray  #: s
    peak_normal_force: np.ndarray  #: N
    peak_friction_force: np.ndarray  #: N (magnitude)
    max_overlap: np.ndarray  #: m
    separation_overlap: np.ndarray  #: m, overlap when the normal force vanished
    time_of_peak_normal_force: np.ndarray  #: s after first contact
    rolling: np.ndarray  #: bool, the contact point was not slipping at separation
    #: bool, solved and inside the validity of Hertz's small-strain contact: the maximum overlap
    #: stays within ``HERTZ_OVERLAP_LIMIT`` (0.1) of the radius. Where False the numbers are
    #: the model's, but a real ball deforms beyond what the model describes.
    hertz_valid: np.ndarray
    closed_form: np.ndarray  #: bool, solved by the tabulated closed form (not the ODE)
    status: np.ndarray  #: int8 codes of :class:`Status`
    n_steps: np.ndarray  #: accepted solver steps

    @property
    def shape(self) -> tuple[int, ...]:
        return self.status.shape

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of solved bounces."""
        return self.status == Status.OK

    @property
    def n_failed(self) -> int:
        return int(np.count_nonzero(~self.ok))

    @property
    def regime(self) -> np.ndarray:
        """``"roll"``, ``"slip"`` or ``"failed"`` per bounce."""
        return np.where(~self.ok, "failed", np.where(self.rolling, "roll", "slip"))

    def failure_summary(self) -> str:
        """Counts of failed bounces by reason, with what to do; empty when all succeeded."""
        codes, counts = np.unique(self.status[~self.ok], return_counts=True)
        return "; ".join(f"{n} x {Status(c).name}: {Status(c).message}"
                         for c, n in zip(codes, counts, strict=True))

    def item(self, index=()) -> dict[str, float | str]:
        """The results of one bounce as plain Python values (for JSON and tables)."""
        row = {f.name: getattr(self, f.name)[index] for f in fields(self)}
        flags = ("rolling", "hertz_valid", "closed_form")
        out: dict[str, float | str | bool] = {k: float(v) for k, v in row.items()
                                              if k not in flags + ("status", "n_steps")}
        out["regime"] = str(self.regime[index])
        out["status"] = Status(int(row["status"])).name
        out["n_steps"] = int(row["n_steps"])
        for k in flags[1:]:
            out[k] = bool(row[k])
        return out


@dataclass(frozen=True)
class _Prepared:
    """Validated inputs as the compiled kernels' arrays (one row per element)."""

    params: np.ndarray
    y0: np.ndarray
    status: np.ndarray
    shape: tuple[int, ...]
    max_contact_time_factor: float

    @property
    def gravity_x(self) -> np.ndarray:
        return self.params[:, K.P_GX]

    @property
    def gravity_y(self) -> np.ndarray:
        return self.params[:, K.P_GY]

    def ode_arrays(self, rows=slice(None)):
        """What only the ODE solver needs, for ``rows``: (params with the overlap scale
        filled in, y0, tolerance scales, largest step, time limit). The scales: the Hertz
        overlap d* = (m V^2/k)^(2/5) for positions, the incident speed for velocities,
        speed / radius for spin; the step and time limits: fractions and multiples of the
        elastic Hertz contact time."""
        params = self.params[rows].copy()
        y0 = self.y0[rows]
        r, m, k = params[:, K.P_R], params[:, K.P_M], params[:, K.P_K]
        v_normal = -y0[:, K.S_V]
        speed = np.hypot(y0[:, K.S_U], v_normal)
        d_scale = (m * v_normal**2 / k) ** 0.4
        e_star = k / (4.0 / 3.0 * np.sqrt(r))
        t_hertz = HERTZ_CONTACT_TIME_CONSTANT * (m**2 / (r * e_star**2 * v_normal)) ** 0.2
        params[:, K.P_DSCALE] = d_scale
        scale = np.column_stack([d_scale, d_scale, speed, speed, speed / r])
        return params, np.ascontiguousarray(y0), scale, t_hertz / 10.0, \
            self.max_contact_time_factor * t_hertz


# name, unit, low, high, low_open, high_open
_ARG_RANGES = {
    "mu": ("", 0.0, None, False, False),
    "eta": ("kg/s or s/m", 0.0, None, False, False),
    "speed": ("m/s", 0.0, None, True, False),
    "angle": ("deg", 0.0, 90.0, False, True),
    "spin": ("rad/s", None, None, False, False),
    "inclination": ("deg", -90.0, 90.0, True, True),
    "youngs_modulus": ("Pa", 0.0, None, True, False),
    "gravity": ("m/s^2", 0.0, None, False, False),
}
_BENIGN = {"mu": 0.0, "eta": 0.0, "speed": 1.0, "angle": 0.0, "spin": 0.0, "inclination": 0.0,
           "youngs_modulus": 1.0e6, "gravity": 0.0}


def _check_inputs(values: dict, errors: Errors,
                  normal_law: str) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Validate (definition, then physical domain) and broadcast; in ``flag`` mode mark bad
    elements instead of raising."""
    domains = {k: parameter_domain(k, normal_law) for k in values if k in PARAMETER_DOMAINS}
    if errors == "raise":
        arrays = {k: check_array(k, v, unit=_ARG_RANGES[k][0], low=_ARG_RANGES[k][1],
                                 high=_ARG_RANGES[k][2], low_open=_ARG_RANGES[k][3],
                                 high_open=_ARG_RANGES[k][4]) for k, v in values.items()}
        for k, domain in domains.items():
            domain.check(arrays[k])
        arrays = broadcast(**arrays)
        return arrays, np.zeros(next(iter(arrays.values())).shape, dtype=bool)
    arrays = broadcast(**{k: as_float_array(k, v) for k, v in values.items()})
    bad = np.zeros(next(iter(arrays.values())).shape, dtype=bool)
    for k, arr in arrays.items():
        ok = in_range_mask(arr, *_ARG_RANGES[k][1:])
        if k in domains:
            ok &= domains[k].contains(arr)
        bad |= ~ok
        arrays[k] = np.where(ok, arr, _BENIGN[k])
    return arrays, bad


def _prepare(ball: Ball, values: dict, normal_law: str, solver: SolverConfig,
             errors: Errors) -> _Prepared:
    arrays, bad = _check_inputs(values, errors, normal_law)
    r = ball.radius
    return prepare_raw(r, ball.mass, 4.0 / 3.0 * math.sqrt(r) / (1.0 - ball.poisson_ratio**2),
                       ball.moment_of_inertia, arrays, bad, normal_law,
                       solver.max_contact_time_factor)


def prepare_raw(radius: float, mass: float, stiffness_per_modulus: float, inertia: float,
                arrays: dict, bad: np.ndarray, normal_law: str,
                max_contact_time_factor: float) -> _Prepared:
    """Kernel arrays from checked, broadcast inputs (no validation: the scaled unit problem
    of the closed-form table is no real ball)."""
    shape = bad.shape
    a = {k: np.ascontiguousarray(v, dtype=float).ravel() for k, v in arrays.items()}
    n = bad.size
    r = radius
    theta = np.radians(a["angle"])
    incl = np.radians(a["inclination"])
    speed = a["speed"]
    params = np.empty((n, K.N_PARAMS))
    params[:, K.P_R] = r
    params[:, K.P_M] = mass
    params[:, K.P_K] = stiffness_per_modulus * a["youngs_modulus"]
    params[:, K.P_I] = inertia
    params[:, K.P_MU] = a["mu"]
    params[:, K.P_ETA] = a["eta"]
    params[:, K.P_GX] = a["gravity"] * np.sin(incl)
    params[:, K.P_GY] = a["gravity"] * np.cos(incl)
    params[:, K.P_LAW] = _LAW_CODES[normal_law]
    params[:, K.P_DSCALE] = np.nan  # the ODE's overlap scale: see _Prepared.ode_arrays
    y0 = np.zeros((n, K.N_STATE))
    y0[:, K.S_U] = speed * np.sin(theta)
    y0[:, K.S_V] = -speed * np.cos(theta)
    y0[:, K.S_W] = a["spin"]
    status = np.where(bad.ravel(), K.ST_INVALID, K.ST_OK).astype(np.int8)
    return _Prepared(params, y0, status, shape, max_contact_time_factor)


def solve_prepared(prep: _Prepared, solver: SolverConfig,
                   mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Run the compiled ODE solver on prepared elements (those in ``mask``, if given; the
    other rows of the results are NaN)."""
    status = prep.status.copy()
    res = np.full((status.size, K.N_RESULTS), np.nan)
    rows = np.flatnonzero(status == K.ST_OK if mask is None else mask & (status == K.ST_OK))
    if rows.size:
        res[rows], status[rows] = solve_rows(prep, solver, rows)
    return res, status


def solve_rows(prep: _Prepared, solver: SolverConfig,
               rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ODE solver on the given rows only: (results, status) of those rows."""
    params, y0, scale, h_max, t_max = prep.ode_arrays(rows)
    status = prep.status[rows].copy()
    res = np.full((rows.size, K.N_RESULTS), np.nan)
    solve_chunked(params, y0, scale, h_max, t_max, solver, status, res)
    return res, status


ODE_CHUNK = 1024  # bounces per solver call between two looks at the clock


def solve_chunked(params, y0, scale, h_max, t_max, solver: SolverConfig, status: np.ndarray,
                  res: np.ndarray) -> None:
    """The compiled solver over all rows, in chunks of ``ODE_CHUNK`` against the deadline of
    ``solver.time_limit``: the first chunk always runs, later ones only before the deadline;
    rows of chunks not started in time get ``TIMEOUT``. A chunk, once started, finishes (each
    bounce is bounded by ``max_steps`` attempts)."""
    deadline = None if solver.time_limit is None else time.monotonic() + solver.time_limit
    for start in range(0, status.size, ODE_CHUNK):
        part = slice(start, start + ODE_CHUNK)
        if start and deadline is not None and time.monotonic() > deadline:
            status[start:][status[start:] == K.ST_OK] = K.ST_TIMEOUT
            return
        K.solve_batch(params[part], y0[part], scale[part], h_max[part], t_max[part],
                      solver.rtol, solver.atol, solver.max_steps, status[part], res[part])


def _solve_auto(prep: _Prepared, normal_law: str,
                solver: SolverConfig) -> tuple[np.ndarray, np.ndarray]:
    """Closed form where exact, the ODE for the elements the closed form hands back."""
    from ._fast import fast_prepared

    res, status, fallback = fast_prepared(prep, normal_law)
    rows = np.flatnonzero((fallback != 0) & (status == K.ST_OK))
    if rows.size:
        res[rows], status[rows] = solve_rows(prep, solver, rows)
    return res, status


def _assemble(res: np.ndarray, status: np.ndarray, shape: tuple[int, ...],
              radius: float) -> Bounces:
    ok = status == K.ST_OK  # rows that are not OK hold NaN already (both solver paths)
    with np.errstate(invalid="ignore"):
        small_strain = res[:, K.R_D_MAX] <= HERTZ_OVERLAP_LIMIT * radius
    u, vn, w = res[:, K.R_U], res[:, K.R_V], res[:, K.R_W]

    def shaped(x):
        return np.reshape(x, shape)

    return Bounces(
        rebound_speed=shaped(np.hypot(u, vn)),
        rebound_angle=shaped(np.degrees(np.arctan2(u, vn))),
        rebound_spin=shaped(w),
        rebound_tangential_velocity=shaped(u),
        rebound_normal_velocity=shaped(vn),
        contact_time=shaped(res[:, K.R_TC]),
        peak_normal_force=shaped(res[:, K.R_FN_PEAK]),
        peak_friction_force=shaped(res[:, K.R_FT_PEAK]),
        max_overlap=shaped(res[:, K.R_D_MAX]),
        separation_overlap=shaped(res[:, K.R_D]),
        time_of_peak_normal_force=shaped(res[:, K.R_T_FN_PEAK]),
        rolling=shaped(ok & (res[:, K.R_PHASE] == 0)),
        hertz_valid=shaped(ok & small_strain),
        closed_form=shaped(ok & (res[:, K.R_STEPS] == 0)),
        status=shaped(status),
        n_steps=shaped(np.where(ok, np.nan_to_num(res[:, K.R_STEPS]), 0).astype(np.int64)),
    )


def simulate(ball: Ball = PAPER_BALL, *, mu, eta, speed, angle, spin=0.0, inclination=0.0,
             youngs_modulus=None, normal_law: str = "kelvin-voigt",
             gravity=STANDARD_GRAVITY, solver: SolverConfig | None = None,
             errors: Errors = "raise", method: Method = "auto") -> Bounces:
    """Simulate oblique bounces of ``ball`` on a rigid plane, batched over broadcast arrays.

    Free flight is ballistic (closed form); only the contact is integrated, from first touch
    (where ``speed``, ``angle`` and ``spin`` are given) to separation (where the rebound is
    reported). Every numeric argument may be an array; all broadcast together.

    Arguments:
        ball: the ball (radius, mass, modulus, Poisson ratio, inertia factor).
        mu: Coulomb friction coefficient, >= 0.
        eta: damping coefficient, >= 0: kg/s for ``"kelvin-voigt"`` (F_n = k d^1.5 + eta d'),
            s/m for ``"hunt-crossley"`` (F_n = k d^1.5 (1 + 1.5 eta d')).
        speed: incident speed at first contact, m/s, > 0.
        angle: incident angle from the plane normal, degrees, in [0, 90).
        spin: incident spin, rad/s, counter-clockwise positive (x forward, y outward).
        inclination: plane inclination to the horizontal, degrees, in (-90, 90); positive when
            the ball travels down-slope (tangential gravity g sin(inclination) along +x).
        youngs_modulus: optional Young's modulus in Pa overriding ``ball.youngs_modulus``
            element-wise (for inferring it).
        normal_law: ``"kelvin-voigt"`` (the paper's) or ``"hunt-crossley"``; forces are
            clamped at >= 0 (a contact never pulls) and the ball separates where F_n returns
            to zero.
        gravity: gravitational acceleration, m/s^2, >= 0 (the standard 9.80665 by default).
        solver: tolerances and limits (:class:`SolverConfig`).
        errors: ``"raise"``: invalid input raises ``ValueError`` and unsolved bounces give a
            :class:`SimulationWarning`; ``"flag"``: both only set the element's ``status``.
        method: ``"auto"`` (default): the tabulated normal impact with the closed-form
            tangential outcome wherever that is exact (``bouncebayes.model._fast``), the ODE
            solver elsewhere, element by element; ``"ode"``: the ODE solver everywhere.

    Returns:
        :class:`Bounces` with one entry per broadcast element.
    """
    check_choice("errors", errors, ("raise", "flag"))
    check_choice("method", method, ("auto", "ode"))
    normal_law = check_normal_law(normal_law)
    solver = SolverConfig() if solver is None else solver
    values = {"mu": mu, "eta": eta, "speed": speed, "angle": angle, "spin": spin,
              "inclination": inclination,
              "youngs_modulus": ball.youngs_modulus if youngs_modulus is None else youngs_modulus,
              "gravity": gravity}
    prep = _prepare(ball, values, normal_law, solver, errors)
    if method == "ode":
        res, status = solve_prepared(prep, solver)
    else:
        res, status = _solve_auto(prep, normal_law, solver)
    out = _assemble(res, status, prep.shape, ball.radius)
    if errors == "raise" and out.n_failed:
        warnings.warn(f"{out.n_failed} of {status.size} bounces could not be solved: "
                      f"{out.failure_summary()}", SimulationWarning, stacklevel=2)
    return out
