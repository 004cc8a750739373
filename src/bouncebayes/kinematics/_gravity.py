"""What the free flights' fall says of the length scale.

A ball in free flight falls at ``g``. The flights' fitted accelerations are in the
trajectories' length unit, so if every length is ``s`` times the true one (a length scale off by
``s - 1``) they come out as ``s g``. Their magnitude, with the air's drag added back where the
ball is known, measures the scale independently of how it was set (the ball's diameter in
pixels, a reference length in the scene): no blur, shading or compression of the footage moves
it, only the frame rate (``s`` goes as its square) and the aerodynamics. Video-analysis
software for teaching (Tracker, D. Brown) offers the same check: the fall of a thrown object
against ``g``.

One bounce gives a :class:`Fall` (its two flights); a campaign, :func:`gravity_scale`: their
weighted mean against the experiment's ``g``, with the statistical error of the fits, the drag
correction's and the Magnus lift's uncertainty (systematic: the same ball in every trial), and
how it compares with the scale uncertainty the tracker stated.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import _drag
from ._flight import Flight

#: Flights whose fall differs from the weighted mean beyond their errors (chi-square p below
#: this) are said to scatter; the standard error is then scaled by sqrt(chi2 / dof) in any case
#: where that exceeds 1 (the Particle Data Group's scale factor).
SCATTER_P = 1e-3
#: |z| above this: the fall and the stated scale disagree (the warning).
DISAGREE_Z = 3.0
#: The summary says the fall would be the better scale where its SD is at most the stated
#: scale's SD over this (10 px balls under a 1.5 px blur: the edge states 7 %, a video's fall
#: 0.4-0.7 %, a campaign's 0.17 %; benchmarks/gravity_scale.py)
PRECISE_RATIO = 3.0
#: The drag coefficient's relative SD where the ball is known, and the SD of each lift
#: component in units of it: as the drag fit's priors (FitConfig.drag_k).
DRAG_REL_SD = 0.5
LIFT_SD_PER_K = 1.0


@dataclass(frozen=True)
class Fall:
    """The fall of one bounce's free flights (before, after the impact), m/s^2.

    ``value``: the magnitude of each flight's fitted acceleration, with the mean drag along
    the flight added back where ``k`` (the ball's drag coefficient, 1/m) is known (a
    constant-acceleration fit of a flight in air gives ``g`` minus the drag's mean); with a
    drag fit, its constant part. ``se``: the fit's standard error of it. ``drag_slope``:
    d(value)/dk (m^2/s^2: the mean of ``|v| v`` along the fall's direction), ``lift_arm``:
    |d(value)/dc| per unit lift coefficient (m^2/s^2; zero for a drag fit, which fits the
    lift), both zero where ``k`` is not known.
    """

    value: tuple[float, ...]
    se: tuple[float, ...]
    drag_slope: tuple[float, ...]
    lift_arm: tuple[float, ...]
    k: float | None = None


def flight_fall(flight: Flight, k: float | None) -> tuple[float, float, float, float]:
    """(value, se, drag_slope, lift_arm) of one flight (see :class:`Fall`)."""
    d = flight.d
    a = np.asarray(flight.acceleration, dtype=float)
    quadratic = flight.model == "quadratic"
    idx = [3 * c + 2 for c in range(d)] if quadratic else list(range(2 * d, 3 * d))
    cov = (4.0 if quadratic else 1.0) * flight.cov[np.ix_(idx, idx)]
    slope = arm = 0.0
    if k is not None and flight.tau is not None:
        a, slope, arm = _aero(flight, flight.tau, a, k)
    value = float(np.linalg.norm(a))
    u = a / value if value > 0 else np.eye(d)[-1]
    se = math.sqrt(max(float(u @ cov @ u), 0.0))
    return value, se, slope, arm


def _aero(flight: Flight, tau: np.ndarray, a: np.ndarray, k: float
          ) -> tuple[np.ndarray, float, float]:
    """The flight's fall with the drag's mean added back (constant-acceleration fits only: a
    drag fit's ``a`` is its constant part already), its derivative in ``k`` along the fall, and
    the lift's arm there (the lift where it was not fitted: ``|v| (c x v)``, whose part along
    the fall ``u`` is ``c . (|v| v x u)``; in 2-D the normal ``c`` times ``|v| (u_y v_x - u_x
    v_y)``)."""
    d = flight.d
    if flight.model == "quadratic":
        c = flight.params.reshape(d, 3)
        v = c[:, 1][None, :] + 2.0 * c[:, 2][None, :] * tau[:, None]  # (n, d)
    else:
        v = _drag.solve(flight.params, d, tau, sensitivities=False)[1]
    speed = np.linalg.norm(v, axis=1)
    drag = np.mean(speed[:, None] * v, axis=0)  # mean |v| v (m^2/s^2)
    if flight.model == "quadratic":
        a = a + k * drag
    u = a / np.linalg.norm(a)
    if flight.model != "quadratic":
        arm = 0.0
    elif d == 2:
        arm = abs(float(np.mean(speed * (u[1] * v[:, 0] - u[0] * v[:, 1]))))
    else:
        arm = float(np.linalg.norm(np.mean(speed[:, None] * np.cross(v, u), axis=0)))
    return a, float(u @ drag), arm


def bounce_fall(before: Flight, after: Flight, k: float | None) -> Fall:
    """The :class:`Fall` of a bounce's two flights."""
    parts = [flight_fall(f, k) for f in (before, after)]
    value, se, slope, arm = (tuple(p[i] for p in parts) for i in range(4))
    return Fall(value, se, slope, arm, k)


@dataclass(frozen=True)
class GravityScale:
    """The length scale the flights' fall implies, against the experiment's ``g``.

    ``fall``: the flights' weighted mean fall (m/s^2; weights the inverse variances of the
    fits); ``fall_se``: its statistical standard error (scaled up by sqrt(chi2 / dof) where the
    flights scatter more than their errors); ``systematic``: the aerodynamic part (m/s^2: the
    drag coefficient's 50 % and the lift's uncertainty, the same ball in every flight, so
    added linearly over the flights); ``n_flights``; ``chi2``/``dof``: the flights' scatter
    about the mean; ``stated``: the scale's relative SD the tracker stated (the trials'
    ``scale_rel_sd``, their median; None: none stated); ``drag_corrected``: False where the
    ball's drag was not known (no correction; the systematic part is then 0 and the summary
    says so).
    """

    gravity: float
    fall: float
    fall_se: float
    systematic: float
    n_flights: int
    chi2: float
    dof: int
    stated: float | None
    drag_corrected: bool

    @property
    def scale(self) -> float:
        """How many times the true length every length of the trajectories is: ``fall / g``
        (1: right; 1.03: 3 % too long, speeds 3 % too fast)."""
        return self.fall / self.gravity

    @property
    def scale_sd(self) -> float:
        """Standard deviation of :attr:`scale` (statistical and aerodynamic)."""
        return math.hypot(self.fall_se, self.systematic) / self.gravity

    @property
    def scatter_p(self) -> float:
        """Chi-square p-value of the flights' scatter about their mean (1 for one flight)."""
        from scipy import stats

        return float(stats.chi2.sf(self.chi2, self.dof)) if self.dof > 0 else 1.0

    @property
    def z(self) -> float | None:
        """(scale - 1) over the fall's SD and the stated scale SD in quadrature; None where
        neither gives an uncertainty."""
        sd = math.hypot(self.scale_sd, self.stated or 0.0)
        return (self.scale - 1.0) / sd if sd > 0 else None

    @property
    def agrees(self) -> bool:
        """|z| <= 3 (or no uncertainty to compare with)."""
        return self.z is None or abs(self.z) <= DISAGREE_Z

    def combined(self) -> tuple[float, float]:
        """The lengths' factor and its relative SD from the stated scale (1 +- ``stated``)
        and the fall (``scale +- scale_sd``), by inverse variances: divide every length (and
        speed) of the trajectories by the factor. Without a stated SD: the fall's alone."""
        if self.stated is None or self.stated <= 0:
            return self.scale, self.scale_sd
        w1, w2 = 1.0 / self.stated**2, 1.0 / self.scale_sd**2
        return (w1 + w2 * self.scale) / (w1 + w2), 1.0 / math.sqrt(w1 + w2)

    def record(self) -> dict[str, Any]:
        """The check as plain numbers and words, for a file's provenance."""
        return {"gravity_m_s2": self.gravity, "fall_m_s2": self.fall,
                "fall_se_m_s2": self.fall_se, "systematic_m_s2": self.systematic,
                "n_flights": self.n_flights, "chi2": self.chi2, "dof": self.dof,
                "scale": self.scale, "scale_sd": self.scale_sd, "stated_rel_sd": self.stated,
                "z": self.z, "agrees": self.agrees, "drag_corrected": self.drag_corrected,
                "summary": self.summary()}

    def summary(self) -> str:
        """The check in words, one line (two with a warning)."""
        pct = 100.0 * (self.scale - 1.0)
        head = (f"gravity: the {self.n_flights} free flights fall at {self.fall:.3f} +- "
                f"{math.hypot(self.fall_se, self.systematic):.3f} m/s^2 (g = {self.gravity:.4g}):"
                f" the lengths are {abs(pct):.2f} % too {'long' if pct >= 0 else 'short'} "
                f"+- {100 * self.scale_sd:.2f} %")
        head += ("" if self.drag_corrected else " (air drag not corrected: no ball given)")
        if self.scatter_p < SCATTER_P:
            head += (f"; the flights scatter beyond their errors (chi2 {self.chi2:.0f} on "
                     f"{self.dof}), the error scaled up")
        if self.stated is None:
            return head + "; no scale uncertainty was stated to compare with"
        stated = f"the tracker's stated scale uncertainty (+- {100 * self.stated:.2f} %)"
        if self.agrees:
            line = head + f"; {abs(self.z or 0.0):.1f} SD given {stated}: consistent"
            if self.scale_sd > 0 and self.stated >= PRECISE_RATIO * self.scale_sd:
                line += (f"; the fall is {self.stated / self.scale_sd:.0f}x as precise: "
                         "`scale = \"gravity\"` in [trajectories] would take the lengths from it")
            return line
        return (f"{head}\n  warning: that is {abs(self.z or 0.0):.1f} SD given {stated}: the "
                "scale (--ball-diameter or --reference) is off, or the frame rate (the fall "
                f"is g at {math.sqrt(self.gravity / self.fall):.4g} times the rate used), or "
                "the filmed plane does not hold the vertical"
                + ("" if self.drag_corrected else ", or the air's drag on a light ball (not "
                   "corrected here; the kinematics correct it for the experiment's ball)")
                + "; check them (a wrong frame rate needs --fps: the fall cannot mend it), "
                "and where the scale is what is off, `scale = \"gravity\"` in [trajectories] "
                "corrects the lengths by the fall")


def gravity_scale(falls: Sequence[Fall], gravity: float,
                  stated: Sequence[float | None] = ()) -> GravityScale | None:
    """The campaign's :class:`GravityScale` from its bounces' falls against ``gravity``
    (m/s^2); ``stated``: the trials' scale_rel_sd (None where not stated). None without a
    usable flight or where ``gravity`` is not positive."""
    if not (math.isfinite(gravity) and gravity > 0):
        return None  # nothing falls: no scale to read
    value = np.array([v for f in falls for v in f.value], dtype=float)
    se = np.array([s for f in falls for s in f.se], dtype=float)
    slope = np.array([s for f in falls for s in f.drag_slope], dtype=float)
    arm = np.array([s for f in falls for s in f.lift_arm], dtype=float)
    ok = np.isfinite(value) & (value > 0) & np.isfinite(se) & (se > 0)
    if not ok.any():
        return None
    value, se, slope, arm = value[ok], se[ok], slope[ok], arm[ok]
    w = 1.0 / se**2
    mean = float(np.sum(w * value) / np.sum(w))
    chi2 = float(np.sum(w * (value - mean) ** 2))
    dof = int(value.size - 1)
    fall_se = 1.0 / math.sqrt(float(np.sum(w))) * max(1.0, math.sqrt(chi2 / dof) if dof else 1.0)
    ks = [f.k for f in falls if f.k is not None]
    k = float(np.median(ks)) if ks else 0.0
    wn = w / np.sum(w)
    systematic = math.hypot(DRAG_REL_SD * k * float(wn @ slope),
                            LIFT_SD_PER_K * k * float(wn @ arm))
    given = [s for s in stated if s is not None and math.isfinite(s)]
    return GravityScale(gravity=float(gravity), fall=mean, fall_se=fall_se,
                        systematic=systematic, n_flights=int(value.size), chi2=chi2, dof=dof,
                        stated=float(np.median(given)) if given else None,
                        drag_corrected=bool(ks))
