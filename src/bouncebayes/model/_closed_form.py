"""Closed-form reference results of docs/model.md §3 (Hertz elastic impact, rigid-body oblique impact).

These are exact limits the simulator must reproduce; they are public because users check their
own numbers against them too.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.special import beta

from ._config import Ball

# t_c = C (m^2 / (r E*^2 V))^(1/5) with C = 2 (15/16)^(2/5) (2/5) B(2/5, 1/2) = 2.868266...
# (integrating dt = d delta / v over the Hertz energy balance); docs/model.md §3 prints it as 2.8683.
HERTZ_CONTACT_TIME_CONSTANT = 2.0 * (15.0 / 16.0) ** 0.4 * 0.4 * float(beta(0.4, 0.5))


class HertzImpact(NamedTuple):
    """Elastic (undamped, frictionless) normal impact of a sphere on a rigid plane."""

    max_overlap: np.ndarray  #: m
    contact_time: np.ndarray  #: s
    peak_force: np.ndarray  #: N


def hertz_elastic_impact(ball: Ball, normal_speed: float | np.ndarray) -> HertzImpact:
    """Hertz closed forms for a normal impact at ``normal_speed`` (m/s), without gravity.

    ``delta_max = (15 m V^2 / (16 E* sqrt(r)))^(2/5)``, ``F_max = k delta_max^(3/2)``,
    ``t_c = 2.868266 (m^2 / (r E*^2 V))^(1/5)`` (docs/model.md §3, which rounds the constant to
    2.8683; Johnson, Contact Mechanics, §11.4).
    """
    v = np.asarray(normal_speed, dtype=float)
    m, r, e_star = ball.mass, ball.radius, ball.effective_modulus
    d_max = (15.0 * m * v**2 / (16.0 * e_star * np.sqrt(r))) ** 0.4
    t_c = HERTZ_CONTACT_TIME_CONSTANT * (m**2 / (r * e_star**2 * v)) ** 0.2
    return HertzImpact(d_max, t_c, ball.hertz_stiffness * d_max**1.5)


class RigidBodyRebound(NamedTuple):
    """Rebound of a rigid sphere with Coulomb friction and normal restitution ``e``."""

    tangential_velocity: np.ndarray  #: m/s, along the plane
    normal_velocity: np.ndarray  #: m/s, outward
    spin: np.ndarray  #: rad/s, counter-clockwise
    rolling: np.ndarray  #: bool: the slip velocity reached zero during the impact


def rigid_body_rebound(*, tangential_velocity, normal_speed, spin, radius, mu, restitution,
                       inertia_factor=0.4) -> RigidBodyRebound:
    """Rigid-body impact law of docs/model.md §3, generalised to ``I = kappa m r^2``.

    With incident tangential velocity ``U``, normal speed ``V`` (> 0, towards the plane), spin
    ``w0`` and slip ``s0 = U + r w0``: if ``mu (1 + e) V < kappa/(1 + kappa) |s0|`` the ball
    slides throughout and ``U' = U - mu (1+e) V sign(s0)``, ``w' = w0 - mu (1+e) V sign(s0) /
    (kappa r)``; otherwise it leaves rolling with ``U' = U - kappa/(1+kappa) s0`` and
    ``w' = w0 - s0 / ((1 + kappa) r)``. For kappa = 2/5 these are the 2/7 and 5/7 of docs/model.md.
    """
    u, v, w = (np.asarray(a, dtype=float) for a in (tangential_velocity, normal_speed, spin))
    kappa = np.asarray(inertia_factor, dtype=float)
    s0 = u + radius * w
    impulse = mu * (1.0 + restitution) * v  # tangential impulse per unit mass if sliding
    sign = np.sign(s0)
    rolling = impulse >= kappa / (1.0 + kappa) * np.abs(s0)
    u_out = np.where(rolling, u - kappa / (1.0 + kappa) * s0, u - impulse * sign)
    w_out = np.where(rolling, w - s0 / ((1.0 + kappa) * radius),
                     w - impulse * sign / (kappa * radius))
    return RigidBodyRebound(u_out, restitution * v, w_out, rolling)
