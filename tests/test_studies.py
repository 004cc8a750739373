"""Studies through dask.distributed: a real scheduler and two worker processes on localhost
(no mocks); results identical to the serial run, failures retried and reported, resume."""

import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from bouncebayes.cli import main
from bouncebayes.studies import Task, read_manifest, run_tasks, task_seed

SMALL_SBC = ["--campaigns", "3", "--n-trials", "8", "--draws", "199", "--grid-points", "96"]


@pytest.fixture(scope="module")
def cluster():
    """A dask.distributed scheduler and two worker processes on localhost."""
    import cloudpickle
    from distributed import LocalCluster

    # the helper tasks below live in this test module, which the workers cannot import
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None, scheduler_kwargs={"dashboard_address": ":0"},
                      env={"OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}) as c:
        yield c
    cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def test_task_seeds_are_numpy_seedsequence_children():
    # expected value: numpy's own spawn of the study's SeedSequence
    children = np.random.SeedSequence(7).spawn(4)
    for i, child in enumerate(children):
        assert task_seed(7, i) == int(child.generate_state(1, np.uint64)[0] >> np.uint64(1))
    assert len({task_seed(7, i) for i in range(1000)}) == 1000
    with pytest.raises(ValueError, match="`seed` must be a non-negative integer"):
        task_seed(-1, 0)


def campaign_results(folder: Path) -> dict:
    return {p.name: json.loads(p.read_text())["result"] for p in sorted(folder.glob("*.json"))}


def test_sbc_on_a_cluster_is_identical_to_the_serial_run(cluster, tmp_path, capsys):
    serial, remote = tmp_path / "serial", tmp_path / "remote"
    assert main(["sbc", "--out", str(serial), "--scheduler", "serial", *SMALL_SBC]) == 0
    assert main(["sbc", "--out", str(remote), "--scheduler", cluster.scheduler_address,
                 *SMALL_SBC]) == 0
    a, b = campaign_results(serial / "campaigns"), campaign_results(remote / "campaigns")
    assert len(a) == 3 and a == b  # bit-identical: same floats, ranks, coverage
    sa = json.loads((serial / "sbc.json").read_text())
    sb = json.loads((remote / "sbc.json").read_text())
    assert sa["parameters"] == sb["parameters"] and sb["where"].startswith("tcp://")
    # a rerun resumes: nothing is computed again
    assert main(["sbc", "--out", str(remote), "--scheduler", cluster.scheduler_address,
                 *SMALL_SBC]) == 0
    assert json.loads((remote / "sbc.json").read_text())["resumed"] == 3
    capsys.readouterr()


def test_design_on_a_cluster_is_identical_to_the_serial_run(cluster, tmp_path, capsys):
    base = ["examples/paper.toml", "--angles", "70", "--bounces", "5", "--campaigns", "2",
            "--quiet"]
    assert main(["design", *base, "--out", str(tmp_path / "s"), "--scheduler", "serial"]) == 0
    assert main(["design", *base, "--out", str(tmp_path / "r"),
                 "--scheduler", cluster.scheduler_address]) == 0
    a = json.loads((tmp_path / "s" / "design.json").read_text())
    b = json.loads((tmp_path / "r" / "design.json").read_text())
    assert a["designs"] == b["designs"]
    capsys.readouterr()


def flaky(marker: str) -> int:
    """Fails on the first call (leaving ``marker``), succeeds on the second."""
    path = Path(marker)
    if not path.exists():
        path.write_text("failed once")
        raise RuntimeError("first attempt fails")
    return 42


def broken(x: int) -> int:
    raise ValueError(f"bad value {x}")


def square(x: int) -> int:
    return x * x


def dies_once(marker: str) -> int:
    """Kills its worker process on the first call."""
    path = Path(marker)
    if not path.exists():
        path.write_text("killed")
        os._exit(1)
    return 7


@pytest.mark.parametrize("where", ["serial", "cluster"])
def test_failed_tasks_are_retried_once_and_reported(cluster, tmp_path, where):
    scheduler = "serial" if where == "serial" else cluster.scheduler_address
    tasks = [Task("flaky", flaky, (str(tmp_path / "marker"),)),
             Task("broken", broken, (3,)),
             *[Task(f"square-{i}", square, (i,), {"i": i}, tmp_path / f"sq{i}.json")
               for i in range(4)]]
    lines = []
    outcome = run_tasks(tasks, scheduler=scheduler, log=lines.append)
    assert outcome.results["flaky"] == 42 and outcome.retried == ("flaky",)
    assert set(outcome.failed) == {"broken"}
    assert "ValueError: bad value 3" in outcome.failed["broken"]
    assert [outcome.results[f"square-{i}"] for i in range(4)] == [0, 1, 4, 9]
    assert any("broken failed again" in line for line in lines)
    assert any("flaky failed (RuntimeError: first attempt fails" in line for line in lines)
    # resume: the stored results are reused only for the same spec
    again = run_tasks(tasks[2:], scheduler="serial")
    assert set(again.resumed) == {f"square-{i}" for i in range(4)}
    changed = [Task("square-0", square, (5,), {"i": 5}, tmp_path / "sq0.json")]
    assert run_tasks(changed, scheduler="serial").results["square-0"] == 25


def test_a_killed_worker_does_not_lose_the_study(cluster, tmp_path):
    tasks = [Task("dies", dies_once, (str(tmp_path / "marker"),)),
             *[Task(f"square-{i}", square, (i,)) for i in range(3)]]
    outcome = run_tasks(tasks, scheduler=cluster.scheduler_address)
    assert outcome.results == {"dies": 7, "square-0": 0, "square-1": 1, "square-2": 4}
    assert not outcome.failed


def test_manifest_is_checked(tmp_path):
    (tmp_path / "e.toml").write_text("")
    (tmp_path / "m.toml").write_text('seed = 3\n[[run]]\nexperiment = "e.toml"\n'
                                     'data = "missing.csv"\nout = "o"\n')
    with pytest.raises(ValueError, match=r"run\[0\]\.data.*missing\.csv does not exist"):
        read_manifest(tmp_path / "m.toml")
    (tmp_path / "m.toml").write_text('[[run]]\nexperiment = "e.toml"\ndata = "e.toml"\n'
                                     'out = "o"\nsampler = 3\n')
    with pytest.raises(ValueError, match=r"run\[0\]\.sampler.*must be a string; got 3"):
        read_manifest(tmp_path / "m.toml")


def test_batch_reports_a_failed_run_and_seeds_the_others(tmp_path, demo, capsys):
    import shutil

    from bouncebayes.studies import batch_tasks

    shutil.copy(demo.experiment, tmp_path / "exp.toml")
    (tmp_path / "bad.csv").write_text("rebound_speed,rebound_angle\n1.0,oops\n")
    (tmp_path / "m.toml").write_text(
        'seed = 5\n[[run]]\nexperiment = "exp.toml"\ndata = "bad.csv"\nout = "runs/bad"\n')
    (task,) = batch_tasks(tmp_path / "m.toml")
    assert task.args[1] == task_seed(5, 0) and task.record == tmp_path / "runs/bad/batch.json"
    assert main(["batch", str(tmp_path / "m.toml"), "--scheduler", "serial"]) == 1
    captured = capsys.readouterr()
    assert "run-0000: FAILED (InputFileError:" in captured.out and "bad.csv" in captured.out
    assert "0 of 1 runs complete" in captured.out
    assert "retrying" in captured.err and not (tmp_path / "runs/bad/batch.json").exists()


@pytest.mark.slow
def test_batch_runs_a_manifest_on_a_cluster_and_resumes(cluster, demo, tmp_path, capsys):
    import shutil

    shutil.copy(demo.experiment, tmp_path / "exp.toml")
    shutil.copy(demo.trials, tmp_path / "trials.csv")
    (tmp_path / "m.toml").write_text(
        'seed = 11\n'
        '[[run]]\nexperiment = "exp.toml"\ndata = "trials.csv"\nout = "runs/a"\n'
        'sampler = "grid"\ndraws = 100\n'
        '[[run]]\nexperiment = "exp.toml"\ndata = "trials.csv"\nout = "runs/b"\n'
        'sampler = "grid"\ndraws = 100\nseed = 4\n')
    argv = ["batch", str(tmp_path / "m.toml"), "--scheduler", cluster.scheduler_address]
    assert main(argv) == 0
    first = capsys.readouterr().out
    assert "2 of 2 runs complete (0 from earlier" in first
    for name, seed in (("a", task_seed(11, 0)), ("b", 4)):
        summary = json.loads((tmp_path / "runs" / name / "summary.json").read_text())
        assert summary["seed"] == seed and summary["sampler"] == "grid"
        assert (tmp_path / "runs" / name / "report.html").exists()
    assert main(argv) == 0
    assert "2 of 2 runs complete (2 from earlier" in capsys.readouterr().out


def test_the_default_local_cluster_gives_the_serial_result(tmp_path, capsys):
    """`--scheduler local` (the default): a cluster of processes started for the command and
    stopped after it; the campaigns are bit-identical to the serial run's."""
    serial, local = tmp_path / "serial", tmp_path / "local"
    assert main(["sbc", "--out", str(serial), "--scheduler", "serial", *SMALL_SBC]) == 0
    assert main(["sbc", "--out", str(local), "--workers", "2", *SMALL_SBC]) == 0
    assert campaign_results(serial / "campaigns") == campaign_results(local / "campaigns")
    assert json.loads((local / "sbc.json").read_text())["where"].startswith("local")
    capsys.readouterr()
