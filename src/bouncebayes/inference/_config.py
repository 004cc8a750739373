"""One small frozen configuration per sampler, each checked on construction."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any, Literal, get_args

SamplerName = Literal["mh", "ensemble", "grid"]
SAMPLERS: tuple[str, ...] = get_args(SamplerName)
GRID_POINTS = {1: 2048, 2: 512, 3: 96}  #: default grid points per parameter, by dimension


def _integer(config: Any, name: str, low: int) -> None:
    value = getattr(config, name)
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"`{name}` must be an integer >= {low}; got {value!r}")


class _Config:
    """Shared behaviour: a JSON-ready record of the fields."""

    def to_dict(self) -> dict[str, Any]:
        """The fields, for summary.json and the provenance of posterior.nc."""
        return asdict(self)  # type: ignore[call-overload]


@dataclass(frozen=True, kw_only=True)
class MHConfig(_Config):
    """Random-walk Metropolis–Hastings; the defaults are the paper's settings.

    Arguments:
        draws: draws kept over all chains (each chain keeps ``ceil(draws / chains)``).
        chains: chains, started from dispersed points around the mode and advanced together.
        burn_in: iterations per chain discarded at the start; the proposal scale is tuned
            during them.
        thin: keep every ``thin``-th iteration after the burn-in.
    """

    draws: int = 15_000
    chains: int = 4
    burn_in: int = 100
    thin: int = 3

    def __post_init__(self) -> None:
        for name, low in (("draws", 100), ("chains", 1), ("burn_in", 0), ("thin", 1)):
            _integer(self, name, low)

    def per_chain(self) -> int:
        """Draws kept per chain."""
        return math.ceil(self.draws / self.chains)

    def iterations(self) -> int:
        """Iterations per chain, burn-in included."""
        return self.burn_in + self.per_chain() * self.thin


@dataclass(frozen=True, kw_only=True)
class EnsembleConfig(_Config):
    """emcee's affine-invariant ensemble sampler.

    Arguments:
        draws: draws kept over all walkers.
        walkers: walkers (raised to at least 2 x parameters + 2, and to an even number).
        burn_in: steps discarded at the start.
        thin: keep every ``thin``-th step.
    """

    draws: int = 15_000
    walkers: int = 32
    burn_in: int = 500
    thin: int = 5

    def __post_init__(self) -> None:
        for name, low in (("draws", 100), ("walkers", 4), ("burn_in", 0), ("thin", 1)):
            _integer(self, name, low)

    def walkers_for(self, dim: int) -> int:
        """The walkers used for ``dim`` parameters."""
        w = max(self.walkers, 2 * dim + 2)
        return w + w % 2


@dataclass(frozen=True, kw_only=True)
class GridConfig(_Config):
    """Exact quadrature on a regular grid over the prior box (1 to 3 parameters).

    Arguments:
        draws: draws resampled from the grid cells (for propagation and the outputs).
        points: grid points per parameter (default 2048, 512, 96 for 1, 2, 3 parameters).
    """

    draws: int = 15_000
    points: int | None = None

    def __post_init__(self) -> None:
        _integer(self, "draws", 100)
        if self.points is not None and (isinstance(self.points, bool)
                                        or not isinstance(self.points, int)
                                        or not 8 <= self.points <= 100_000):
            raise ValueError(f"`points` must be an integer in [8, 100000]; got {self.points!r}")

    def points_for(self, dim: int) -> int:
        """Grid points per parameter for ``dim`` parameters."""
        if dim not in GRID_POINTS:
            raise ValueError(f"the grid sampler handles 1 to 3 parameters; this problem has "
                             f"{dim}: use `mh` or `ensemble`")
        return int(self.points or GRID_POINTS[dim])


AnyConfig = MHConfig | EnsembleConfig | GridConfig
CONFIGS: dict[str, type[AnyConfig]] = {"mh": MHConfig, "ensemble": EnsembleConfig,
                                       "grid": GridConfig}


def sampler_config(sampler: str, **settings: Any) -> AnyConfig:
    """The configuration of ``sampler`` from keyword settings (``None``: the default), e.g.
    ``sampler_config("grid", draws=500, points=128)``; a setting the sampler does not have is
    refused naming the ones it has."""
    if sampler not in CONFIGS:
        raise ValueError(f"`sampler` must be one of {', '.join(map(repr, SAMPLERS))}; "
                         f"got {sampler!r}")
    cls = CONFIGS[sampler]
    names = [f.name for f in fields(cls)]
    given = {k: v for k, v in settings.items() if v is not None}
    unknown = sorted(set(given) - set(names))
    if unknown:
        raise ValueError(f"`{unknown[0]}` is not a setting of the {sampler} sampler; "
                         f"{cls.__name__} has {', '.join(names)}")
    return cls(**given)


def config_for(sampler: str, config: object) -> AnyConfig:
    """``config`` checked against ``sampler`` (``None``: the sampler's defaults)."""
    cls = CONFIGS[sampler]
    if config is None:
        return cls()
    if not isinstance(config, cls):
        raise TypeError(f"`config` must be a {cls.__name__} for sampler={sampler!r}; got "
                        f"{type(config).__name__}")
    return config


def default_sampler(likelihood: str | None) -> str:
    """The sampler used when none is named: the paper's ``"mh"``, except ``"ensemble"``
    (emcee) for the ``population`` likelihood. A truncated population's mean and spread trade
    off along a narrow curved ridge (a wide population cut by the prior's bounds, or a spread
    near zero): a random-walk proposal tuned in burn-in crawls along it (in one synthetic
    campaign, `benchmarks/population_sbc.py` campaign 164, mh's bulk ESS was 8 of 4000 draws;
    the affine-invariant ensemble's 1,200 of 3,200)."""
    return "ensemble" if likelihood == "population" else "mh"


def sampler_of(config: object) -> str | None:
    """The sampler a configuration belongs to (``None`` for none)."""
    return next((name for name, cls in CONFIGS.items() if isinstance(config, cls)), None)


def resolve_sampler(sampler: str | None, config: object, likelihood: str | None) -> str:
    """The sampler a run uses: ``sampler`` if named, else the one ``config`` belongs to, else
    the likelihood's default (:func:`default_sampler`)."""
    if sampler is not None:
        return sampler
    return sampler_of(config) or default_sampler(likelihood)

