"""Atomic file output: a run that fails never leaves a half-written result behind.

Two levels:

- one file: :func:`atomic_path` (and :func:`write_text`, :func:`write_json`, :func:`write_with`,
  :func:`write_all`) writes a temporary file beside the target and renames it into place;
- a set of files: :func:`staged_output` gives a private staging folder; the command writes every
  file there and, only when all of them are complete, they are moved into place at once (a run
  folder is swapped whole, other outputs entry by entry, each entry a file or a sub-folder).

Temporary names carry the writing process's id: a process killed outright (SIGKILL, power loss)
leaves them behind, and the next output into the same place removes those whose process is gone
(:func:`remove_stale`).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import secrets
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any, Literal

# `.NAME.staging-PID-HEX` (a staging folder), `.NAME.old-PID-HEX` (a replaced folder on its way
# out), `.NAME.PID.RANDOM.partSUFFIX` (a file being written)
_TEMP = re.compile(r"^\.(?P<name>.+)\.(?:(?P<kind>staging|old)-(?P<pid>\d+)-[0-9a-f]+"
                   r"|(?P<fpid>\d+)\.[^.]+\.part[^/]*)$")


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it into place only if the block succeeds."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.",
                               suffix=".part" + target.suffix, dir=target.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a result file is as readable as any
    try:
        yield Path(tmp)
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_json(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``obj`` as indented JSON atomically."""
    return write_text(path, json_text(obj))


def write_with(path: str | os.PathLike, writer: Callable[[Path], None]) -> Path:
    """Call ``writer(tmp_path)`` and move the result into place atomically."""
    with atomic_path(path) as tmp:
        writer(tmp)
    return Path(path)


def write_all(writers: Mapping[str | os.PathLike, Callable[[Path], None]]) -> list[Path]:
    """Write several files as one: every ``writer(tmp)`` runs first, and the files are moved
    into place only if all succeeded (a failure replaces none of them)."""
    with ExitStack() as stack:
        for path, writer in writers.items():
            writer(stack.enter_context(atomic_path(path)))
    return [Path(p) for p in writers]


def json_text(obj: Any) -> str:
    """The JSON this package writes: indented, UTF-8 text kept readable."""
    return json.dumps(obj, indent=2, ensure_ascii=False) + "\n"


# --------------------------------------------------------------------------- staged outputs

StagingMode = Literal["folder", "entries", "file"]


@contextmanager
def staged_output(target: str | os.PathLike, mode: StagingMode, *,
                  start_from: str | os.PathLike | None = None,
                  owned: Iterable[str] = ()) -> Iterator[Path]:
    """Stage a command's outputs and put them in place only if the block succeeds.

    Arguments:
        target: where the outputs go.
        mode: ``"folder"``: ``target`` is a folder the command owns (a run folder); the staging
            folder replaces it whole. ``"entries"``: ``target`` is a folder that may hold other
            things; each entry written to the staging folder (a file or a sub-folder) replaces
            its namesake in ``target``, and everything else in ``target`` is left alone.
            ``"file"``: ``target`` is one file; write it as ``stage / target.name``.
        start_from: (``"folder"`` only) fill the staging folder with hard links to (or copies
            of) this folder's files first: the command then rewrites some of them (every write
            in this package replaces a file, so the originals are never touched).
        owned: (``"entries"`` only) names in ``target`` that belong to this command's output
            as a set: those not written this time are removed (a stale file of an earlier
            output must not be mistaken for part of the new one).

    Yields the staging folder. On any exception, KeyboardInterrupt included, the staging folder
    is removed and ``target`` is exactly as it was.
    """
    target = Path(target)
    if mode == "file" or (mode == "folder" and _beside_possible(target)):
        home, label = target.parent, target.name
    else:
        home, label = target, "bouncebayes"
    created = _make_missing(home)
    remove_stale(home)
    if home == target.parent and target.is_dir():
        remove_stale(target)
    stage = home / _temp_name(label, "staging")
    _ACTIVE[stage] = created
    try:
        if start_from is not None:
            shutil.copytree(start_from, stage, copy_function=link_or_copy, symlinks=True,
                            ignore=_ignore_temporaries)
        else:
            stage.mkdir()
        yield stage
        with _signals_held():
            _install(stage, target, mode, frozenset(owned))
            INSTALLED.append(target)
    except BaseException:
        _discard(stage)
        raise
    finally:
        _ACTIVE.pop(stage, None)


# staging folder -> the folders made for it (removed again if still empty when it is discarded)
_ACTIVE: dict[Path, list[Path]] = {}


def _discard(stage: Path) -> None:
    shutil.rmtree(stage, ignore_errors=True)
    for folder in _ACTIVE.get(stage, ()):  # folders made for this output only, still empty
        with contextlib.suppress(OSError):
            folder.rmdir()


def discard_staged() -> None:
    """Remove every staging folder of this process (a process that stops at once calls it:
    its outputs are then as they were before it started)."""
    for stage in list(_ACTIVE):
        _discard(stage)


# every output put in place by this process, in order (the command line tells a user whose
# Ctrl-C came after the results were in place that they are complete)
INSTALLED: list[Path] = []


@contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM while outputs are moved into place (a few renames): a stop then
    takes effect just after, never half-way."""
    import signal
    import threading

    held = {signal.SIGINT, signal.SIGTERM}
    if threading.current_thread() is not threading.main_thread() or \
            not hasattr(signal, "pthread_sigmask"):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _beside_possible(target: Path) -> bool:
    """A staging folder can sit beside ``target`` (same file system, writable parent) and
    replacing ``target`` whole does not pull the working directory away from under the user."""
    parent = target.parent
    existing = next((p for p in (parent, *parent.parents) if p.exists()), None)
    if existing is None or not os.access(existing, os.W_OK | os.X_OK):
        return False
    if target.is_dir():
        with contextlib.suppress(OSError):
            cwd = Path.cwd().resolve()
            resolved = target.resolve()
            if cwd == resolved or resolved in cwd.parents:
                return False
    return True


def _make_missing(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; returns those created, deepest first."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    return missing


def _install(stage: Path, target: Path, mode: StagingMode, owned: frozenset[str]) -> None:
    if mode == "file":
        os.replace(stage / target.name, target)
        shutil.rmtree(stage, ignore_errors=True)
    elif stage.parent == target.parent:  # folder mode beside the target
        _replace_entry(stage, target)
    else:  # staged inside the target: move entry by entry
        names = {p.name for p in stage.iterdir()}
        for entry in sorted(stage.iterdir()):
            _replace_entry(entry, target / entry.name)
        for entry in list(target.iterdir()):  # what the new output does not have goes
            if (entry.name not in names and entry != stage and not _TEMP.match(entry.name)
                    and (mode == "folder" or entry.name in owned)):
                _remove(entry)
        stage.rmdir()


def _replace_entry(src: Path, dst: Path) -> None:
    """Put ``src`` where ``dst`` is, in one step where the system allows it."""
    if not os.path.lexists(dst):
        os.rename(src, dst)
    elif dst.is_dir() and not dst.is_symlink():
        _swap_folders(src, dst)
    elif src.is_dir():  # a folder replaces a file
        dst.unlink()
        os.rename(src, dst)
    else:
        os.replace(src, dst)


def _swap_folders(src: Path, dst: Path) -> None:
    if _exchange(src, dst):  # src now holds the old folder
        shutil.rmtree(src, ignore_errors=True)
        return
    # two renames: a process killed between them leaves `.NAME.old-PID-HEX`, which
    # remove_stale moves back if `dst` is then missing
    old = dst.parent / _temp_name(dst.name, "old")
    os.rename(dst, old)
    os.rename(src, dst)
    shutil.rmtree(old, ignore_errors=True)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2(RENAME_EXCHANGE)``); False if the system
    or file system cannot. The standard library has no such call, hence ctypes."""
    if not sys.platform.startswith("linux"):
        return False
    import ctypes

    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), os.fspath(b))


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()


def link_or_copy(src: str | os.PathLike, dst: str | os.PathLike) -> None:
    """Hard-link ``src`` as ``dst`` (no copy, and safe: this package replaces files, never
    rewrites them in place); copy where the file system cannot link."""
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def is_temporary(name: str) -> bool:
    """Whether a file or folder name is one of this module's temporary names."""
    return _TEMP.match(name) is not None


def _ignore_temporaries(folder: str, names: list[str]) -> list[str]:
    return [n for n in names if is_temporary(n)]


def _temp_name(name: str, kind: str) -> str:
    return f".{name}.{kind}-{os.getpid()}-{secrets.token_hex(4)}"


def _alive(pid: int) -> bool:
    if pid == os.getpid() or os.name == "nt":  # Windows' os.kill would end the process
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def remove_stale(folder: str | os.PathLike) -> list[Path]:
    """Remove what killed writers left in ``folder``: staging folders, replaced folders and
    partial files whose process is gone. A replaced folder whose replacement never arrived
    (killed between two renames) is moved back instead. Returns the paths removed."""
    folder = Path(folder)
    removed: list[Path] = []
    try:
        entries = sorted(folder.iterdir())
    except OSError:
        return removed
    for entry in entries:
        m = _TEMP.match(entry.name)
        if m is None or _alive(int(m["pid"] or m["fpid"])):
            continue
        original = folder / m["name"]
        with contextlib.suppress(OSError):
            if m["kind"] == "old" and not original.exists():
                os.rename(entry, original)
                continue
            _remove(entry)
            removed.append(entry)
    return removed
