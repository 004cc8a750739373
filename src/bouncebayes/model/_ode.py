"""The ODE path driven from Python: elements in chunks against a deadline, and histories."""

from __future__ import annotations

import time

import numpy as np

from . import _kernel as K
from ._arrays import Inputs, ode_arrays
from ._config import SolverConfig

ODE_CHUNK = 1024  # bounces per solver call between two looks at the clock


def solve_rows(inputs: Inputs, rows: np.ndarray,
               solver: SolverConfig) -> tuple[np.ndarray, np.ndarray]:
    """The compiled solver on the elements ``rows`` (all valid): (results ``R_*``, status)."""
    params, y0, scale, h_max, t_max = ode_arrays(inputs, rows)
    status = np.zeros(rows.size, dtype=np.int8)
    res = np.full((rows.size, K.N_RESULTS), np.nan)
    solve_chunked(params, y0, scale, h_max, t_max, solver, status, res)
    return res, status


def solve_chunked(params, y0, scale, h_max, t_max, solver: SolverConfig, status: np.ndarray,
                  res: np.ndarray) -> None:
    """The compiled solver over all rows, in chunks of ``ODE_CHUNK`` against the deadline of
    ``solver.time_limit``: the first chunk always runs, later ones only before the deadline;
    rows of chunks not started in time get ``TIMEOUT``. A chunk, once started, finishes (each
    bounce is bounded by ``max_steps`` attempts)."""
    deadline = None if solver.time_limit is None else time.monotonic() + solver.time_limit
    for start in range(0, status.size, ODE_CHUNK):
        part = slice(start, start + ODE_CHUNK)
        if start and deadline is not None and time.monotonic() > deadline:
            status[start:][status[start:] == K.ST_OK] = K.ST_TIMEOUT
            return
        K.solve_batch(params[part], y0[part], scale[part], h_max[part], t_max[part],
                      solver.rtol, solver.atol, solver.max_steps, status[part], res[part])


def solve_with_segments(inputs: Inputs, row: int, solver: SolverConfig):
    """One element with its dense output kept: (results, status, segments, params)."""
    params, y0, scale, h_max, t_max = ode_arrays(inputs, np.array([row]))
    segs = np.empty((solver.max_steps, K.N_SEGMENT))
    res = np.full(K.N_RESULTS, np.nan)
    status = K.solve_contact(params[0], y0[0], scale[0], h_max[0], t_max[0], solver.rtol,
                             solver.atol, solver.max_steps, segs, res)
    if status != K.ST_OK:
        res[:] = np.nan
    return res, status, segs, params[0]


def sample(res: np.ndarray, segs: np.ndarray, params: np.ndarray,
           times: np.ndarray) -> np.ndarray:
    """History rows (``N_HISTORY`` columns) of a solved element at ascending ``times`` in
    [0, contact time], from the dense output the solve kept (no second integration)."""
    hist = np.empty((times.size, K.N_HISTORY))
    final = np.ascontiguousarray(res[K.R_X:K.R_X + K.N_STATE])
    K.sample_segments(segs, int(res[K.R_STEPS]), params, np.ascontiguousarray(times, float),
                      final, res[K.R_PHASE], hist)
    return hist
