"""The package code each DVC stage runs, written into its ``deps``: ``python tools/stage_deps.py``.

A stage depends on exactly the package modules its command can load: the static import closure
(imports inside functions included, relative imports resolved) of the module its ``python -m``
command runs and, for a notebook stage, of every ``wsmap`` import in the notebook's code cells.
Changing a module outside that closure leaves the stage up to date; changing one inside it makes
the stage stale. A package directory whose every module is in the closure is listed as the
directory.

``python tools/stage_deps.py`` rewrites the ``src/...`` lines of every stage's ``deps`` in
``dvc.yaml`` (other deps, such as data files and ``environment.lock``, are kept as written);
``--check`` writes nothing and exits 1 naming each stage whose deps differ from its closure.
``tests/test_dvc_stages.py`` runs the check.
"""

from __future__ import annotations

import argparse
import ast
import functools
import re
import sys
from pathlib import Path

import nbformat
import yaml

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
DVC_YAML = ROOT / "dvc.yaml"


@functools.cache  # one process reads one tree: every stage asks for the same modules
def module_file(name: str) -> Path | None:
    """The source file of the dotted module ``name`` under ``src/``, or ``None``."""
    rel = Path(*name.split("."))
    for cand in (SRC / rel.with_suffix(".py"), SRC / rel / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def module_name(path: Path) -> str:
    """The dotted name of a source file under ``src/``."""
    rel = path.resolve().relative_to(SRC.resolve()).with_suffix("")
    return ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)


def wsmap_imports(source: str, module: str | None) -> set[str]:
    """Every ``wsmap`` module an import anywhere in ``source`` names (function bodies included, ``if
    TYPE_CHECKING:`` blocks not), with the packages above each (importing ``a.b.c`` runs ``a`` and
    ``a.b`` first).

    ``module`` is the dotted name of the module ``source`` belongs to (for relative imports);
    ``from pkg import name`` counts ``pkg.name`` when that is a module.
    """
    found = set()
    is_pkg = module is not None and module_file(module) is not None and module_file(module).name == "__init__.py"
    tree = ast.parse(source)
    # ``if TYPE_CHECKING:`` blocks never run (they name the types of annotations, wsmap._typing): not deps
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            node.body = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "wsmap"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                if module is None:
                    continue
                base = module.split(".") if is_pkg else module.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "wsmap":
                continue
            found.add(target)
            found |= {f"{target}.{a.name}" for a in node.names if module_file(f"{target}.{a.name}")}
    # a plug-in package that imports every module of its folder when it is imported (a module-level
    # ``for ... in pkgutil.iter_modules(__path__)``, the closed forms' registry) loads each of them,
    # though no import names it; a loop inside a function (paper.parts.registry) runs only when called
    # ``discover(__name__, __path__)`` (wsmap._plugins) at module level does the same
    def loads_folder(n):
        if isinstance(n, ast.For):
            return "iter_modules(__path__)" in ast.unparse(n.iter)
        return isinstance(n, ast.Expr) and isinstance(n.value, ast.Call) and ast.unparse(n.value.func) == "discover"

    if is_pkg and any(loads_folder(n) for n in tree.body):
        folder = module_file(module).parent
        found |= {f"{module}.{p.stem}" for p in folder.glob("*.py") if p.name != "__init__.py"}
        found |= {f"{module}.{p.parent.name}" for p in folder.glob("*/__init__.py")}
    return {".".join(m.split(".")[:i]) for m in found for i in range(1, len(m.split(".")) + 1)}


@functools.cache
def _module_imports(m: str) -> frozenset[str]:
    """`wsmap_imports` of the module `m`'s source, parsed once per process."""
    return frozenset(wsmap_imports(module_file(m).read_text(), m))


def import_closure(roots: set[str]) -> set[Path]:
    """The source files of ``roots`` and of every ``wsmap`` module they import, transitively."""
    seen: set[str] = set()
    todo = list(roots)
    while todo:
        m = todo.pop()
        if m in seen or module_file(m) is None:
            continue
        seen.add(m)
        todo += _module_imports(m) - seen
    return {module_file(m) for m in seen}


def notebook_imports(name: str) -> set[str]:
    """The ``wsmap`` modules imported by the code cells of ``notebooks/<name>.ipynb``."""
    nb = nbformat.read(ROOT / "notebooks" / f"{name}.ipynb", as_version=4)
    code = "\n".join(c.source for c in nb.cells if c.cell_type == "code" and not c.source.lstrip().startswith(("%", "!")))
    return wsmap_imports(code, None)


_MODULE = re.compile(r"python\s+-m\s+([\w.]+)")
_NOTEBOOK = re.compile(r"(?:\bpaper\s+run|-m\s+wsmap\.paper\.notebook)\s+(\w+)")


def stage_roots(cmd: str) -> set[str]:
    """The modules a stage's command loads first: the ``python -m`` module (``__main__`` of a
    package) and, for ``... paper run NAME``, the notebook's imports."""
    m = _MODULE.search(cmd)
    if not m:
        raise ValueError(f"stage command {cmd!r} does not run a module (python -m wsmap...)")
    entry = m.group(1)
    f = module_file(entry)
    if f is None:
        raise ValueError(f"stage command {cmd!r} runs {entry}, which is not a module under src/")
    roots = {entry}
    if f.name == "__init__.py":
        roots.add(f"{entry}.__main__")
    nb = _NOTEBOOK.search(cmd)
    if nb:
        roots |= notebook_imports(nb.group(1))
    return roots


def _compress(files: set[Path]) -> list[str]:
    """Relative paths of ``files``, a directory in place of its files when all its modules are in."""
    files = {f.resolve() for f in files}
    out: list[str] = []

    def walk(d: Path):
        mods = {p.resolve() for p in d.rglob("*.py") if "__pycache__" not in p.parts}
        if mods and mods <= files:
            out.append(d.relative_to(ROOT).as_posix())
            return
        for p in sorted(d.iterdir()):
            if p.is_dir() and p.name != "__pycache__":
                walk(p)
            elif p.suffix == ".py" and p.resolve() in files:
                out.append(p.relative_to(ROOT).as_posix())

    walk(SRC / "wsmap")
    return sorted(out)


#: Compiled extensions: the module that loads one -> the folder of its sources. A change there
#: changes what a stage computes, though no Python import names those files.
EXTENSIONS = {"wsmap.kinematics.lm_lanes": "src/wsmap/kinematics/_lanes"}


def code_deps(cmd: str) -> list[str]:
    """The ``src/...`` deps a stage running ``cmd`` must declare (sorted): its import closure, and
    the sources of the compiled extensions that closure loads."""
    closure = import_closure(stage_roots(cmd))
    out = set(_compress(closure))
    out |= {folder for mod, folder in EXTENSIONS.items() if module_file(mod) in closure}
    return sorted(out)


def _stages(text: str) -> dict:
    return yaml.safe_load(text)["stages"]


def _body(stage: dict) -> dict:
    return stage.get("do", stage)


def declared_code_deps(stage: dict) -> list[str]:
    deps = [d if isinstance(d, str) else next(iter(d)) for d in _body(stage).get("deps", [])]
    return sorted(d for d in deps if d.startswith("src/"))


def stale(text: str) -> dict[str, tuple[list[str], list[str]]]:
    """Stages whose declared ``src/`` deps differ from their closure: name -> (declared, wanted)."""
    out = {}
    for name, stage in _stages(text).items():
        want = code_deps(_body(stage)["cmd"])
        have = declared_code_deps(stage)
        if have != want:
            out[name] = (have, want)
    return out


def rewrite(text: str) -> str:
    """``dvc.yaml``'s text with each stage's ``src/`` deps replaced by its closure (the rest kept
    line for line: comments, order, other deps)."""
    stages = _stages(text)
    lines = text.splitlines(keepends=True)
    out: list[str] = []
    stage = None
    in_deps = False
    indent = None
    for line in lines:
        m = re.match(r"^  (\S[^:]*):\s*$", line)
        if m:
            stage = m.group(1)
            in_deps = False
        stripped = line.strip()
        if stripped == "deps:":
            in_deps = True
            indent = line[: len(line) - len(line.lstrip())] + "  "
            out.append(line)
            wanted = code_deps(_body(stages[stage])["cmd"])
            out.extend(f"{indent}- {d}\n" for d in wanted)
            continue
        if in_deps:
            if stripped.startswith("- "):
                if stripped[2:].startswith("src/"):
                    continue
                out.append(line)
                continue
            in_deps = False
        out.append(line)
    return "".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if a stage's deps differ")
    args = ap.parse_args(argv)
    text = DVC_YAML.read_text()
    if args.check:
        bad = stale(text)
        for name, (have, want) in bad.items():
            print(f"{name}: declares {have}, runs {want}")
        return 1 if bad else 0
    new = rewrite(text)
    if new != text:
        tmp = DVC_YAML.with_name(".dvc.yaml.tmp")
        tmp.write_text(new)
        tmp.replace(DVC_YAML)
        print(f"dvc.yaml: deps of {len(stale(text))} stage(s) rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main())
