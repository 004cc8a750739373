"""Work in a forked copy of the process (src/bouncebayes/_background.py)."""

from __future__ import annotations

import os
import sys
import threading

import pytest

from bouncebayes import _background as bg

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork: Linux only")


def _writer(path):
    def work():
        path.write_text(str(os.getpid()))
    return work


@linux
def test_work_runs_in_a_forked_copy_while_the_body_runs(tmp_path, monkeypatch):
    monkeypatch.setattr(bg, "spare_core", lambda: True)
    out = tmp_path / "pid"
    with bg.in_background(_writer(out)):
        body_pid = os.getpid()
    assert out.exists()  # waited for at the end of the block
    assert int(out.read_text()) != body_pid  # written by the copy


def test_without_a_spare_core_the_work_is_done_here_first(tmp_path, monkeypatch):
    monkeypatch.setattr(bg, "spare_core", lambda: False)
    out = tmp_path / "pid"
    with bg.in_background(_writer(out)):
        assert int(out.read_text()) == os.getpid()  # done before the body


def test_no_fork_with_another_python_thread_running(monkeypatch):
    """A fork copies only the calling thread; a lock held by another could hang the copy."""
    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()
    try:
        assert not bg.can_fork()
    finally:
        stop.set()
        thread.join()
    assert bg.can_fork() == sys.platform.startswith("linux")


@linux
def test_a_copy_that_fails_is_followed_by_the_work_here(tmp_path, monkeypatch):
    """The copy's failure is not lost: the work is done again here, raising what goes wrong."""
    monkeypatch.setattr(bg, "spare_core", lambda: True)
    parent = os.getpid()

    def work():
        if os.getpid() != parent:
            raise RuntimeError("the copy fails")
        raise ValueError("done here: disk full")

    with pytest.raises(ValueError, match="done here: disk full"):
        with bg.in_background(work):
            pass


@linux
def test_a_failing_body_stops_the_copy(tmp_path, monkeypatch):
    monkeypatch.setattr(bg, "spare_core", lambda: True)
    out = tmp_path / "late"

    def work():
        import time

        time.sleep(5.0)
        out.write_text("written after the run failed")

    with pytest.raises(KeyError):
        with bg.in_background(work):
            raise KeyError("stage failed")
    assert not out.exists()  # the copy was stopped, and waited for


def test_spare_core_from_cores_and_load(monkeypatch):
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    monkeypatch.setattr(os, "getloadavg", lambda: (0.3, 0.0, 0.0))
    assert bg.spare_core()  # 2 + 1 - 0.3 = 2.7 idle
    monkeypatch.setattr(os, "getloadavg", lambda: (2.0, 0.0, 0.0))
    assert not bg.spare_core()  # 1.0 idle: this process's own core only
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0}, raising=False)
    monkeypatch.setattr(os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert not bg.spare_core()  # one core
