"""Shared fixtures: one small end-to-end run of the demo campaign, reused by several modules."""

import pytest

from bouncebayes.data import demo_campaign
from bouncebayes.inference import MHConfig


@pytest.fixture(scope="session")
def demo():
    return demo_campaign()


@pytest.fixture(scope="session")
def small_run(tmp_path_factory, demo):
    """The whole pipeline on the demo trial table with a short MH run (2000 draws)."""
    from bouncebayes.pipeline import run

    out = tmp_path_factory.mktemp("run")
    outcome = run(demo.experiment, demo.trials, out, seed=11,
                  config=MHConfig(draws=2000, chains=4), log=lambda m: None,
                  truth=demo.folder / "truth.json")
    return outcome
