"""Independent tasks through dask.distributed: seeded by index, written as they arrive, resumed.

A study is a list of :class:`Task` records. Each task is a picklable top-level function with its
arguments (its seed among them, made by :func:`task_seed` from the study's seed and the task's
index), so its result does not depend on where it runs: serially in this process, on a local
cluster of processes, or on a remote cluster. :func:`run_tasks` sends them to the chosen place,
retries a failed task once, writes each result as soon as it arrives (atomically, beside the
task's specification) and, on a rerun, skips every task whose record is already there.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._io import json_text, write_text

SERIAL = "serial"  #: run every task in this process, one after the other
LOCAL = "local"  #: start a local cluster of processes (the default)
RETRIES = 1  #: a failed task is run once more before it is reported as failed


def task_seed(seed: int, index: int) -> int:
    """The seed of task ``index`` of a study seeded with ``seed``: child ``index`` of
    ``numpy.random.SeedSequence(seed)`` (what ``SeedSequence(seed).spawn(n)[index]`` gives),
    as a non-negative integer below 2**63."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"`seed` must be a non-negative integer; got {seed!r}")
    child = np.random.SeedSequence(int(seed), spawn_key=(int(index),))
    return int(child.generate_state(1, np.uint64)[0] >> np.uint64(1))


@dataclass(frozen=True)
class Task:
    """One independent piece of a study.

    ``key``: unique name (file-safe); ``fn(*args)`` computes a JSON-ready result; ``spec``: the
    JSON-ready description of the inputs (a stored result is reused only if its spec is equal);
    ``record``: where the result is written (``None``: not written, never resumed).
    """

    key: str
    fn: Callable[..., Any]
    args: tuple = ()
    spec: Any = None
    record: Path | None = None


@dataclass(frozen=True)
class Outcome:
    """What a study produced: results by key, failures (key -> error), tasks taken from earlier
    runs, tasks that failed once and succeeded on the retry, and where it ran."""

    results: dict[str, Any]
    failed: dict[str, str] = field(default_factory=dict)
    resumed: tuple[str, ...] = ()
    retried: tuple[str, ...] = ()
    where: str = SERIAL
    seconds: float = 0.0
    task_cpu_seconds: float = 0.0  #: CPU time the finished tasks reported (all processes)

    def ordered(self, tasks: Sequence[Task]) -> list[Any]:
        """The results in task order (``None`` for a failed task)."""
        return [self.results.get(t.key) for t in tasks]


def _stored(task: Task) -> Any:
    """The stored result of ``task`` if its record holds the same spec, else ``None``."""
    import json

    if task.record is None or not task.record.is_file():
        return None
    try:
        doc = json.loads(task.record.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None  # damaged or half-written by another tool: compute again
    if not isinstance(doc, dict) or doc.get("spec") != _jsonable(task.spec):
        return None
    return doc.get("result")


def _jsonable(obj: Any) -> Any:
    import json

    return json.loads(json_text(obj))


def timed_call(fn: Callable[..., Any], *args: Any) -> tuple[Any, float]:
    """``fn(*args)`` and the CPU seconds it took in its process (what a worker runs)."""
    start = time.process_time()
    value = fn(*args)
    return value, time.process_time() - start


def run_tasks(tasks: Sequence[Task], *, scheduler: str | None = None, workers: int | None = None,
              progress: bool = False, log: Callable[[str], None] | None = None,
              desc: str = "tasks") -> Outcome:
    """Run ``tasks``; return their results (also written to each task's record).

    Arguments:
        tasks: the study; keys must be unique.
        scheduler: ``"serial"`` (this process), ``"local"`` or ``None`` (a local cluster of
            ``workers`` processes, started and stopped here), or the address of a running
            dask.distributed scheduler (``tcp://HOST:PORT``).
        workers: processes of the local cluster (default: the machine's cores, at most the
            number of tasks to run).
        progress: a progress bar (tqdm).
        log: receives one line per failure and retry.
        desc: the progress bar's label.

    A task that raises is run once more; if it fails again its error is reported in
    :attr:`Outcome.failed` and every other result is kept.
    """
    keys = [t.key for t in tasks]
    if len(set(keys)) != len(keys):
        raise ValueError("task keys must be unique")
    start = time.perf_counter()
    results: dict[str, Any] = {}
    resumed = []
    todo = []
    for t in tasks:
        stored = _stored(t)
        if stored is not None:
            results[t.key] = stored
            resumed.append(t.key)
        else:
            todo.append(t)
    run = _Run(results, log or (lambda message: None))
    where = scheduler or LOCAL
    if todo:
        if where == SERIAL:
            _serial(todo, run, progress, desc)
        else:
            _distributed(todo, run, where, workers, progress, desc)
    return Outcome(results, dict(run.failed), tuple(resumed), tuple(run.retried),
                   where if todo else "resumed", time.perf_counter() - start, run.cpu)


class _Run:
    """Book-keeping shared by the serial and the distributed loop."""

    def __init__(self, results: dict[str, Any], log: Callable[[str], None]) -> None:
        self.results = results
        self.log = log
        self.failed: dict[str, str] = {}
        self.retried: list[str] = []
        self.attempts: dict[str, int] = {}
        self.cpu = 0.0

    def done(self, task: Task, value: Any, cpu: float) -> None:
        self.cpu += cpu
        if task.key in self.attempts:
            self.retried.append(task.key)
        if task.record is not None:
            write_text(task.record, json_text({"key": task.key, "spec": task.spec,
                                               "result": value, "cpu_seconds": cpu}))
        self.results[task.key] = _jsonable(value)

    def error(self, task: Task, message: str) -> bool:
        """Record a failure; True if the task is to be run again."""
        n = self.attempts.get(task.key, 0)
        self.attempts[task.key] = n + 1
        if n < RETRIES:
            self.log(f"task {task.key} failed ({message}); retrying")
            return True
        self.log(f"task {task.key} failed again ({message}); its result is missing, the "
                 f"others are kept")
        self.failed[task.key] = message
        return False


def _describe(exc: BaseException) -> str:
    last = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
    where = f" at {Path(last[0].filename).name}:{last[0].lineno}" if last else ""
    return f"{type(exc).__name__}: {exc}{where}"


def _serial(todo: Sequence[Task], run: _Run, progress: bool, desc: str) -> None:
    from tqdm.auto import tqdm

    with tqdm(total=len(todo), desc=desc, disable=not progress, unit="task") as bar:
        for task in todo:
            while True:
                try:
                    value, cpu = timed_call(task.fn, *task.args)
                except Exception as exc:  # a task's failure must not stop the study
                    if run.error(task, _describe(exc)):
                        continue
                else:
                    run.done(task, value, cpu)
                break
            bar.update()


def _distributed(todo: Sequence[Task], run: _Run, where: str, workers: int | None,
                 progress: bool, desc: str) -> None:
    from distributed import as_completed
    from tqdm.auto import tqdm

    with _client(where, workers, len(todo)) as client:
        by_key = {}
        futures = []
        for task in todo:
            future = client.submit(timed_call, task.fn, *task.args, pure=False)
            by_key[future.key] = task
            futures.append(future)
        pending = as_completed(futures)
        with tqdm(total=len(todo), desc=desc, disable=not progress, unit="task") as bar:
            for future in pending:
                task = by_key.pop(future.key)
                if future.status == "finished":
                    run.done(task, *future.result())
                    bar.update()
                    continue
                if run.error(task, _describe_future(future)):
                    again = client.submit(timed_call, task.fn, *task.args, pure=False)
                    by_key[again.key] = task
                    pending.add(again)
                else:
                    bar.update()
                future.release()


def _describe_future(future) -> str:
    try:
        exc = future.exception()
    except Exception as err:  # cancelled, or the scheduler lost it
        return f"{type(err).__name__}: {err}"
    return _describe(exc) if exc is not None else f"task ended as {future.status}"


def worker_environment(workers: int) -> dict[str, str]:
    """Thread limits for each of ``workers`` processes on this machine: one BLAS thread, and
    numba threads sharing the cores (so that workers do not oversubscribe them)."""
    cores = os.cpu_count() or 1
    return {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
            "NUMBA_NUM_THREADS": str(max(1, cores // max(1, workers)))}


SCHEMES = ("tcp", "tls", "inproc", "ucx", "ws", "wss")  #: dask.distributed's address schemes


class _client:
    """A dask.distributed client: to ``where`` (an address), or to a local cluster of
    processes started for the study and stopped after it."""

    def __init__(self, where: str, workers: int | None, n_tasks: int) -> None:
        self.where, self.workers, self.n_tasks = where, workers, n_tasks
        self.cluster: Any = None

    def __enter__(self):
        import logging

        from distributed import Client, LocalCluster

        if self.where != LOCAL:
            scheme = self.where.split("://", 1)[0] if "://" in self.where else None
            if scheme not in SCHEMES:
                raise ValueError(f"`scheduler` must be 'serial', 'local' or an address such as "
                                 f"tcp://HOST:PORT (schemes {', '.join(SCHEMES)}); got "
                                 f"{self.where!r}")
            try:
                self.client = Client(self.where, timeout="20s")
            except (OSError, ValueError) as exc:
                raise ValueError(f"`scheduler` {self.where}: cannot connect ({exc}); start "
                                 f"the scheduler or give another address") from None
            return self.client
        n = self.workers or min(os.cpu_count() or 1, self.n_tasks)
        if n < 1:
            raise ValueError(f"`workers` must be an integer >= 1; got {n!r}")
        self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                    dashboard_address=None, silence_logs=logging.ERROR,
                                    # the scheduler's HTTP server on a free port, not 8787
                                    scheduler_kwargs={"dashboard_address": ":0"},
                                    env=worker_environment(n))
        self.client = Client(self.cluster)
        return self.client

    def __exit__(self, *exc: object) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()
