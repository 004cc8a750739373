"""Independent generator of 3-D trajectories of a light spinning ball bouncing several times.

What it simulates, written from textbook physics without the package's kinematics code (it does
not import bouncebayes), so that the package recovering its bounces is evidence:

- a 40 mm hollow ball of 2.7 g (a table-tennis ball; ITTF ball standard), inertia
  ``I = (2/3) m r^2`` (thin shell);
- flight (``scipy.integrate.solve_ivp``, DOP853, rtol 1e-11) under gravity, quadratic air drag
  and Magnus lift: ``m r'' = m g - (1/2) rho A C_d |v| v + (1/2) rho A C_L |v| (w_hat x v)``,
  ``rho = 1.2 kg/m^3``, ``C_d = 0.5`` (a sphere at Re ~ 1e4; F.M. White, Fluid Mechanics, 2011),
  ``C_L = S / (2 S + 1)`` with spin ratio ``S = r |w| / |v|`` (a saturating lift, 0.1-0.5 over
  the spin ratios of table-tennis strokes, cf. the measurements summarised by Nakashima et al.,
  J. Syst. Des. Dyn. 4 (2010) 473); the spin is constant in flight;
- an instantaneous rigid-body bounce on the floor ``y = r`` (normal ``+y``): the normal velocity
  reverses with a restitution ``e``; the contact point's slip ``s = v_t + w x (-r y_hat)`` is
  reduced by a Coulomb impulse ``|J_t| = min(mu (1 + e) m |v_n|, m |s| / (1 + 1/kappa))``
  against ``s`` (gross slip, or rolling when the slip stops; Brody, Am. J. Phys. 52 (1984)
  140), which also changes the spin;
- samples at ``rate`` (random phase) with Gaussian position noise.

The truth of each bounce is the velocity just before and just after the impact, at the impact
time: there the two flights meet, which is what the kinematics estimates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

RADIUS = 0.02  # m
MASS = 2.7e-3  # kg
KAPPA = 2.0 / 3.0  # thin shell
RHO_AIR = 1.2  # kg/m^3
C_DRAG = 0.5
G = 9.81
AREA = math.pi * RADIUS**2
DRAG_K = RHO_AIR * AREA * C_DRAG / (2 * MASS)  # 1/m, = 0.14


@dataclass(frozen=True)
class Bounce:
    """True state at one impact (3-D; y up)."""

    time: float
    v_in: np.ndarray
    v_out: np.ndarray
    spin_in: np.ndarray  # rad/s vector

    def observables(self) -> dict[str, float]:
        """Speeds and angles from the normal in the plane of incidence (rebound: its
        projection onto that plane), the spin about the plane's normal axis (counter-clockwise
        with x along the travel and y up)."""
        h = math.hypot(self.v_in[0], self.v_in[2])
        e = np.array([self.v_in[0] / h, 0.0, self.v_in[2] / h])
        u = float(self.v_out @ e)
        axis = np.cross(e, [0.0, 1.0, 0.0])  # e x y_hat: "out of the page"
        return {"incidence_speed": float(np.linalg.norm(self.v_in)),
                "incidence_angle": math.degrees(math.atan2(h, -self.v_in[1])),
                "rebound_speed": math.hypot(u, self.v_out[1]),
                "rebound_angle": math.degrees(math.atan2(u, self.v_out[1])),
                "incidence_spin": float(self.spin_in @ axis)}


def _rhs(_, s, w):
    v = s[3:]
    speed = np.linalg.norm(v)
    wn = np.linalg.norm(w)
    acc = np.array([0.0, -G, 0.0]) - DRAG_K * speed * v
    if wn > 0 and speed > 0:
        ratio = RADIUS * wn / speed
        c_lift = ratio / (2 * ratio + 1)
        acc = acc + RHO_AIR * AREA * c_lift / (2 * MASS) * speed * np.cross(w / wn, v)
    return np.concatenate([v, acc])


def _floor(_, s, w):
    return s[1] - RADIUS


_floor.terminal = True  # type: ignore[attr-defined]
_floor.direction = -1  # type: ignore[attr-defined]


def _bounce(v: np.ndarray, w: np.ndarray, e: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    vn = v[1]
    vt = np.array([v[0], 0.0, v[2]])
    r_c = np.array([0.0, -RADIUS, 0.0])
    slip = vt + np.cross(w, r_c)
    s = np.linalg.norm(slip)
    v_new = vt.copy()
    w_new = w.copy()
    if s > 0:
        j = min(mu * (1 + e) * MASS * abs(vn), MASS * s / (1 + 1 / KAPPA))
        impulse = -j * slip / s
        v_new = vt + impulse / MASS
        w_new = w + np.cross(r_c, impulse) / (KAPPA * MASS * RADIUS**2)
    v_new[1] = -e * vn
    return v_new, w_new


def simulate(rng, *, speed, angle_deg, azimuth_deg, spin, n_bounces=3, rate=150.0,
             noise=5e-4, e=0.88, mu=0.25, height=0.25):
    """Sampled noisy positions ``(t, xyz)`` and the true :class:`Bounce` list.

    The ball starts ``height`` above the floor moving so that it arrives at about ``speed`` and
    ``angle_deg`` from the normal, heading ``azimuth_deg`` from x in the floor plane, with spin
    vector ``spin`` (rad/s); the record runs from the start to half-way up after the last
    bounce.
    """
    a, az = math.radians(angle_deg), math.radians(azimuth_deg)
    v = speed * np.array([math.sin(a) * math.cos(az), -math.cos(a), math.sin(a) * math.sin(az)])
    state = np.r_[0.0, RADIUS + height, 0.0, v]
    w = np.asarray(spin, dtype=float)
    t0, pieces, bounces = 0.0, [], []
    for _ in range(n_bounces):
        sol = solve_ivp(_rhs, (t0, t0 + 5.0), state, args=(w,), method="DOP853", rtol=1e-11,
                        atol=1e-13, events=_floor, dense_output=True)
        t_hit = float(sol.t_events[0][0])
        hit = sol.y_events[0][0]
        pieces.append((t0, t_hit, sol.sol))
        v_out, w_out = _bounce(hit[3:], w, e, mu)
        bounces.append(Bounce(t_hit, hit[3:].copy(), v_out, w.copy()))
        state, w, t0 = np.r_[hit[:3], v_out], w_out, t_hit
    t_end = t0 + 0.5 * state[4] / G  # half-way up after the last bounce
    sol = solve_ivp(_rhs, (t0, t_end), state, args=(w,), method="DOP853", rtol=1e-11,
                    atol=1e-13, dense_output=True)
    pieces.append((t0, t_end, sol.sol))
    times = np.arange(rng.uniform(0, 1 / rate), t_end, 1 / rate)
    pos = np.empty((times.size, 3))
    for lo, hi, f in pieces:
        inside = (times >= lo) & (times < hi)
        pos[inside] = f(times[inside])[:3].T
    return times, pos + rng.normal(0.0, noise, pos.shape), bounces
