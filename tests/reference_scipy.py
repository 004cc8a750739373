"""Independent SciPy reference solution of ONE bounce of the bouncebayes contact model.

What it implements (docs/model.md §1-2 with the project's model specification):

- plane-aligned frame, state ``(x, d, u, vn, w)``: position along the plane, overlap
  ``d = r - y``, tangential velocity, outward normal velocity, spin (counter-clockwise positive);
  the contact starts at ``t = 0`` with ``d = 0``, ``u = V sin(theta)``, ``vn = -V cos(theta)``,
  ``w = spin``;
- Hertz stiffness ``k = (4/3) sqrt(r) E / (1 - nu^2)``; normal force, clamped at >= 0:
  Kelvin–Voigt ``F_n = max(0, k d^1.5 + eta d')`` (eta in kg/s) or Hunt–Crossley
  ``F_n = max(0, k d^1.5 (1 + 1.5 eta d'))`` (eta in s/m), ``d' = -vn``; ``F_n = 0`` for ``d <= 0``;
- gravity ``g_x = g sin(beta)`` (positive inclination: the ball travels down-slope) and
  ``g_y = g cos(beta)`` pulling into the plane;
- exact Coulomb friction with stick/slip phases (no regularisation): sliding
  ``F_t = -mu F_n sign(s)``, ``s = u + r w``; when ``s`` reaches 0 the ball rolls if the friction
  needed to keep ``s = 0``, ``F_req = -g_x / (1/m + r^2/I)``, satisfies ``|F_req| <= mu F_n``,
  otherwise it keeps sliding towards ``sign(g_x)``; a rolling ball slides again (towards
  ``sign(g_x)``) once ``|F_req| > mu F_n``; at ``t = 0`` with ``s0 == 0`` the same rule decides;
- ``m u' = F_t + m g_x``, ``m vn' = F_n - m g_y``, ``I w' = r F_t``, ``x' = u``, ``d' = -vn``;
- separation: first zero of the unclamped normal force during restitution: Kelvin–Voigt
  ``k d^1.5 - eta vn = 0`` (``d = 0`` when ``eta = 0``), Hunt–Crossley ``d = 0`` or
  ``1 - 1.5 eta vn = 0``, whichever comes first.

Every phase switch and the separation are terminal events of ``scipy.integrate.solve_ivp``;
integration restarts from the event state in the new phase. The peak normal force is located
with a non-terminal event on ``dF_n/dt = 0`` (plus the phase end points, which catch the
Kelvin–Voigt jump ``F_n(0) = eta V cos(theta)``), the maximum overlap with a non-terminal event
on ``vn = 0``.

Independence: this module was written from docs/model.md and the written model specification only,
WITHOUT reading the package's compiled kernel (``bouncebayes/model/_kernel.py``), and it does not
import bouncebayes, so that agreement between the two is evidence, not tautology.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

STANDARD_GRAVITY = 9.80665  # m/s^2 (CGPM 1901), the package's default
HERTZ_CONTACT_TIME_CONSTANT = 2.8683  # t_c = 2.8683 (m^2 / (r E*^2 V))^(1/5), docs/model.md §3

ROLL = 0  # phase codes: +1 / -1 = sliding with sign(s) = +1 / -1, 0 = rolling


@dataclass(frozen=True)
class ReferenceBounce:
    """Result of :func:`reference_bounce` (SI units; angle in degrees from the normal)."""

    rebound_speed: float
    rebound_angle: float
    rebound_spin: float
    rebound_tangential_velocity: float
    rebound_normal_velocity: float
    contact_time: float
    peak_normal_force: float
    peak_friction_force: float
    max_overlap: float
    separation_overlap: float
    rolling: bool
    phases: tuple[int, ...] = field(default=())  #: phase sequence, e.g. (1, 0) = slide then roll
    switch_times: tuple[float, ...] = field(default=())  #: times of the phase switches, s
    nfev: int = 0  #: right-hand-side evaluations, all phases


def reference_bounce(ball=None, *, mu: float, eta: float, speed: float, angle: float,
                     spin: float = 0.0, inclination: float = 0.0,
                     normal_law: str = "kelvin-voigt", gravity: float = STANDARD_GRAVITY,
                     radius: float | None = None, mass: float | None = None,
                     youngs_modulus: float | None = None, poisson_ratio: float | None = None,
                     inertia_factor: float | None = None, method: str = "DOP853",
                     rtol: float = 1e-12, atol: float = 1e-13,
                     max_contact_time_factor: float = 50.0) -> ReferenceBounce:
    """Solve one bounce from first contact to separation with ``solve_ivp``.

    Arguments:
        ball: any object with ``radius``, ``mass``, ``youngs_modulus``, ``poisson_ratio`` and
            ``inertia_factor`` attributes (e.g. ``bouncebayes.PAPER_BALL``); the keyword
            arguments of the same names override it (or replace it when ``ball`` is None).
        mu, eta, speed, angle (deg), spin (rad/s), inclination (deg), normal_law, gravity:
            as in ``bouncebayes.simulate``.
        method: ``solve_ivp`` method (``"DOP853"`` for the reference, ``"RK45"`` as a
            benchmark baseline).
        rtol: relative tolerance.
        atol: absolute tolerance as a FRACTION of each component's natural scale: the Hertz
            overlap scale ``(m Vn^2 / k)^0.4`` for ``x`` and ``d``, ``V`` for ``u`` and ``vn``,
            ``V / r`` for ``w``.
        max_contact_time_factor: give up (``RuntimeError``) after this many elastic Hertz
            contact times without separation.
    """
    def pick(name, value):
        if value is not None:
            return float(value)
        if ball is None:
            raise TypeError(f"give `ball` or `{name}`")
        return float(getattr(ball, name))

    r = pick("radius", radius)
    m = pick("mass", mass)
    e_mod = pick("youngs_modulus", youngs_modulus)
    nu = pick("poisson_ratio", poisson_ratio)
    kappa = pick("inertia_factor", inertia_factor)
    if normal_law not in ("kelvin-voigt", "hunt-crossley"):
        raise ValueError(f"unknown normal_law {normal_law!r}")
    kv = normal_law == "kelvin-voigt"
    mu, eta, speed, angle = float(mu), float(eta), float(speed), float(angle)
    spin, inclination, gravity = float(spin), float(inclination), float(gravity)

    inertia = kappa * m * r * r
    e_star = e_mod / (1.0 - nu * nu)
    k = 4.0 / 3.0 * math.sqrt(r) * e_star
    beta = math.radians(inclination)
    gx = gravity * math.sin(beta)
    gy = gravity * math.cos(beta)
    theta = math.radians(angle)
    u0 = speed * math.sin(theta)
    vn0 = -speed * math.cos(theta)
    vnormal = -vn0
    # Friction that keeps s = 0 (rolling): s' = F_t (1/m + r^2/I) + g_x = 0.
    f_req = -gx / (1.0 / m + r * r / inertia)
    abs_f_req = abs(f_req)
    sgn_gx = (gx > 0.0) - (gx < 0.0)

    d_scale = (m * vnormal**2 / k) ** 0.4
    t_hertz = HERTZ_CONTACT_TIME_CONSTANT * (m * m / (r * e_star**2 * vnormal)) ** 0.2
    atol_vec = atol * np.array([d_scale, d_scale, speed, speed, speed / r])
    t_max = max_contact_time_factor * t_hertz

    # --- forces -------------------------------------------------------------------------
    if kv:
        def unclamped(d, vn):
            # k d^1.5 + eta d', d' = -vn; signed power keeps it smooth through d = 0
            return k * math.copysign(abs(d) ** 1.5, d) - eta * vn
    else:
        def unclamped(d, vn):
            return k * math.copysign(abs(d) ** 1.5, d) * (1.0 - 1.5 * eta * vn)

    def normal_force(d, vn):
        # F_n = 0 out of contact; at d == 0 exactly we take the limit from inside the contact,
        # so that the Kelvin-Voigt jump F_n(0+) = eta V cos(theta) is seen by the first stage
        if d < 0.0:
            return 0.0
        f = unclamped(d, vn)
        return f if f > 0.0 else 0.0

    def friction(phase, fn):
        return f_req if phase == ROLL else -mu * fn * phase

    def make_rhs(phase):
        def rhs(t, y):
            _, d, u, vn, w = y.tolist()
            fn = normal_force(d, vn)
            ft = friction(phase, fn)
            return [u, -vn, ft / m + gx, fn / m - gy, r * ft / inertia]
        return rhs

    # --- events ---------------------------------------------------------------------------
    def terminal(fun, direction):
        fun.terminal = True
        fun.direction = direction
        return fun

    def nonterminal(fun, direction):
        fun.terminal = False
        fun.direction = direction
        return fun

    if kv:
        separation_events = [terminal(lambda t, y: unclamped(y[1], y[3]), -1.0)]
    else:
        separation_events = [terminal(lambda t, y: y[1], -1.0),
                             terminal(lambda t, y: 1.0 - 1.5 * eta * y[3], -1.0)]
    n_sep = len(separation_events)

    if kv:
        def dfn_dt(t, y):
            # d/dt (k d^1.5 - eta vn) = -1.5 k sqrt(d) vn - eta vn'
            _, d, _, vn, _ = y.tolist()
            fn = normal_force(d, vn)
            return -1.5 * k * math.sqrt(max(d, 0.0)) * vn - eta * (fn / m - gy)
    else:
        def dfn_dt(t, y):
            # d/dt [k d^1.5 (1 - 1.5 eta vn)] = k sqrt(d) [-1.5 vn (1 - 1.5 eta vn)
            #                                             - 1.5 eta d vn'], bracket only
            _, d, _, vn, _ = y.tolist()
            fn = normal_force(d, vn)
            return -vn * (1.0 - 1.5 * eta * vn) - eta * max(d, 0.0) * (fn / m - gy)
    peak_event = nonterminal(dfn_dt, -1.0)  # dF_n/dt goes + -> -: a local maximum
    overlap_event = nonterminal(lambda t, y: y[3], 1.0)  # vn goes - -> +: maximum overlap

    def switch_event(phase):
        if phase == ROLL:
            if abs_f_req == 0.0:
                return None  # |F_req| = 0 <= mu F_n always: rolling never ends
            return terminal(lambda t, y: mu * normal_force(y[1], y[3]) - abs_f_req, -1.0)
        # sliding with sign(s) = phase: s * phase falls to zero
        return terminal(lambda t, y: phase * (y[2] + r * y[4]), -1.0)

    def phase_at_stick(fn):
        """Phase once s = 0, given the normal force there."""
        return ROLL if abs_f_req <= mu * fn else sgn_gx

    # --- phase loop -------------------------------------------------------------------------
    s0 = u0 + r * spin
    fn_start = normal_force(0.0, vn0)  # KV: eta V cos(theta); HC: 0
    if s0 > 0.0:
        phase = 1
    elif s0 < 0.0:
        phase = -1
    else:
        phase = phase_at_stick(fn_start)

    t0 = 0.0
    y0 = np.array([0.0, 0.0, u0, vn0, spin])
    phases = [phase]
    switch_times = []
    peak_fn = fn_start
    peak_ft = 0.0
    max_d = 0.0
    nfev = 0
    for _ in range(1000):
        sw = switch_event(phase)
        events = list(separation_events) + [peak_event, overlap_event]
        if sw is not None:
            events.append(sw)
        sol = solve_ivp(make_rhs(phase), (t0, t_max), y0, method=method, rtol=rtol,
                        atol=atol_vec, events=events)
        nfev += sol.nfev
        if sol.status == -1:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        # candidates for the peaks in this phase: its end points and interior maxima
        fn_seg = [normal_force(y0[1], y0[3])]
        for yy in sol.y_events[n_sep]:
            fn_seg.append(normal_force(yy[1], yy[3]))
        for yy in sol.y_events[n_sep + 1]:
            max_d = max(max_d, yy[1])
        if sol.status != 1:
            raise RuntimeError(f"no separation within {max_contact_time_factor} Hertz "
                               f"contact times (t = {sol.t[-1]:.3g} s)")
        t_end = sol.t[-1]
        y_end = sol.y[:, -1]
        fn_end = normal_force(y_end[1], y_end[3])
        fn_seg.append(fn_end)
        max_d = max(max_d, y_end[1], y0[1])
        peak_fn = max(peak_fn, max(fn_seg))
        peak_ft = max(peak_ft, abs_f_req if phase == ROLL else mu * max(fn_seg))
        separated = any(len(sol.t_events[i]) for i in range(n_sep))
        if separated:
            break
        # phase switch
        if phase == ROLL:
            phase = sgn_gx
        else:
            phase = phase_at_stick(fn_end)
        phases.append(phase)
        switch_times.append(t_end)
        t0, y0 = t_end, y_end.copy()
    else:
        raise RuntimeError("more than 1000 phase switches (chattering?)")

    _, d_sep, u, vn, w = (float(v) for v in y_end)
    return ReferenceBounce(
        rebound_speed=math.hypot(u, vn),
        rebound_angle=math.degrees(math.atan2(u, vn)),
        rebound_spin=w,
        rebound_tangential_velocity=u,
        rebound_normal_velocity=vn,
        contact_time=float(t_end),
        peak_normal_force=peak_fn,
        peak_friction_force=peak_ft,
        max_overlap=max_d,
        separation_overlap=d_sep,
        rolling=phase == ROLL,
        phases=tuple(phases),
        switch_times=tuple(switch_times),
        nfev=nfev,
    )
