"""The shape of the code, checked from its syntax tree (no import is executed).

- No package reaches into another package's private names: what one stage needs from another
  is public there (exported from its ``__init__``). The shared private modules at the top
  (``bouncebayes._io``, ``_errors``, ``_validate``, ``_provenance``) are the exception: they are
  the package's own plumbing, used by every stage.
- The stages' module-level imports form no cycle (a function-local import, used to keep a heavy
  dependency out of the package import, is not a cycle at import time).
- No function outside the compiled numba kernels is longer than 50 lines (docstring excluded).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parent.parent / "src" / "bouncebayes"
MAX_LINES = 50
COMPILED = ("njit", "jit", "vectorize", "guvectorize", "cfunc")


def _modules() -> list[tuple[Path, ast.Module]]:
    return [(f, ast.parse(f.read_text(), filename=str(f))) for f in sorted(SRC.rglob("*.py"))]


def _stage(path: Path) -> str:
    """The stage a file belongs to: its top-level package or module name."""
    rel = path.relative_to(SRC)
    return rel.parts[0].removesuffix(".py")


def _target(path: Path, node: ast.ImportFrom) -> list[str]:
    """The dotted parts (below ``bouncebayes``) a relative import names."""
    here = list(path.relative_to(SRC).parent.parts)
    base = here[: len(here) - (node.level - 1)] if node.level > 1 else here
    return [*base, *(node.module.split(".") if node.module else [])]


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_no_stage_imports_another_stages_private_names():
    offences = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom) or node.level == 0:
                continue
            parts = _target(path, node)
            if not parts or parts[0] == _stage(path) or _private(parts[0]):
                continue  # same stage, or the shared private plumbing
            for alias in node.names:
                if any(_private(p) for p in [*parts[1:], alias.name]):
                    offences.append(f"{path.relative_to(SRC)}:{node.lineno} "
                                    f"{'.'.join(parts)}.{alias.name}")
    assert not offences, "private names used across stages:\n" + "\n".join(offences)


def _module_level_imports(tree: ast.Module):
    """Imports executed when the module loads (not inside functions; TYPE_CHECKING excluded)."""
    for node in tree.body:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            continue
        if isinstance(node, ast.ImportFrom | ast.Import):
            yield node
        elif isinstance(node, ast.If | ast.Try):
            for child in ast.walk(node):
                if isinstance(child, ast.ImportFrom | ast.Import):
                    yield child


def test_the_stages_import_one_another_without_a_cycle():
    graph: dict[str, set[str]] = {}
    for path, tree in _modules():
        stage = _stage(path)
        for node in _module_level_imports(tree):
            if isinstance(node, ast.ImportFrom) and node.level > 0:
                parts = _target(path, node)
                if parts and parts[0] != stage and not _private(parts[0]):
                    graph.setdefault(stage, set()).add(parts[0])
    # depth-first search for a back edge
    state: dict[str, int] = {}
    cycle: list[str] = []

    def visit(node: str, trail: list[str]) -> bool:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycle.extend([*trail, node, nxt])
                return True
            if nxt not in state and visit(nxt, [*trail, node]):
                return True
        state[node] = 2
        return False

    assert not any(visit(n, []) for n in sorted(graph) if n not in state), " -> ".join(cycle)


def _code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines of a function without its docstring (the documentation is not the logic)."""
    n = (node.end_lineno or node.lineno) - node.lineno + 1
    first = node.body[0]
    if (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
            and isinstance(first.value.value, str)):
        n -= (first.end_lineno or first.lineno) - first.lineno + 1
    return n


def test_functions_are_short_outside_the_compiled_kernels():
    long = []
    for path, tree in _modules():
        for node in ast.walk(tree):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            if any(name in ast.unparse(d) for d in node.decorator_list for name in COMPILED):
                continue
            n = _code_lines(node)
            if n > MAX_LINES:
                long.append(f"{path.relative_to(SRC)}:{node.lineno} {node.name} ({n} lines)")
    assert not long, f"functions longer than {MAX_LINES} lines:\n" + "\n".join(long)


@pytest.mark.parametrize("offence, found", [
    ("from ..model._kernel import solve", True),
    ("from ..model import simulate", False),
    ("from .._io import write_json", False),
])
def test_the_private_name_check_can_fail(tmp_path, offence, found):
    # the check above, on a made-up module inside a made-up stage
    path = SRC / "inference" / "_made_up.py"
    node = ast.parse(offence).body[0]
    assert isinstance(node, ast.ImportFrom)
    parts = _target(path, node)
    hit = parts[0] != "inference" and not _private(parts[0]) and any(
        _private(p) for p in [*parts[1:], *(a.name for a in node.names)])
    assert hit is found


ROOT = SRC.parents[1]
# a path into the repository, as docs, the README and code name them
REPO_PATH = re.compile(r"(?<![\w/.])((?:docs|tests|benchmarks|examples|src)/[\w./-]*\w"
                       r"\.(?:md|py|toml|json|png|svg|csv|txt))")
CITED = ("README.md", "docs/*.md", "src/**/*.py", "tests/*.py", "benchmarks/*.py",
         "tests/data/**/*.md", "examples/*.toml")


def _cited_files() -> list[Path]:
    return sorted({p for pattern in CITED for p in ROOT.glob(pattern) if p.is_file()})


def test_the_repository_cites_only_what_it_holds():
    """Every repository path named in the README, docs, code, tests and examples exists, and
    nothing cites files outside the repository, a brief or an issue number."""
    missing, outside = [], []
    for path in _cited_files():
        text = path.read_text(encoding="utf-8")
        upstream = path.is_relative_to(ROOT / "tests" / "data")  # names paths of its sources
        for m in ([] if upstream else REPO_PATH.finditer(text)):
            if "*" not in m[1] and not (ROOT / m[1]).exists():
                missing.append(f"{path.relative_to(ROOT)}: {m[1]}")
        for bad in re.finditer(r"MODEL\.md|paper\.md|\bthe brief\b|\b[Ii]ssue #?\d+|"
                               r"\bthe issue'?s?\b", text):
            outside.append(f"{path.relative_to(ROOT)}: {bad[0]}")
    assert not missing, "paths that do not exist:\n" + "\n".join(missing)
    assert not outside, "citations outside the repository:\n" + "\n".join(outside)
