"""posterior.nc (an ArviZ DataTree), summary.json and grid.npz: writing them as one, and
reading a result back.

posterior.nc holds the groups ArviZ users expect: ``posterior`` (chain, draw), ``sample_stats``
(``lp``, and ``accepted`` for Metropolis–Hastings), ``observed_data`` (per trial),
``log_likelihood`` (variable ``rebound``: per trial for the gaussian likelihood, one
``campaign`` term per draw for kde and consistent; see ``_likelihood``), ``posterior_predictive``
(replicated rebound speed and angle at a subset of draws, whose indices are the ``draw``
coordinate), ``adequacy`` (per trial: standardised residuals of rebound speed and angle and the
posterior predictive p-value of the adequacy check) and provenance attributes on the root.
With the population likelihood also ``population_predictive`` (chain, draw: one new bounce's
parameters per posterior draw) and ``bounces`` (per trial: each bounce's estimate under the
population, alone, and the shrinkage). It opens with ``xarray.open_datatree`` and
``arviz_base.convert_to_datatree``.
"""

from __future__ import annotations

import json
import platform
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import InputFileError
from .._io import json_text, write_all
from .._version import __version__
from ._adequacy import PER_TRIAL
from ._grid import GridRun

OBSERVED = ("rebound_speed", "rebound_angle", "incidence_speed", "incidence_angle",
            "incidence_spin")


def provenance(result: Any) -> dict[str, Any]:
    """Attributes of posterior.nc: what made it, from which inputs, with which settings, and
    the package's one provenance record (``provenance``, as every output file carries it; a
    command stamps its own, with its command line, over it)."""
    import arviz_base

    from .._provenance import one_line
    from .._provenance import provenance as record

    t, e = result.trials, result.experiment
    stamp = record(inputs={}, seed=result.seed, config={
        "likelihood": result.likelihood, "sampler": result.sampler,
        "discrepancy": result.discrepancy, "sampler_config": result.config.to_dict(),
        "memory_budget": result.memory_budget})
    stamp["inputs"] = {"experiment": {"path": e.source, "sha256": e.text_sha256},
                       "trials": {"path": t.source, "sha256": t.sha256}}
    return {"provenance": one_line(stamp), "bouncebayes_version": __version__,
            "seed": result.seed,
            "likelihood": result.likelihood, "sampler": result.sampler,
            "config": json.dumps(result.config.to_dict()),
            "memory_budget_bytes": result.memory_budget,
            "data_file": t.source, "data_sha256": t.sha256,
            "experiment_file": e.source, "experiment_sha256": e.text_sha256,
            "units": json.dumps(dict(zip(result.names, result.posterior.units, strict=True))),
            "pointwise_log_likelihood": result.likelihood_info.get("pointwise", ""),
            "python": platform.python_version(), "numpy": np.__version__,
            "arviz_base": arviz_base.__version__}


def inference_data(result: Any):
    """The result as an ArviZ DataTree (see the module docstring for its groups)."""
    with warnings.catch_warnings():
        # ArviZ guesses that (chain, draw) were swapped when an ensemble run keeps fewer draws
        # per walker than it has walkers; the axes here are named, and right
        warnings.filterwarnings("ignore", "Found chain dimension to be longer", UserWarning)
        return _inference_data(result)


def _inference_data(result: Any):
    import arviz_base
    import xarray as xr

    s, t = result.draws.samples, result.trials
    groups: dict[str, dict[str, np.ndarray]] = {
        "posterior": {n: s[..., i] for i, n in enumerate(result.names)},
        "sample_stats": {k: np.asarray(v) for k, v in result.draws.stats.items()},
        "observed_data": {k: np.asarray(t.column(k)) for k in OBSERVED}}
    obs_dim = "trial" if result.observations == t.labels else "campaign"
    coords = {"trial": list(t.labels), obs_dim: list(result.observations)}
    dims = {k: ["trial"] for k in OBSERVED} | {"rebound": [obs_dim]}
    if result.log_likelihood is not None:
        groups["log_likelihood"] = {"rebound": result.log_likelihood}
    tree = arviz_base.from_dict(groups, coords=coords, dims=dims,
                                attrs={"/": provenance(result)})
    if result.adequacy is not None:
        tree["adequacy"] = xr.DataTree(xr.Dataset(
            {k: (("trial",), np.asarray(v, dtype=float))
             for k, v in result.adequacy.per_trial().items()}, coords={"trial": list(t.labels)}))
    pop = getattr(result, "population", None)
    if pop is not None:  # a new bounce's parameters per draw, and each bounce's estimates
        tree["population_predictive"] = xr.DataTree(arviz_base.dict_to_dataset(
            {n: pop.predictive[..., i] for i, n in enumerate(pop.names)}))
        tree["bounces"] = xr.DataTree(xr.Dataset(
            {k: (("trial",), np.asarray(v, dtype=float)) for k, v in pop.bounces.items()},
            coords={"trial": list(t.labels)}))
    rep = result.replicates
    if rep is not None:
        tree["posterior_predictive"] = xr.DataTree(arviz_base.dict_to_dataset(
            {"rebound_speed": rep.rebound_speed, "rebound_angle": rep.rebound_angle},
            coords={"draw": rep.draw.tolist()} | coords,
            dims={"rebound_speed": [obs_dim], "rebound_angle": [obs_dim]}))
    return tree


def write_outputs(result: Any, out: str | Path) -> dict[str, Path]:
    """Write ``posterior.nc`` (NetCDF-4 via h5netcdf) and ``summary.json``, with the grid
    sampler also ``grid.npz`` (normalised joint density and marginals), as one: if any of them
    cannot be written, none of the earlier files is replaced."""
    out = Path(out)
    summary = json_text(result.summary())
    tree = inference_data(result)
    writers: dict[Any, Callable[[Path], Any]] = {
        out / "posterior.nc": lambda tmp: tree.to_netcdf(str(tmp), engine="h5netcdf"),
        out / "summary.json": lambda tmp: tmp.write_text(summary, encoding="utf-8")}
    grid = result.draws.info.grid if isinstance(result.draws.info, GridRun) else None
    if grid is not None:
        writers[out / "grid.npz"] = lambda tmp: _save_grid(tmp, grid, result.names)
    paths = write_all(writers)
    return dict(zip(("posterior", "summary", "grid"), paths, strict=False))


def _save_grid(tmp: Path, grid: Any, names: tuple[str, ...]) -> None:
    arrays = {"density": grid.density, "names": np.array(names)}
    arrays |= {f"centres_{i}": np.asarray(c) for i, c in enumerate(grid.centres)}
    arrays |= {f"marginal_{i}": np.asarray(m) for i, m in enumerate(grid.marginals)}
    with open(tmp, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def read_posterior(path: str | Path, names: tuple[str, ...]) -> dict[str, Any]:
    """The arrays of a posterior.nc: samples (chains, draws, d) in ``names`` order, sample
    statistics, the pointwise log-likelihood and the replicates (``None`` where absent)."""
    import xarray as xr

    path = Path(path)
    try:
        with xr.open_datatree(path) as tree:
            tree = tree.load()
    except (OSError, ValueError) as err:
        raise InputFileError(path, f"damaged: not a readable posterior file ({err})") from None
    missing = [n for n in names if "posterior" not in tree or n not in tree["posterior"]]
    if missing:
        raise InputFileError(path, f"damaged: no posterior draws of {', '.join(missing)}")
    stats: Any = tree["sample_stats"].to_dataset() if "sample_stats" in tree else {}
    posterior: Any = tree["posterior"]
    out: dict[str, Any] = {
        "samples": np.stack([posterior[n].values for n in names], axis=-1),
        "stats": {k: stats[k].values for k in stats}, "log_likelihood": None,
        "replicates": None}
    if "log_likelihood" in tree:
        out["log_likelihood"] = tree["log_likelihood"]["rebound"].values
    out["adequacy"] = ({k: tree["adequacy"][k].values for k in PER_TRIAL}
                       if "adequacy" in tree else None)
    if "population_predictive" in tree:
        pp = tree["population_predictive"]
        out["population_predictive"] = {str(k): pp[str(k)].values for k in pp.data_vars}
        bounces = tree["bounces"]
        out["bounces"] = {str(k): bounces[str(k)].values for k in bounces.data_vars}
    if "posterior_predictive" in tree:
        pp = tree["posterior_predictive"]
        out["replicates"] = (pp["draw"].values, pp["rebound_speed"].values,
                             pp["rebound_angle"].values)
    return out
