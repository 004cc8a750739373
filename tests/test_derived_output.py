"""DEM-ready output of a run: derived.json, its figure and report section (docs/model.md §4.7)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import bouncebayes as bb
from bouncebayes._errors import InputFileError
from bouncebayes.propagation import derive, load_derived, write_derived
from bouncebayes.report import load_result


@pytest.fixture(scope="module")
def derived(small_run):
    return json.loads((small_run.folder / "derived.json").read_text())


def test_every_quantity_has_its_definition_and_transfer_note(derived):
    q = derived["quantities"]
    assert set(bb.model.DERIVED_QUANTITIES) <= set(q)
    for name, record in q.items():
        assert record["definition"] and "holds for this ball on this surface" in \
            record["transfer"], name
    assert q["normal_restitution"]["grid_name"] == "impact_speed"
    assert q["normal_restitution"]["grid"][0] == pytest.approx(0.5)
    assert q["normal_restitution"]["grid"][-1] == pytest.approx(10.0)
    assert q["tangential_restitution"]["grid_unit"] == "deg"
    assert derived["cautions"] == []  # the demo's model reproduces its data


def test_numbers_agree_with_the_posterior_and_an_independent_bounce(small_run, derived):
    """The friction coefficient is the posterior of mu itself; the restitution at the reference
    speed is that of a head-on bounce simulated by ``bb.simulate`` at the posterior median of
    eta (the median of a monotone function is the function of the median: the Kelvin-Voigt
    restitution falls with eta); the linear equivalent obeys k_n t_c^2 = m (pi^2 + ln^2 e)
    (docs/model.md §4.7) at the medians."""
    result = load_result(small_run.folder)
    q = derived["quantities"]
    mu = result.samples("mu")
    assert q["friction_coefficient"]["median"] == pytest.approx(np.median(mu), abs=3e-3)
    eta = float(np.median(result.samples("eta")))
    v = derived["reference_speed_m_s"]
    head_on = bb.simulate(result.experiment.ball, mu=0.0, eta=eta, speed=v, angle=0.0,
                          gravity=0.0)
    e = float(head_on.rebound_speed) / v
    assert q["restitution_at_reference"]["median"] == pytest.approx(e, abs=2e-3)
    e_med, t_med = (q[k]["median"] for k in ("restitution_at_reference",
                                              "contact_time_at_reference"))
    m = result.experiment.ball.mass
    assert q["linear_normal_stiffness"]["median"] == pytest.approx(
        m * (np.pi**2 + np.log(e_med) ** 2) / t_med**2, rel=2e-3)
    lo, hi = q["friction_coefficient"]["ci90"]
    assert lo < np.median(mu) < hi


def test_derive_is_seeded_and_round_trips(small_run, tmp_path, derived):
    """Same seed, same numbers; what write_derived writes, load_derived reads."""
    result = load_result(small_run.folder)
    again = derive(result)
    assert again["quantities"] == derived["quantities"]
    write_derived(again, tmp_path)
    assert load_derived(tmp_path)["quantities"] == derived["quantities"]
    assert load_derived(tmp_path / "nowhere") is None


def test_a_damaged_derived_file_is_named(tmp_path):
    (tmp_path / "derived.json").write_text("{\"quantities\": 3}")
    with pytest.raises(InputFileError, match="derived.json: damaged"):
        load_derived(tmp_path)


def test_cautions_say_when_the_numbers_are_a_misfitting_models(small_run):
    """A misfit without a discrepancy term makes the numbers the misfitting model's."""
    import dataclasses

    result = load_result(small_run.folder)
    bad = dataclasses.replace(result.adequacy, adequate=False)
    d = derive(dataclasses.replace(result, adequacy=bad), n_draws=20)
    assert any("does not reproduce the data" in c for c in d["cautions"])
