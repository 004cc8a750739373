"""Shared fixtures: one small end-to-end run of the demo campaign, reused by several modules;
and numba's on-disk cache dropped when any compiled kernel's source changed."""

import hashlib
from pathlib import Path

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


def _drop_stale_kernel_caches() -> None:
    """Numba keys a cached function on its own file only: a kernel that calls a kernel of
    another module (the MH chains call the model's rebound kernel) keeps the callee's old
    code after the callee's file changes, and the bit-for-bit tests then compare old code with
    new. Where any source file with compiled code changed since the last test session, every
    cached kernel of the package is dropped (they are compiled again as needed). Installed
    copies are unaffected: installing writes every file anew."""
    src = Path(__file__).resolve().parents[1] / "src" / "bouncebayes"
    if not src.is_dir():
        return
    digest = hashlib.sha256()
    for path in sorted(src.rglob("*.py")):
        text = path.read_bytes()
        if b"@njit" in text or b"@intrinsic" in text or b"intrinsic(" in text:
            digest.update(str(path.relative_to(src)).encode() + text)
    stamp = src / "__pycache__" / "kernel-sources.sha256"
    try:
        # no stamp yet: the caches are taken as made from these sources (a fresh install's
        # `bouncebayes warmup`), so that the first session does not compile everything again
        if stamp.exists() and stamp.read_text() != digest.hexdigest():
            for cached in [*src.rglob("*.nbi"), *src.rglob("*.nbc")]:
                cached.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest.hexdigest())
    except OSError:  # a read-only checkout: numba then keeps no cache there either
        pass


_drop_stale_kernel_caches()
