"""The bundled campaigns: ``paper``, 55 synthetic bounces of the paper's setup with their truth
(the default demo), and ``kharaz``, the measurements of Kharaz et al. (2001) as a trial table."""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

DEMO_SEED = 2016  # `bouncebayes synth experiment.toml --n 55 --seed 2016` in the demo folder
#: campaign name -> its folder inside the package
CAMPAIGNS = {"paper": "demo", "kharaz": "demo_kharaz2001"}


@dataclass(frozen=True)
class DemoCampaign:
    """Paths of a bundled campaign's files and, for a synthetic one, its true values."""

    folder: Path
    experiment: Path  #: the experiment file (paper: identical to examples/paper.toml)
    trials: Path  #: trial table (paper: 55 bounces, sliding throughout; kharaz: 11 angles)
    trajectories: Path | None  #: paper: one t,x,y file per bounce, 1000 Hz, 0.2 mm noise
    truth: dict | None  #: paper: seed, population values (mu = 0.16, eta = 1.35 kg/s), per bounce
    name: str = "paper"

    @property
    def data(self) -> Path:
        """What a run reads: the trajectories where there are some, else the trial table."""
        return self.trajectories if self.trajectories is not None else self.trials


def demo_campaign(name: str = "paper") -> DemoCampaign:
    """A campaign shipped inside the package: ``"paper"`` (the default demo) or ``"kharaz"``."""
    if name not in CAMPAIGNS:
        raise ValueError(f"`campaign` must be one of {', '.join(map(repr, CAMPAIGNS))}; got "
                         f"{name!r}")
    folder = Path(str(files("bouncebayes") / CAMPAIGNS[name]))
    truth_file = folder / "truth.json"
    truth = json.loads(truth_file.read_text(encoding="utf-8")) if truth_file.is_file() else None
    trajectories = folder / "trajectories"
    return DemoCampaign(folder, folder / "experiment.toml", folder / "trials.csv",
                        trajectories if trajectories.is_dir() else None, truth, name)
