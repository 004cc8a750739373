"""The conversions DEM codes use between a restitution coefficient and their damping.

A DEM user sets a restitution coefficient ``e``; the codes turn it into a damping ratio by the
closed form of the linear spring-dashpot oscillator without clamping or gravity,

    zeta = -ln(e) / sqrt(pi^2 + ln(e)^2),        e = exp(-pi zeta / sqrt(1 - zeta^2)),

(``beta = ln e / sqrt(ln^2 e + pi^2) = -zeta`` in the LIGGGHTS and EDEM manuals), and then into
a dashpot: ``c_n = 2 zeta sqrt(m k_n)`` for the linear law (Cundall & Strack 1979; Schwager &
Pöschel 2007 for the restitution it really gives once the force is clamped at zero), and
``c_n = 2 sqrt(5/6) zeta sqrt(S_n m)`` with ``S_n = 2 E* sqrt(R delta)`` for Hertz, i.e.
Tsuji et al.'s ``c_n = alpha sqrt(m k) delta^(1/4)`` with ``alpha = sqrt(5) zeta`` (Tsuji,
Tanaka & Ishida 1992; docs/model.md §4.5-4.6). bouncebayes takes ``e`` as those codes do, so
that an inferred ``restitution`` is the number to type into them; the restitution the clamped
law really produces is a derived quantity (``bouncebayes.model.derived``).
"""

from __future__ import annotations

import numpy as np


def restitution_damping_ratio(restitution) -> np.ndarray:
    """The damping ratio zeta = -ln e / sqrt(pi^2 + ln^2 e) DEM codes set for a restitution
    coefficient ``e`` in (0, 1] (NaN elsewhere)."""
    e = np.asarray(restitution, dtype=float)
    ok = (e > 0.0) & (e <= 1.0)
    with np.errstate(all="ignore"):
        log_e = np.log(np.where(ok, e, 1.0))
        ratio = -log_e / np.sqrt(np.pi**2 + log_e**2)
    return np.where(ok, ratio, np.nan)


def damping_ratio_restitution(damping_ratio) -> np.ndarray:
    """The inverse: e = exp(-pi zeta / sqrt(1 - zeta^2)) for zeta in [0, 1), 0 at and beyond
    critical damping (NaN for negative zeta)."""
    z = np.asarray(damping_ratio, dtype=float)
    under = (z >= 0.0) & (z < 1.0)
    with np.errstate(all="ignore"):
        e = np.exp(-np.pi * z / np.sqrt(np.where(under, 1.0 - z * z, 1.0)))
    return np.where(under, e, np.where(z >= 1.0, 0.0, np.nan))
