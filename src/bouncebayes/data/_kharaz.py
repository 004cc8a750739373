"""The Kharaz et al. (2001) campaign: published measurements turned into a trial table.

5 mm alumina spheres hit a thick glass anvil at 3.9 m/s from the normal to near-grazing
incidence (Kharaz, Gorham & Salman 2001, docs/references.md). The numbers are third-party
digitizations of the paper's figures (the bundled ``SOURCE.md`` names them): the tangential
restitution ``e_t = u'/u`` of the centre of mass, the rebound spin, and two rebound angles, each
against the incidence angle. :func:`kharaz_rows` turns them into a trial table (one trial per
measured angle) with standard errors from their spread:

1. **The observation** at each angle is the ``e_t`` figure (the mean of the digitizations that
   read it). With the normal restitution 0.98 that every reproduction uses, it gives the
   rebound: ``u' = e_t V sin(theta)``, ``v'_n = 0.98 V cos(theta)``, hence the rebound speed and
   angle of the trial table.
2. **Its error**, in the tangential rebound velocity ``u'`` (m/s), has three parts:

   - the reading of the ``e_t`` figure: 1 % of its axis (SOURCE.md), over the square root of the
     number of digitizations;
   - the experiment's own scatter ``s``: the other figures (spin, contact-point angle,
     centre-of-mass angle) each imply a ``u'`` at the same angle (a sphere's spin and velocity
     change by one contact impulse: ``r (w' - w0) = (u' - u) / kappa``). Their differences from
     the ``e_t`` figure, beyond each reading's own 1 % of its axis, are put down to an
     independent scatter of size ``s`` in every figure, fitted by the method of moments
     (the sum of the squared standardised differences equals their number);
   - the reading of the incidence angle: the readings of one point in the different figures
     spread by ``x_sd`` (pooled); an angle misread by ``dx`` moves the ``e_t`` read there by the
     curve's slope times ``dx``.

3. **Two columns, one measurement.** Rebound speed and angle both follow from the one measured
   ``u'`` (``v'_n`` is fixed by the 0.98), so their errors are perfectly correlated; the trial
   table holds standard errors only, so each is the propagated error times ``sqrt(2)``: in the
   linearised likelihood the two columns then carry that measurement's information once.
   The incidence angle is exact by construction (standard error 0): its reading error is in the
   rebound's.

The whole derivation is run again by ``tests/test_data_kharaz.py``, which checks the bundled
table against it; ``python -m bouncebayes.data._kharaz FOLDER`` rewrites it.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

SPEED = 3.9  #: m/s, the impact speed of every reproduction (Chung & Ooi 2011 Test 4, MFIX, Lethe)
NORMAL_RESTITUTION = 0.98  #: the normal restitution every reproduction uses
RADIUS = 0.0025  #: m, the spheres' radius
KAPPA = 0.4  #: inertia factor of a solid sphere
DIGITIZED = "kharaz2001_alumina_on_glass_digitized.csv"
E_T = "tangential_COR_et"
#: 1 % of each figure's axis range (SOURCE.md: "errors of order 1 % of the axis range"): the
#: tangential restitution axis spans 0.6, the spin 750 rad/s, the rebound angles 120 deg
AXIS_ERROR = {E_T: 0.006, "angular_velocity_after": 7.5, "rebound_angle_contact_patch": 1.2,
              "rebound_angle_centre_of_mass": 1.2}
SAME_POINT_DEG = 1.6  #: readings of other figures within this of an e_t point belong to it
CLUSTER_DEG = 1.0  #: e_t readings closer than this are two digitizations of one point


@dataclass(frozen=True)
class Reading:
    """One digitized value: who read it, what, at which incidence angle (deg)."""

    digitized_by: str
    quantity: str
    angle: float
    value: float


@dataclass(frozen=True)
class ErrorModel:
    """The fitted error terms: the experiment's scatter in ``u'`` (m/s) and the spread of the
    incidence-angle readings (deg), with the numbers of differences and readings behind them."""

    scatter: float
    angle_sd: float
    n_differences: int
    n_angle_readings: int


def read_digitized(path: str | Path) -> list[Reading]:
    """The readings of the digitized file (its unit field may hold an unquoted comma, so the
    fields are split from both ends)."""
    rows = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        if not line.strip() or line.startswith(("#", "digitized_by,")):
            continue
        who, what, rest = line.split(",", 2)
        _, angle, value = rest.rsplit(",", 2)
        rows.append(Reading(who, what, float(angle), float(value)))
    return rows


def tangential_rebound(quantity: str, angle: float, value: float) -> float:
    """The tangential rebound velocity u' (m/s) that a reading implies at ``angle`` (deg):
    e_t directly; the spin (magnitude) through r w' = (u' - u) / kappa (topspin); the
    contact-point angle through tan(b) = (u' + r w') / v'_n; the centre-of-mass angle through
    tan(g) = u' / v'_n."""
    t = math.radians(angle)
    u, vn = SPEED * math.sin(t), NORMAL_RESTITUTION * SPEED * math.cos(t)
    if quantity == E_T:
        return value * u
    if quantity == "angular_velocity_after":
        return u - KAPPA * RADIUS * abs(value)
    if quantity == "rebound_angle_contact_patch":
        return (KAPPA * vn * math.tan(math.radians(value)) + u) / (1.0 + KAPPA)
    if quantity == "rebound_angle_centre_of_mass":
        return vn * math.tan(math.radians(value))
    raise ValueError(f"unknown digitized quantity {quantity!r}")


def _reading_error(quantity: str, angle: float, value: float) -> float:
    """1 % of the figure's axis, carried into u' (m/s) by a central difference."""
    h = 1e-4 * max(1.0, abs(value))
    slope = (tangential_rebound(quantity, angle, value + h)
             - tangential_rebound(quantity, angle, value - h)) / (2.0 * h)
    return abs(slope) * AXIS_ERROR[quantity]


def _points(readings: list[Reading]) -> list[list[Reading]]:
    """The e_t readings grouped into points (digitizations of one point lie within
    CLUSTER_DEG)."""
    points: list[list[Reading]] = []
    for r in sorted((r for r in readings if r.quantity == E_T), key=lambda r: r.angle):
        if points and r.angle - points[-1][-1].angle < CLUSTER_DEG:
            points[-1].append(r)
        else:
            points.append([r])
    return points


def _others(readings: list[Reading], angle: float) -> list[Reading]:
    """Readings of the other figures that belong to the e_t point at ``angle``."""
    return [r for r in readings if r.quantity != E_T and abs(r.angle - angle) < SAME_POINT_DEG]


def error_model(readings: list[Reading]) -> ErrorModel:
    """The experiment's scatter and the angle readings' spread (see the module docstring)."""
    diffs, sds, offsets = [], [], []
    for point in _points(readings):
        angle = float(np.mean([r.angle for r in point]))
        e_t = float(np.mean([r.value for r in point]))
        own = _reading_error(E_T, angle, e_t) / math.sqrt(len(point))
        for r in _others(readings, angle):
            diffs.append(tangential_rebound(r.quantity, angle, r.value)
                         - tangential_rebound(E_T, angle, e_t))
            sds.append(math.hypot(_reading_error(r.quantity, angle, r.value), own))
        xs = np.array([r.angle for r in point + _others(readings, angle)])
        offsets.append(xs - xs.mean())
    d, sd = np.array(diffs), np.array(sds)
    # each figure has its own scatter s: a difference of two figures has variance 2 s^2
    scatter = brentq(lambda s: float(np.sum(d**2 / (sd**2 + 2 * s**2))) - d.size, 0.0, 1.0)
    pooled = np.concatenate(offsets)
    angle_sd = math.sqrt(float(np.sum(pooled**2)) / (pooled.size - len(offsets)))
    return ErrorModel(float(scatter), angle_sd, int(d.size), int(pooled.size))


def kharaz_rows(path: str | Path) -> tuple[list[dict[str, float | str]], ErrorModel]:
    """The trial table's rows (one per measured angle; the columns of the bundled trials.csv)
    and the error model behind their standard errors."""
    readings = read_digitized(path)
    model = error_model(readings)
    points = _points(readings)
    angles = np.array([np.mean([r.angle for r in p]) for p in points])
    e_t = np.array([np.mean([r.value for r in p]) for p in points])
    slopes = np.gradient(e_t, angles)  # per degree
    rows: list[dict[str, float | str]] = []
    for point, angle, et, slope in zip(points, angles, e_t, slopes, strict=True):
        t = math.radians(angle)
        u_out = et * SPEED * math.sin(t)
        vn_out = NORMAL_RESTITUTION * SPEED * math.cos(t)
        speed, rebound = math.hypot(u_out, vn_out), math.atan2(u_out, vn_out)
        su = math.sqrt(model.scatter**2
                       + (_reading_error(E_T, angle, et) / math.sqrt(len(point)))**2
                       + (slope * model.angle_sd * SPEED * math.sin(t))**2)
        rows.append({"trial": f"theta_{angle:04.1f}", "rebound_speed": round(speed, 5),
                     "rebound_angle": round(math.degrees(rebound), 4),
                     "incidence_angle": round(float(angle), 3),
                     "rebound_speed_se": round(math.sqrt(2) * math.sin(rebound) * su, 5),
                     "rebound_angle_se": round(math.degrees(
                         math.sqrt(2) * math.cos(rebound) / speed * su), 4),
                     "incidence_angle_se": 0.0})
    return rows, model


def table_text(rows: list[dict[str, float | str]], model: ErrorModel) -> str:
    """The bundled trials.csv: a comment naming its derivation, the header, the rows."""
    head = (f"# Kharaz, Gorham & Salman (2001), 5 mm alumina on glass at {SPEED} m/s, from the "
            f"digitized figures in {DIGITIZED} (bouncebayes.data._kharaz): normal restitution "
            f"{NORMAL_RESTITUTION}; experiment's scatter in u' {model.scatter:.4g} m/s from "
            f"{model.n_differences} differences between figures; incidence readings spread "
            f"{model.angle_sd:.3g} deg ({model.n_angle_readings} readings)")
    columns = list(rows[0])
    lines = [head, ",".join(columns)]
    lines += [",".join(str(row[c]) for c in columns) for row in rows]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":  # python -m bouncebayes.data._kharaz FOLDER: rewrite its trials.csv
    folder = Path(sys.argv[1])
    (folder / "trials.csv").write_text(table_text(*kharaz_rows(folder / DIGITIZED)),
                                       encoding="utf-8")
