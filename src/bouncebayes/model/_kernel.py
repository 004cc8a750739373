"""Compiled contact-phase solver: Dormand–Prince 5(4) with dense output and event location.

Written by hand (not SciPy's ``solve_ivp``) because the solver must run inside a numba ``prange``
loop over many parameter sets, and no maintained library offers an adaptive Runge–Kutta method
callable from numba with event location and a switch of right-hand side at each event (the
slip/roll transitions of Coulomb friction). The tableau and the dense-output matrix are the ones
SciPy's ``RK45`` uses (Dormand & Prince 1980; Shampine 1986); ``tests/test_model.py`` checks
them against ``scipy.integrate.RK45`` so that they cannot drift.

Everything here works on plain float arrays with fixed layouts (the ``P_*``, ``S_*``, ``R_*``
and ``G_*`` indices); ``_arrays.py`` builds them, ``_ode.py`` drives the solver in chunks.

State (plane-aligned frame, docs/model.md): ``x`` along the plane since first contact, overlap
``d = r - y`` (positive in contact), tangential velocity ``u``, normal velocity ``vn = y'``
(outward positive), spin ``w`` (counter-clockwise positive) and the force of the tangential
spring ``ft`` (N, along +x on the ball; zero and unused without tangential compliance).

Tangential phase: ``+1``/``-1`` sliding with the slip velocity ``s = u + r w`` of that sign
(friction ``-mu F_n`` times the sign), or ``0``. Without tangential compliance ``0`` is rolling
(``s = 0``, the friction that holds it); with compliance it is elastic stick: the spring force
``ft`` is integrated, ``ft' = -k_t s`` while the overlap grows and ``ft' = -k_t s + ft k_t'/k_t``
while it shrinks (the spring unloads with its stiffness, docs/model.md §5.2), until
``|ft| = mu F_n``; then the contact slides with ``ft = -sign mu F_n`` (the spring held at the
Coulomb cap, following it down as the normal force fades) until the elastic rate would take the
spring back inside the cap.

Normal laws (``LAW_*``): Kelvin–Voigt ``k d^1.5 + eta d'``, Hunt–Crossley
``k d^1.5 (1 + 1.5 eta d')``, the linear spring-dashpot ``k d + eta d'`` and Hertz with the
nonlinear dashpot of Tsuji et al. ``k d^1.5 + eta d^(1/4) d'``, all clamped at zero (``eta`` here
is the physical coefficient of each law; ``_arrays`` converts the users' parameters). Tangential
laws (``TLAW_*``): none, ``k_t = P_KT sqrt(d)`` (Mindlin's no-slip stiffness, proportional to
the contact radius) or ``k_t = P_KT`` (a linear Cundall–Strack spring).

The closed-form path applies only to the laws it has a table for (``_fast.DOMAIN``) and to
models without tangential compliance; everything else goes to this solver element by element.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

# Parameter vector layout.
(P_R, P_M, P_K, P_I, P_MU, P_ETA, P_GX, P_GY, P_LAW, P_DSCALE, P_KT, P_TLAW) = range(12)
N_PARAMS = 12
# State layout.
S_X, S_D, S_U, S_V, S_W, S_FT = range(6)
N_STATE = 6
# Result layout: contact time, the state at separation, then the summary quantities.
R_TC = 0
R_X, R_D, R_U, R_V, R_W, R_FT = range(1, 1 + N_STATE)
(R_FN_PEAK, R_FT_PEAK, R_D_MAX, R_PHASE, R_STEPS, R_SWITCHES, R_T_FN_PEAK,
 R_V_FN_PEAK) = range(1 + N_STATE, 9 + N_STATE)
N_RESULTS = 9 + N_STATE
# History columns: state, then normal force, friction force, phase.
H_FN, H_FT, H_PHASE = N_STATE, N_STATE + 1, N_STATE + 2
N_HISTORY = N_STATE + 3
# Dense-output segments (one per accepted step, cut at events): start time, step size, the
# fraction of the step kept, tangential phase, the state at the start, the polynomial Q.
G_T0, G_H, G_THETA, G_PHASE, G_Y0 = 0, 1, 2, 3, 4
G_Q = G_Y0 + N_STATE
N_SEGMENT = G_Q + 4 * N_STATE

LAW_KELVIN_VOIGT = 0
LAW_HUNT_CROSSLEY = 1
LAW_LINEAR = 2
LAW_TSUJI = 3
TLAW_NONE = 0
TLAW_SQRT = 1  # k_t = P_KT sqrt(d): Mindlin under a Hertz law
TLAW_CONSTANT = 2  # k_t = P_KT

# Per-element status codes (mirrored by ``bouncebayes.model.Status``).
ST_OK = 0
ST_INVALID = 1
ST_NO_SEPARATION = 2
ST_MAX_STEPS = 3
ST_STEP_UNDERFLOW = 4
ST_NONFINITE = 5
ST_TIMEOUT = 6  # set by the Python driver for elements it did not reach before its deadline

# Events. STICK: the slip reaches zero (rigid) or the elastic rate would take the spring inside
# the Coulomb cap (compliant, then called "grip"); SLIP: rolling ends on a slope (rigid) or the
# spring force reaches the cap (compliant).
EV_NONE, EV_SEPARATION, EV_STICK, EV_SLIP, EV_MAX_OVERLAP = 0, 1, 2, 3, 4

# Dormand–Prince 5(4): the coefficients of scipy.integrate.RK45.
A21 = 1.0 / 5.0
A31, A32 = 3.0 / 40.0, 9.0 / 40.0
A41, A42, A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
A51, A52, A53, A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
A61, A62, A63, A64, A65 = (9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0,
                           -5103.0 / 18656.0)
B1, B3, B4, B5, B6 = 35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0
E1, E3, E4, E5, E6, E7 = (-71.0 / 57600.0, 71.0 / 16695.0, -71.0 / 1920.0, 17253.0 / 339200.0,
                          -22.0 / 525.0, 1.0 / 40.0)
DENSE = np.array([
    [1.0, -8048581381.0 / 2820520608.0, 8663915743.0 / 2820520608.0,
     -12715105075.0 / 11282082432.0],
    [0.0, 0.0, 0.0, 0.0],
    [0.0, 131558114200.0 / 32700410799.0, -68118460800.0 / 10900136933.0,
     87487479700.0 / 32700410799.0],
    [0.0, -1754552775.0 / 470086768.0, 14199869525.0 / 1410260304.0,
     -10690763975.0 / 1880347072.0],
    [0.0, 127303824393.0 / 49829197408.0, -318862633887.0 / 49829197408.0,
     701980252875.0 / 199316789632.0],
    [0.0, -282668133.0 / 205662961.0, 2019193451.0 / 616988883.0,
     -1453857185.0 / 822651844.0],
    [0.0, 40617522.0 / 29380423.0, -110615467.0 / 29380423.0, 69997945.0 / 29380423.0],
])
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
ROOT_ITERATIONS = 200
GOLDEN_ITERATIONS = 60


@njit(cache=True, inline="always")
def unclamped_force(d, vn, p):
    """The normal force law before clamping, for ``d >= 0`` (``d' = -vn``)."""
    law = p[P_LAW]
    if law == LAW_LINEAR:
        return p[P_K] * d - p[P_ETA] * vn
    sq = math.sqrt(d)
    elastic = p[P_K] * d * sq
    if law == LAW_KELVIN_VOIGT:
        return elastic - p[P_ETA] * vn  # eta * (overlap rate), overlap rate = -vn
    if law == LAW_HUNT_CROSSLEY:
        return elastic * (1.0 - 1.5 * p[P_ETA] * vn)
    return elastic - p[P_ETA] * math.sqrt(sq) * vn  # Tsuji: eta d^(1/4) d'


@njit(cache=True, inline="always")
def normal_force(d, vn, p):
    """Clamped normal force of the element's law, never pulling.

    At ``d = 0`` the in-contact value is used: a Kelvin–Voigt (or linear spring-dashpot)
    contact pushes with ``eta V`` from the instant of first touch (the classic force jump).
    """
    if d < 0.0:
        return 0.0
    return max(unclamped_force(d, vn, p), 0.0)


@njit(cache=True, inline="always")
def rolling_friction(p):
    """Friction that keeps the slip velocity at zero against the tangential gravity."""
    return -p[P_GX] / (1.0 / p[P_M] + p[P_R] * p[P_R] / p[P_I])


@njit(cache=True, inline="always")
def tangential_stiffness(d, p):
    """Stiffness of the tangential spring at overlap ``d``, N/m."""
    if p[P_TLAW] == TLAW_SQRT:
        return p[P_KT] * math.sqrt(max(d, 0.0))
    return p[P_KT]


@njit(cache=True, inline="always")
def friction_force(fn, y, phase, p):
    """Tangential force on the ball at the contact: rolling, sliding, or the elastic spring."""
    if phase == 0:
        if p[P_TLAW] != TLAW_NONE:
            return y[S_FT]
        return rolling_friction(p)
    return -p[P_MU] * fn * phase


@njit(cache=True, inline="always")
def spring_rate(y, p):
    """Rate of the elastic spring force in stick: ``-k_t s`` plus, while the overlap shrinks
    and the stiffness with it, the unloading ``ft k_t'/k_t`` (``k_t'/k_t = d'/(2d)`` for
    Mindlin's stiffness); the rule never creates energy (docs/model.md §5.2)."""
    d = y[S_D]
    rate = -tangential_stiffness(d, p) * (y[S_U] + p[P_R] * y[S_W])
    if p[P_TLAW] == TLAW_SQRT and y[S_V] > 0.0 and d > 0.0:
        rate -= y[S_FT] * y[S_V] / (2.0 * d)
    return rate


@njit(cache=True)
def rhs(y, p, phase, out):
    """Equations of motion in contact (docs/model.md §3) for the given tangential phase."""
    fn = normal_force(y[S_D], y[S_V], p)
    ft = friction_force(fn, y, phase, p)
    out[S_X] = y[S_U]
    out[S_D] = -y[S_V]
    out[S_U] = ft / p[P_M] + p[P_GX]
    out[S_V] = fn / p[P_M] - p[P_GY]
    out[S_W] = p[P_R] * ft / p[P_I]
    out[S_FT] = spring_rate(y, p) if phase == 0 and p[P_TLAW] != TLAW_NONE else 0.0


@njit(cache=True)
def normal_force_rate(y, dy, p):
    """Time derivative of the (unclamped) normal force, for locating its maximum."""
    d = y[S_D]
    if d <= 0.0:
        return 0.0
    law = p[P_LAW]
    rate_d = -y[S_V]  # d'
    if law == LAW_LINEAR:
        return p[P_K] * rate_d - p[P_ETA] * dy[S_V]
    sq = math.sqrt(d)
    rate_elastic = 1.5 * p[P_K] * sq * rate_d
    if law == LAW_KELVIN_VOIGT:
        return rate_elastic - p[P_ETA] * dy[S_V]
    if law == LAW_HUNT_CROSSLEY:
        fac = 1.0 - 1.5 * p[P_ETA] * y[S_V]
        return rate_elastic * fac - p[P_K] * d * sq * 1.5 * p[P_ETA] * dy[S_V]
    q = math.sqrt(sq)  # Tsuji: d/dt (-eta d^(1/4) vn)
    return rate_elastic - p[P_ETA] * (0.25 * rate_d * y[S_V] / (q * q * q) + q * dy[S_V])


@njit(cache=True, inline="always")
def force_rate_now(y, p):
    """``normal_force_rate`` with the normal acceleration from the state (``vn' = F_n/m -
    g_y``): the slope of the Coulomb cap in the compliant grip test (of the unclamped force,
    so that it stays continuous through separation)."""
    fn = normal_force(y[S_D], y[S_V], p)
    d = y[S_D]
    if d <= 0.0:
        return 0.0
    law = p[P_LAW]
    rate_d = -y[S_V]
    acc = fn / p[P_M] - p[P_GY]
    if law == LAW_LINEAR:
        return p[P_K] * rate_d - p[P_ETA] * acc
    sq = math.sqrt(d)
    rate_elastic = 1.5 * p[P_K] * sq * rate_d
    if law == LAW_KELVIN_VOIGT:
        return rate_elastic - p[P_ETA] * acc
    if law == LAW_HUNT_CROSSLEY:
        return (rate_elastic * (1.0 - 1.5 * p[P_ETA] * y[S_V])
                - p[P_K] * d * sq * 1.5 * p[P_ETA] * acc)
    q = math.sqrt(sq)
    return rate_elastic - p[P_ETA] * (0.25 * rate_d * y[S_V] / (q * q * q) + q * acc)


@njit(cache=True)
def separation_value(y, p):
    """Positive in contact, crossing zero where the unclamped normal force does (scaled)."""
    d = y[S_D]
    law = p[P_LAW]
    ds = p[P_DSCALE]
    if law == LAW_LINEAR:
        return (d - p[P_ETA] / p[P_K] * y[S_V]) / ds
    signed = d * math.sqrt(abs(d))  # continuous through d = 0
    if law == LAW_KELVIN_VOIGT:
        return (signed - p[P_ETA] / p[P_K] * y[S_V]) / (ds * math.sqrt(ds))
    if law == LAW_HUNT_CROSSLEY:
        return min(d / ds, 1.0 - 1.5 * p[P_ETA] * y[S_V])
    # Tsuji: d^(1/4) (k d^(5/4) - eta vn); the bracket, with a signed power
    signed = math.copysign(abs(d) ** 1.25, d)
    return (signed - p[P_ETA] / p[P_K] * y[S_V]) / ds ** 1.25


@njit(cache=True)
def grip_value(y, p, phase):
    """Compliant sliding with sign ``phase``: positive while the elastic rate of the spring
    would push it beyond the Coulomb cap (so it slides on), i.e. ``sign * (k_t s - ft
    min(0, k_t')/k_t) - mu F_n'`` with ``ft`` at the cap; crosses zero where the contact grips."""
    d = y[S_D]
    fn = normal_force(d, y[S_V], p)
    kt = tangential_stiffness(d, p)
    value = phase * kt * (y[S_U] + p[P_R] * y[S_W]) - p[P_MU] * force_rate_now(y, p)
    if p[P_TLAW] == TLAW_SQRT and y[S_V] > 0.0 and d > 0.0:
        value -= p[P_MU] * fn * y[S_V] / (2.0 * d)
    return value


@njit(cache=True)
def event_value(kind, y, p, phase):
    """Event functions: positive before the event, crossing zero at it."""
    if kind == EV_SEPARATION:
        return separation_value(y, p)
    if kind == EV_MAX_OVERLAP:
        return -y[S_V]
    compliant = p[P_TLAW] != TLAW_NONE
    if kind == EV_STICK:
        if compliant:
            return grip_value(y, p, phase)
        return (y[S_U] + p[P_R] * y[S_W]) * phase
    fn = normal_force(y[S_D], y[S_V], p)
    if compliant:
        return p[P_MU] * fn - abs(y[S_FT])
    return p[P_MU] * fn - abs(rolling_friction(p))


@njit(cache=True, inline="always")
def interpolate(y0, q, h, theta, out):
    """Dense output y(t0 + theta h) = y0 + h * Q @ [theta, theta^2, theta^3, theta^4]."""
    t2 = theta * theta
    t3 = t2 * theta
    t4 = t3 * theta
    for i in range(N_STATE):
        out[i] = y0[i] + h * (q[i, 0] * theta + q[i, 1] * t2 + q[i, 2] * t3 + q[i, 3] * t4)


@njit(cache=True)
def find_root(kind, y0, q, h, p, phase, ga, gb, a, b, work):
    """Root of an event function on the dense output, theta in [a, b] (Illinois regula falsi)."""
    side = 0
    for _ in range(ROOT_ITERATIONS):
        if b - a <= 4e-16 * max(1.0, b):
            break
        c = (a * gb - b * ga) / (gb - ga)
        if not (a < c < b):
            c = 0.5 * (a + b)
        interpolate(y0, q, h, c, work)
        gc = event_value(kind, work, p, phase)
        if gc > 0.0:
            a, ga = c, gc
            if side == 1:
                gb *= 0.5
            side = 1
        else:
            b, gb = c, gc
            if side == -1:
                ga *= 0.5
            side = -1
    return b  # the first point where the event has happened


@njit(cache=True, inline="always")
def peak_quantity(which, y, p):
    """The quantity whose maximum :func:`golden_max` finds: the normal force (0) or the
    magnitude of the spring force (1)."""
    if which == 0:
        return normal_force(y[S_D], y[S_V], p)
    return abs(y[S_FT])


@njit(cache=True)
def golden_max(which, y0, q, h, p, a, b, work):
    """Maximum of :func:`peak_quantity` on the dense output over theta in [a, b]."""
    inv_phi = 0.6180339887498949
    c = b - inv_phi * (b - a)
    d = a + inv_phi * (b - a)
    interpolate(y0, q, h, c, work)
    fc = peak_quantity(which, work, p)
    interpolate(y0, q, h, d, work)
    fd = peak_quantity(which, work, p)
    for _ in range(GOLDEN_ITERATIONS):
        if fc > fd:
            b, d, fd = d, c, fc
            c = b - inv_phi * (b - a)
            interpolate(y0, q, h, c, work)
            fc = peak_quantity(which, work, p)
        else:
            a, c, fc = c, d, fd
            d = a + inv_phi * (b - a)
            interpolate(y0, q, h, d, work)
            fd = peak_quantity(which, work, p)
    if fc > fd:
        return fc, c
    return fd, d


@njit(cache=True)
def initial_phase(y, p):
    """Phase at first touch. Without compliance: the sign of the slip, or the rolling rule.
    With compliance the unloaded spring sticks if the Coulomb cap is open (``mu F_n > 0``);
    when the force starts from zero, it sticks if, to leading order in the overlap, the spring
    loaded by the incident slip stays under the cap (``|s0|/V int_0^d k_t < mu F_n(d)`` at a
    tiny overlap: Mindlin's spring and a Hertz force grow alike, so this compares
    ``lambda |s0|`` with ``mu V``; a linear spring under a Hertz force outgrows the cap)."""
    s = y[S_U] + p[P_R] * y[S_W]
    if p[P_TLAW] == TLAW_NONE:
        if s > 0.0:
            return 1
        if s < 0.0:
            return -1
        return phase_after_stick(y, p)
    if p[P_MU] <= 0.0:
        return 1 if s >= 0.0 else -1  # no friction: the spring never loads
    if normal_force(y[S_D], y[S_V], p) > 0.0 or s == 0.0:
        return 0
    d = 1e-6 * p[P_DSCALE]
    if p[P_TLAW] == TLAW_SQRT:
        spring = p[P_KT] * d * math.sqrt(d) / 1.5
    else:
        spring = p[P_KT] * d
    vn = -y[S_V]
    if abs(s) / vn * spring <= p[P_MU] * normal_force(d, y[S_V], p):
        return 0
    return 1 if s > 0.0 else -1


@njit(cache=True)
def phase_after_stick(y, p):
    """Rigid contact: roll if Coulomb friction can hold the contact point still, else slide
    with gravity."""
    fn = normal_force(y[S_D], y[S_V], p)
    need = rolling_friction(p)
    if abs(need) <= p[P_MU] * fn:
        return 0
    return 1 if p[P_GX] > 0.0 else -1


@njit(cache=True)
def phase_after_event(event, y, p, phase):
    """The tangential phase after a stick or slip event at state ``y`` (compliant: the spring
    force is set onto the cap when the contact grips, as the cap held it while sliding)."""
    if p[P_TLAW] != TLAW_NONE:
        if event == EV_STICK:  # grip: elastic stick from the cap
            y[S_FT] = -phase * p[P_MU] * normal_force(y[S_D], y[S_V], p)
            return 0
        return 1 if y[S_FT] < 0.0 else -1  # the spring reached the cap: slide
    if event == EV_STICK:
        return phase_after_stick(y, p)
    return 1 if p[P_GX] > 0.0 else -1


@njit(cache=True)
def store_segment(segs, n, t, h, theta_end, phase, y0, q):
    """Keep the dense output of an accepted step (``segs`` has no rows when not recording)."""
    if n >= segs.shape[0]:
        return
    row = segs[n]
    row[G_T0] = t
    row[G_H] = h
    row[G_THETA] = theta_end
    row[G_PHASE] = phase
    for i in range(N_STATE):
        row[G_Y0 + i] = y0[i]
        for j in range(4):
            row[G_Q + 4 * i + j] = q[i, j]


@njit(cache=True)
def sample_segments(segs, n_segs, p, times, final, final_phase, hist):
    """Sample the kept dense output at ascending ``times`` (from 0 to the separation time):
    state, normal force, friction force and phase per row of ``hist``. Times at or after the
    end of the last segment take the final state (exactly the reported rebound)."""
    q = np.empty((N_STATE, 4))
    work = np.empty(N_STATE)
    t_end = segs[n_segs - 1, G_T0] + segs[n_segs - 1, G_THETA] * segs[n_segs - 1, G_H]
    k = 0
    for io in range(times.shape[0]):
        t = times[io]
        if t >= t_end:
            for i in range(N_STATE):
                work[i] = final[i]
            phase = final_phase
        else:
            while k + 1 < n_segs and segs[k + 1, G_T0] < t:
                k += 1
            row = segs[k]
            for i in range(N_STATE):
                for j in range(4):
                    q[i, j] = row[G_Q + 4 * i + j]
            interpolate(row[G_Y0:G_Q], q, row[G_H], (t - row[G_T0]) / row[G_H], work)
            phase = row[G_PHASE]
        fn = normal_force(work[S_D], work[S_V], p)
        for i in range(N_STATE):
            hist[io, i] = work[i]
        hist[io, H_FN] = fn
        hist[io, H_FT] = friction_force(fn, work, phase, p)
        if p[P_TLAW] != TLAW_NONE:
            hist[io, S_FT] = hist[io, H_FT]  # the spring force (held at the cap in slip)
        hist[io, H_PHASE] = phase


@njit(cache=True)
def dense_coefficients(k, q):
    """Q = K^T P: the dense-output polynomial of the last step (computed only when needed)."""
    for i in range(N_STATE):
        for j in range(4):
            acc = 0.0
            for s in range(7):
                acc += k[s, i] * DENSE[s, j]
            q[i, j] = acc


@njit(cache=True)
def phase_event_kind(phase, p):
    """The event that ends the current tangential phase (``EV_NONE``: nothing can)."""
    if p[P_TLAW] != TLAW_NONE:
        if p[P_MU] <= 0.0:
            return EV_NONE
        return EV_SLIP if phase == 0 else EV_STICK
    if phase != 0:
        return EV_STICK
    if p[P_GX] != 0.0:
        return EV_SLIP
    return EV_NONE


@njit(cache=True)
def dopri_step(y, h, p, phase, k, tmp, y1, scale, rtol, atol):
    """One Dormand–Prince 5(4) step from ``y`` (``k[0]`` = f(y)); returns the error norm."""
    for i in range(N_STATE):
        tmp[i] = y[i] + h * A21 * k[0, i]
    rhs(tmp, p, phase, k[1])
    for i in range(N_STATE):
        tmp[i] = y[i] + h * (A31 * k[0, i] + A32 * k[1, i])
    rhs(tmp, p, phase, k[2])
    for i in range(N_STATE):
        tmp[i] = y[i] + h * (A41 * k[0, i] + A42 * k[1, i] + A43 * k[2, i])
    rhs(tmp, p, phase, k[3])
    for i in range(N_STATE):
        tmp[i] = y[i] + h * (A51 * k[0, i] + A52 * k[1, i] + A53 * k[2, i] + A54 * k[3, i])
    rhs(tmp, p, phase, k[4])
    for i in range(N_STATE):
        tmp[i] = y[i] + h * (A61 * k[0, i] + A62 * k[1, i] + A63 * k[2, i] + A64 * k[3, i]
                             + A65 * k[4, i])
    rhs(tmp, p, phase, k[5])
    for i in range(N_STATE):
        y1[i] = y[i] + h * (B1 * k[0, i] + B3 * k[2, i] + B4 * k[3, i] + B5 * k[4, i]
                            + B6 * k[5, i])
    rhs(y1, p, phase, k[6])
    err = 0.0
    n_err = N_STATE if p[P_TLAW] != TLAW_NONE else N_STATE - 1  # no spring: its zero skipped
    for i in range(n_err):
        e = h * (E1 * k[0, i] + E3 * k[2, i] + E4 * k[3, i] + E5 * k[4, i] + E6 * k[5, i]
                 + E7 * k[6, i])
        sc = atol * scale[i] + rtol * max(abs(y[i]), abs(y1[i]))
        err += (e / sc) ** 2
    return math.sqrt(err / n_err)


@njit(cache=True)
def solve_contact(p, y0, scale, h_max, t_max, rtol, atol, max_steps, segs, res):
    """Integrate one contact phase from first touch to separation; fill ``res``; return status.

    ``segs`` (rows of ``N_SEGMENT``) receives the dense output of every accepted step when it
    has rows (``max_steps`` rows always suffice), for :func:`sample_segments`.
    """
    if not finite_inputs(p, y0, scale, h_max, t_max):
        return ST_NONFINITE
    y = y0.copy()
    y1 = np.empty(N_STATE)
    work = np.empty(N_STATE)
    k = np.empty((7, N_STATE))
    q = np.empty((N_STATE, 4))
    tmp = np.empty(N_STATE)
    phase = initial_phase(y, p)
    rhs(y, p, phase, k[0])
    t = 0.0
    h = 1e-4 * h_max
    h_min = 1e-12 * h_max
    fn0 = normal_force(y[S_D], y[S_V], p)
    fn_peak, t_fn_peak, v_fn_peak = fn0, 0.0, y[S_V]
    ft_peak = abs(friction_force(fn0, y, phase, p))
    compliant = p[P_TLAW] != TLAW_NONE
    d_max = max(y[S_D], 0.0)
    n_steps = 0  # accepted steps
    n_attempts = 0  # accepted and rejected: what max_steps caps
    n_switch = 0
    # Event functions and the force rate at the start of the step, carried between steps.
    kind = phase_event_kind(phase, p)
    g_sep = event_value(EV_SEPARATION, y, p, phase)
    g_phase = event_value(kind, y, p, phase) if kind != EV_NONE else 0.0
    if compliant:
        g_phase = max(g_phase, 0.0)  # at first touch the cap may be exactly reached (zero)
    rate0 = normal_force_rate(y, k[0], p)
    while True:
        if n_attempts >= max_steps:
            return ST_MAX_STEPS
        if t >= t_max:
            return ST_NO_SEPARATION
        h = min(h, h_max)
        if not (h >= h_min):  # also catches NaN
            return ST_STEP_UNDERFLOW if h < h_min else ST_NONFINITE
        n_attempts += 1
        err = dopri_step(y, h, p, phase, k, tmp, y1, scale, rtol, atol)
        if not (err <= 1.0):  # also catches NaN
            h *= MIN_FACTOR if err != err else max(MIN_FACTOR, SAFETY * err ** -0.2)
            continue
        n_steps += 1
        have_q = False
        theta_end = 1.0
        event = EV_NONE
        g_sep1 = event_value(EV_SEPARATION, y1, p, phase)
        if y1[S_V] > 0.0 and g_sep > 0.0 and g_sep1 <= 0.0:
            dense_coefficients(k, q)
            have_q = True
            theta_end = find_root(EV_SEPARATION, y, q, h, p, phase, g_sep, g_sep1, 0.0, 1.0,
                                  work)
            event = EV_SEPARATION
        theta_sep = theta_end
        g_phase1 = 0.0
        if kind != EV_NONE:
            if event == EV_NONE:
                g_phase1 = event_value(kind, y1, p, phase)
            else:
                interpolate(y, q, h, theta_end, work)
                g_phase1 = event_value(kind, work, p, phase)
            if kind == EV_STICK and not compliant:
                start_ok, end_hit = g_phase > 0.0, g_phase1 <= 0.0
            else:
                start_ok, end_hit = g_phase >= 0.0, g_phase1 < 0.0
            if start_ok and end_hit:
                if not have_q:
                    dense_coefficients(k, q)
                    have_q = True
                theta_end = find_root(kind, y, q, h, p, phase, g_phase, g_phase1, 0.0,
                                      theta_end, work)
                event = kind
        if event != EV_NONE and event != EV_SEPARATION and theta_end >= theta_sep:
            event = EV_SEPARATION  # a phase event at separation itself: the ball leaves
        if event != EV_NONE:
            interpolate(y, q, h, theta_end, y1)
            rhs(y1, p, phase, k[6])
        t_end = t + theta_end * h
        # Maximum overlap where the normal velocity changes sign.
        if y[S_V] < 0.0 and y1[S_V] >= 0.0:
            if not have_q:
                dense_coefficients(k, q)
                have_q = True
            th = find_root(EV_MAX_OVERLAP, y, q, h, p, phase, -y[S_V], -y1[S_V], 0.0, theta_end,
                           work)
            interpolate(y, q, h, th, work)
            d_max = max(d_max, work[S_D])
        d_max = max(d_max, y1[S_D])
        # Peak normal (and friction) force: the end point, or an interior maximum.
        fn1 = normal_force(y1[S_D], y1[S_V], p)
        if fn1 > fn_peak:
            fn_peak, t_fn_peak, v_fn_peak = fn1, t_end, y1[S_V]
        ft_peak = max(ft_peak, abs(friction_force(fn1, y1, phase, p)))
        rate1 = normal_force_rate(y1, k[6], p)
        if rate0 > 0.0 and rate1 < 0.0:
            if not have_q:
                dense_coefficients(k, q)
                have_q = True
            fmax, th = golden_max(0, y, q, h, p, 0.0, theta_end, work)
            if fmax > fn_peak:
                interpolate(y, q, h, th, work)
                fn_peak, t_fn_peak, v_fn_peak = fmax, t + th * h, work[S_V]
            if phase != 0:  # sliding: the friction peaks with the normal force
                ft_peak = max(ft_peak, p[P_MU] * fmax)
        if compliant and phase == 0 and y[S_FT] * k[0, S_FT] > 0.0 \
                and y1[S_FT] * k[6, S_FT] < 0.0:  # the spring force peaks inside the step
            if not have_q:
                dense_coefficients(k, q)
                have_q = True
            ft_peak = max(ft_peak, golden_max(1, y, q, h, p, 0.0, theta_end, work)[0])
        if segs.shape[0] > 0:
            if not have_q:
                dense_coefficients(k, q)
            store_segment(segs, n_steps - 1, t, h, theta_end, phase, y, q)
        t = t_end
        for i in range(N_STATE):
            y[i] = y1[i]
        if event == EV_SEPARATION:
            res[R_TC] = t
            for i in range(N_STATE):
                res[R_X + i] = y[i]
            res[R_FT] = friction_force(normal_force(y[S_D], y[S_V], p), y, phase, p) \
                if compliant else 0.0
            res[R_FN_PEAK] = fn_peak
            res[R_FT_PEAK] = ft_peak
            res[R_D_MAX] = d_max
            res[R_PHASE] = phase
            res[R_STEPS] = n_steps
            res[R_SWITCHES] = n_switch
            res[R_T_FN_PEAK] = t_fn_peak
            res[R_V_FN_PEAK] = v_fn_peak
            return ST_OK
        if event == EV_NONE:
            for i in range(N_STATE):
                k[0, i] = k[6, i]
            g_sep, g_phase, rate0 = g_sep1, g_phase1, rate1
        else:
            phase = phase_after_event(event, y, p, phase)
            n_switch += 1
            rhs(y, p, phase, k[0])
            ft_peak = max(ft_peak, abs(friction_force(fn1, y, phase, p)))
            kind = phase_event_kind(phase, p)
            g_sep = event_value(EV_SEPARATION, y, p, phase)
            g_phase = event_value(kind, y, p, phase) if kind != EV_NONE else 0.0
            if compliant:
                g_phase = max(g_phase, 0.0)  # on the switching surface: zero up to rounding
            rate0 = normal_force_rate(y, k[0], p)
        h *= MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** -0.2)


@njit(cache=True)
def finite_inputs(p, y0, scale, h_max, t_max):
    """Whether the element's arrays are finite and its step and time limits positive (inputs
    that overflowed while being prepared would otherwise give infinite step sizes)."""
    if not (0.0 < h_max < math.inf and 0.0 < t_max < math.inf):
        return False
    for i in range(N_STATE):
        if not (math.isfinite(y0[i]) and 0.0 < scale[i] < math.inf):
            return False
    for i in range(N_PARAMS):
        if not math.isfinite(p[i]):
            return False
    return True


@njit(cache=True, parallel=True)
def solve_batch(params, y0, scale, h_max, t_max, rtol, atol, max_steps, status, res):
    """Solve every element whose status is still OK, in parallel over elements."""
    no_segments = np.empty((0, N_SEGMENT))
    for i in prange(params.shape[0]):
        if status[i] == ST_OK:
            status[i] = solve_contact(params[i], y0[i], scale[i], h_max[i], t_max[i], rtol, atol,
                                      max_steps, no_segments, res[i])
