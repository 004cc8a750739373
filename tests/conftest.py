"""Shared fixtures: one small end-to-end run of the demo campaign, reused by several modules."""

import pytest

from bouncebayes.data import demo_campaign
from bouncebayes.inference import MHConfig


@pytest.fixture(scope="session")
def demo():
    return demo_campaign()


@pytest.fixture(scope="session")
def small_run(tmp_path_factory, demo):
    """The whole pipeline on the demo trial table with a short MH run (2000 draws); the
    posterior's files written by a forked copy, as on a machine with an idle core (the tests
    that read the run folder then check what that copy wrote)."""
    from unittest import mock

    from bouncebayes.pipeline import run

    out = tmp_path_factory.mktemp("run")
    with mock.patch("bouncebayes._background.spare_core", return_value=True):
        outcome = run(demo.experiment, demo.trials, out, seed=11,
                      config=MHConfig(draws=2000, chains=4), log=lambda m: None,
                      truth=demo.folder / "truth.json")
    return outcome
