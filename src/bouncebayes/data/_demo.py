"""The bundled demo campaign: 55 synthetic bounces of the paper's setup, with their truth."""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

DEMO_SEED = 2016  # `bouncebayes synth experiment.toml --n 55 --seed 2016` in the demo folder


@dataclass(frozen=True)
class DemoCampaign:
    """Paths of the demo files and the true values they were generated with."""

    folder: Path
    experiment: Path  #: the paper's setup (identical to examples/paper.toml)
    trials: Path  #: trial table (55 bounces, sliding throughout)
    trajectories: Path  #: one t,x,y file per bounce, 1000 Hz, 0.2 mm noise
    truth: dict  #: seed, population values (mu = 0.16, eta = 1.35 kg/s), per-bounce values


def demo_campaign() -> DemoCampaign:
    """The demo campaign shipped inside the package."""
    folder = Path(str(files("bouncebayes") / "demo"))
    truth = json.loads((folder / "truth.json").read_text(encoding="utf-8"))
    return DemoCampaign(folder, folder / "experiment.toml", folder / "trials.csv",
                        folder / "trajectories", truth)
