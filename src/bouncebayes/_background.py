"""Work done by a forked copy of this process while the process goes on (Linux).

A run's stages leave files behind that nothing later in the run reads (``posterior.nc``, the
rendered figures); on a machine with an idle core a forked copy writes them while this
process goes on. The copy shares nothing with this process after the fork: what it writes
goes through the same atomic writers, and a copy that fails is followed by the same work
here, which raises what goes wrong. The standard library's process pools are not used: they
pickle the work (a figure, an inference result) and start fresh interpreters that import
everything again; a fork needs neither.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass


def can_fork() -> bool:
    """Whether work may go to a forked copy: Linux, and no other (non-daemon) Python thread.

    A fork copies only the calling thread: another thread could hold a lock the copy then
    waits on forever (matplotlib's renderer lock, say). Daemon threads are background helpers
    that touch none of this (tqdm's monitor of progress bars); numba's and BLAS' worker
    threads are not Python threads, and the copy calls neither."""
    if not sys.platform.startswith("linux"):
        return False
    return not any(t is not threading.current_thread() and not t.daemon
                   for t in threading.enumerate())


def idle_cores() -> tuple[int, float]:
    """(cores this process may use, idle ones among them): the cores less the 1-minute load
    average, this process's own share counted as idle (a forked copy only adds work on a
    machine whose cores are busy)."""
    cores = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
             else os.cpu_count() or 1)
    return cores, cores + 1.0 - (os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0)


def spare_core() -> bool:
    """Whether a forked copy would find an idle core (:func:`idle_cores`)."""
    cores, idle = idle_cores()
    return cores > 1 and idle >= 1.5


@dataclass
class Forked:
    """A forked copy running ``work``; :meth:`join` waits for it."""

    pid: int
    work: Callable[[], object]

    def join(self) -> None:
        """Wait for the copy; if it failed, do its work here (raising what goes wrong)."""
        _, status = os.waitpid(self.pid, 0)
        if not (os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0):
            self.work()

    def cancel(self) -> None:
        """Stop the copy (this process failed: what it writes is not wanted)."""
        with contextlib.suppress(ProcessLookupError):
            os.kill(self.pid, signal.SIGKILL)
        with contextlib.suppress(ChildProcessError):
            os.waitpid(self.pid, 0)


def fork_call(work: Callable[[], object]) -> Forked:
    """Start ``work`` in a forked copy of this process (check :func:`can_fork` first)."""
    sys.stdout.flush()
    sys.stderr.flush()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # Python >= 3.12 on threads
        pid = os.fork()  # the copy runs no thread of the parent's (numba's, BLAS')
    if pid == 0:  # pragma: no cover - the forked copy (its coverage is not collected)
        code = 1
        try:
            work()
            code = 0
        finally:
            os._exit(code)
    return Forked(pid, work)


@contextlib.contextmanager
def in_background(work: Callable[[], object], enabled: bool = True) -> Iterator[None]:
    """Do ``work`` in a forked copy while the body runs, and wait for it at the end (doing it
    here if the copy failed); without a fork (``enabled`` false, :func:`can_fork` false, or
    no :func:`spare_core`),
    do it here first. If the body raises, the copy is stopped."""
    if not (enabled and can_fork() and spare_core()):
        work()
        yield
        return
    child = fork_call(work)
    try:
        yield
    except BaseException:
        child.cancel()
        raise
    child.join()
