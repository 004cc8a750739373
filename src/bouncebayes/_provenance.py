"""Provenance: what made a file (package version, inputs' hashes, seed, command, time).

:func:`provenance` builds the record once per command; :func:`stamp` writes it into one output
file in the form that file's format allows, and :func:`read_provenance` reads it back:

- JSON (an object): a ``"provenance"`` key;
- CSV, text and TOML: a first line ``# provenance: {...}`` (one line of JSON,
  :func:`comment_line` / :func:`parse_comment_line`; the readers of this package skip ``#``
  lines, and so do spreadsheet and pandas readers told ``comment="#"``);
- NetCDF (``.nc``): a ``provenance`` attribute of the root group (JSON text);
- NumPy archives (``.npz``): a ``provenance`` entry (a string array);
- PNG: a ``tEXt`` chunk with the keyword ``provenance``; SVG: a ``<!-- provenance: ... -->``
  comment after the XML declaration;
- HTML: the report shows the record in a table (:func:`provenance_rows`); not stamped.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
import platform
import shlex
import shutil
import struct
import sys
import zlib
from collections.abc import Iterable, Mapping
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import Any

from ._io import atomic_path, json_text, write_text

KEY = "provenance"
_COMMENT = f"# {KEY}: "
# versions worth recording when the command loaded them (never imported here)
_LIBRARIES = ("numpy", "scipy", "numba", "emcee", "arviz", "xarray", "h5netcdf", "matplotlib",
              "cv2")
TRAJECTORIES = "trajectories"  # the sub-folder of trajectory files in campaigns and run folders
_CHUNK = 1 << 20
_HDF5 = b"\x89HDF\r\n\x1a\n"


def provenance(*, inputs: Mapping[str, str | os.PathLike | None], seed: int | None = None,
               config: Any = None, argv: Iterable[str] | None = None) -> dict:
    """The provenance record of one command.

    Arguments:
        inputs: name -> file or folder read (``None`` entries are skipped). A file gets its
            sha256; a folder the sha256 of the sorted list of its files' relative paths and
            sha256 (:func:`tree_sha256`) and its file count.
        seed: the seed of every random draw, if any.
        config: the settings (a dict or a dataclass; paths become strings).
        argv: the command line, ``["bouncebayes", "run", ...]``; ``None`` when called from
            Python.

    Returns a JSON-ready dict: ``bouncebayes_version``, ``created_utc`` (ISO 8601),
    ``command``, ``seed``, ``config``, ``inputs`` (name -> ``{"path", "sha256", ...}``),
    ``python_version``, ``numpy_version``, ``platform`` and ``libraries`` (versions of the
    numerical libraries the command had loaded).
    """
    from ._version import __version__

    numpy = sys.modules.get("numpy")
    return {
        "bouncebayes_version": __version__,
        "created_utc": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "command": None if argv is None else shlex.join(str(a) for a in argv),
        "seed": None if seed is None else int(seed),
        "config": jsonable(config),
        "inputs": {name: describe_input(path) for name, path in inputs.items()
                   if path is not None},
        "python_version": platform.python_version(),
        "numpy_version": getattr(numpy, "__version__", None),
        "platform": platform.platform(),
        "libraries": {name: str(getattr(sys.modules[name], "__version__", "?"))
                      for name in _LIBRARIES if name in sys.modules},
    }


def describe_input(path: str | os.PathLike) -> dict:
    """``{"path", "sha256", "bytes"}`` of a file; ``{"path", "sha256", "files"}`` of a folder;
    ``{"path", "sha256": None}`` if it cannot be read."""
    p = Path(path)
    try:
        if p.is_dir():
            digest, n = tree_sha256(p)
            return {"path": str(p.resolve()), "sha256": digest, "files": n}
        return {"path": str(p.resolve()), "sha256": file_sha256(p), "bytes": p.stat().st_size}
    except OSError:
        return {"path": str(p), "sha256": None}


def file_sha256(path: str | os.PathLike) -> str:
    """sha256 of a file's bytes, read in chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(_CHUNK):
            h.update(chunk)
    return h.hexdigest()


def tree_sha256(folder: str | os.PathLike) -> tuple[str, int]:
    """sha256 over a folder's files (``relative/path sha256`` lines, sorted; hidden entries
    skipped) and the number of files."""
    root = Path(folder)
    files = sorted(p for p in root.rglob("*") if p.is_file()
                   and not any(part.startswith(".") for part in p.relative_to(root).parts))
    lines = "".join(f"{p.relative_to(root).as_posix()} {file_sha256(p)}\n" for p in files)
    return hashlib.sha256(lines.encode("utf-8")).hexdigest(), len(files)


def jsonable(value: Any) -> Any:
    """Settings as JSON values: dataclasses and mappings as dicts, paths as strings."""
    if is_dataclass(value) and not isinstance(value, type):
        return jsonable(asdict(value))
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if value is None or isinstance(value, bool | int | float | str):
        return value
    item = getattr(value, "item", None)  # NumPy scalars
    return item() if callable(item) else str(value)


def one_line(record: Mapping) -> str:
    """The record as one line of ASCII JSON, safe inside an XML comment (no ``--``).

    Raises:
        TypeError: ``record`` is not a mapping, or holds what JSON cannot write.
    """
    if not isinstance(record, Mapping):
        raise TypeError(f"`provenance` must be a dict; got {type(record).__name__}")
    try:
        text = json.dumps(dict(record), ensure_ascii=True, separators=(",", ":"), allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"`provenance` must be JSON-serialisable (strings, numbers, lists, "
                        f"dicts; finite numbers); {exc}") from None
    return text.replace("--", "-\\u002d")


def comment_line(record: Mapping) -> str:
    """The provenance comment line of a text file (without the newline)."""
    return _COMMENT + one_line(record)


def parse_comment_line(line: str) -> dict | None:
    """The record of a provenance comment line; None if the line is not one."""
    text = line.strip()
    if not text.startswith(_COMMENT.strip()):
        return None
    try:
        value = json.loads(text[len(_COMMENT.strip()):].strip())
    except ValueError:
        return None
    return value if isinstance(value, dict) else None


# --------------------------------------------------------------------------- stamping


def stamp(path: str | os.PathLike, record: Mapping) -> bool:
    """Write ``record`` into the file at ``path`` (replacing an earlier stamp), atomically.
    Returns False for a format that has no place for it."""
    path = Path(path)
    writer = _STAMPERS.get(path.suffix.lower())
    if writer is None:
        return False
    writer(path, record)
    return True


def stamp_tree(folder: str | os.PathLike, record: Mapping, *,
               exclude: Iterable[str] = ()) -> list[Path]:
    """Stamp every file under ``folder`` that has a place for it, except in the sub-folders
    named in ``exclude``; returns those stamped."""
    root = Path(folder)
    skip = set(exclude)
    return [p for p in sorted(root.rglob("*")) if p.is_file()
            and p.relative_to(root).parts[0] not in skip and stamp(p, record)]


def read_provenance(path: str | os.PathLike) -> dict | None:
    """The record :func:`stamp` wrote into a file, or None."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".json":
        obj = json.loads(path.read_text(encoding="utf-8"))
        return obj.get(KEY) if isinstance(obj, dict) else None
    if suffix in _TEXT:
        return parse_comment_line(path.read_text(encoding="utf-8").split("\n", 1)[0])
    if suffix == ".npz":
        import numpy as np

        with np.load(path) as z:
            return json.loads(str(z[KEY])) if KEY in z.files else None
    if suffix == ".nc":
        import h5py

        with h5py.File(path, "r") as f:
            text = f.attrs.get(KEY)
        return None if text is None else json.loads(_str(text))
    if suffix == ".png":
        return _png_text(path.read_bytes()).get(KEY)
    if suffix == ".svg":
        head = path.read_text(encoding="utf-8")[:65536]
        start = head.find(f"<!-- {KEY}: ")
        if start < 0:
            return None
        return json.loads(head[start + len(KEY) + 7:head.index(" -->", start)])
    return None


def _str(value: Any) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)


def _stamp_json(path: Path, record: Mapping) -> None:
    obj = json.loads(path.read_text(encoding="utf-8"))
    if isinstance(obj, dict):
        obj[KEY] = dict(record)
        write_text(path, json_text(obj))


def _stamp_text(path: Path, record: Mapping) -> None:
    text = path.read_text(encoding="utf-8")
    if text.startswith(_COMMENT):
        text = text.split("\n", 1)[1] if "\n" in text else ""
    write_text(path, f"{comment_line(record)}\n{text}")


def _stamp_npz(path: Path, record: Mapping) -> None:
    import numpy as np

    with np.load(path) as z:
        arrays: dict[str, Any] = {k: z[k] for k in z.files if k != KEY}
    arrays[KEY] = np.array(one_line(record))
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def _stamp_netcdf(path: Path, record: Mapping) -> None:
    import h5py

    with open(path, "rb") as fh:
        if fh.read(8) != _HDF5:  # a NetCDF-3 file has no place for text attributes we can add
            return
    with atomic_path(path) as tmp:  # a copy: the original may be hard-linked elsewhere
        shutil.copyfile(path, tmp)
        with h5py.File(tmp, "a") as f:
            f.attrs[KEY] = one_line(record)


def _stamp_png(path: Path, record: Mapping) -> None:
    data = path.read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return
    body = KEY.encode("latin-1") + b"\0" + one_line(record).encode("ascii")
    chunk = struct.pack(">I", len(body)) + b"tEXt" + body + struct.pack(
        ">I", zlib.crc32(b"tEXt" + body))
    chunks = [c for c in _png_chunks(data) if not (c[0] == b"tEXt" and
                                                   c[1].startswith(KEY.encode() + b"\0"))]
    out = [data[:8]]
    for i, (kind, _payload, raw) in enumerate(chunks):
        out.append(raw)
        if i == 0 and kind == b"IHDR":
            out.append(chunk)
    with atomic_path(path) as tmp:
        tmp.write_bytes(b"".join(out))


def _png_chunks(data: bytes) -> list[tuple[bytes, bytes, bytes]]:
    """(type, payload, raw bytes) of every chunk of a PNG."""
    chunks, i = [], 8
    while i + 8 <= len(data):
        (length,) = struct.unpack(">I", data[i:i + 4])
        kind = data[i + 4:i + 8]
        chunks.append((kind, data[i + 8:i + 8 + length], data[i:i + 12 + length]))
        i += 12 + length
    return chunks


def _png_text(data: bytes) -> dict:
    out = {}
    for kind, payload, _ in _png_chunks(data):
        if kind == b"tEXt" and b"\0" in payload:
            key, text = payload.split(b"\0", 1)
            if key.decode("latin-1") == KEY:
                out[KEY] = json.loads(text.decode("latin-1"))
    return out


def _stamp_svg(path: Path, record: Mapping) -> None:
    text = path.read_text(encoding="utf-8")
    start = text.find(f"<!-- {KEY}: ")
    if start >= 0:
        text = text[:start] + text[text.index(" -->\n", start) + 5:]
    comment = f"<!-- {KEY}: {one_line(record)} -->\n"
    head, sep, rest = text.partition("?>\n") if text.startswith("<?xml") else ("", "", text)
    write_text(path, head + sep + comment + rest)


_TEXT = (".csv", ".txt", ".toml")
_STAMPERS = {".json": _stamp_json, ".npz": _stamp_npz, ".nc": _stamp_netcdf,
             ".png": _stamp_png, ".svg": _stamp_svg, **dict.fromkeys(_TEXT, _stamp_text)}


def provenance_rows(record: Mapping) -> list[list[str]]:
    """The record as (label, value) rows for a report table."""
    rows = [["bouncebayes", str(record.get("bouncebayes_version"))],
            ["command", str(record.get("command") or "called from Python")],
            ["created (UTC)", str(record.get("created_utc"))],
            ["seed", str(record.get("seed"))],
            ["python", str(record.get("python_version"))],
            ["numpy", str(record.get("numpy_version"))],
            ["platform", str(record.get("platform"))]]
    rows += [[f"{name} (input)", f"{d.get('path')} (sha256 {d.get('sha256')})"]
             for name, d in (record.get("inputs") or {}).items()]
    rows += [[name, version] for name, version in (record.get("libraries") or {}).items()
             if name != "numpy"]
    if record.get("config") is not None:
        rows.append(["settings", json.dumps(record["config"], sort_keys=True)])
    return rows
