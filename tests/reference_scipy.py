"""Independent SciPy reference solution of ONE bounce of the bouncebayes contact model.

What it implements (docs/model.md §1-2 with the project's model specification):

- plane-aligned frame, state ``(x, d, u, vn, w)``: position along the plane, overlap
  ``d = r - y``, tangential velocity, outward normal velocity, spin (counter-clockwise positive);
  the contact starts at ``t = 0`` with ``d = 0``, ``u = V sin(theta)``, ``vn = -V cos(theta)``,
  ``w = spin``;
- Hertz stiffness ``k = (4/3) sqrt(r) E / (1 - nu^2)``; normal force, clamped at >= 0:
  Kelvin–Voigt ``F_n = max(0, k d^1.5 + eta d')`` (eta in kg/s) or Hunt–Crossley
  ``F_n = max(0, k d^1.5 (1 + 1.5 eta d'))`` (eta in s/m), ``d' = -vn``; ``F_n = 0`` for ``d <= 0``;
  the DEM laws from a restitution coefficient ``e`` through the damping ratio
  ``zeta = -ln e / sqrt(pi^2 + ln^2 e)``: the linear spring-dashpot ``k_n d + 2 zeta sqrt(m k_n) d'``
  and Hertz with the LIGGGHTS/EDEM dashpot ``k d^1.5 + 2 sqrt(5/6) zeta sqrt(S_n m) d'``,
  ``S_n = 2 E* sqrt(r d)``;
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
  ``1 - 1.5 eta vn = 0``, whichever comes first (and likewise for the DEM laws);
- tangential compliance (``tangential="mindlin"`` or ``"linear"``, docs/model.md §5.2): the
  tangential force is a spring force ``ft`` (a sixth state) of stiffness ``k_t`` = the ratio
  ``lambda`` times Mindlin's ``2 E* sqrt(r d)`` (the tangent stiffness of the Hertz force), or
  a constant ``lambda m (pi / t_H)^2`` (``t_H`` the elastic Hertz contact time), or
  ``lambda k_n`` under the linear law. In stick ``ft' = -k_t s`` while the overlap grows and
  ``ft' = -k_t s + ft k_t'/k_t`` while it shrinks; when ``|ft|`` reaches ``mu F_n`` the contact
  slides with ``ft = -sigma mu F_n`` (``sigma = -sign ft``), the state following the cap, until
  the elastic rate would take ``|ft|`` below the cap again (``sigma (k_t s - ft
  min(0, k_t')/k_t) = mu F_n'``), where it sticks. At first touch: sliding without friction;
  stick when ``F_n(0) > 0`` or ``s0 = 0``; otherwise the leading-order comparison of the spring
  loaded by the incident slip with the cap (a spring growing like the Hertz force sticks iff
  ``lambda |s0| <= mu V (1 + 1.5 eta V)`` [Hunt–Crossley; ``mu V`` without damping], a
  damped Tsuji force always sticks, a constant spring under a force starting from zero slides).

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
from scipy.special import beta as beta_function

STANDARD_GRAVITY = 9.80665  # m/s^2 (CGPM 1901), the package's default
HERTZ_CONTACT_TIME_CONSTANT = 2.8683  # t_c = 2.8683 (m^2 / (r E*^2 V))^(1/5), docs/model.md §3
# the same constant unrounded, 2 (15/16)^(2/5) (2/5) B(2/5, 1/2) (docs/model.md §7.1), for the
# linear tangential spring's stiffness, which it sets
HERTZ_CONTACT_TIME_EXACT = 2.0 * (15.0 / 16.0) ** 0.4 * 0.4 * float(beta_function(0.4, 0.5))

ROLL = 0  # phase codes: +1 / -1 = sliding with sign(s) = +1 / -1, 0 = rolling
STICK = 2  # compliant contact: the spring holds (elastic stick)


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


def reference_bounce(ball=None, *, mu: float, eta: float = 0.0, speed: float, angle: float,
                     spin: float = 0.0, inclination: float = 0.0,
                     normal_law: str = "kelvin-voigt", gravity: float = STANDARD_GRAVITY,
                     tangential: str = "none", restitution: float | None = None,
                     normal_stiffness: float | None = None,
                     tangential_stiffness_ratio: float | None = None,
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
        mu, eta, speed, angle (deg), spin (rad/s), inclination (deg), normal_law, gravity,
            tangential, restitution, normal_stiffness, tangential_stiffness_ratio: as in
            ``bouncebayes.simulate`` (the ratio defaults to 2(1-nu)/(2-nu)).
        method: ``solve_ivp`` method (``"DOP853"`` for the reference, ``"RK45"`` as a
            benchmark baseline).
        rtol: relative tolerance.
        atol: absolute tolerance as a FRACTION of each component's natural scale: the overlap
            scale (Hertz ``(m Vn^2 / k)^0.4``, linear ``Vn sqrt(m / k_n)``) for ``x`` and
            ``d``, ``V`` for ``u`` and ``vn``, ``V / r`` for ``w``, ``m V^2`` over the overlap
            scale for the spring force.
        max_contact_time_factor: give up (``RuntimeError``) after this many elastic contact
            times without separation.
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
    if normal_law not in ("kelvin-voigt", "hunt-crossley", "linear-dashpot", "hertz-tsuji"):
        raise ValueError(f"unknown normal_law {normal_law!r}")
    if tangential not in ("none", "mindlin", "linear"):
        raise ValueError(f"unknown tangential {tangential!r}")
    mu, eta, speed, angle = float(mu), float(eta), float(speed), float(angle)
    spin, inclination, gravity = float(spin), float(inclination), float(gravity)

    inertia = kappa * m * r * r
    e_star = e_mod / (1.0 - nu * nu)
    linear = normal_law == "linear-dashpot"
    k = float(normal_stiffness) if linear else 4.0 / 3.0 * math.sqrt(r) * e_star
    if normal_law in ("linear-dashpot", "hertz-tsuji"):
        log_e = math.log(float(restitution))
        zeta = -log_e / math.sqrt(math.pi**2 + log_e**2)  # as DEM codes set it
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

    if linear:
        d_scale = vnormal * math.sqrt(m / k)
        t_hertz = math.pi * math.sqrt(m / k)  # half period of the undamped spring
    else:
        d_scale = (m * vnormal**2 / k) ** 0.4
        t_hertz = HERTZ_CONTACT_TIME_CONSTANT * (m * m / (r * e_star**2 * vnormal)) ** 0.2
    atol_vec = atol * np.array([d_scale, d_scale, speed, speed, speed / r])
    t_max = max_contact_time_factor * t_hertz

    # --- forces -------------------------------------------------------------------------
    def signed(d, power):
        return math.copysign(abs(d) ** power, d)  # smooth through d = 0

    if normal_law == "kelvin-voigt":
        def unclamped(d, vn):
            # k d^1.5 + eta d', d' = -vn; signed power keeps it smooth through d = 0
            return k * signed(d, 1.5) - eta * vn
    elif normal_law == "hunt-crossley":
        def unclamped(d, vn):
            return k * signed(d, 1.5) * (1.0 - 1.5 * eta * vn)
    elif linear:
        c_lin = 2.0 * zeta * math.sqrt(m * k)

        def unclamped(d, vn):
            return k * d - c_lin * vn
    else:
        def unclamped(d, vn):
            # the LIGGGHTS / EDEM dashpot, written as the manuals do: S_n = 2 E* sqrt(r d)
            s_n = 2.0 * e_star * math.sqrt(r * max(d, 0.0))
            c_n = 2.0 * math.sqrt(5.0 / 6.0) * zeta * math.sqrt(s_n * m)
            return k * signed(d, 1.5) - c_n * vn

    def normal_force(d, vn):
        # F_n = 0 out of contact; at d == 0 exactly we take the limit from inside the contact,
        # so that the Kelvin-Voigt jump F_n(0+) = eta V cos(theta) is seen by the first stage
        if d < 0.0:
            return 0.0
        f = unclamped(d, vn)
        return f if f > 0.0 else 0.0

    def force_rate(d, vn, acc):
        """d/dt of the unclamped normal force, acc = vn'."""
        dd = -vn
        if normal_law == "kelvin-voigt":
            return 1.5 * k * math.sqrt(max(d, 0.0)) * dd - eta * acc
        if normal_law == "hunt-crossley":
            return (1.5 * k * math.sqrt(max(d, 0.0)) * dd * (1.0 - 1.5 * eta * vn)
                    - 1.5 * eta * k * max(d, 0.0) ** 1.5 * acc)
        if linear:
            return k * dd - c_lin * acc
        # c_n(d) = C d^(1/4): d/dt (c_n vn) = C (d^(1/4) acc + (1/4) d^(-3/4) dd vn)
        big_c = 2.0 * math.sqrt(5.0 / 6.0) * zeta * math.sqrt(2.0 * e_star * math.sqrt(r) * m)
        dq = max(d, 1e-300) ** 0.25
        return 1.5 * k * math.sqrt(max(d, 0.0)) * dd - big_c * (dq * acc
                                                                 + 0.25 * dd * vn / dq**3)

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

    if normal_law == "hunt-crossley":
        separation_events = [terminal(lambda t, y: y[1], -1.0),
                             terminal(lambda t, y: 1.0 - 1.5 * eta * y[3], -1.0)]
    elif normal_law == "hertz-tsuji":  # F = d^(1/4) (k d^(5/4) - C vn): the bracket
        big_c_t = 2.0 * math.sqrt(5.0 / 6.0) * zeta * math.sqrt(2.0 * e_star * math.sqrt(r) * m)
        separation_events = [terminal(lambda t, y: k * signed(y[1], 1.25) - big_c_t * y[3],
                                      -1.0)]
    else:
        separation_events = [terminal(lambda t, y: unclamped(y[1], y[3]), -1.0)]
    n_sep = len(separation_events)

    def dfn_dt(t, y):
        d, vn = y[1], y[3]
        return force_rate(d, vn, normal_force(d, vn) / m - gy)
    peak_event = nonterminal(dfn_dt, -1.0)  # dF_n/dt goes + -> -: a local maximum
    overlap_event = nonterminal(lambda t, y: y[3], 1.0)  # vn goes - -> +: maximum overlap

    common = dict(r=r, m=m, inertia=inertia, mu=mu, gx=gx, gy=gy, u0=u0, vn0=vn0, spin=spin,
                  linear=linear, method=method, rtol=rtol, t_max=t_max, normal_force=normal_force,
                  force_rate=force_rate, separation_events=separation_events,
                  peak_event=peak_event, overlap_event=overlap_event)
    if tangential != "none":
        ratio = (2.0 * (1.0 - nu) / (2.0 - nu) if tangential_stiffness_ratio is None
                 else float(tangential_stiffness_ratio))
        if linear:
            spring = ("constant", ratio * k)
        elif tangential == "mindlin":
            spring = ("mindlin", ratio * 2.0 * e_star * math.sqrt(r))  # k_t = this sqrt(d)
        else:
            t_exact = HERTZ_CONTACT_TIME_EXACT * (m * m / (r * e_star**2 * vnormal)) ** 0.2
            spring = ("constant", ratio * m * (math.pi / t_exact) ** 2)
        damped_start = normal_force(0.0, vn0) > 0.0
        hc_factor = 1.0 + 1.5 * eta * vnormal if normal_law == "hunt-crossley" else 1.0
        tsuji_damped = normal_law == "hertz-tsuji" and zeta > 0.0
        return _compliant_bounce(common, spring, ratio, damped_start, hc_factor, tsuji_damped,
                                 np.append(atol_vec, atol * m * speed**2 / d_scale))

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


def _compliant_bounce(c: dict, spring: tuple[str, float], ratio: float, damped_start: bool,
                      hc_factor: float, tsuji_damped: bool,
                      atol_vec: np.ndarray) -> ReferenceBounce:
    """One bounce with the tangential spring of the module docstring (state x, d, u, vn, w, ft).

    ``spring``: ("mindlin", C) for k_t = C sqrt(d), or ("constant", k_t).
    """
    r, m, inertia, mu = c["r"], c["m"], c["inertia"], c["mu"]
    gx, gy, normal_force, force_rate = c["gx"], c["gy"], c["normal_force"], c["force_rate"]
    kind, coefficient = spring
    mindlin = kind == "mindlin"

    def k_t(d):
        return coefficient * math.sqrt(max(d, 0.0)) if mindlin else coefficient

    def unloading(d, vn, ft):
        """ft k_t'/k_t while the overlap shrinks (vn > 0), else 0: k_t'/k_t = d'/(2 d)."""
        if not mindlin or vn <= 0.0 or d <= 0.0 or ft == 0.0:
            return 0.0
        return ft * (-vn) / (2.0 * d)

    def make_rhs(phase):
        def rhs(t, y):
            _, d, u, vn, w, ft = y.tolist()
            fn = normal_force(d, vn)
            acc = fn / m - gy
            if phase == STICK:
                force = ft
                dft = -k_t(d) * (u + r * w) + unloading(d, vn, ft)
            else:  # the spring rides on the cap: ft = -phase mu F_n
                force = -phase * mu * fn
                dft = -phase * mu * force_rate(d, vn, acc) if fn > 0.0 else 0.0
            return [u, -vn, force / m + gx, acc, r * force / inertia, dft]
        return rhs

    def terminal(fun, direction=-1.0):
        fun.terminal, fun.direction = True, direction
        return fun

    def switch_event(phase):
        if mu == 0.0:
            return None
        if phase == STICK:  # the spring reaches the Coulomb cap
            return terminal(lambda t, y: mu * normal_force(y[1], y[3]) - abs(y[5]))

        def grip(t, y):  # the elastic rate no longer pushes the spring beyond the cap
            d, vn = y[1], y[3]
            fn = normal_force(d, vn)
            cap_rate = mu * force_rate(d, vn, fn / m - gy)
            elastic = k_t(d) * (y[2] + r * y[4]) - unloading(d, vn, -phase * mu * fn)
            return phase * elastic - cap_rate
        return terminal(grip)

    def spring_peak(t, y):  # |ft| has an interior maximum where ft' = 0 in stick
        _, d, u, vn, w, ft = y.tolist()
        return -k_t(d) * (u + r * w) + unloading(d, vn, ft)
    spring_peak.terminal = False

    # --- the phase at first touch ----------------------------------------------------------
    s0 = c["u0"] + r * c["spin"]
    grows_like_the_force = mindlin or c["linear"]  # a spring and a cap both ~ d^1.5 (or ~ d)
    if mu == 0.0:
        phase = 1 if s0 >= 0.0 else -1
    elif damped_start or s0 == 0.0 or tsuji_damped:
        phase = STICK
    elif grows_like_the_force and ratio * abs(s0) <= mu * (-c["vn0"]) * hc_factor:
        phase = STICK
    else:
        phase = 1 if s0 > 0.0 else -1
    return _run_phases(c, phase, make_rhs, switch_event, spring_peak, atol_vec)


def _run_phases(c: dict, phase: int, make_rhs, switch_event, spring_peak,
                atol_vec: np.ndarray) -> ReferenceBounce:
    """The phase loop of :func:`_compliant_bounce`: each phase a ``solve_ivp`` run ended by
    separation or by its switch event."""
    mu, normal_force = c["mu"], c["normal_force"]
    sep, n_sep = c["separation_events"], len(c["separation_events"])
    t0 = 0.0
    y0 = np.array([0.0, 0.0, c["u0"], c["vn0"], c["spin"], 0.0])
    phases, switch_times = [phase], []
    peak_fn = normal_force(0.0, c["vn0"])
    peak_ft, max_d, nfev = 0.0, 0.0, 0
    for _ in range(1000):
        sw = switch_event(phase)
        events = list(sep) + [c["peak_event"], c["overlap_event"], spring_peak]
        if sw is not None:
            events.append(sw)
        sol = solve_ivp(make_rhs(phase), (t0, c["t_max"]), y0, method=c["method"],
                        rtol=c["rtol"], atol=atol_vec, events=events)
        nfev += sol.nfev
        if sol.status != 1:
            raise RuntimeError(f"no separation or solve_ivp failure: {sol.message}")
        y_end = sol.y[:, -1]
        fn_seg = [normal_force(y0[1], y0[3]), normal_force(y_end[1], y_end[3])]
        fn_seg += [normal_force(yy[1], yy[3]) for yy in sol.y_events[n_sep]]
        max_d = max([max_d, y0[1], y_end[1]] + [yy[1] for yy in sol.y_events[n_sep + 1]])
        peak_fn = max(peak_fn, max(fn_seg))
        if phase == STICK:
            peak_ft = max([peak_ft, abs(y0[5]), abs(y_end[5])]
                          + [abs(yy[5]) for yy in sol.y_events[n_sep + 2]])
        else:
            peak_ft = max(peak_ft, mu * max(fn_seg))
        t_end = float(sol.t[-1])
        if any(len(sol.t_events[i]) for i in range(n_sep)):
            break
        y0 = y_end.copy()
        if phase == STICK:  # the spring reached the cap: slide against it
            phase = 1 if y0[5] < 0.0 else -1
        else:  # grip: stick from the cap
            y0[5] = -phase * mu * normal_force(y0[1], y0[3])
            phase = STICK
        phases.append(phase)
        switch_times.append(t_end)
        t0 = t_end
    else:
        raise RuntimeError("more than 1000 phase switches (chattering?)")
    _, d_sep, u, vn, w, _ = (float(v) for v in y_end)
    return ReferenceBounce(
        rebound_speed=math.hypot(u, vn), rebound_angle=math.degrees(math.atan2(u, vn)),
        rebound_spin=w, rebound_tangential_velocity=u, rebound_normal_velocity=vn,
        contact_time=t_end, peak_normal_force=peak_fn, peak_friction_force=peak_ft,
        max_overlap=max_d, separation_overlap=d_sep, rolling=phase == STICK,
        phases=tuple(phases), switch_times=tuple(switch_times), nfev=nfev)
