"""Many ``run``s from a manifest: a TOML list of ``[[run]]`` tables, one task each."""

from __future__ import annotations

import hashlib
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .._errors import InputFileError
from ._tasks import Outcome, Task, run_tasks, task_seed

RUN_KEYS = {"experiment": str, "data": str, "out": str, "likelihood": str, "sampler": str,
            "seed": int, "draws": int}
REQUIRED = ("experiment", "data", "out")
TOP_KEYS = {"run", "seed"}
MARKER = "batch.json"  #: written into a run folder when its task has finished


def read_manifest(path: str | Path) -> tuple[int, list[dict[str, Any]]]:
    """The study seed (``seed = N`` at the top, default 0) and the ``[[run]]`` tables, paths
    made absolute (relative to the manifest's folder); every problem names the table and key."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputFileError(path, f"cannot read the manifest ({exc.strerror})") from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputFileError(path, f"not valid TOML: {exc}") from None
    extra = sorted(set(doc) - TOP_KEYS)
    if extra:
        raise InputFileError(path, "unknown key; a manifest has `seed` and [[run]] tables",
                             field=extra[0])
    seed = doc.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputFileError(path, f"must be a non-negative integer; got {seed!r}", field="seed")
    runs = doc.get("run")
    if runs is not None and not (isinstance(runs, list)
                                 and all(isinstance(r, dict) for r in runs)):
        raise InputFileError(path, f"must be [[run]] tables; got {runs!r}", field="run")
    if not runs:
        raise InputFileError(path, "no [[run]] tables; each needs experiment, data and out",
                             field="run")
    return seed, [_check_run(path, i, r) for i, r in enumerate(runs)]


def _check_run(path: Path, i: int, run: dict) -> dict[str, Any]:
    where = f"run[{i}]"
    for key, value in run.items():
        kind = RUN_KEYS.get(key)
        if kind is None:
            raise InputFileError(path, f"unknown key; a [[run]] has {', '.join(RUN_KEYS)}",
                                 field=f"{where}.{key}")
        if isinstance(value, bool) or not isinstance(value, kind):
            what = "an integer" if kind is int else "a string"
            raise InputFileError(path, f"must be {what}; got {value!r}", field=f"{where}.{key}")
    for key in REQUIRED:
        if key not in run:
            raise InputFileError(path, "missing (paths are relative to the manifest)",
                                 field=f"{where}.{key}")
    out = dict(run)
    for key in REQUIRED:
        out[key] = str((path.parent / run[key]).resolve())
        if key != "out" and not Path(out[key]).exists():
            raise InputFileError(path, f"{out[key]} does not exist", field=f"{where}.{key}")
    _check_settings(path, where, out)
    return out


def _check_settings(path: Path, where: str, run: dict[str, Any]) -> None:
    """A run's settings checked as ``run`` would check them, before any task starts: a
    mistake is the manifest's, named by its key, not a task that fails twice."""
    from ..inference import LIKELIHOODS, sampler_config
    from ..pipeline import check_run_folder

    checks = (("likelihood", lambda: _choice(run.get("likelihood"), LIKELIHOODS)),
              ("sampler", lambda: sampler_config(run.get("sampler", "mh"))),
              ("seed", lambda: _non_negative(run.get("seed"))),
              ("draws", lambda: sampler_config(run.get("sampler", "mh"), draws=run.get("draws"))),
              ("out", lambda: check_run_folder(Path(run["out"]))))
    for key, check in checks:
        try:
            check()
        except ValueError as exc:
            raise InputFileError(path, str(exc).replace(f"`{key}` ", "", 1),
                                 field=f"{where}.{key}") from None


def _choice(value: str | None, allowed: tuple[str, ...]) -> None:
    if value is not None and value not in allowed:
        raise ValueError(f"must be one of {', '.join(map(repr, allowed))}; got {value!r}")


def _non_negative(value: int | None) -> None:
    if value is not None and value < 0:
        raise ValueError(f"must be a non-negative integer; got {value!r}")


def batch_run(run: dict[str, Any], seed: int) -> dict[str, Any]:
    """One ``run`` of the manifest (a task): the whole pipeline into ``run["out"]``; returns
    the posterior summary in words and numbers."""
    from ..inference import sampler_config
    from ..pipeline import run as pipeline_run

    lines: list[str] = []
    sampler = run.get("sampler", "mh")
    outcome = pipeline_run(run["experiment"], run["data"], run["out"],
                           likelihood=run.get("likelihood"), sampler=sampler,
                           seed=seed, config=sampler_config(sampler, draws=run.get("draws")),
                           log=lines.append)
    return {"out": run["out"], "seed": seed, "verdict": outcome.verdict,
            "table": outcome.table, "report": str(outcome.report)}


def _fingerprint(path: str) -> str:
    """sha256 of a file, or of a folder's file names, sizes and modification times (cheap)."""
    p = Path(path)
    h = hashlib.sha256()
    if p.is_file():
        h.update(p.read_bytes())
    else:
        for f in sorted(q for q in p.rglob("*") if q.is_file()):
            st = f.stat()
            h.update(f"{f.relative_to(p)}|{st.st_size}|{st.st_mtime_ns}\n".encode())
    return h.hexdigest()


def batch_tasks(manifest: str | Path) -> list[Task]:
    """The manifest's runs as tasks; run ``i`` without a ``seed`` gets :func:`task_seed`
    (manifest seed, i). Each task's record is ``OUT/batch.json``."""
    seed, runs = read_manifest(manifest)
    outs = [r["out"] for r in runs]
    if len(set(outs)) != len(outs):
        dup = next(o for o in outs if outs.count(o) > 1)
        raise InputFileError(manifest, f"two [[run]] tables write to {dup}; give each its own "
                                       f"`out`", field="run.out")
    tasks = []
    for i, r in enumerate(runs):
        s = int(r.get("seed", task_seed(seed, i)))
        spec = r | {"seed": s, "experiment_sha256": _fingerprint(r["experiment"]),
                    "data_fingerprint": _fingerprint(r["data"])}
        tasks.append(Task(f"run-{i:04d}", batch_run, (r, s), spec, Path(r["out"]) / MARKER))
    return tasks


def run_batch(manifest: str | Path, *, scheduler: str | None = None, workers: int | None = None,
              progress: bool = False, log: Callable[[str], None] | None = None) -> Outcome:
    """Every run of ``manifest``; finished runs (same inputs and settings) are skipped."""
    return run_tasks(batch_tasks(manifest), scheduler=scheduler, workers=workers,
                     progress=progress, log=log, desc="runs")
