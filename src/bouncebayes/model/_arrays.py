"""Inputs as the compiled kernels read them: the layer below both solution paths.

:func:`prepare` turns the user's (broadcastable) arguments into :class:`Inputs`: one float array
per input, of length 1 when all elements share the value (no copy of scalars) and of the
broadcast size otherwise, plus the ball's constants and the normal law's code. The element's
derived quantities (stiffness, incident velocities, gravity components) are computed in ONE
compiled function, :func:`element`, which both the closed form and the ODE packer call, so the
two paths see bit-identical initial conditions. Range checks run inside the kernels against
:func:`input_bounds` (definition and physical domain of each input); :func:`explain_invalid`
words the first violation when an error must be raised.

Each input has a *slot* (``INPUT_NAMES``). Two slots hold a parameter whose name depends on the
normal law (``slot_names``): the damping slot holds ``eta`` (Kelvin–Voigt, Hunt–Crossley) or,
for the DEM laws, the damping number that their ``restitution`` gives (the linear law's damping
ratio, the Hertz law's Tsuji constant: :func:`slot_damping`); the stiffness slot holds the
Young's modulus (Hertz laws) or the linear spring's stiffness in N/m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .._validate import as_float_array, check_array
from . import _kernel as K
from ._closed_form import HERTZ_CONTACT_TIME_CONSTANT
from ._config import LAW_PARAMETERS, Ball
from ._domain import PARAMETER_DOMAINS, parameter_domain
from ._laws import restitution_damping_ratio
from ._vmath import cbrt, root5, sincos_deg

INPUT_NAMES = ("mu", "eta", "speed", "angle", "spin", "inclination", "youngs_modulus", "gravity",
               "tangential_stiffness_ratio")
I_MU, I_ETA, I_SPEED, I_ANGLE, I_SPIN, I_INCL, I_E, I_G, I_KT = range(len(INPUT_NAMES))
N_INPUTS = len(INPUT_NAMES)
# Ball constants: radius, mass, stiffness per unit of the stiffness slot (the Hertz k per unit
# Young's modulus, or 1 for the linear law), moment of inertia.
B_R, B_M, B_KFAC, B_I = range(4)

LAW_CODES = {"kelvin-voigt": K.LAW_KELVIN_VOIGT, "hunt-crossley": K.LAW_HUNT_CROSSLEY,
             "linear-dashpot": K.LAW_LINEAR, "hertz-tsuji": K.LAW_TSUJI}
TANGENTIAL_CODES = {"none": 0, "mindlin": 1, "linear": 2}
T_NONE, T_MINDLIN, T_LINEAR = 0, 1, 2
# Tsuji's constant per unit damping ratio as LIGGGHTS and EDEM set it (docs/model.md §4.6).
TSUJI_PER_RATIO = math.sqrt(5.0)

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
    "tangential_stiffness_ratio": ("", 0.0, None, True, False),
    "restitution": ("", 0.0, 1.0, True, False),
    "normal_stiffness": ("N/m", 0.0, None, True, False),
}


def slot_names(normal_law: str) -> tuple[str, ...]:
    """The user's name of each input slot under ``normal_law``."""
    damping, stiffness = LAW_PARAMETERS[normal_law]
    names = list(INPUT_NAMES)
    names[I_ETA], names[I_E] = damping, stiffness
    return tuple(names)


def slot_damping(normal_law: str, value) -> np.ndarray:
    """The damping slot from the law's damping parameter: ``eta`` unchanged; a restitution
    coefficient to the linear law's damping ratio or the Hertz law's Tsuji constant (NaN
    outside (0, 1], so that the kernels flag it)."""
    value = np.asarray(value, dtype=float)
    if LAW_PARAMETERS[normal_law][0] == "eta":
        return value
    ratio = restitution_damping_ratio(value)
    return ratio * TSUJI_PER_RATIO if normal_law == "hertz-tsuji" else ratio


@dataclass(frozen=True, eq=False)
class Inputs:
    """Elements as the kernels read them (see the module docstring)."""

    values: tuple[np.ndarray, ...]  #: per input of ``INPUT_NAMES``: length 1 or ``size``
    ball: np.ndarray  #: radius, mass, stiffness per unit of the stiffness slot, inertia
    law: int  #: ``LAW_CODES`` value
    shape: tuple[int, ...]  #: broadcast shape of the elements
    bounds: np.ndarray  #: (N_INPUTS, 2) closed bounds each input must lie in
    max_contact_time_factor: float
    tangential: int = T_NONE  #: ``TANGENTIAL_CODES`` value

    @property
    def size(self) -> int:
        """Number of elements."""
        return math.prod(self.shape)


def ball_constants(ball: Ball, normal_law: str = "kelvin-voigt") -> np.ndarray:
    """The ball as the kernels read it (``B_*`` layout) under ``normal_law``."""
    r = ball.radius
    kfac = 1.0 if normal_law == "linear-dashpot" else \
        4.0 / 3.0 * math.sqrt(r) / (1.0 - ball.poisson_ratio**2)
    return np.array([r, ball.mass, kfac, ball.moment_of_inertia])


def input_bounds(normal_law: str) -> np.ndarray:
    """(N_INPUTS, 2) closed bounds of the slots: the definition of each input intersected with
    its physical domain; open ends become the neighbouring float; a restitution's bounds become
    those of the damping number it gives (which falls as the restitution rises)."""
    out = np.empty((N_INPUTS, 2))
    for i, name in enumerate(slot_names(normal_law)):
        _, low, high, low_open, high_open = DEFINITIONS[name]
        low = -math.inf if low is None else (math.nextafter(low, math.inf) if low_open else low)
        high = math.inf if high is None else (math.nextafter(high, -math.inf) if high_open
                                              else high)
        if name in PARAMETER_DOMAINS:
            d = parameter_domain(name, normal_law)
            low = max(low, math.nextafter(d.low, math.inf) if d.low_open else d.low)
            high = min(high, math.nextafter(d.high, -math.inf) if d.high_open else d.high)
        if name == "restitution":
            low, high = (float(slot_damping(normal_law, e)) for e in (high, low))
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
            max_contact_time_factor: float, tangential: str = "none") -> Inputs:
    """Inputs of the kernels from the arguments (the names of :func:`slot_names`, each
    broadcastable); no range check here: the kernels flag elements outside ``bounds``."""
    names = slot_names(normal_law)
    arrays = {k: as_float_array(k, values[k], unit=DEFINITIONS[k][0]) for k in names}
    shape = _broadcast_shape(arrays)
    damping = names[I_ETA]
    if damping != "eta":
        with np.errstate(all="ignore"):  # NaN outside (0, 1]: the kernels flag it
            arrays[damping] = slot_damping(normal_law, arrays[damping])
    return Inputs(tuple(_compact(arrays[k], shape) for k in names), ball_consts,
                  LAW_CODES[normal_law], tuple(shape), bounds, max_contact_time_factor,
                  TANGENTIAL_CODES[tangential])


def explain_invalid(values: dict, normal_law: str) -> None:
    """Raise the one-line ``ValueError`` of the first input outside its definition (all inputs),
    then of the first outside its physical domain."""
    names = slot_names(normal_law)
    arrays = {}
    for k in names:
        unit, low, high, low_open, high_open = DEFINITIONS[k]
        arrays[k] = check_array(k, values[k], unit=unit, low=low, high=high, low_open=low_open,
                                high_open=high_open)
    for k in names:
        if k in PARAMETER_DOMAINS:
            parameter_domain(k, normal_law).check(arrays[k], k)


def unit_inputs(law: str, damping: np.ndarray, gamma: np.ndarray,
                max_contact_time_factor: float) -> Inputs:
    """The scaled normal problem (m = k = V = 1, head-on, no friction) of the closed-form
    tables, for the damping numbers ``damping`` (:func:`law_scales`): no real ball, so no
    physical bounds."""
    ones = np.ones(1)
    damping = np.ascontiguousarray(damping, dtype=float)
    if law == "linear-dashpot":  # damping number 2 zeta, with the slot holding zeta
        ball, stiffness, damping = np.array([1.0, 1.0, 1.0, 0.4]), ones, 0.5 * damping
    else:
        ball, stiffness = np.array([1.0, 1.0, 4.0 / 3.0, 0.4]), 0.75 * ones
    values = (0.0 * ones, damping, ones, 0.0 * ones, 0.0 * ones, 0.0 * ones, stiffness,
              np.ascontiguousarray(gamma, dtype=float), ones)
    bounds = np.tile([-math.inf, math.inf], (N_INPUTS, 1))
    return Inputs(values, ball, LAW_CODES[law], (max(damping.size, gamma.size),), bounds,
                  max_contact_time_factor)


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
    sin, cos = sincos_deg(at(values[I_INCL], i))
    g = at(values[I_G], i)
    return g * sin, g * cos


@njit(cache=True, inline="always")
def element_with(values, ball, i, gx, gy):
    """Derived quantities of element ``i`` whose gravity components are (gx, gy): (mu, eta, k,
    gx, gy, u0, vn, w0) with the incident normal speed ``vn`` > 0 (towards the plane) and the
    Hertz stiffness ``k``."""
    u0, vn = incident_velocity(at(values[I_SPEED], i), at(values[I_ANGLE], i))
    return (at(values[I_MU], i), at(values[I_ETA], i), ball[B_KFAC] * at(values[I_E], i), gx,
            gy, u0, vn, at(values[I_SPIN], i))


@njit(cache=True, inline="always")
def incident_velocity(speed, angle):
    """(u0, vn): the incident tangential and normal velocities of a speed at ``angle`` degrees
    from the normal (:func:`._vmath.sincos_deg`, which a loop of these vectorises)."""
    sin, cos = sincos_deg(angle)
    return speed * sin, speed * cos


@njit(cache=True, inline="always")
def element(values, ball, i):
    """Derived quantities of element ``i`` (see :func:`element_with`)."""
    gx, gy = gravity_parts(values, i)
    return element_with(values, ball, i, gx, gy)


@njit(cache=True, inline="always")
def law_scales(law, m, k, eta, gy, vn):
    """(delta*, t*, damping number, damping variable x, gravity number) of a normal impact at
    the incident normal speed ``vn`` under ``law``, with the damping slot ``eta``
    (docs/model.md §8). Hertz laws: ``delta* = (m vn^2/k)^(2/5)``; the linear law:
    ``delta* = vn sqrt(m/k)``; ``t* = delta*/vn``, ``gamma = gy delta*/vn^2``. The damping
    numbers: Kelvin–Voigt ``eta delta*/(m vn)``, Hunt–Crossley ``eta vn``, the linear law
    ``2 zeta`` (= c/sqrt(m k)), Tsuji's constant itself."""
    if law == K.LAW_LINEAR:
        d_star = vn * math.sqrt(m / k)
        damping = 2.0 * eta
    else:
        z = root5(m * vn * vn / k)  # delta* = z^2 (the vectorisable root: _vmath)
        d_star = z * z
        if law == K.LAW_KELVIN_VOIGT:
            damping = eta * (d_star / (m * vn))
        elif law == K.LAW_HUNT_CROSSLEY:
            damping = eta * vn
        else:
            damping = eta
    t_star, gamma = time_and_gravity_scales(d_star, vn, gy)
    return d_star, t_star, damping, damping_variable(law, damping), gamma


@njit(cache=True, inline="always")
def time_and_gravity_scales(d_star, vn, gy):
    """(t*, gravity number) = (delta*/vn, gy delta*/vn^2) of :func:`law_scales` (also used
    where delta* was computed in a vector pass, ``_fast._block_scales``)."""
    return d_star / vn, gy * d_star / (vn * vn)


@njit(cache=True, inline="always")
def damping_variable(law, damping):
    """The table's variable of a damping number: its cube root for Kelvin–Voigt (the overlap
    at separation grows like zeta^(2/3)), its fifth root for Tsuji's law (like alpha^(4/5)),
    the number itself otherwise (docs/model.md §8)."""
    if law == K.LAW_KELVIN_VOIGT:
        return cbrt(damping)
    if law == K.LAW_TSUJI:
        return root5(damping)
    return damping


@njit(cache=True, inline="always")
def initial_force(law, damping):
    """The scaled normal force at first touch: the damping number for the laws whose dashpot
    acts from the first instant (Kelvin–Voigt, linear), zero otherwise."""
    if law == K.LAW_KELVIN_VOIGT or law == K.LAW_LINEAR:
        return damping
    return 0.0


@njit(cache=True)
def pack_ode(values, ball, law, tangential, rows, factor, params, y0, scale, h_max, t_max):
    """The ODE solver's arrays for the elements ``rows``: parameters, initial state, tolerance
    scales (the overlap scale delta* for positions, the incident speed for velocities,
    speed / radius for spin, m V^2 / delta* for the spring force), largest step (a tenth of
    the elastic contact time: Hertz's, or pi sqrt(m/k) for the linear law) and time limit
    (``factor`` elastic contact times)."""
    r, m, inertia = ball[B_R], ball[B_M], ball[B_I]
    for j in range(rows.shape[0]):
        mu, eta, k, gx, gy, u0, vn, w0 = element(values, ball, rows[j])
        d_scale = law_scales(law, m, k, eta, gy, vn)[0]
        if law == K.LAW_LINEAR:
            t_elastic = math.pi * math.sqrt(m / k)
            coefficient = 2.0 * eta * math.sqrt(m * k)
        else:
            e_star = k / (4.0 / 3.0 * math.sqrt(r))
            t_elastic = HERTZ_CONTACT_TIME_CONSTANT * (m * m / (r * e_star * e_star * vn)) ** 0.2
            coefficient = eta * math.sqrt(m * k) if law == K.LAW_TSUJI else eta
        p = params[j]
        p[K.P_R], p[K.P_M], p[K.P_K], p[K.P_I] = r, m, k, inertia
        p[K.P_MU], p[K.P_ETA], p[K.P_GX], p[K.P_GY] = mu, coefficient, gx, gy
        p[K.P_LAW] = law
        p[K.P_DSCALE] = d_scale
        p[K.P_TLAW], p[K.P_KT] = spring(law, tangential, at(values[I_KT], rows[j]), m, k,
                                        t_elastic)
        y = y0[j]
        y[K.S_X], y[K.S_D], y[K.S_U], y[K.S_V], y[K.S_W] = 0.0, 0.0, u0, -vn, w0
        y[K.S_FT] = 0.0
        speed = math.hypot(u0, vn)
        scale[j, K.S_X], scale[j, K.S_D] = d_scale, d_scale
        scale[j, K.S_U], scale[j, K.S_V], scale[j, K.S_W] = speed, speed, speed / r
        scale[j, K.S_FT] = m * speed * speed / d_scale
        h_max[j] = t_elastic / 10.0
        t_max[j] = factor * t_elastic


@njit(cache=True, inline="always")
def spring(law, tangential, ratio, m, k, t_elastic):
    """(kernel tangential law, stiffness coefficient) of the tangential spring whose stiffness
    is ``ratio`` times the normal stiffness it refers to (docs/model.md §5.2): Mindlin under a
    Hertz law, ``k_t = ratio * (3/2) k sqrt(d)`` (the tangent stiffness dF/dd of the elastic
    force: ``8 G* a`` when ratio = 4 G*/E*); under the linear law both tangential laws give
    ``ratio * k``; the linear spring under a Hertz law, ``ratio * m (pi / t_H)^2``, the
    stiffness of the linear spring with the elastic Hertz contact time of the bounce."""
    if tangential == T_NONE:
        return K.TLAW_NONE, 0.0
    if law == K.LAW_LINEAR:
        return K.TLAW_CONSTANT, ratio * k
    if tangential == T_MINDLIN:
        return K.TLAW_SQRT, ratio * 1.5 * k
    return K.TLAW_CONSTANT, ratio * m * (math.pi / t_elastic) ** 2


def ode_arrays(inputs: Inputs, rows: np.ndarray):
    """(params, y0, scale, h_max, t_max) of the ODE solver for the elements ``rows``."""
    n = rows.size
    params, y0 = np.empty((n, K.N_PARAMS)), np.empty((n, K.N_STATE))
    scale, h_max, t_max = np.empty((n, K.N_STATE)), np.empty(n), np.empty(n)
    pack_ode(inputs.values, inputs.ball, inputs.law, inputs.tangential,
             np.ascontiguousarray(rows, dtype=np.int64), inputs.max_contact_time_factor, params,
             y0, scale, h_max, t_max)
    return params, y0, scale, h_max, t_max


@njit(cache=True)
def valid_mask(values, bounds, out):
    """``out[i]``: whether every input of element ``i`` lies inside its bounds."""
    for i in range(out.shape[0]):
        out[i] = valid(values, bounds, i)
