"""Figures: no import-time matplotlib, robust axis limits, the shared density of the measured
rebounds, binned KDEs, residuals, and labels/legends on every figure of a run."""

import os
import subprocess
import sys
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

import bouncebayes as bb
from bouncebayes import plots
from bouncebayes.density import kde1d, rebound_density
from bouncebayes.plots._kde import binned_kde_2d, kde_curve
from bouncebayes.plots._limits import robust_limits


@pytest.fixture(scope="module")
def run(small_run):
    from bouncebayes.propagation import load_propagation
    from bouncebayes.report import load_result, load_truth

    folder = small_run.folder
    return SimpleNamespace(folder=folder, result=load_result(folder),
                           prop=load_propagation(folder), truth=load_truth(folder))


def _legend_texts(fig) -> list[str]:
    legends = [ax.get_legend() for ax in fig.axes] + list(fig.legends)
    return [t.get_text() for leg in legends if leg is not None for t in leg.get_texts()]


def test_importing_the_package_or_simulating_does_not_import_matplotlib():
    code = ("import sys; import bouncebayes, bouncebayes.plots, bouncebayes.report;"
            "from bouncebayes.cli import main;"
            "main(['simulate', '--mu', '0.16', '--eta', '1.35', '--speed', '3', '--angle', '60',"
            " '--json']);"
            "assert 'matplotlib' not in sys.modules, 'matplotlib imported'")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_robust_limits():
    rng = np.random.default_rng(0)
    x = rng.normal(2.5, 0.05, 55)
    # a normal sample is inside the fences (4.7 sd from the median): limits = range + 5 % pad
    lo, hi = robust_limits(x)
    w = np.ptp(x)
    assert lo == pytest.approx(x.min() - 0.05 * w) and hi == pytest.approx(x.max() + 0.05 * w)
    # one wild value (a failed fit at 80,000 m/s) does not stretch the axis
    assert robust_limits(np.append(x, 8e4)) == (lo, hi)
    assert robust_limits(np.append(x, -8e4), pad=0.0) == (x.min(), x.max())
    # include widens, NaN is ignored, empty input falls back
    assert robust_limits(x, np.nan, include=(0.0,), pad=0.0) == (0.0, x.max())
    assert robust_limits([]) == (0.0, 1.0)
    assert robust_limits([], include=(1.0, 3.0), pad=0.0) == (1.0, 3.0)
    # half the values equal (zero interquartile range): nothing clipped
    assert robust_limits([1.0] * 6 + [5.0], pad=0.0) == (1.0, 5.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_binned_kde_curve_matches_the_exact_sum(seed):
    """The binned 1-D KDE against the direct kernel sum of density.kde1d (the same bandwidth
    rule, an independent evaluation): within 0.3 % of the peak, also on a grid that cuts the
    sample (values beyond it still count)."""
    rng = np.random.default_rng(seed)
    x = np.concatenate([rng.normal(0, 1, 3000), rng.normal(6, 0.3, 500)])
    exact = kde1d(x)
    for grid in (np.linspace(-5, 9, 400), np.linspace(-1, 1, 400)):
        curve = kde_curve(x, grid)
        peak = exact.pdf(np.linspace(-5, 9, 2000)).max()
        assert np.max(np.abs(curve - exact.pdf(grid))) < 3e-3 * peak
    assert kde_curve([1.0, 1.0, 1.0], grid) is None  # no spread: no curve


def test_binned_joint_kde_matches_scipy():
    """The binned 2-D KDE against scipy.stats.gaussian_kde (Scott's bandwidth matrix, direct
    sum) for correlated draws: within 2 % of the peak (binning moves each draw by up to half a
    node spacing, a third of a bandwidth here; measured 1.3 %)."""
    rng = np.random.default_rng(2)
    xy = rng.multivariate_normal([0.16, 1.35], [[1e-6, 8e-6], [8e-6, 2.5e-4]], 4000)
    gx = np.linspace(0.155, 0.165, 120)
    gy = np.linspace(1.28, 1.42, 130)
    mx, my = np.meshgrid(gx, gy, indexing="ij")
    ref = stats.gaussian_kde(xy.T)(np.vstack([mx.ravel(), my.ravel()])).reshape(mx.shape)
    ours = binned_kde_2d(xy[:, 0], xy[:, 1], gx, gy)
    assert np.max(np.abs(ours - ref)) < 0.02 * ref.max()


def test_data_and_predictive_figures_draw_the_likelihoods_density(run):
    """Fig. 3's KDE and Fig. 7's experimental curve are one density: the one the kde likelihood
    evaluates (rebound_density with the normal-reference bandwidth)."""
    t = run.result.trials
    density = plots.measured_density(run.result)
    like = rebound_density(t.rebound_speed, t.rebound_angle)  # the kde likelihood's defaults
    assert density.speed.bandwidth == like.speed.bandwidth
    assert density.angle.bandwidth == like.angle.bandwidth
    data, predictive = plots.plot_data(density), plots.plot_predictive(run.prop, density)
    for fig, prefix in ((data, "KDE, normal-reference"), (predictive, "experiment (KDE, no")):
        for ax, kde in zip(fig.axes[:2], (density.speed, density.angle), strict=True):
            curves = [line for line in ax.get_lines() if line.get_label().startswith(prefix)]
            assert len(curves) == 1
            x, y = curves[0].get_data()
            np.testing.assert_allclose(y, kde.pdf(x), rtol=1e-12)


def test_measured_density_follows_the_run(run):
    """A run that used a joint KDE (or user bandwidths) gets that density in its figures."""
    t = run.result.trials
    joint = rebound_density(t.rebound_speed, t.rebound_angle, kind="joint")
    fake = SimpleNamespace(trials=t, likelihood_info={"density": joint.to_dict()})
    got = plots.measured_density(fake)
    assert got.kind == "joint" and got.speed.bandwidth == joint.speed.bandwidth
    user = rebound_density(t.rebound_speed, t.rebound_angle, bandwidth=(0.01, 0.2))
    got = plots.measured_density(SimpleNamespace(
        trials=t, likelihood_info={"observed_density": user.to_dict()}))
    assert (got.speed.bandwidth, got.angle.bandwidth) == (0.01, 0.2)


def test_outliers_are_clipped_and_counted_not_dropped(run):
    """A bounce at 80,000 m/s (a failed drag fit) and a predictive distribution with wild draws:
    the axes keep the bulk in view; the outliers are marked at the edge and counted."""
    rng = np.random.default_rng(4)
    speed = np.append(rng.normal(2.5, 0.05, 54), 8e4)
    angle = rng.normal(58.0, 1.0, 55)
    density = rebound_density(speed, angle, kind="product")
    fig = plots.plot_data(density)
    lo, hi = fig.axes[0].get_xlim()
    assert hi < 3.0 and lo > 2.0
    assert "1 bounce beyond the axis (at 8e+04 m/s)" in _legend_texts(fig)
    pred = np.append(rng.normal(2.5, 0.05, 1990), rng.normal(0, 3e4, 10))
    prop = SimpleNamespace(predicted_speed=pred, predicted_angle=rng.normal(58, 1, 2000),
                           match={})
    fig = plots.plot_predictive(prop, density)
    assert fig.axes[0].get_xlim()[1] < 3.0
    texts = _legend_texts(fig)
    assert any(t.startswith("1 bounce beyond the axis") for t in texts)
    assert any(t.startswith("10 predicted draws beyond the axis") for t in texts)


def test_residuals_figure_and_its_input():
    rng = np.random.default_rng(5)
    n = 30
    r = rng.normal(0, 1, n)
    r[3] = 40.0  # one wild trial: clipped at the top edge and counted
    res = plots.Residuals(r, rng.normal(0, 1, n), tuple(f"b{i}" for i in range(n)),
                          rng.normal(3, 0.1, n), rng.normal(60, 1, n))
    fig = plots.plot_residuals(res)
    top = fig.axes[0].get_ylim()[1]
    assert 3.0 < top < 10.0
    assert "1 trial beyond the axis (at 40)" in _legend_texts(fig)
    # a model that misses every trial by ~30 sd: the axis follows, nothing is hidden
    far = plots.Residuals(r + 30, r, res.labels, res.incidence_speed, res.incidence_angle)
    lo, hi = plots.plot_residuals(far).axes[0].get_ylim()
    assert lo < -3 and np.sort(r + 30)[-2] < hi < 70  # the +-3 band and the bulk; not 70
    with pytest.raises(ValueError, match=r"Residuals.angle must hold one value per trial"):
        plots.Residuals(r, r[:-1], res.labels, res.incidence_speed, res.incidence_angle)


def test_posterior_residuals_are_the_adequacy_checks(run):
    """The residual figure draws the run's adequacy residuals; at the posterior of a
    well-specified synthetic campaign (the demo) they scatter like N(0, 1) (rms within 0.6-1.4
    for 55 trials). A result without a check (a run folder from before it) has no figure."""
    result = run.result
    base = plots.posterior_residuals(result)
    assert base.labels == result.trials.labels and base.incidence_measured
    np.testing.assert_array_equal(base.speed, result.adequacy.residual_speed)
    for r in (base.speed, base.angle):
        assert 0.6 < np.sqrt(np.mean(r**2)) < 1.4
    assert base.scale == result.adequacy.basis
    assert plots.posterior_residuals(replace(result, adequacy=None)) is None


def test_every_figure_of_a_run_has_labels_units_and_a_legend(run):
    from bouncebayes.report import figure_makers

    for key, draw in figure_makers(run.result, run.prop, run.folder, run.truth).items():
        fig = draw()
        assert fig.get_suptitle() or any(ax.get_title() for ax in fig.axes), key
        assert _legend_texts(fig), key
        for ax in fig.axes:
            if hasattr(ax, "_colorbar"):
                assert ax.get_ylabel().startswith("density"), key
                continue
            assert ax.get_xlabel(), key
            siblings = ax.get_shared_y_axes().get_siblings(ax)
            assert any(a.get_ylabel() for a in siblings), key
        units = " ".join(ax.get_xlabel() + ax.get_ylabel() for ax in fig.axes)
        assert any(u in units for u in ("(m/s)", "(deg)", "(ms)", "(mm)", "(N)", "(kg/s)",
                                        "dimensionless", "(1/")), key


def test_save_figure_checks_the_suffix(tmp_path, run):
    fig = plots.plot_contact_time(run.prop)
    with pytest.raises(ValueError, match=r"must end in one of \.png, \.svg, \.pdf; got '\.jpg'"):
        plots.save_figure(fig, tmp_path / "a.jpg")
    assert not list(tmp_path.iterdir())
    out = plots.save_figure(fig, tmp_path / "a.png")
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert plots.save_figure(fig, tmp_path / "a.pdf").read_bytes()[:4] == b"%PDF"


def _overlaps(a, b, tol=1.0) -> bool:
    return (a.x0 < b.x1 - tol and b.x0 < a.x1 - tol and a.y0 < b.y1 - tol and b.y0 < a.y1 - tol)


def _drawn_tick_labels(axis):
    lo, hi = sorted(axis.get_view_interval())
    slack = 1e-9 * (hi - lo)
    locs = axis.get_majorticklocs()
    ticks = axis.get_major_ticks(len(locs))
    return [tick.label1 for loc, tick in zip(locs, ticks, strict=True)
            if lo - slack <= loc <= hi + slack]


def _texts(ax, renderer):
    """Window extents of the texts of a panel: tick labels, axis labels, titles, legend."""
    texts = _drawn_tick_labels(ax.xaxis) + _drawn_tick_labels(ax.yaxis)
    texts += [ax.xaxis.label, ax.yaxis.label, ax.xaxis.get_offset_text(),
              ax.yaxis.get_offset_text(), *ax.texts, ax.title, ax._left_title, ax._right_title]
    boxes = [t.get_window_extent(renderer) for t in texts
             if t.get_visible() and t.get_text()]
    if ax.get_legend() is not None:
        boxes.append(ax.get_legend().get_window_extent(renderer))
    return boxes


def _check_layout(fig, name):
    """Drawn, nothing sticks out of the figure; no text of a panel (tick labels, labels,
    titles, legend) runs into another panel's plotting area or texts, nor into the suptitle
    or the figure legend."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()
    with np.errstate(over="ignore", invalid="ignore"):  # as save_figure: mplot3d's projection
        fig.draw(renderer)
    page = fig.bbox
    whole = fig.get_tightbbox(renderer).transformed(fig.dpi_scale_trans)
    assert whole.x0 >= page.x0 - 1 and whole.y0 >= page.y0 - 1, name
    assert whole.x1 <= page.x1 + 1 and whole.y1 <= page.y1 + 1, name
    panels = [ax for ax in fig.axes if not hasattr(ax, "_colorbar") and not hasattr(ax, "zaxis")]
    texts = {i: _texts(ax, renderer) for i, ax in enumerate(panels)}
    extra = [leg.get_window_extent(renderer) for leg in fig.legends]
    if fig.get_suptitle():
        extra.append(fig._suptitle.get_window_extent(renderer))
    for i, ax in enumerate(panels):
        for j, other in enumerate(panels):
            if i == j:
                continue
            for box in texts[i]:
                assert not _overlaps(box, other.bbox), f"{name}: panel {i} text on panel {j}"
                assert not any(_overlaps(box, b) for b in texts[j]), f"{name}: {i} and {j}"
        for box in extra:
            assert not _overlaps(box, ax.bbox), f"{name}: figure text on panel {i}"
            assert not any(_overlaps(box, b) for b in texts[i]), f"{name}: figure text, {i}"


def test_panels_are_placed_without_overlaps(run):
    from bouncebayes.report import figure_makers

    for key, draw in figure_makers(run.result, run.prop, run.folder, run.truth).items():
        _check_layout(draw(), key)
    # long tick labels (an offset axis) and an outlier marked at the edge
    rng = np.random.default_rng(6)
    speed = np.append(rng.normal(1234.5678, 0.002, 40), 1240.0)
    density = rebound_density(speed, rng.normal(-45.0, 0.01, 41), kind="product")
    _check_layout(plots.plot_data(density), "data with long tick labels")
    history = bb.simulate_history(bb.PAPER_BALL, mu=0.16, eta=1.35, speed=3.0, angle=60.0)
    _check_layout(plots.plot_bounce(history, title="one bounce"), "bounce")


def test_figures_of_a_posterior_whose_bounces_all_fail(run):
    """Damping that stops the ball: every propagated bounce fails. The figures still draw, say
    so, and raise no warning (the suite turns warnings into errors)."""
    from bouncebayes.propagation import propagate

    result = run.result
    samples = result.draws.samples.copy()
    samples[..., result.names.index("eta")] = 5000.0
    broken = replace(result, draws=replace(result.draws, samples=samples))
    prop = propagate(broken, n_draws=20, n_histories=2)
    contact = plots.plot_contact_time(prop)
    assert "no propagated bounce separated" in contact.axes[0].texts[0].get_text()
    for fig in (plots.plot_trajectories(prop, 0.0128), plots.plot_forces(prop),
                plots.plot_predictive(prop, plots.measured_density(result)), contact):
        _check_layout(fig, "failed bounces")
    nan = np.full(result.trials.n, np.nan)
    res = plots.Residuals(nan, nan, result.trials.labels, result.trials.incidence_speed,
                          result.trials.incidence_angle)
    _check_layout(plots.plot_residuals(res), "NaN residuals")


def test_figure_workers_come_from_the_environment_or_the_cores(monkeypatch):
    """BOUNCEBAYES_FIGURE_WORKERS sets how many processes render figures (checked: a positive
    integer); without it, one per idle core (cores + 1 - load average), up to four."""
    from bouncebayes.plots._figure import _default_workers

    monkeypatch.setenv("BOUNCEBAYES_FIGURE_WORKERS", "3")
    assert _default_workers() == 3
    monkeypatch.setenv("BOUNCEBAYES_FIGURE_WORKERS", "0")
    with pytest.raises(ValueError, match=r"BOUNCEBAYES_FIGURE_WORKERS must be a positive "
                                         r"integer \(processes rendering figures\); got '0'"):
        _default_workers()
    monkeypatch.delenv("BOUNCEBAYES_FIGURE_WORKERS")
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1, 2, 3, 4, 5}, raising=False)
    monkeypatch.setattr(os, "getloadavg", lambda: (1.1, 1.0, 1.0))
    assert _default_workers() == 4  # six idle cores, capped
    monkeypatch.setattr(os, "getloadavg", lambda: (4.2, 1.0, 1.0))
    assert _default_workers() == 3  # 6 + 1 - 4.2 = 2.8 idle
    monkeypatch.setattr(os, "getloadavg", lambda: (9.0, 1.0, 1.0))
    assert _default_workers() == 1
