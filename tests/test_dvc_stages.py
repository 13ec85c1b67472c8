"""DVC stages cannot go stale: each depends on all the package code its command runs, and on the lock.

For every stage the test finds what it runs (a notebook through ``wsmap paper run``, or ``wsmap data
build``), computes the import closure of the package modules it loads in a fresh interpreter (the
notebook's code cells' imports, then every ``wsmap`` module those import, lazily imported ones too,
found by scanning their source), and checks that each module's file lies under a dependency the
stage declares.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
import yaml

from wsmap import paths

ROOT = paths.ROOT
PKG = ROOT / "src" / "wsmap"
STAGES = yaml.safe_load((ROOT / "dvc.yaml").read_text())["stages"]


def _module_file(name: str) -> Path | None:
    rel = Path(*name.split("."))
    for cand in (ROOT / "src" / rel.with_suffix(".py"), ROOT / "src" / rel / "__init__.py"):
        if cand.exists():
            return cand
    return None


def _wsmap_imports(source: str, module: str | None) -> set[str]:
    """Every ``wsmap`` module named by an import anywhere in ``source`` (function bodies included)."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "wsmap"}
        elif isinstance(node, ast.ImportFrom):
            if node.level and module:
                pkg = module.split(".")
                is_pkg = _module_file(module) is not None and _module_file(module).name == "__init__.py"
                base = pkg if is_pkg else pkg[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "wsmap":
                continue
            found.add(target)
            found |= {f"{target}.{a.name}" for a in node.names if _module_file(f"{target}.{a.name}")}
    # parents are imported too
    return {".".join(m.split(".")[:i]) for m in found for i in range(1, len(m.split(".")) + 1)}


def import_closure(roots: set[str]) -> set[Path]:
    seen: set[str] = set()
    todo = list(roots)
    while todo:
        m = todo.pop()
        if m in seen or _module_file(m) is None:
            continue
        seen.add(m)
        todo += _wsmap_imports(_module_file(m).read_text(), m) - seen
    return {_module_file(m) for m in seen}


def _stage_roots(stage: dict) -> set[str]:
    cmd = stage["cmd"]
    m = re.search(r"wsmap paper run (\w+)", cmd)
    roots = {"wsmap.__main__", "wsmap.cli"}
    if m:
        nb = nbformat.read(ROOT / "notebooks" / f"{m.group(1)}.ipynb", as_version=4)
        code = "\n".join(c.source for c in nb.cells if c.cell_type == "code" and not c.source.lstrip().startswith("%"))
        roots |= _wsmap_imports(code, None) | {"wsmap.paper.pipeline"}
    elif "wsmap data build" in cmd:
        roots |= {"wsmap.datasets"}
    else:
        raise AssertionError(f"unknown stage command {cmd!r}")
    return roots


def _covered(path: Path, deps: list[str]) -> bool:
    return any(path == ROOT / d or (ROOT / d) in path.parents for d in deps)


@pytest.mark.parametrize("name", sorted(STAGES))
def test_stage_depends_on_its_code_and_the_lock(name):
    stage = STAGES[name]
    body = stage.get("do", stage)
    deps = [d if isinstance(d, str) else next(iter(d)) for d in body["deps"]]
    assert "environment.lock" in deps, f"stage {name} does not depend on environment.lock"
    closure = import_closure(_stage_roots(body))
    assert len(closure) > 3
    missing = sorted(str(p.relative_to(ROOT)) for p in closure if not _covered(p, deps))
    assert not missing, f"stage {name} runs code it does not depend on: {missing}"


def test_the_closure_finder_sees_lazy_imports():
    # the CLI imports wsmap.viz only inside a function: a stage running the CLI must cover it
    closure = import_closure({"wsmap.cli"})
    assert PKG / "viz.py" in closure and PKG / "workspace" / "maps.py" in closure


def test_the_closure_matches_what_python_loads():
    """What a fresh interpreter loads for the CLI is inside the static closure (no import missed)."""
    code = ("import sys, json, wsmap.cli, wsmap.paper.pipeline; "
            "print(json.dumps(sorted(m.__file__ for n, m in sys.modules.items() "
            "if n.split('.')[0] == 'wsmap' and getattr(m, '__file__', None))))")
    loaded = {Path(p) for p in json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True,
                                                         text=True, check=True).stdout)}
    static = import_closure({"wsmap.cli", "wsmap.paper.pipeline", "wsmap.__main__"})
    assert {p.resolve() for p in loaded} <= {p.resolve() for p in static}
