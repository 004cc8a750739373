"""Inputs as the compiled kernels read them: the layer below both solution paths.

:func:`prepare` turns the user's (broadcastable) arguments into :class:`Inputs`: one float array
per input, of length 1 when all elements share the value (no copy of scalars) and of the
broadcast size otherwise, plus the ball's constants and the normal law's code. The element's
derived quantities (stiffness, incident velocities, gravity components) are computed in ONE
compiled function, :func:`element`, which both the closed form and the ODE packer call, so the
two paths see bit-identical initial conditions. Range checks run inside the kernels against
:func:`input_bounds` (definition and physical domain of each input); :func:`explain_invalid`
words the first violation when an error must be raised.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .._validate import as_float_array, check_array
from . import _kernel as K
from ._closed_form import HERTZ_CONTACT_TIME_CONSTANT
from ._config import Ball
from ._domain import PARAMETER_DOMAINS, parameter_domain

INPUT_NAMES = ("mu", "eta", "speed", "angle", "spin", "inclination", "youngs_modulus", "gravity")
I_MU, I_ETA, I_SPEED, I_ANGLE, I_SPIN, I_INCL, I_E, I_G = range(len(INPUT_NAMES))
N_INPUTS = len(INPUT_NAMES)
# Ball constants: radius, mass, Hertz stiffness per unit Young's modulus, moment of inertia.
B_R, B_M, B_KFAC, B_I = range(4)

LAW_CODES = {"kelvin-voigt": K.LAW_KELVIN_VOIGT, "hunt-crossley": K.LAW_HUNT_CROSSLEY}

# Where each input is defined (unit, low, high, low_open, high_open); the physical domains
# (``PARAMETER_DOMAINS``) narrow these further.
DEFINITIONS = {
    "mu": ("", 0.0, None, False, False),
    "eta": ("kg/s or s/m", 0.0, None, False, False),
    "speed": ("m/s", 0.0, None, True, False),
    "angle": ("deg", 0.0, 90.0, False, True),
    "spin": ("rad/s", None, None, False, False),
    "inclination": ("deg", -90.0, 90.0, True, True),
    "youngs_modulus": ("Pa", 0.0, None, True, False),
    "gravity": ("m/s^2", 0.0, None, False, False),
}


@dataclass(frozen=True, eq=False)
class Inputs:
    """Elements as the kernels read them (see the module docstring)."""

    values: tuple[np.ndarray, ...]  #: per input of ``INPUT_NAMES``: length 1 or ``size``
    ball: np.ndarray  #: radius, mass, stiffness per modulus, inertia
    law: int  #: ``LAW_CODES`` value
    shape: tuple[int, ...]  #: broadcast shape of the elements
    bounds: np.ndarray  #: (N_INPUTS, 2) closed bounds each input must lie in
    max_contact_time_factor: float

    @property
    def size(self) -> int:
        """Number of elements."""
        return math.prod(self.shape)


def ball_constants(ball: Ball) -> np.ndarray:
    """The ball as the kernels read it (``B_*`` layout)."""
    r = ball.radius
    return np.array([r, ball.mass, 4.0 / 3.0 * math.sqrt(r) / (1.0 - ball.poisson_ratio**2),
                     ball.moment_of_inertia])


def input_bounds(normal_law: str) -> np.ndarray:
    """(N_INPUTS, 2) closed bounds: the definition of each input intersected with its physical
    domain; open ends become the neighbouring float."""
    out = np.empty((N_INPUTS, 2))
    for i, name in enumerate(INPUT_NAMES):
        _, low, high, low_open, high_open = DEFINITIONS[name]
        low = -math.inf if low is None else (math.nextafter(low, math.inf) if low_open else low)
        high = math.inf if high is None else (math.nextafter(high, -math.inf) if high_open
                                              else high)
        if name in PARAMETER_DOMAINS:
            d = parameter_domain(name, normal_law)
            low = max(low, math.nextafter(d.low, math.inf) if d.low_open else d.low)
            high = min(high, math.nextafter(d.high, -math.inf) if d.high_open else d.high)
        out[i] = low, high
    return out


def _broadcast_shape(arrays: dict[str, np.ndarray]) -> tuple[int, ...]:
    try:
        return np.broadcast_shapes(*(a.shape for a in arrays.values()))
    except ValueError:
        shapes = ", ".join(f"`{k}` {a.shape}" for k, a in arrays.items())
        raise ValueError(f"array arguments must broadcast to one shape; got {shapes}") from None


def _compact(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """1-D float array of length 1 (shared value) or the broadcast size, copied only when the
    array must be expanded or is read-only (the kernels take one array type)."""
    if a.size == 1:
        a = a.reshape(1)
    elif a.size != math.prod(shape):
        a = np.broadcast_to(a, shape)
    out = np.ascontiguousarray(a, dtype=np.float64).reshape(-1)
    return out if out.flags.writeable else out.copy()


def prepare(ball_consts: np.ndarray, values: dict, normal_law: str, bounds: np.ndarray,
            max_contact_time_factor: float) -> Inputs:
    """Inputs of the kernels from the arguments (names of ``INPUT_NAMES``, each broadcastable);
    no range check here: the kernels flag elements outside ``bounds``."""
    arrays = {k: as_float_array(k, values[k], unit=DEFINITIONS[k][0]) for k in INPUT_NAMES}
    shape = _broadcast_shape(arrays)
    return Inputs(tuple(_compact(arrays[k], shape) for k in INPUT_NAMES), ball_consts,
                  LAW_CODES[normal_law], tuple(shape), bounds, max_contact_time_factor)


def explain_invalid(values: dict, normal_law: str) -> None:
    """Raise the one-line ``ValueError`` of the first input outside its definition (all inputs),
    then of the first outside its physical domain."""
    arrays = {}
    for k in INPUT_NAMES:
        unit, low, high, low_open, high_open = DEFINITIONS[k]
        arrays[k] = check_array(k, values[k], unit=unit, low=low, high=high, low_open=low_open,
                                high_open=high_open)
    for k in INPUT_NAMES:
        if k in PARAMETER_DOMAINS:
            parameter_domain(k, normal_law).check(arrays[k], k)


def unit_inputs(law: str, damping: np.ndarray, gamma: np.ndarray,
                max_contact_time_factor: float) -> Inputs:
    """The scaled normal problem (m = k = V = 1, head-on, no friction) of the closed-form
    tables: no real ball, so no physical bounds."""
    ones = np.ones(1)
    values = (0.0 * ones, np.ascontiguousarray(damping, dtype=float), ones, 0.0 * ones,
              0.0 * ones, 0.0 * ones, 0.75 * ones, np.ascontiguousarray(gamma, dtype=float))
    bounds = np.tile([-math.inf, math.inf], (N_INPUTS, 1))
    return Inputs(values, np.array([1.0, 1.0, 4.0 / 3.0, 0.4]), LAW_CODES[law],
                  (max(damping.size, gamma.size),), bounds, max_contact_time_factor)


@njit(cache=True, inline="always")
def at(a, i):
    """Element ``i`` of an input array of length 1 (shared) or n."""
    return a[0] if a.shape[0] == 1 else a[i]


@njit(cache=True, inline="always")
def valid(values, bounds, i):
    """Whether every input of element ``i`` lies inside its bounds (False for NaN)."""
    for j in range(N_INPUTS):
        v = at(values[j], i)
        if not (bounds[j, 0] <= v <= bounds[j, 1]):
            return False
    return True


DEG = math.pi / 180.0


@njit(cache=True)
def all_valid(values, bounds):
    """Whether every element of every input lies in its bounds (one pass per input array: the
    kernels then skip the per-element check)."""
    for j in range(N_INPUTS):
        a = values[j]
        lo, hi = bounds[j, 0], bounds[j, 1]
        bad = 0
        for k in range(a.shape[0]):
            bad += not (lo <= a[k] <= hi)
        if bad:
            return False
    return True


@njit(cache=True, inline="always")
def gravity_parts(values, i):
    """Tangential and normal gravity (gx, gy) of element ``i``."""
    incl = at(values[I_INCL], i) * DEG
    g = at(values[I_G], i)
    return g * math.sin(incl), g * math.cos(incl)


@njit(cache=True, inline="always")
def element_with(values, ball, i, gx, gy):
    """Derived quantities of element ``i`` whose gravity components are (gx, gy): (mu, eta, k,
    gx, gy, u0, vn, w0) with the incident normal speed ``vn`` > 0 (towards the plane) and the
    Hertz stiffness ``k``."""
    angle = at(values[I_ANGLE], i) * DEG
    speed = at(values[I_SPEED], i)
    return (at(values[I_MU], i), at(values[I_ETA], i), ball[B_KFAC] * at(values[I_E], i), gx,
            gy, speed * math.sin(angle), speed * math.cos(angle), at(values[I_SPIN], i))


@njit(cache=True, inline="always")
def element(values, ball, i):
    """Derived quantities of element ``i`` (see :func:`element_with`)."""
    gx, gy = gravity_parts(values, i)
    return element_with(values, ball, i, gx, gy)


@njit(cache=True)
def pack_ode(values, ball, law, rows, factor, params, y0, scale, h_max, t_max):
    """The ODE solver's arrays for the elements ``rows``: parameters, initial state, tolerance
    scales (the Hertz overlap d* = (m V^2/k)^(2/5) for positions, the incident speed for
    velocities, speed / radius for spin), largest step (a tenth of the elastic Hertz contact
    time) and time limit (``factor`` Hertz contact times)."""
    r, m, inertia = ball[B_R], ball[B_M], ball[B_I]
    for j in range(rows.shape[0]):
        mu, eta, k, gx, gy, u0, vn, w0 = element(values, ball, rows[j])
        p = params[j]
        p[K.P_R], p[K.P_M], p[K.P_K], p[K.P_I] = r, m, k, inertia
        p[K.P_MU], p[K.P_ETA], p[K.P_GX], p[K.P_GY] = mu, eta, gx, gy
        p[K.P_LAW] = law
        d_scale = (m * vn * vn / k) ** 0.4
        p[K.P_DSCALE] = d_scale
        y = y0[j]
        y[K.S_X], y[K.S_D], y[K.S_U], y[K.S_V], y[K.S_W] = 0.0, 0.0, u0, -vn, w0
        speed = math.hypot(u0, vn)
        scale[j, K.S_X], scale[j, K.S_D] = d_scale, d_scale
        scale[j, K.S_U], scale[j, K.S_V], scale[j, K.S_W] = speed, speed, speed / r
        e_star = k / (4.0 / 3.0 * math.sqrt(r))
        t_hertz = HERTZ_CONTACT_TIME_CONSTANT * (m * m / (r * e_star * e_star * vn)) ** 0.2
        h_max[j] = t_hertz / 10.0
        t_max[j] = factor * t_hertz


def ode_arrays(inputs: Inputs, rows: np.ndarray):
    """(params, y0, scale, h_max, t_max) of the ODE solver for the elements ``rows``."""
    n = rows.size
    params, y0 = np.empty((n, K.N_PARAMS)), np.empty((n, K.N_STATE))
    scale, h_max, t_max = np.empty((n, K.N_STATE)), np.empty(n), np.empty(n)
    pack_ode(inputs.values, inputs.ball, inputs.law, np.ascontiguousarray(rows, dtype=np.int64),
             inputs.max_contact_time_factor, params, y0, scale, h_max, t_max)
    return params, y0, scale, h_max, t_max
