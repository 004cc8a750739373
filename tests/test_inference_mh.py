"""Metropolis–Hastings driver (``bouncebayes.inference._mh``): the compiled chain blocks give the
draws of the step-by-step path, bit for bit.

Where the expected values come from: the independent implementation is the module's own
``(init, step)`` pair driven from Python (``compiled_posterior`` patched to ``None``), whose
posterior evaluation goes through the public ``LogPosterior`` and ``BounceModel`` calls; the
compiled blocks must reproduce its draws, log densities, accepts and tuned scales exactly.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from bouncebayes.data import demo_campaign, load_trials, parse_experiment, synthesize
from bouncebayes.inference import MHConfig, infer
from bouncebayes.inference import _mh

DEMO = demo_campaign()


def posterior(exp, trials):
    """The gaussian-likelihood posterior that ``infer`` builds (a short run)."""
    return infer(exp, trials, likelihood="gaussian", sampler="mh", seed=0,
                 config=MHConfig(draws=100, chains=2, burn_in=4, thin=1)).posterior


def run_both(post, config, seed, monkeypatch):
    """Draws of the compiled path, then of the Python path, and the Python steps of each."""
    calls = []
    step = _mh.step

    def counted(*args):
        calls.append(1)
        return step(*args)

    monkeypatch.setattr(_mh, "step", counted)
    a = _mh.sample_mh(post, config, np.random.default_rng(seed))
    n_python = len(calls)
    monkeypatch.setattr(_mh, "compiled_posterior", lambda post: None)
    b = _mh.sample_mh(post, config, np.random.default_rng(seed))
    return a, b, n_python


def assert_same(a, b):
    assert np.array_equal(a.samples, b.samples)
    assert np.array_equal(a.lp, b.lp)
    assert np.array_equal(a.accepted, b.accepted)
    assert a.info == b.info  # acceptance rates, tuned scales, mode, starts


def test_compiled_chains_reproduce_the_python_steps_bit_for_bit(monkeypatch):
    # the demo campaign (55 trials at their own incidence, horizontal plane): every step in
    # compiled blocks, across several blocks of random inputs (RANDOM_BLOCK = 1024)
    exp = parse_experiment(tomllib.loads(DEMO.experiment.read_text(encoding="utf-8")))
    post = posterior(exp, load_trials(DEMO.trials, exp))
    assert _mh.compiled_posterior(post) is not None
    config = MHConfig(draws=2400, chains=4, burn_in=50, thin=2)
    a, b, n_python = run_both(post, config, 11, monkeypatch)
    assert n_python == 0 and config.iterations() > _mh.RANDOM_BLOCK
    assert_same(a, b)


def test_steps_that_need_the_ode_are_handed_to_the_python_path(monkeypatch):
    # damping near the edge of the closed form's table (at 3 m/s the tabulated damping ends
    # between eta = 9.5 and 10 kg/s, bb.simulate's closed_form flag): proposals beyond it
    # need the ODE and leave the compiled block for one step, the others stay in it
    doc = tomllib.loads(DEMO.experiment.read_text(encoding="utf-8"))
    doc["contact"]["eta"] = 9.8
    doc["parameters"]["eta"]["high"] = 20.0
    exp = parse_experiment(doc)
    trials = synthesize(exp, seed=5, n=6).trials
    post = posterior(exp, trials)
    config = MHConfig(draws=100, chains=2, burn_in=6, thin=1)
    a, b, n_python = run_both(post, config, 12, monkeypatch)
    assert 0 < n_python < config.iterations()
    assert_same(a, b)


@pytest.mark.parametrize("likelihood", ["kde"])
def test_other_posteriors_take_the_python_path(likelihood):
    exp = parse_experiment(tomllib.loads(DEMO.experiment.read_text(encoding="utf-8")))
    trials = load_trials(DEMO.trials, exp)
    post = infer(exp, trials, likelihood=likelihood, sampler="mh", seed=0,
                 config=MHConfig(draws=100, chains=2, burn_in=4, thin=1)).posterior
    assert _mh.compiled_posterior(post) is None
