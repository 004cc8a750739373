"""The fast exact path: a tabulated normal impact plus the closed-form tangential outcome.

Without tangential compliance the normal motion does not depend on ``mu`` or on the tangential
state. Scaled by ``delta* = (m V^2 / k)^(2/5)`` and ``t* = delta* / V`` (``V`` the incident
normal speed), the normal problem

    D'' = -Phi(D, D') + gamma,   D(0) = 0, D'(0) = 1,

has only two numbers: the damping number (``zeta = eta delta* / (m V)`` for Kelvin–Voigt,
``chi = eta V`` for Hunt–Crossley) and the gravity number ``gamma = g cos(beta) delta* / V^2``.
Its outcomes (restitution, contact time, peak force, overlaps, the impulse up to the force peak)
are tabulated once per law by 2-D Chebyshev interpolation of tight ODE solutions (built in
about half a CPU-second at first use, then kept on disk beside numba's cached kernels). The
rebound then follows in closed form from the normal impulse ``P`` (docs/model.md): a ball
that slides throughout loses ``mu P / m`` of tangential velocity; one whose slip reaches zero
leaves rolling with ``U' = U - kappa/(1+kappa) s0``.

Why a hand-written table: no library tabulates a parametrised ODE outcome with the variable
change this one needs. The damping number enters through ``zeta^(1/3)`` for Kelvin–Voigt (the
overlap at separation scales like ``zeta^(2/3)``, which spoils polynomial interpolation in
``zeta`` itself); in that variable 24 x 8 Chebyshev nodes reach ~1e-10 (tests/test_model_fast.py).

How it is evaluated (the cost of a bounce): the kernels read the table in 32 pieces of the
damping axis, each an 8-term series (``MAIN_PIECES``: the 24-term series re-expanded, to
~5e-12); in the bounce's piece the gravity axis is contracted first, for all quantities at once
(``gravity_rows``: eight explicit terms per coefficient, a loop the compiler vectorises), then
each quantity is a dot product with the Chebyshev basis in the damping variable
(``x_values``). Samplers evaluate the same incidence conditions over and over, so
:class:`~bouncebayes.model.BounceModel` contracts the gravity axis once per condition and piece
(``prepare_conditions``) and a bounce then costs one cube root and two 8-term dot products.
The elementary functions (the roots of the scales, the incidence's sine and cosine, the
rebound angle's ``atan2``) are those of :mod:`._vmath`, taken over a block of elements at a
time in loops that compile to vector code (``bounce_range``'s passes).

Where the closed form is not exact (on a slope when the slip stops or might stop, when the ball
starts rolling on a slope) or the table does not reach (strong damping, slow impacts), the
element is handed to the ODE solver (a ``fallback`` reason per element).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numba
import numpy as np
from numba import njit, prange

from . import _kernel as K
from ._arrays import (B_I, B_KFAC, B_M, B_R, I_ANGLE, I_E, I_ETA, I_G, I_INCL, I_MU, I_SPEED,
                      I_SPIN, LAW_CODES, all_valid, at, damping_variable, element, gravity_parts,
                      incident_velocity, initial_force, law_scales, time_and_gravity_scales,
                      unit_inputs, valid)
from ._config import SolverConfig
from ._domain import HERTZ_OVERLAP_LIMIT
from ._ode import sample, solve_rows, solve_with_segments
from ._outputs import (O_ANGLE, O_DMAX, O_DSEP, O_FN, O_FT, O_SPEED, O_SPIN, O_STEPS,
                       O_TC, O_TPK, O_U, O_VN, RB_ANGLE, RB_SPEED, RB_SPIN, RB_TC, fill_failed,
                       speed_angle)
from ._vmath import root5

# Table quantities, all in scaled units of the unit normal problem.
T_E, T_TC, T_FN, T_DMAX, T_DSEP, T_TPK, T_PPK = range(7)
N_TABLE = 7
TABLE_NODES = (24, 8)  # damping x gravity
NG = TABLE_NODES[1]  # the kernels are written for eight gravity terms
# The kernels read the main table in MAIN_PIECES equal pieces of the damping axis, each a
# Chebyshev series of NX terms in the piece's own variable (gravity untouched): the 24-term
# series re-expanded exactly, piece by piece (:func:`_main_pieces`), which reproduces it to
# ~5e-12, 7e-11 for Tsuji's law (tests/test_model_fast.py), for a third of the multiply-adds
# of a bounce (8 x 8 terms a quantity instead of 24 x 8). Six gravity terms in the pieces would
# leave ~1e-7: gravity stays.
MAIN_PIECES = 32
NX = 8
# Samplers contract the gravity axis once per condition and piece (``prepare_conditions``:
# 2 x 8 x 32 values, 4 KiB a condition) where that takes at most this much memory; a larger
# table (thousands of trials) contracts it at each evaluation instead (the same arithmetic,
# so the same numbers; ~25 % more time a bounce).
PRECONTRACT_BYTES = 16 * 2**20
# The compression table: the scaled normal force Phi along the compression before the force
# peak, as a function of sigma = sqrt(t / t_peak) (the ODE solution is a power series in
# sqrt(t) there, so that Phi is smooth in sigma), the damping variable and the gravity number;
# the damping axis split into COMPRESSION_PIECES equal intervals, each with its own Chebyshev
# nodes. The impulse is not tabulated: it is the integral of the force, taken exactly on the
# Chebyshev series (:func:`_early_series`). 16 pieces of 6 x 5 x 20 terms (600 a bounce)
# give the force within ~2e-8 of tight ODE solutions at random points of the Kelvin–Voigt,
# Hunt–Crossley and linear boxes, as 4 pieces of 10 x 8 x 20 terms did (the floor of the ODE's
# dense output the table is built from; 8 x 5 x 16 or 6 x 4 x 20 terms are 3-10x worse); the
# peak friction of an early-stopping ball then agrees with the ODE path to ~1e-8
# (tests/test_model_fast.py). A table of the force against the impulse, which would need no
# root search, converges far more slowly: under Kelvin–Voigt the impulse grows like zeta t
# until t ~ zeta^(2/3), then like t^(5/2), so that any single power of the impulse fraction
# leaves a kink whose place moves with the damping (32 terms in (Pi / Pi_peak)^(1/5) leave
# 6e-7 at zeta = 1e-5; docs/speed.md).
COMPRESSION_PIECES = 16
COMPRESSION_NODES = (6, 5, 20)
# Domain: KV zeta <= 0.6 (beyond ~0.7 the initial force eta V becomes the peak: a kink),
# HC chi <= 2 (restitution ~0.3; the factor 1 - 1.5 chi |D'| stays positive, so the ball
# separates at zero overlap without a kink); gravity number <= 0.09 for KV (slow, grazing
# impacts of the prior box reach 0.1; eight gravity nodes still give the same 5e-9 agreement on
# the rebound as over [0, 0.05], tests/test_model_fast.py) and <= 0.05 for HC (its restitution
# converges more slowly in gravity); beyond, strong damping and slow impacts may never
# separate. The linear spring-dashpot: damping number 2 zeta <= 0.6 (restitution >= 0.37; its
# initial force 2 zeta V sqrt(m k) nears the peak beyond, a kink as for KV); Tsuji's Hertz
# law: alpha <= 1 (restitution >= 0.21), in the variable alpha^(1/5) (its separation overlap
# grows like alpha^(4/5)); both reach 1e-9 (tests/test_model_laws.py). A law without an entry
# here goes to the ODE solver.
DOMAIN = {"kelvin-voigt": (0.6, 0.09), "hunt-crossley": (2.0, 0.05),
          "linear-dashpot": (0.6, 0.09), "hertz-tsuji": (1.0, 0.05)}
TABLE_SOLVER = SolverConfig(rtol=1e-13, atol=1e-13, max_steps=200_000, time_limit=None)
LAW_POWER = {"kelvin-voigt": 3.0, "hunt-crossley": 1.0, "linear-dashpot": 1.0,
             "hertz-tsuji": 5.0}  # damping = x ** power (_arrays.damping_variable)

# Fallback reasons (per element), 0 = closed form applied.
FB_NONE, FB_DOMAIN, FB_SLOPE, FB_ODE = 0, 1, 2, 3
SERIAL_MAX = 4096  # batches up to this size run on one thread (no parallel start-up cost)
CHUNK = 256  # elements per parallel task of the sampler kernels
TASK = 16 * 256  # elements per parallel task of full results: sixteen blocks of bounce_range


@dataclass(frozen=True, eq=False)
class NormalTable:
    """Chebyshev coefficients of the scaled normal-impact outcomes of one law."""

    law: str
    coef: np.ndarray  # (N_TABLE, n_damping, n_gravity)
    compression: np.ndarray  # (piece, n_sigma, n_damping, n_gravity): the force Phi
    x_max: float  # table variable x: zeta^(1/3) (Kelvin–Voigt) or chi (Hunt–Crossley)
    gamma_max: float
    power: float

    @property
    def kv(self) -> int:
        """The law's code (``_arrays.LAW_CODES``), which the kernels' ``kv`` argument carries
        to select the law's scaling (``_arrays.law_scales``)."""
        return LAW_CODES[self.law]

    @property
    def gravity_first(self) -> np.ndarray:
        """The main table as the kernels read it: (MAIN_PIECES, NG, N_TABLE * NX), in pieces
        of the damping axis (:func:`_main_pieces`), gravity axis first."""
        return np.ascontiguousarray(np.stack([_gravity_first(c)
                                              for c in _main_pieces(self.coef)]))

    @property
    def compression_gravity_first(self) -> np.ndarray:
        """The compression table as the kernels read it: (piece, n_gravity,
        n_damping * n_sigma), sigma fastest (:func:`_compression_series`)."""
        return np.ascontiguousarray(self.compression.transpose(0, 3, 2, 1).reshape(
            self.compression.shape[0], self.compression.shape[3], -1))


def _gravity_first(coef: np.ndarray) -> np.ndarray:
    """(q, i, j) -> (j, q * n_i + i)."""
    return np.ascontiguousarray(coef.transpose(2, 0, 1).reshape(coef.shape[2], -1))


def _main_pieces(coef: np.ndarray) -> np.ndarray:
    """The main table's damping axis in MAIN_PIECES equal pieces of NX Chebyshev terms each:
    (piece, quantity, NX, n_gravity). Each gravity coefficient's series in the damping variable
    is evaluated at the piece's NX Chebyshev nodes and interpolated there (to ~5e-12 of the
    24-term series, 7e-11 for Tsuji's law; no new ODE solutions)."""
    nodes = _cheb_nodes(NX)
    basis_inv = np.linalg.inv(np.polynomial.chebyshev.chebvander(nodes, NX - 1))
    out = np.empty((MAIN_PIECES, coef.shape[0], NX, coef.shape[2]))
    for p in range(MAIN_PIECES):
        u = 2.0 * (p + 0.5 * (nodes + 1.0)) / MAIN_PIECES - 1.0  # the global variable
        values = np.einsum("qij,ni->qnj", coef,
                           np.polynomial.chebyshev.chebvander(u, coef.shape[1] - 1))
        out[p] = np.einsum("an,qnj->qaj", basis_inv, values)
    return out


def _cheb_nodes(n: int) -> np.ndarray:
    return np.cos(np.pi * (np.arange(n) + 0.5) / n)


@lru_cache(maxsize=None)
def normal_table(law: str) -> NormalTable:
    """The table of a normal law (once per process): from the disk cache, else built from
    tight ODE solutions (half a CPU-second) and cached on disk."""
    damping_max, gamma_max = DOMAIN[law]
    power = LAW_POWER[law]
    x_max = damping_max ** (1.0 / power)
    cached = _load_cached(law)
    if cached is not None:
        return NormalTable(law, cached[0], cached[1], x_max, gamma_max, power)
    table = _build_table(law, x_max, gamma_max, power)
    _store_cached(law, table.coef, table.compression)
    return table


# Where a built table is kept, beside numba's cached kernels; its name holds a hash of every
# source file the table depends on (and NumPy's version), so that any change rebuilds it.
_TABLE_SOURCES = ("_fast.py", "_kernel.py", "_ode.py", "_arrays.py", "_laws.py", "_config.py",
                  "_domain.py", "_closed_form.py", "_vmath.py")


def _cache_path(law: str) -> Path:
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256(np.__version__.encode())
    for name in _TABLE_SOURCES:
        digest.update((here / name).read_bytes())
    return here / "__pycache__" / f"table-{law}-{digest.hexdigest()[:16]}.npz"


def _load_cached(law: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(main, compression) coefficients of the cached table, or None (none, or unreadable)."""
    try:
        with np.load(_cache_path(law)) as f:
            coef, compression = f["coef"], f["compression"]
    except (OSError, KeyError, ValueError):
        return None
    pieces = (COMPRESSION_PIECES, COMPRESSION_NODES[2]) + COMPRESSION_NODES[:2]
    if coef.shape != (N_TABLE,) + TABLE_NODES or compression.shape != pieces:
        return None
    return coef, compression


def _store_cached(law: str, coef: np.ndarray, compression: np.ndarray) -> None:
    """Keep a built table on disk (atomically; nothing when the folder is not writable), and
    remove the tables of earlier sources."""
    from .._io import write_with

    try:
        path = _cache_path(law)
        path.parent.mkdir(exist_ok=True)
        write_with(path, lambda tmp: _save_npz(tmp, coef, compression))
        for old in path.parent.glob(f"table-{law}-*.npz"):
            if old != path:
                old.unlink(missing_ok=True)
    except OSError:
        pass


def _save_npz(path: Path, coef: np.ndarray, compression: np.ndarray) -> None:
    with open(path, "wb") as fh:
        np.savez(fh, coef=coef, compression=compression)


def _build_table(law: str, x_max: float, gamma_max: float, power: float) -> NormalTable:
    """The table of a normal law from tight ODE solutions."""
    nx, ng = TABLE_NODES
    cx, cg = _cheb_nodes(nx), _cheb_nodes(ng)
    x, g = np.meshgrid(0.5 * x_max * (1 + cx), 0.5 * gamma_max * (1 + cg), indexing="ij")
    res = _solve_unit(law, x.ravel() ** power, g.ravel())
    f = np.empty((N_TABLE, x.size))
    f[T_E] = res[:, K.R_V]
    f[T_TC] = res[:, K.R_TC]
    f[T_FN] = res[:, K.R_FN_PEAK]
    f[T_DMAX] = res[:, K.R_D_MAX]
    f[T_DSEP] = res[:, K.R_D]
    f[T_TPK] = res[:, K.R_T_FN_PEAK]
    f[T_PPK] = res[:, K.R_V_FN_PEAK] + 1.0 + g.ravel() * res[:, K.R_T_FN_PEAK]
    coef = _interpolate(f.reshape(N_TABLE, nx, ng), (cx, cg))
    return NormalTable(law, coef, _compression_table(law, x_max, gamma_max, power), x_max,
                       gamma_max, power)


@lru_cache(maxsize=None)
def kernel_tables(law: str) -> tuple[np.ndarray, np.ndarray, float, float, int]:
    """The table of ``law`` in the kernels' layouts (cached): (main, compression, x_max,
    gamma_max, the law's code)."""
    t = normal_table(law)
    return t.gravity_first, t.compression_gravity_first, t.x_max, t.gamma_max, t.kv


def _solve_unit(law: str, damping: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """Tight ODE solutions of the scaled normal problem (results rows)."""
    inputs = unit_inputs(law, damping, gamma, TABLE_SOLVER.max_contact_time_factor)
    res, status = solve_rows(inputs, np.arange(inputs.size), TABLE_SOLVER)
    if np.any(status != K.ST_OK):  # pragma: no cover - the domain is chosen to avoid this
        raise RuntimeError(f"normal table for {law} has unsolved nodes")
    return res


def _compression_table(law: str, x_max: float, gamma_max: float, power: float) -> np.ndarray:
    """Chebyshev coefficients, per damping piece, of the force Phi at sigma = sqrt(t / t_peak)
    (the impulse follows from it: :func:`_early_series`)."""
    nx, ng, ns = COMPRESSION_NODES
    cx, cg, cs = _cheb_nodes(nx), _cheb_nodes(ng), _cheb_nodes(ns)
    edges = np.linspace(0.0, x_max, COMPRESSION_PIECES + 1)
    sigma = np.sort(0.5 * (1.0 + cs))
    order = np.argsort(0.5 * (1.0 + cs))
    pieces = []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        x, g = np.meshgrid(lo + 0.5 * (hi - lo) * (1 + cx), 0.5 * gamma_max * (1 + cg),
                           indexing="ij")
        damping, gamma = x.ravel() ** power, g.ravel()
        inputs = unit_inputs(law, damping, gamma, TABLE_SOLVER.max_contact_time_factor)
        out = np.empty((1, damping.size, ns))
        for i in range(damping.size):
            res, status, segs, params = solve_with_segments(inputs, i, TABLE_SOLVER)
            if status != K.ST_OK:  # pragma: no cover - the domain is chosen to avoid this
                raise RuntimeError(f"compression table for {law} has unsolved nodes")
            times = sigma**2 * res[K.R_T_FN_PEAK]
            hist = sample(res, segs, params, times)
            out[0, i, order] = hist[:, K.H_FN]
        coef = _interpolate(out.reshape(1, nx, ng, ns), (cx, cg, cs))
        pieces.append(coef.transpose(0, 3, 1, 2).reshape(ns, nx, ng))
    return np.ascontiguousarray(np.stack(pieces))


def _interpolate(values: np.ndarray, nodes: tuple[np.ndarray, ...]) -> np.ndarray:
    """Chebyshev coefficients of tensor-grid values (first axis: quantities)."""
    coef = values
    for axis, c in enumerate(nodes, start=1):
        v = np.polynomial.chebyshev.chebvander(c, c.size - 1)
        moved = np.moveaxis(coef, axis, 0)
        solved = np.linalg.solve(v, moved.reshape(c.size, -1)).reshape(moved.shape)
        coef = np.moveaxis(solved, 0, axis)
    return np.ascontiguousarray(coef)


@njit(cache=True, fastmath=True)
def _contract(coef, x, gamma, x_max, gamma_max, tx, tg, out, nq=-1):
    """Reference evaluation of a (quantity, damping, gravity) table at one point (the tests'
    check of the table; the kernels use ``gravity_rows`` and ``x_values``)."""
    _chebyshev_basis(2.0 * x / x_max - 1.0, tx)
    _chebyshev_basis(2.0 * gamma / gamma_max - 1.0, tg)
    nq = coef.shape[0] if nq < 0 else nq
    for q in range(nq):
        acc = 0.0
        for i in range(coef.shape[1]):
            row = 0.0
            for j in range(coef.shape[2]):
                row += coef[q, i, j] * tg[j]
            acc += row * tx[i]
        out[q] = acc


@njit(cache=True, inline="always")
def _chebyshev_basis(u, out):
    out[0] = 1.0
    if out.shape[0] > 1:
        out[1] = u
    for i in range(2, out.shape[0]):
        out[i] = 2.0 * u * out[i - 1] - out[i - 2]


@njit(cache=True, inline="always")
def cheb_basis(u, out, n):
    """T_0(u) .. T_{n-1}(u) (n >= 4) by doubling: T_2k = 2 T_k^2 - 1 and
    T_{k+j} = 2 T_k T_j - T_{k-j}. The three-term recurrence is a chain of n dependent
    multiply-adds; this is a tree of depth ~2 log2(n), whose branches the processor runs side
    by side (the basis is on the critical path of every bounce)."""
    out[0] = 1.0
    out[1] = u
    out[2] = 2.0 * u * u - 1.0
    out[3] = 2.0 * u * out[2] - u
    k = 4
    while k < n:
        tk = 2.0 * out[k // 2] * out[k // 2] - 1.0
        out[k] = tk
        two_tk = 2.0 * tk
        for j in range(1, min(k, n - k)):
            out[k + j] = two_tk * out[j] - out[k - j]
        k *= 2


@njit(cache=True, inline="always")
def gravity_rows(c, gamma, gamma_max, start, stop, rows):
    """rows[k] = sum_j c[j, k] T_j(u) for k in [start, stop), u the gravity variable: the
    gravity axis of a gravity-first table contracted (eight terms written out, so that the
    loop over k is plain multiply-adds the compiler vectorises)."""
    v = 2.0 * gamma / gamma_max - 1.0
    t2 = 2.0 * v * v - 1.0
    t3 = 2.0 * v * t2 - v
    t4 = 2.0 * t2 * t2 - 1.0  # the doubling formulas of cheb_basis
    t5 = 2.0 * t4 * v - t3
    t6 = 2.0 * t4 * t2 - t2
    t7 = 2.0 * t4 * t3 - v
    c0, c1, c2, c3, c4, c5, c6, c7 = c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]
    for k in range(start, stop):
        rows[k] = (c0[k] + c1[k] * v + c2[k] * t2 + c3[k] * t3 + c4[k] * t4 + c5[k] * t5
                   + c6[k] * t6 + c7[k] * t7)


@njit(cache=True, inline="always")
def gravity_rows5(c, gamma, gamma_max, start, stop, rows):
    """:func:`gravity_rows` for a table of five gravity terms (the compression table)."""
    v = 2.0 * gamma / gamma_max - 1.0
    t2 = 2.0 * v * v - 1.0
    t3 = 2.0 * v * t2 - v
    t4 = 2.0 * t2 * t2 - 1.0
    c0, c1, c2, c3, c4 = c[0], c[1], c[2], c[3], c[4]
    for k in range(start, stop):
        rows[k] = c0[k] + c1[k] * v + c2[k] * t2 + c3[k] * t3 + c4[k] * t4


@njit(cache=True, inline="always")
def main_piece(x, x_max):
    """The main table's piece of the damping variable ``x`` in [0, x_max] and the piece's own
    variable in [-1, 1]."""
    z = x * (MAIN_PIECES / x_max)
    piece = min(max(int(z), 0), MAIN_PIECES - 1)
    return piece, 2.0 * (z - piece) - 1.0


@njit(cache=True, inline="always")
def x_values(rows, n, q0, q1, u, tx, vals):
    """vals[q] = sum_i rows[q n + i] T_i(u) for q in [q0, q1): the damping axis (basis once,
    then dot products with four partial sums)."""
    cheb_basis(u, tx, n)
    for q in range(q0, q1):
        vals[q] = _dot(rows, q * n, tx, n)


@njit(cache=True, inline="always")
def _dot(rows, base, tx, n):
    """sum_i rows[base + i] tx[i], i < n, in four partial sums (one summation order for every
    caller, so that every path rounds alike)."""
    a0 = a1 = a2 = a3 = 0.0
    for i in range(0, n - 3, 4):
        a0 += rows[base + i] * tx[i]
        a1 += rows[base + i + 1] * tx[i + 1]
        a2 += rows[base + i + 2] * tx[i + 2]
        a3 += rows[base + i + 3] * tx[i + 3]
    for i in range(n - n % 4, n):
        a0 += rows[base + i] * tx[i]
    return (a0 + a1) + (a2 + a3)


@njit(cache=True, inline="always")
def normal_scales(m, k, eta, gy, vn, kv):
    """(delta*, t*, damping number, damping variable x, gravity number) of a normal impact
    under the law of code ``kv``."""
    return law_scales(kv, m, k, eta, gy, vn)


@njit(cache=True, inline="always")
def tangential_one(r, m, inertia, mu, gx, u0, w0, tc, impulse):
    """Closed-form tangential outcome (docs/model.md) given the normal impulse per unit mass:
    returns (exact, u, w, phase, slides); ``exact`` is False where only the ODE can tell
    (on a slope when the slip stops, or may stop, during the contact)."""
    kappa = inertia / (m * r * r)
    slip_rate = mu * (1.0 + 1.0 / kappa)  # change of the slip per unit P / m while sliding
    s0 = u0 + r * w0
    sign = 1.0 if s0 > 0.0 else -1.0
    margin = abs(s0) - slip_rate * impulse
    slides = margin > 0.0
    if gx != 0.0:
        if s0 == 0.0:
            return False, 0.0, 0.0, 0.0, False
        if sign * gx < 0.0:
            slides = margin + sign * gx * tc > 0.0
        if not slides:
            return False, 0.0, 0.0, 0.0, False
    if slides:
        return (True, u0 - mu * sign * impulse + gx * tc,
                w0 - mu * sign * impulse / (kappa * r), sign, True)
    # the slip stops during the contact (horizontal plane only): rolls until separation
    return True, u0 - kappa / (1.0 + kappa) * s0, w0 - s0 / ((1.0 + kappa) * r), 0.0, False


@njit(cache=True, inline="always")
def _bounce_one(values, ball, i, scales, j, main, x_max, gamma_max, kv, rows, tx, vals, out,
                early, n_early):
    """Closed-form bounce of element ``i`` (its gravity, incident velocities and normal
    scales in column ``j`` of ``scales``: :func:`_block_inputs`, :func:`_block_scales`) with
    every output but the rebound speed and angle (:func:`_block_speed_angle`) and the peak
    friction of a ball whose slip stops before the force peak: such an element is appended to
    ``early`` (its index and what :func:`_early_friction` needs) and its peak friction left for
    that pass.
    Returns (fallback reason (> 0), 0 when it slides, -1 when it rolls; the new length of
    ``early``)."""
    r, m, inertia = ball[B_R], ball[B_M], ball[B_I]
    mu, w0 = at(values[I_MU], i), at(values[I_SPIN], i)
    gx, u0, vn = scales[S_GX, j], scales[S_U0, j], scales[S_VN, j]
    d_star, damping, x = scales[S_DSTAR, j], scales[S_DAMPING, j], scales[S_X, j]
    t_star, gamma = time_and_gravity_scales(d_star, vn, scales[S_GY, j])
    if not (x <= x_max and gamma <= gamma_max):
        return FB_DOMAIN, n_early
    piece, ux = main_piece(x, x_max)
    gravity_rows(main[piece], gamma, gamma_max, 0, T_PPK * NX, rows)
    x_values(rows, NX, T_E, T_PPK, ux, tx, vals)
    tc = vals[T_TC] * t_star
    impulse = vn * (1.0 + vals[T_E] + gamma * vals[T_TC])  # P / m over the contact
    exact, u, w, phase, slides = tangential_one(r, m, inertia, mu, gx, u0, w0, tc, impulse)
    if not exact:
        return FB_SLOPE, n_early
    f_scale = m * vn * vn / d_star
    fn_peak = max(vals[T_FN], initial_force(kv, damping)) * f_scale
    ft_peak = mu * fn_peak
    if not slides:
        s0 = u0 + r * w0
        slip_rate = mu * (1.0 + m * r * r / inertia)
        if s0 != 0.0:  # the impulse up to the force peak (tx still holds the damping basis)
            gravity_rows(main[piece], gamma, gamma_max, T_PPK * NX, N_TABLE * NX, rows)
            vals[T_PPK] = _dot(rows, T_PPK * NX, tx, NX)
        if s0 == 0.0:
            ft_peak = 0.0
        elif abs(s0) / slip_rate < vn * vals[T_PPK]:  # stops before the force peak
            e = early[n_early]
            e[E_INDEX], e[E_X], e[E_GAMMA], e[E_TARGET] = i, x, gamma, abs(s0) / (slip_rate * vn)
            e[E_MU], e[E_PPK], e[E_DAMPING] = mu, vals[T_PPK], damping
            e[E_FSCALE] = f_scale
            n_early += 1
    out[O_SPIN, i] = w
    out[O_U, i] = u
    out[O_VN, i] = vals[T_E] * vn
    out[O_TC, i] = tc
    out[O_FN, i] = fn_peak
    out[O_FT, i] = ft_peak
    out[O_DMAX, i] = vals[T_DMAX] * d_star
    out[O_DSEP, i] = vals[T_DSEP] * d_star
    out[O_TPK, i] = vals[T_TPK] * t_star
    out[O_STEPS, i] = 0.0
    return (FB_NONE if phase != 0.0 else -1), n_early  # -1: solved, rolling


# A block's inputs and normal scales (:func:`bounce_range`), one row each.
S_SPEED, S_ANGLE, S_K, S_ETA, S_GX, S_GY, S_U0, S_VN, S_DSTAR, S_DAMPING, S_X = range(11)
N_SCALES = 11


@njit(cache=True, inline="always")
def _block_inputs(values, ball, shared_gravity, gx, gy, i0, n, scales):
    """The inputs of elements [i0, i0 + n) that :func:`_block_scales` needs, gathered into
    rows of ``scales`` (the arrays may hold one value for all elements)."""
    for j in range(n):
        i = i0 + j
        if not shared_gravity:
            gx, gy = gravity_parts(values, i)
        scales[S_SPEED, j], scales[S_ANGLE, j] = at(values[I_SPEED], i), at(values[I_ANGLE], i)
        scales[S_K, j] = ball[B_KFAC] * at(values[I_E], i)
        scales[S_ETA, j] = at(values[I_ETA], i)
        scales[S_GX, j], scales[S_GY, j] = gx, gy


@njit(cache=True, error_model="numpy")
def _block_scales(m, kv, n, scales):
    """The incident velocities and normal scales of a block's elements (``element_with`` and
    ``normal_scales``, the same arithmetic; t* and the gravity number, one division each, are
    left to the element's own pass): plain arithmetic and the functions of :mod:`._vmath`
    over rows taken as 1-D arrays, so that the loop compiles to vector code (the reason for
    the block's passes; tests/test_model_vmath.py checks that it does). One loop per law, the
    law's code a constant in each: with the law's branches inside, or with more rows (the
    compiler's checks that they do not overlap grow), the compiler keeps the loop scalar."""
    a, b, c, d = scales[S_SPEED], scales[S_ANGLE], scales[S_K], scales[S_ETA]
    e, f, g, h, i = scales[S_U0], scales[S_VN], scales[S_DSTAR], scales[S_DAMPING], scales[S_X]
    if kv == K.LAW_KELVIN_VOIGT:
        _scales_loop(m, K.LAW_KELVIN_VOIGT, n, a, b, c, d, e, f, g, h, i)
    elif kv == K.LAW_HUNT_CROSSLEY:
        _scales_loop(m, K.LAW_HUNT_CROSSLEY, n, a, b, c, d, e, f, g, h, i)
    elif kv == K.LAW_LINEAR:
        _scales_loop(m, K.LAW_LINEAR, n, a, b, c, d, e, f, g, h, i)
    else:
        _scales_loop(m, K.LAW_TSUJI, n, a, b, c, d, e, f, g, h, i)


@njit(cache=True, inline="always")
def _scales_loop(m, law, n, speed, angle, k, eta, u0_out, vn_out, d_out, damping_out, x_out):
    for j in range(n):
        u0, vn = incident_velocity(speed[j], angle[j])
        d_star, t_star, damping, x, gamma = normal_scales(m, k[j], eta[j], 0.0, vn, law)
        u0_out[j], vn_out[j] = u0, vn
        d_out[j], damping_out[j], x_out[j] = d_star, damping, x


@njit(cache=True, error_model="numpy")
def _block_speed_angle(out, i0, n):
    """Rebound speed and angle of elements [i0, i0 + n) from their velocities (vector code, as
    :func:`_block_scales`; NaN where the element failed or waits for the ODE solver, whose
    results replace them)."""
    u, vn = out[O_U, i0:i0 + n], out[O_VN, i0:i0 + n]
    speed, angle = out[O_SPEED, i0:i0 + n], out[O_ANGLE, i0:i0 + n]
    for j in range(n):
        speed[j], angle[j] = speed_angle(u[j], vn[j])


# What the last pass of :func:`bounce_range` needs of a ball whose slip stops before the force
# peak (E_SIGMA: at the end, the scaled normal force when the slip stops).
(E_INDEX, E_X, E_GAMMA, E_MU, E_PPK, E_DAMPING, E_FSCALE, E_PIECE, E_TARGET,
 E_SIGMA) = range(10)
N_EARLY = 10
BLOCK = 256  # elements per pass pair of bounce_range: its scratch stays in the L1 cache
NS = COMPRESSION_NODES[2]  # the compression table's terms in sigma
# The rows of the early balls' vector pass (:func:`_early_newton`), one column per ball: the
# impulse's NS + 2 Chebyshev coefficients, the force's NS, the impulse the slip needs, the
# impulse series' scale and the impulse at the force peak; and of its results.
R_PI, R_PHI, R_TARGET, R_SCALE, R_PPK = 0, NS + 2, 2 * NS + 2, 2 * NS + 3, 2 * NS + 4
N_ROWS_EARLY = 2 * NS + 5
R_FORCE, R_ROOT, R_OK = range(3)
# Their rows lie ROW values apart, a stride that is not a multiple of 4 KiB: at BLOCK's 2 KiB,
# the 45 rows of a ball's column shared two sets of the first-level cache, whose 16 lines the
# passes then evicted again and again (filling a column took 3x the time, measured).
ROW = BLOCK + 8
if COMPRESSION_NODES != (6, 5, 20):  # pragma: no cover - a guard for whoever changes them
    raise ImportError("_compression_series, _series_pair and _early_series are written out "
                      "for 6 x 5 x 20 terms")
# The vector pass (:func:`_early_newton`) takes four Newton steps from the two-term model's
# start (MODEL_STEPS steps on the model; within ~5 % of the root): enough to reach the root to
# ~1e-11 (the last step at most NEWTON_TOL, then quadratic) for ~99 % of balls at random points
# of the table (1.1 % of 10,240 were not); a ball whose last step is larger, or left the
# bracket, is searched again one at a time (:func:`_early_search`).
MODEL_STEPS = 4
NEWTON_TOL = 3e-6  # a last step this small leaves ~1e-11 (quadratic convergence)


@njit(cache=True, inline="always")
def _compression_series(cp, gamma, gamma_max, u, work, out):
    """The force's NS Chebyshev coefficients in sigma of one ball, its piece ``cp`` of the
    compression table (n_gravity, n_damping * NS) contracted at gravity number ``gamma`` and
    the piece's damping variable ``u``: the gravity axis into ``work`` (:func:`gravity_rows5`),
    then the damping axis, six terms over the NS coefficients side by side (both loops run
    over contiguous coefficients, so they compile to vector code)."""
    gravity_rows5(cp, gamma, gamma_max, 0, cp.shape[1], work)
    u2 = 2.0 * u * u - 1.0
    u3 = 2.0 * u * u2 - u
    u4 = 2.0 * u2 * u2 - 1.0
    u5 = 2.0 * u4 * u - u3
    w0, w1, w2 = work[0:NS], work[NS:2 * NS], work[2 * NS:3 * NS]
    w3, w4, w5 = work[3 * NS:4 * NS], work[4 * NS:5 * NS], work[5 * NS:6 * NS]
    for s in range(NS):
        out[s] = w0[s] + w1[s] * u + w2[s] * u2 + w3[s] * u3 + w4[s] * u4 + w5[s] * u5


@njit(cache=True, inline="always")
def _series_pair(soa, k, u):
    """(Pi, Phi) of ball ``k`` of the vector pass at u = 2 sigma - 1: the Chebyshev basis by
    doubling (T_2j = 2 T_j^2 - 1, T_2j+1 = 2 T_j+1 T_j - u, as :func:`cheb_basis`: a tree of
    depth ~log2(NS), where Clenshaw's recurrence is a chain of NS dependent steps, on the
    critical path of every Newton step), then both sums in four partial sums each; written
    out in local variables, so that the pass's loop over balls compiles to vector code."""
    t1 = u
    t2 = 2.0 * u * u - 1.0
    t3 = 2.0 * t2 * u - u
    t4 = 2.0 * t2 * t2 - 1.0
    t5 = 2.0 * t3 * t2 - u
    t6 = 2.0 * t3 * t3 - 1.0
    t7 = 2.0 * t4 * t3 - u
    t8 = 2.0 * t4 * t4 - 1.0
    t9 = 2.0 * t5 * t4 - u
    t10 = 2.0 * t5 * t5 - 1.0
    t11 = 2.0 * t6 * t5 - u
    t12 = 2.0 * t6 * t6 - 1.0
    t13 = 2.0 * t7 * t6 - u
    t14 = 2.0 * t7 * t7 - 1.0
    t15 = 2.0 * t8 * t7 - u
    t16 = 2.0 * t8 * t8 - 1.0
    t17 = 2.0 * t9 * t8 - u
    t18 = 2.0 * t9 * t9 - 1.0
    t19 = 2.0 * t10 * t9 - u
    t20 = 2.0 * t10 * t10 - 1.0
    t21 = 2.0 * t11 * t10 - u
    p0 = soa[R_PI * ROW + k] + soa[(R_PI + 4) * ROW + k] * t4
    p0 += soa[(R_PI + 8) * ROW + k] * t8 + soa[(R_PI + 12) * ROW + k] * t12
    p0 += soa[(R_PI + 16) * ROW + k] * t16 + soa[(R_PI + 20) * ROW + k] * t20
    p1 = soa[(R_PI + 1) * ROW + k] * t1 + soa[(R_PI + 5) * ROW + k] * t5
    p1 += soa[(R_PI + 9) * ROW + k] * t9 + soa[(R_PI + 13) * ROW + k] * t13
    p1 += soa[(R_PI + 17) * ROW + k] * t17 + soa[(R_PI + 21) * ROW + k] * t21
    p2 = soa[(R_PI + 2) * ROW + k] * t2 + soa[(R_PI + 6) * ROW + k] * t6
    p2 += soa[(R_PI + 10) * ROW + k] * t10 + soa[(R_PI + 14) * ROW + k] * t14
    p2 += soa[(R_PI + 18) * ROW + k] * t18
    p3 = soa[(R_PI + 3) * ROW + k] * t3 + soa[(R_PI + 7) * ROW + k] * t7
    p3 += soa[(R_PI + 11) * ROW + k] * t11 + soa[(R_PI + 15) * ROW + k] * t15
    p3 += soa[(R_PI + 19) * ROW + k] * t19
    f0 = soa[R_PHI * ROW + k] + soa[(R_PHI + 4) * ROW + k] * t4
    f0 += soa[(R_PHI + 8) * ROW + k] * t8 + soa[(R_PHI + 12) * ROW + k] * t12
    f0 += soa[(R_PHI + 16) * ROW + k] * t16
    f1 = soa[(R_PHI + 1) * ROW + k] * t1 + soa[(R_PHI + 5) * ROW + k] * t5
    f1 += soa[(R_PHI + 9) * ROW + k] * t9 + soa[(R_PHI + 13) * ROW + k] * t13
    f1 += soa[(R_PHI + 17) * ROW + k] * t17
    f2 = soa[(R_PHI + 2) * ROW + k] * t2 + soa[(R_PHI + 6) * ROW + k] * t6
    f2 += soa[(R_PHI + 10) * ROW + k] * t10 + soa[(R_PHI + 14) * ROW + k] * t14
    f2 += soa[(R_PHI + 18) * ROW + k] * t18
    f3 = soa[(R_PHI + 3) * ROW + k] * t3 + soa[(R_PHI + 7) * ROW + k] * t7
    f3 += soa[(R_PHI + 11) * ROW + k] * t11 + soa[(R_PHI + 15) * ROW + k] * t15
    f3 += soa[(R_PHI + 19) * ROW + k] * t19
    return (p0 + p1) + (p2 + p3), (f0 + f1) + (f2 + f3)


@njit(cache=True, inline="always")
def _model_guess(soa, k, target, scale, ppk):
    """Start of ball ``k``'s root search: the root of the two-term model
    Pi ~ alpha sigma^2 + beta sigma^5 of the compression, alpha from Pi''(0) = 4 scale Phi(0)
    (:func:`_early_series`; the initial force of Kelvin–Voigt), beta from Pi(1) = ppk; both
    sums are free (T_k(1) = 1, T_k(-1) = (-1)^k). Newton on the model from the smaller of the
    roots of its two terms alone (each at or beyond the model's root, the smaller within a
    factor 2^(1/2) of it), so that the iterates descend onto it; from (target / Pi(1))^(1/5)
    alone, where the first term dominates, each step took a fifth off sigma. The model is
    good to a few per cent, which the Newton steps on the series then take off."""
    even = odd = 0.0
    for i in range(0, NS, 2):
        even += soa[(R_PHI + i) * ROW + k]
        odd += soa[(R_PHI + i + 1) * ROW + k]
    alpha = max(2.0 * scale * (even - odd), 0.0)
    beta = ppk - alpha
    start = min(1.0, root5(target / ppk))
    sigma = min(start, math.sqrt(target / alpha))  # inf where alpha = 0
    for _ in range(MODEL_STEPS):
        s2 = sigma * sigma
        s4 = s2 * s2
        f = alpha * s2 + beta * s4 * sigma - target
        sigma -= f / (2.0 * alpha * sigma + 5.0 * beta * s4)
    sigma = min(max(sigma, 0.0), 1.0)
    return sigma if beta > 0.0 else start


@njit(cache=True, inline="always")
def _newton_step(soa, k, sigma, lo, hi, target, scale):
    """One safeguarded Newton step on Pi(sigma) = target with dPi/dsigma = 4 scale sigma Phi
    (dPi/dt = Phi): the bracket [lo, hi] updated, a step out of it replaced by bisection.
    Returns (sigma, lo, hi, the Newton step, whether it stayed in the bracket)."""
    pi, phi = _series_pair(soa, k, 2.0 * sigma - 1.0)
    f = pi - target
    hi = sigma if f > 0.0 else hi
    lo = lo if f > 0.0 else sigma
    slope = phi * 4.0 * sigma * scale
    step = f / slope if slope > 0.0 else math.inf
    new = sigma - step
    inside = lo <= new and new <= hi
    return (new if inside else 0.5 * (lo + hi)), lo, hi, step, inside


@njit(cache=True, error_model="numpy")
def _early_series(soa, n):
    """The impulse's Chebyshev series of balls [0, n) of ``soa`` from their force's, into rows
    R_PI.. (and the scale into R_SCALE): with dt = 2 t_peak sigma dsigma and u = 2 sigma - 1,
    Pi(u) is proportional to I(u), the integral from -1 of (u + 1) Phi (the product by u + 1
    and the integral are exact recurrences on the coefficients: u T_j = (T_j+1 + T_|j-1|) / 2;
    the integral of T_j is T_j+1 / (2(j+1)) - T_j-1 / (2(j-1)), of T_0 T_1), scaled so that
    Pi(1) is the main table's impulse at the force peak R_PPK (accurate to ~1e-10, where
    t_peak is ~3e-8); the scale s gives Pi = s I and dPi/dsigma = 4 s sigma Phi. Written out
    for NS = 20 in local variables (c_j: the coefficients of (u + 1) Phi, a_q: of I), so that
    the loop over balls compiles to vector code."""
    for k in range(n):
        b0 = soa[R_PHI * ROW + k]
        b1 = soa[(R_PHI + 1) * ROW + k]
        b2 = soa[(R_PHI + 2) * ROW + k]
        b3 = soa[(R_PHI + 3) * ROW + k]
        b4 = soa[(R_PHI + 4) * ROW + k]
        b5 = soa[(R_PHI + 5) * ROW + k]
        b6 = soa[(R_PHI + 6) * ROW + k]
        b7 = soa[(R_PHI + 7) * ROW + k]
        b8 = soa[(R_PHI + 8) * ROW + k]
        b9 = soa[(R_PHI + 9) * ROW + k]
        b10 = soa[(R_PHI + 10) * ROW + k]
        b11 = soa[(R_PHI + 11) * ROW + k]
        b12 = soa[(R_PHI + 12) * ROW + k]
        b13 = soa[(R_PHI + 13) * ROW + k]
        b14 = soa[(R_PHI + 14) * ROW + k]
        b15 = soa[(R_PHI + 15) * ROW + k]
        b16 = soa[(R_PHI + 16) * ROW + k]
        b17 = soa[(R_PHI + 17) * ROW + k]
        b18 = soa[(R_PHI + 18) * ROW + k]
        b19 = soa[(R_PHI + 19) * ROW + k]
        c0 = b0 + 0.5 * b1
        c1 = b1 + b0 + 0.5 * b2
        c2 = b2 + 0.5 * b1 + 0.5 * b3
        c3 = b3 + 0.5 * b2 + 0.5 * b4
        c4 = b4 + 0.5 * b3 + 0.5 * b5
        c5 = b5 + 0.5 * b4 + 0.5 * b6
        c6 = b6 + 0.5 * b5 + 0.5 * b7
        c7 = b7 + 0.5 * b6 + 0.5 * b8
        c8 = b8 + 0.5 * b7 + 0.5 * b9
        c9 = b9 + 0.5 * b8 + 0.5 * b10
        c10 = b10 + 0.5 * b9 + 0.5 * b11
        c11 = b11 + 0.5 * b10 + 0.5 * b12
        c12 = b12 + 0.5 * b11 + 0.5 * b13
        c13 = b13 + 0.5 * b12 + 0.5 * b14
        c14 = b14 + 0.5 * b13 + 0.5 * b15
        c15 = b15 + 0.5 * b14 + 0.5 * b16
        c16 = b16 + 0.5 * b15 + 0.5 * b17
        c17 = b17 + 0.5 * b16 + 0.5 * b18
        c18 = b18 + 0.5 * b17 + 0.5 * b19
        c19 = b19 + 0.5 * b18
        c20 = 0.5 * b19
        a1 = c0 - 0.5 * c2
        a2 = (c1 - c3) * 0.25  # / 4
        a3 = (c2 - c4) * 0.16666666666666666  # / 6
        a4 = (c3 - c5) * 0.125  # / 8
        a5 = (c4 - c6) * 0.1  # / 10
        a6 = (c5 - c7) * 0.08333333333333333  # / 12
        a7 = (c6 - c8) * 0.07142857142857142  # / 14
        a8 = (c7 - c9) * 0.0625  # / 16
        a9 = (c8 - c10) * 0.05555555555555555  # / 18
        a10 = (c9 - c11) * 0.05  # / 20
        a11 = (c10 - c12) * 0.045454545454545456  # / 22
        a12 = (c11 - c13) * 0.041666666666666664  # / 24
        a13 = (c12 - c14) * 0.038461538461538464  # / 26
        a14 = (c13 - c15) * 0.03571428571428571  # / 28
        a15 = (c14 - c16) * 0.03333333333333333  # / 30
        a16 = (c15 - c17) * 0.03125  # / 32
        a17 = (c16 - c18) * 0.029411764705882353  # / 34
        a18 = (c17 - c19) * 0.027777777777777776  # / 36
        a19 = (c18 - c20) * 0.02631578947368421  # / 38
        a20 = c19 * 0.025  # / 40
        a21 = c20 * 0.023809523809523808  # / 42
        total = a1 + a2 + a3 + a4 + a5 + a6 + a7 + a8
        total += a9 + a10 + a11 + a12 + a13 + a14 + a15 + a16
        total += a17 + a18 + a19 + a20 + a21
        start = -a1 + a2 - a3 + a4 - a5 + a6 - a7 + a8
        start += -a9 + a10 - a11 + a12 - a13 + a14 - a15 + a16
        start += -a17 + a18 - a19 + a20 - a21
        a0 = -start  # I(-1) = 0
        scale = soa[R_PPK * ROW + k] / (total + a0)
        soa[R_SCALE * ROW + k] = scale
        soa[R_PI * ROW + k] = a0 * scale
        soa[(R_PI + 1) * ROW + k] = a1 * scale
        soa[(R_PI + 2) * ROW + k] = a2 * scale
        soa[(R_PI + 3) * ROW + k] = a3 * scale
        soa[(R_PI + 4) * ROW + k] = a4 * scale
        soa[(R_PI + 5) * ROW + k] = a5 * scale
        soa[(R_PI + 6) * ROW + k] = a6 * scale
        soa[(R_PI + 7) * ROW + k] = a7 * scale
        soa[(R_PI + 8) * ROW + k] = a8 * scale
        soa[(R_PI + 9) * ROW + k] = a9 * scale
        soa[(R_PI + 10) * ROW + k] = a10 * scale
        soa[(R_PI + 11) * ROW + k] = a11 * scale
        soa[(R_PI + 12) * ROW + k] = a12 * scale
        soa[(R_PI + 13) * ROW + k] = a13 * scale
        soa[(R_PI + 14) * ROW + k] = a14 * scale
        soa[(R_PI + 15) * ROW + k] = a15 * scale
        soa[(R_PI + 16) * ROW + k] = a16 * scale
        soa[(R_PI + 17) * ROW + k] = a17 * scale
        soa[(R_PI + 18) * ROW + k] = a18 * scale
        soa[(R_PI + 19) * ROW + k] = a19 * scale
        soa[(R_PI + 20) * ROW + k] = a20 * scale
        soa[(R_PI + 21) * ROW + k] = a21 * scale


@njit(cache=True, error_model="numpy")
def _early_start(soa, n, res):
    """The start of the root search of balls [0, n) of ``soa`` (:func:`_model_guess`) into
    ``res[R_ROOT]``: a pass of its own, which compiles to vector code (joined to the Newton
    steps' pass, the loop stayed scalar)."""
    for k in range(n):
        target = soa[R_TARGET * ROW + k]
        scale, ppk = soa[R_SCALE * ROW + k], soa[R_PPK * ROW + k]
        res[R_ROOT * ROW + k] = _model_guess(soa, k, target, scale, ppk)


@njit(cache=True, error_model="numpy")
def _early_newton(soa, n, res):
    """The force when the impulse reaches the slip's need, for balls [0, n) of ``soa`` (rows
    ``R_*``), into ``res[R_FORCE]``: from the start in ``res[R_ROOT]`` (:func:`_early_start`)
    four Newton steps written out, with no branch but selects, so that the loop over balls
    compiles to 4-wide vector code (one search after another was a long chain of dependent
    operations and unpredictable exits). ``res[R_OK]`` is 0 where the last step
    was not below NEWTON_TOL or left the bracket (searched again by :func:`_early_search`)."""
    for k in range(n):
        target, scale = soa[R_TARGET * ROW + k], soa[R_SCALE * ROW + k]
        sigma, lo, hi = res[R_ROOT * ROW + k], 0.0, 1.0
        sigma, lo, hi, step, inside = _newton_step(soa, k, sigma, lo, hi, target, scale)
        sigma, lo, hi, step, inside = _newton_step(soa, k, sigma, lo, hi, target, scale)
        sigma, lo, hi, step, inside = _newton_step(soa, k, sigma, lo, hi, target, scale)
        sigma, lo, hi, step, inside = _newton_step(soa, k, sigma, lo, hi, target, scale)
        res[R_FORCE * ROW + k] = _series_pair(soa, k, 2.0 * sigma - 1.0)[1]
        res[R_OK * ROW + k] = 1.0 if (inside and abs(step) <= NEWTON_TOL) else 0.0


@njit(cache=True, inline="always")
def _early_search(soa, k, target, scale):
    """The force at Pi(sigma) = target for ball ``k`` of ``soa``, by safeguarded Newton steps
    (:func:`_newton_step`) from sigma = 1 until the step is below NEWTON_TOL (Pi is
    increasing and convex in sigma and the root lies below 1, so that the iterates descend
    onto it; a bracket catches any step that would leave it): the ball that
    :func:`_early_newton` did not settle."""
    sigma, lo, hi = 1.0, 0.0, 1.0
    for _ in range(200):
        new, lo, hi, step, _inside = _newton_step(soa, k, sigma, lo, hi, target, scale)
        if abs(step) <= NEWTON_TOL:
            sigma -= step
            break
        sigma = new
        if hi - lo <= 1e-12:
            break
    return _series_pair(soa, k, 2.0 * sigma - 1.0)[1]


@njit(cache=True, inline="always")
def _early_friction(comp, x_max, gamma_max, kv, early, n_early, sel, counts, scratch, out):
    """Peak friction of the balls whose slip stops before the force peak (``early`` of
    :func:`_bounce_one`): mu times the normal force when the impulse reaches the slip's need
    (:func:`_early_forces`), the balls taken piece by piece of the compression table (a
    counting sort into ``sel``), so that one piece's coefficients serve them in turn."""
    n_pieces = comp.shape[0]
    width = x_max / n_pieces
    counts[:] = 0
    for j in range(n_early):
        piece = min(int(early[j, E_X] / width), n_pieces - 1)
        early[j, E_PIECE] = piece
        counts[piece + 1] += 1
    for piece in range(n_pieces):
        counts[piece + 1] += counts[piece]
    for j in range(n_early):
        piece = int(early[j, E_PIECE])
        sel[counts[piece]] = j
        counts[piece] += 1
    _early_forces(comp, sel, n_early, early, x_max, gamma_max, scratch)
    for k in range(n_early):
        e = early[k]
        out[O_FT, int(e[E_INDEX])] = (e[E_MU] * max(e[E_SIGMA], initial_force(
            kv, e[E_DAMPING])) * e[E_FSCALE])


@njit(cache=True, inline="always")
def _early_forces(comp, sel, n_sel, early, x_max, gamma_max, scratch):
    """Normal force (scaled) when the impulse reaches ``E_TARGET`` during compression, for the
    elements ``sel[:n_sel]`` of ``early`` (each in its piece ``E_PIECE`` of the compression
    table), into their ``E_SIGMA`` field.

    The compression table gives the force Phi as a Chebyshev series in
    sigma = sqrt(t / t_peak) (:func:`_compression_series`), and :func:`_early_series` the
    impulse Pi; each ball's series go into a column of the vector pass
    (:func:`_early_newton`), which solves Pi(sigma) = target for all of them side by side.
    ``scratch``: the arrays of :func:`early_scratch`."""
    work, phi, soa, res = scratch
    n_pieces = comp.shape[0]
    width = x_max / n_pieces
    for k in range(n_sel):
        e = early[sel[k]]
        piece = int(e[E_PIECE])
        _compression_series(comp[piece], e[E_GAMMA], gamma_max,
                            2.0 * (e[E_X] - piece * width) * n_pieces / x_max - 1.0, work, phi)
        for i in range(NS):
            soa[(R_PHI + i) * ROW + k] = phi[i]
        soa[R_TARGET * ROW + k], soa[R_PPK * ROW + k] = e[E_TARGET], e[E_PPK]
    early_roots(soa, n_sel, res)
    for k in range(n_sel):
        early[sel[k], E_SIGMA] = res[R_FORCE * ROW + k]


@njit(cache=True, inline="always")
def early_roots(soa, n, res):
    """The force at Pi(sigma) = target of balls [0, n) of ``soa`` (their force's series,
    target and impulse at the force peak) into ``res[R_FORCE]``: the vector passes
    (:func:`_early_series`, :func:`_early_start`, :func:`_early_newton`), then, one at a
    time, the balls they did not settle (:func:`_early_search`)."""
    _early_series(soa, n)
    _early_start(soa, n, res)
    _early_newton(soa, n, res)
    for k in range(n):
        if res[R_OK * ROW + k] == 0.0:  # rare: searched again, one ball at a time
            res[R_FORCE * ROW + k] = _early_search(soa, k, soa[R_TARGET * ROW + k],
                                                   soa[R_SCALE * ROW + k])


@njit(cache=True)
def early_scratch(n_compression):
    """Scratch of :func:`_early_forces` (one set per task): the contraction's work row (a
    compression piece's n_damping * NS values), one ball's force series, the vector pass's
    rows and results."""
    return (np.empty(n_compression), np.empty(NS), np.empty(N_ROWS_EARLY * ROW),
            np.empty(3 * ROW))


@njit(cache=True, error_model="numpy")
def bounce_range(values, ball, bounds, check_each, closed_form, main, comp, x_max, gamma_max,
                 kv, start, stop, out, status, rolling, flags, fallback):
    """Full closed-form bounces of elements [start, stop): outputs, status, flags (Hertz
    validity, closed form) and fallback reasons; returns (invalid, fallback) counts.
    ``check_each``: whether elements may lie outside their bounds (see ``all_valid``).

    In blocks of ``BLOCK`` elements, passes: the derived inputs, the normal scales (vector
    code), every other output of every element (one straight loop body), rebound speed and
    angle (vector code), then the peak friction of the balls whose slip stops before the force
    peak (a third of the prior box, each a root search in the compression table), so that the
    long branch does not sit in the loop that every element runs through. (``error_model``
    "numpy": a division by zero would give inf or NaN rather than raise, which no input in
    bounds reaches; without it every division carries a test that keeps the loops scalar.)"""
    rows = np.empty(N_TABLE * NX)
    tx = np.empty(NX)
    vals = np.empty(N_TABLE)
    scratch = early_scratch(comp.shape[2])
    early = np.empty((BLOCK, N_EARLY))  # one row per ball: its fields side by side
    sel = np.empty(BLOCK, dtype=np.int64)
    counts = np.empty(comp.shape[0] + 1, dtype=np.int64)
    scales = np.empty((N_SCALES, BLOCK))
    limit = HERTZ_OVERLAP_LIMIT * ball[B_R]
    shared_gravity = values[I_INCL].shape[0] == 1 and values[I_G].shape[0] == 1
    gx, gy = gravity_parts(values, 0)
    n_invalid = n_fallback = 0
    for block in range(start, stop, BLOCK):
        n_block = min(block + BLOCK, stop) - block
        n_early = 0
        if closed_form:
            _block_inputs(values, ball, shared_gravity, gx, gy, block, n_block, scales)
            _block_scales(ball[B_M], kv, n_block, scales)
        for j in range(n_block):
            i = block + j
            reason = FB_ODE
            if check_each and not valid(values, bounds, i):
                fill_failed(out, i, status, K.ST_INVALID, rolling, flags)
                fallback[i] = FB_NONE
                n_invalid += 1
                continue
            if closed_form:
                reason, n_early = _bounce_one(values, ball, i, scales, j, main, x_max,
                                              gamma_max, kv, rows, tx, vals, out, early,
                                              n_early)
            if reason > 0:
                fill_failed(out, i, status, K.ST_OK, rolling, flags)
                n_fallback += 1
                fallback[i] = reason
                continue
            fallback[i] = FB_NONE
            status[i] = K.ST_OK
            rolling[i] = reason < 0
            flags[0, i] = out[O_DMAX, i] <= limit
            flags[1, i] = True
        _block_speed_angle(out, block, n_block)
        _early_friction(comp, x_max, gamma_max, kv, early, n_early, sel, counts, scratch, out)
    return n_invalid, n_fallback


@njit(cache=True, parallel=True)
def bounce_parallel(values, ball, bounds, check_each, closed_form, main, comp, x_max, gamma_max,
                    kv, out, status, rolling, flags, fallback):
    """:func:`bounce_range` over all elements, in parallel tasks of ``TASK`` elements handed
    out one at a time (:func:`bounces`); returns the counts."""
    n = status.shape[0]
    n_chunks = (n + TASK - 1) // TASK
    counts = np.zeros((n_chunks, 2), dtype=np.int64)
    for c in prange(n_chunks):
        a, b = bounce_range(values, ball, bounds, check_each, closed_form, main, comp, x_max,
                            gamma_max, kv, c * TASK, min(n, (c + 1) * TASK), out, status,
                            rolling, flags, fallback)
        counts[c, 0] = a
        counts[c, 1] = b
    return counts[:, 0].sum(), counts[:, 1].sum()


def bounces(values, ball, bounds, closed_form: bool, tables, out, status, rolling, flags,
            fallback) -> tuple[int, int]:
    """Full closed-form bounces of every element (serial for small batches) with the
    ``tables`` of :func:`kernel_tables`; fallback rows are left for the ODE solver. Returns
    (invalid, fallback) counts."""
    main, comp, x_max, gamma_max, kv = tables
    check_each = not all_valid(values, bounds)
    if status.size <= SERIAL_MAX:
        return bounce_range(values, ball, bounds, check_each, closed_form, main, comp, x_max,
                            gamma_max, kv, 0, status.size, out, status, rolling, flags, fallback)
    # tasks handed out one at a time, not split evenly in advance: on a shared machine a
    # thread that is held up no longer keeps the others waiting (and spinning) at the end
    previous = numba.set_parallel_chunksize(1)
    try:
        return bounce_parallel(values, ball, bounds, check_each, closed_form, main, comp, x_max,
                               gamma_max, kv, out, status, rolling, flags, fallback)
    finally:
        numba.set_parallel_chunksize(previous)


# --- conditions fixed, parameters varying (samplers) -------------------------------------------

# Per-condition fields of ``prepare_conditions``.
(C_MU, C_ETA, C_SPIN, C_E, C_K, C_GX, C_GY, C_U0, C_VN, C_DSTAR, C_TSTAR, C_GAMMA, C_CZ,
 C_STATE) = range(14)
N_COND = 14
CS_INVALID, CS_OUTSIDE, CS_TABLE = 0.0, 1.0, 2.0  # condition states


@njit(cache=True)
def prepare_conditions(values, ball, bounds, main, gamma_max, kv, cond, cond_rows):
    """Per condition: its inputs and derived quantities (``C_*``), and the gravity-contracted
    rows of restitution and contact time (the part of the table a parameter change does not
    touch when the modulus is fixed)."""
    m = ball[B_M]
    for c in range(cond.shape[1]):
        mu, eta, k, gx, gy, u0, vn, w0 = element(values, ball, c)
        cond[C_MU, c], cond[C_ETA, c], cond[C_SPIN, c] = mu, eta, w0
        cond[C_E, c] = at(values[I_E], c)
        cond[C_K, c], cond[C_GX, c], cond[C_GY, c] = k, gx, gy
        cond[C_U0, c], cond[C_VN, c] = u0, vn
        if not valid(values, bounds, c):
            cond[C_STATE, c] = CS_INVALID
            continue
        d_star, t_star, damping, x, gamma = normal_scales(m, k, 1.0, gy, vn, kv)
        cond[C_DSTAR, c], cond[C_TSTAR, c], cond[C_GAMMA, c] = d_star, t_star, gamma
        cond[C_CZ, c] = damping  # damping number per unit eta
        if gamma <= gamma_max:
            cond[C_STATE, c] = CS_TABLE
            for piece in range(cond_rows.shape[1]):  # none: contracted at each evaluation
                gravity_rows(main[piece], gamma, gamma_max, 0, 2 * NX, cond_rows[c, piece])
        else:
            cond[C_STATE, c] = CS_OUTSIDE


@njit(cache=True, inline="always")
def condition_rows(cond_rows, c, piece, main, gamma, gamma_max, rows):
    """The gravity-contracted restitution and contact-time rows of condition ``c`` in
    ``piece``: prepared (``prepare_conditions``), or contracted now into ``rows`` where the
    conditions were too many to prepare (``cond_rows`` with no pieces)."""
    if cond_rows.shape[1] > 0:
        return cond_rows[c, piece]
    gravity_rows(main[piece], gamma, gamma_max, 0, 2 * NX, rows)
    return rows


@njit(cache=True, inline="always")
def _pick(theta, r, col, cond, field, c):
    """Parameter ``col`` of row ``r``, or the condition's value where it does not vary."""
    return theta[r, col] if col >= 0 else cond[field, c]


@njit(cache=True, inline="always")
def _row_valid(theta, r, cols, bounds):
    """Whether the varying parameters of row ``r`` lie in their bounds (False for NaN)."""
    for k, index in ((0, I_MU), (1, I_ETA), (2, I_E), (3, I_SPIN)):
        if cols[k] >= 0 and not bounds[index, 0] <= theta[r, cols[k]] <= bounds[index, 1]:
            return False
    return True


@njit(cache=True, inline="always")
def _rebound_one(theta, r, cols, cond, c, cond_rows, ball, main, x_max, gamma_max, kv, rows, tx,
                 vals, out):
    """Rebound of parameter row ``r`` (valid) under condition ``c`` into ``out[:, r, c]``;
    returns -1 (rolling) / -2 (sliding) when solved, -3 for the ODE, or a status code."""
    state = cond[C_STATE, c]
    if state == CS_INVALID:
        return K.ST_INVALID
    mu = _pick(theta, r, cols[0], cond, C_MU, c)
    eta = _pick(theta, r, cols[1], cond, C_ETA, c)
    vn = cond[C_VN, c]
    if cols[2] >= 0:  # the modulus varies: the normal impact is computed afresh
        d_star, t_star, damping, x, gamma = normal_scales(
            ball[B_M], ball[B_KFAC] * theta[r, cols[2]], eta, cond[C_GY, c], vn, kv)
        if not (x <= x_max and gamma <= gamma_max):
            return -3
        piece, ux = main_piece(x, x_max)
        gravity_rows(main[piece], gamma, gamma_max, 0, 2 * NX, rows)
        x_values(rows, NX, T_E, T_TC + 1, ux, tx, vals)
    else:
        if state == CS_OUTSIDE:
            return -3
        t_star, gamma = cond[C_TSTAR, c], cond[C_GAMMA, c]
        x = damping_variable(kv, eta * cond[C_CZ, c])
        if not x <= x_max:
            return -3
        piece, ux = main_piece(x, x_max)
        x_values(condition_rows(cond_rows, c, piece, main, gamma, gamma_max, rows), NX, T_E,
                 T_TC + 1, ux, tx, vals)
    tc = vals[T_TC] * t_star
    impulse = vn * (1.0 + vals[T_E] + gamma * vals[T_TC])
    exact, u, w, phase, slides = tangential_one(
        ball[B_R], ball[B_M], ball[B_I], mu, cond[C_GX, c], cond[C_U0, c],
        _pick(theta, r, cols[3], cond, C_SPIN, c), tc, impulse)
    if not exact:
        return -3
    out[RB_SPEED, r, c], out[RB_ANGLE, r, c] = speed_angle(u, vals[T_E] * vn)
    out[RB_SPIN, r, c] = w
    out[RB_TC, r, c] = tc
    return -1 if phase == 0.0 else -2


@njit(cache=True, inline="always")
def _rebound_row(theta, r, cols, cond, cond_rows, ball, main, x_max, gamma_max, kv, rows, tx,
                 stage, codes, out):
    """:func:`_rebound_one` for every condition of row ``r`` when the modulus is fixed, in
    four passes over the conditions (damping variable, table, friction, speed and angle):
    short loop bodies whose iterations the processor overlaps, where one long body per bounce
    is a chain of dependent steps; the first and the last compile to vector code
    (:mod:`._vmath`). The arithmetic is exactly that of :func:`_rebound_one`."""
    nc = cond.shape[1]
    eta_r = theta[r, cols[1]] if cols[1] >= 0 else 0.0
    if kv == K.LAW_KELVIN_VOIGT:  # the law a constant in each loop, as in _block_scales
        _damping_variables(K.LAW_KELVIN_VOIGT, cols[1] >= 0, eta_r, cond, nc, stage[0])
    elif kv == K.LAW_TSUJI:
        _damping_variables(K.LAW_TSUJI, cols[1] >= 0, eta_r, cond, nc, stage[0])
    else:
        _damping_variables(K.LAW_LINEAR, cols[1] >= 0, eta_r, cond, nc, stage[0])
    for c in range(nc):
        state = cond[C_STATE, c]
        x = stage[0, c]
        if state == CS_INVALID:
            codes[c] = K.ST_INVALID
        elif state == CS_OUTSIDE or not x <= x_max:
            codes[c] = -3
        else:
            codes[c] = 0
            piece, ux = main_piece(x, x_max)
            row = condition_rows(cond_rows, c, piece, main, cond[C_GAMMA, c], gamma_max, rows)
            cheb_basis(ux, tx, NX)
            stage[1, c] = _dot(row, T_E * NX, tx, NX)
            stage[2, c] = _dot(row, T_TC * NX, tx, NX)
    for c in range(nc):
        stage[3, c] = math.nan
        if codes[c] != 0:
            continue
        e, tc_scaled = stage[1, c], stage[2, c]
        vn = cond[C_VN, c]
        tc = tc_scaled * cond[C_TSTAR, c]
        impulse = vn * (1.0 + e + cond[C_GAMMA, c] * tc_scaled)
        exact, u, w, phase, slides = tangential_one(
            ball[B_R], ball[B_M], ball[B_I], _pick(theta, r, cols[0], cond, C_MU, c),
            cond[C_GX, c], cond[C_U0, c], _pick(theta, r, cols[3], cond, C_SPIN, c), tc,
            impulse)
        if not exact:
            codes[c] = -3
            continue
        stage[3, c], stage[4, c] = u, e * vn
        out[RB_SPIN, r, c] = w
        out[RB_TC, r, c] = tc
        codes[c] = -1 if phase == 0.0 else -2
    u_c, vn_c, speed_c, angle_c = stage[3], stage[4], stage[5], stage[6]
    for c in range(nc):
        speed_c[c], angle_c[c] = speed_angle(u_c[c], vn_c[c])
    for c in range(nc):
        if codes[c] == -1 or codes[c] == -2:  # solved
            out[RB_SPEED, r, c], out[RB_ANGLE, r, c] = speed_c[c], angle_c[c]


@njit(cache=True, inline="always")
def _damping_variables(law, varies, eta_r, cond, nc, x_out):
    """The damping variable of every condition (eta the row's where it ``varies``, else each
    condition's own), in loops that compile to vector code."""
    cz, eta_c = cond[C_CZ], cond[C_ETA]
    if varies:
        for c in range(nc):
            x_out[c] = damping_variable(law, eta_r * cz[c])
    else:
        for c in range(nc):
            x_out[c] = damping_variable(law, eta_c[c] * cz[c])


@njit(cache=True, error_model="numpy")
def rebound_range(theta, cols, cond, cond_rows, ball, bounds, main, x_max, gamma_max, kv, r0,
                  r1, out, status, rolling, ok, fallback):
    """Rebounds of parameter rows [r0, r1) under every condition, into ``out[:, r, c]`` and
    the (row, condition) arrays; marks ``fallback`` for the ODE and returns how many
    (``error_model`` "numpy", as :func:`bounce_range`, so that its passes vectorise)."""
    nc = cond.shape[1]
    rows = np.empty(2 * NX)
    tx = np.empty(NX)
    vals = np.empty(2)
    codes = np.empty(nc, dtype=np.int64)
    stage = np.empty((7, nc))
    n_fallback = 0
    for r in range(r0, r1):
        row_ok = _row_valid(theta, r, cols, bounds)
        if row_ok and cols[2] < 0:
            _rebound_row(theta, r, cols, cond, cond_rows, ball, main, x_max, gamma_max, kv,
                         rows, tx, stage, codes, out)
        for c in range(nc):
            code = K.ST_INVALID
            if row_ok and cols[2] < 0:
                code = codes[c]
            elif row_ok:
                code = _rebound_one(theta, r, cols, cond, c, cond_rows, ball, main, x_max,
                                    gamma_max, kv, rows, tx, vals, out)
            if code < -2:
                n_fallback += 1
            if code < 0:
                status[r, c] = K.ST_OK
                ok[r, c] = code > -3
                rolling[r, c] = code == -1
                fallback[r, c] = code == -3
                if code > -3:
                    continue
            else:
                status[r, c] = code
                ok[r, c] = False
                rolling[r, c] = False
                fallback[r, c] = False
            for q in range(out.shape[0]):
                out[q, r, c] = math.nan
    return n_fallback


@njit(cache=True, parallel=True)
def rebound_parallel(theta, cols, cond, cond_rows, ball, bounds, main, x_max, gamma_max, kv, out,
                     status, rolling, ok, fallback):
    """:func:`rebound_range` over all parameter rows in parallel chunks of rows; returns the
    fallback count."""
    n = theta.shape[0]
    step = max(1, CHUNK // cond.shape[1])
    n_chunks = (n + step - 1) // step
    counts = np.zeros(n_chunks, dtype=np.int64)
    for k in prange(n_chunks):
        counts[k] = rebound_range(theta, cols, cond, cond_rows, ball, bounds, main, x_max,
                                  gamma_max, kv, k * step, min(n, (k + 1) * step), out, status,
                                  rolling, ok, fallback)
    return counts.sum()


@njit(cache=True, parallel=True)
def gaussian_grid(mu, eta, cond, cond_rows, ball, bounds, main, x_max, gamma_max, kv, speed_obs,
                  angle_obs, icov, log_norm, out, bad):
    """Sum over conditions of bivariate-normal log densities of the (rebound speed, angle)
    misfits on a (mu, eta) grid: the normal impact once per (eta, condition), the tangential
    outcome per mu. ``icov`` rows hold the inverse covariance (ss, sa, aa); ``bad`` marks
    cells the closed form cannot do (the caller recomputes them)."""
    n_mu, n_eta, nc = mu.size, eta.size, cond.shape[1]
    r, m, inertia = ball[B_R], ball[B_M], ball[B_I]
    for j in prange(n_eta):
        tx = np.empty(NX)
        vals = np.empty(2)
        rows = np.empty(2 * NX)
        for i in range(n_mu):
            out[i, j] = 0.0
            if not (bounds[I_MU, 0] <= mu[i] <= bounds[I_MU, 1]
                    and bounds[I_ETA, 0] <= eta[j] <= bounds[I_ETA, 1]):
                bad[i, j] = True
        for c in range(nc):
            vn = cond[C_VN, c]
            x = damping_variable(kv, eta[j] * cond[C_CZ, c])
            if cond[C_STATE, c] != CS_TABLE or not x <= x_max:
                for i in range(n_mu):
                    bad[i, j] = True
                continue
            piece, ux = main_piece(x, x_max)
            x_values(condition_rows(cond_rows, c, piece, main, cond[C_GAMMA, c], gamma_max, rows),
                     NX, T_E, T_TC + 1, ux, tx, vals)
            tc = vals[T_TC] * cond[C_TSTAR, c]
            impulse = vn * (1.0 + vals[T_E] + cond[C_GAMMA, c] * vals[T_TC])
            vn_out = vals[T_E] * vn
            for i in range(n_mu):
                exact, u, w, phase, slides = tangential_one(
                    r, m, inertia, mu[i], cond[C_GX, c], cond[C_U0, c], cond[C_SPIN, c], tc,
                    impulse)
                if not exact:
                    bad[i, j] = True
                    continue
                speed, angle = speed_angle(u, vn_out)
                ds = speed - speed_obs[c]
                da = angle - angle_obs[c]
                out[i, j] -= 0.5 * (icov[c, 0] * ds * ds + 2.0 * icov[c, 1] * ds * da
                                    + icov[c, 2] * da * da) + log_norm[c]
