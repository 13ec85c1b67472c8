"""The package's import graph: no circles at any level, no module reading another's private names,
and a classical tool that stays light.

The graph is read from the source, not from what an interpreter happened to load: every import
statement of every module under ``src/wsmap`` counts, at module level, inside a function (a
function-level import is a circle waiting for the day someone moves it to the top) or under
``if TYPE_CHECKING:`` (the names of annotations: a type checker follows them, and a circle there
makes type-checking one module need all of them). ``wsmap._typing`` holds generic aliases only and
imports nothing of wsmap; a module annotating with a class of wsmap imports it from where it lives.
An edge ``A -> B`` means that ``A``'s imports name ``B`` (running them runs ``B``):

* ``import a.b.c`` and ``from a.b.c import name``: ``a.b.c`` and its packages ``a.b`` (their
  ``__init__`` runs first), except the packages that contain ``A`` itself (they are running);
* ``from a.b import c`` where ``a.b.c`` is a module: the module ``a.b.c`` (not ``a.b``'s namespace);
* ``from .. import name`` where ``name`` is not a module: the package itself (``name`` is read
  from its ``__init__``, e.g. ``from .. import __version__``), so a package ``__init__`` re-exporting
  its own submodules is not a circle, but a submodule reading a name back from it is.

A private name (one leading underscore) is its module's own: ``from .x import _name`` is refused
(make what is shared a public function of the right module). A private module (``_plugins``,
``_typing``, ``arms/_ur``) is a helper its package shares, importable as a module; its public names too.
"""

from __future__ import annotations

import ast
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"


# ------------------------------------------------------------------------------------ the graph
def _modules(src: Path, top: str) -> dict[str, Path]:
    """Every module of the package ``top`` under ``src``: dotted name -> file (a package is its ``__init__``)."""
    out = {}
    for f in sorted((src / top).rglob("*.py")):
        rel = f.relative_to(src).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        out[".".join(parts)] = f
    return out


def _compiled(src: Path, top: str) -> set[str]:
    """The compiled extension modules of ``top`` (C++ built into the package at install; their
    sources' folders are named in ``tools/stage_deps.py``'s ``EXTENSIONS``): modules too, which
    import nothing of the package."""
    spec = importlib.util.spec_from_file_location("stage_deps", SRC.parent / "tools" / "stage_deps.py")
    stage_deps = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(stage_deps)
    out = set()
    for folder in stage_deps.EXTENSIONS.values():
        rel = Path(folder).relative_to("src")
        if rel.parts[0] == top and (src / rel).is_dir():
            out.add(".".join(rel.parts))
    return out


def _ancestors(name: str) -> list[str]:
    parts = name.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def _package_of(mod: str, path: Path | None) -> str:
    """The package a module's relative imports start from: itself for a package's ``__init__``."""
    return mod if path is not None and path.name == "__init__.py" else mod.rpartition(".")[0]


def _from_where(package: str, node: ast.ImportFrom) -> str:
    """The absolute name of the module a ``from ... import`` statement in ``package`` reads from."""
    if not node.level:
        return node.module or ""
    base = package.split(".")
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _is_type_checking(node: ast.AST) -> bool:
    """``if TYPE_CHECKING:`` or ``if typing.TYPE_CHECKING:``."""
    if not isinstance(node, ast.If):
        return False
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _statements(path: Path, type_checking: bool = True) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement of the file ``path``, at any depth; ``type_checking=False`` leaves out
    those under ``if TYPE_CHECKING:`` (they never run)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    if not type_checking:
        for node in ast.walk(tree):
            if _is_type_checking(node):
                node.body = []
    return [node for node in ast.walk(tree) if isinstance(node, (ast.Import, ast.ImportFrom))]


def _resolve(modules: dict, name: str) -> str | None:
    """``name`` or its longest prefix that is a module of the package (``None`` outside it)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def _named(node: ast.Import | ast.ImportFrom, package: str, top: str, modules: dict) -> list[tuple[str | None, bool]]:
    """``(module, explicit)`` per module of ``top`` an import statement in ``package`` names;
    ``explicit`` is false for ``import a.b.c`` (it names ``a.b.c`` through its packages)."""
    if isinstance(node, ast.Import):
        return [(_resolve(modules, a.name), False) for a in node.names if a.name.split(".")[0] == top]
    where = _from_where(package, node)
    if where.split(".")[0] != top:
        return []
    # ``from pkg import submodule``: the submodule; any other name is read from ``where``'s namespace
    return [(f"{where}.{a.name}" if f"{where}.{a.name}" in modules else _resolve(modules, where), True)
            for a in node.names]


def import_graph(src: Path, top: str = "wsmap", type_checking: bool = True) -> dict[str, set[str]]:
    """``{module: modules its import statements name}`` for every module of ``top`` (module
    docstring); ``type_checking=False`` leaves out those under ``if TYPE_CHECKING:`` (what runs)."""
    modules = _modules(src, top)
    modules.update({name: None for name in _compiled(src, top)})
    graph: dict[str, set[str]] = {}
    for mod, path in modules.items():
        targets: set[str] = set()
        if path is not None:  # a compiled module has no import statements
            running = set(_ancestors(mod)) | {mod}
            for node in _statements(path, type_checking):
                for target, explicit in _named(node, _package_of(mod, path), top, modules):
                    if target is None:
                        continue
                    # the packages of a module run before it; those containing ``mod`` are running already
                    targets.update(a for a in _ancestors(target) if a not in running)
                    if explicit or target not in running:
                        targets.add(target)
        graph[mod] = targets - {mod}
    return graph


def knots(graph: dict[str, set[str]]) -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm): the modules
    of a knot all import each other, through circles."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []

    def strongconnect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                components.append(comp)

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph) + 100))
    try:
        for v in sorted(graph):
            if v not in index:
                strongconnect(v)
    finally:
        sys.setrecursionlimit(limit)
    return components


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One circle ``[a, b, ..., a]`` through each knot (:func:`knots`): a shortest path from its
    first module back to itself within the knot; sorted."""
    out = []
    for comp in knots(graph):
        start = min(comp)
        # breadth-first from start's successors back to start, inside the component
        prev: dict[str, str] = {}
        frontier = [start]
        found = False
        while frontier and not found:
            nxt = []
            for v in frontier:
                for w in sorted(graph[v] & comp):
                    if w == start:
                        prev[start] = v
                        found = True
                        break
                    if w not in prev:
                        prev[w] = v
                        nxt.append(w)
                if found:
                    break
            frontier = nxt
        path = [start]
        v = prev[start]
        while v != start:
            path.append(v)
            v = prev[v]
        out.append([start] + path[1:][::-1] + [start])
    return sorted(out)


def _private(part: str) -> bool:
    return part.startswith("_") and not part.startswith("__")


def private_imports(src: Path, top: str = "wsmap") -> set[tuple[str, str, str]]:
    """``{(module, where, name)}``: every import in a module of ``top`` (at any level, under
    ``if TYPE_CHECKING:`` too) of a private name ``name`` of the module ``where``, or of a private
    module from outside the package that holds it (module docstring)."""
    modules = _modules(src, top)
    modules.update({name: None for name in _compiled(src, top)})
    found = set()

    def inside(mod: str, package: str) -> bool:
        return mod == package or mod.startswith(package + ".")

    def check(mod: str, where: str, name: str) -> None:
        """``mod`` reads ``name`` from the module ``where`` (``where.name`` may be a module)."""
        target = f"{where}.{name}"
        is_module = target in modules
        if _private(name) and not is_module:  # another module's private name
            found.add((mod, where, name))
        parts = (target if is_module else where).split(".")
        for i, part in enumerate(parts):  # a private module is its package's, to be imported there only
            if _private(part) and not inside(mod, ".".join(parts[:i])):
                found.add((mod, where, name))

    for mod, path in modules.items():
        for node in _statements(path) if path is not None else ():
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == top:
                        check(mod, *alias.name.rpartition(".")[::2])
            elif _from_where(_package_of(mod, path), node).split(".")[0] == top:
                for alias in node.names:
                    check(mod, _from_where(_package_of(mod, path), node), alias.name)
    return found


#: The private imports of wsmap still to be mended (module, where it reads from, the name): none
#: since issue 39 (every shared helper is a public name of its module). Kept, empty, so that a
#: refactor that cannot mend one at once lists it here; an entry that no longer matches an import
#: fails `test_the_private_import_allowlist_is_not_stale`.
PRIVATE_IMPORTS_TO_MEND: set[tuple[str, str, str]] = set()


# ------------------------------------------------------------------------------------ the finder itself
def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        f = tmp_path / rel
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text(text)
    return tmp_path


def test_the_graph_sees_function_level_and_relative_imports(tmp_path):
    src = _package(tmp_path, {
        "pkg/__init__.py": "from . import a\nfrom .sub import b\n",
        "pkg/a.py": "def f():\n    from .sub.b import g\n    return g\n",
        "pkg/sub/__init__.py": "",
        "pkg/sub/b.py": "import os\nfrom ..c import h\n",
        "pkg/c.py": "def h():\n    import pkg.a\n",
    })
    g = import_graph(src, "pkg")
    assert g["pkg"] == {"pkg.a", "pkg.sub", "pkg.sub.b"}
    assert g["pkg.a"] == {"pkg.sub", "pkg.sub.b"}  # the function-level import, and the package it runs
    assert g["pkg.sub.b"] == {"pkg.c"}  # ``..c`` resolved; ``os`` is outside the package
    assert g["pkg.c"] == {"pkg.a"}
    assert circles(g) == [["pkg.a", "pkg.sub.b", "pkg.c", "pkg.a"]]
    assert knots(g) == [{"pkg.a", "pkg.sub.b", "pkg.c"}]


def test_a_package_reexporting_its_submodules_is_not_a_circle_but_reading_it_back_is(tmp_path):
    src = _package(tmp_path, {
        "pkg/__init__.py": "from .version import V\nfrom . import tools\n",
        "pkg/version.py": "V = 1\n",
        "pkg/tools.py": "from . import version\nfrom .version import V\n",
    })
    g = import_graph(src, "pkg")
    assert g["pkg.tools"] == {"pkg.version"} and circles(g) == []
    (src / "pkg" / "tools.py").write_text("def f():\n    from . import V\n    return V\n")
    g = import_graph(src, "pkg")
    assert g["pkg.tools"] == {"pkg"}
    assert circles(g) == [["pkg", "pkg.tools", "pkg"]]


def test_the_graph_counts_type_checking_imports(tmp_path):
    src = _package(tmp_path, {
        "pkg/__init__.py": "",
        "pkg/low.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.high import High\n",
        "pkg/high.py": "import typing\nfrom . import low\nif typing.TYPE_CHECKING:\n    from ._names import Alias\n",
        "pkg/_names.py": "",
    })
    g = import_graph(src, "pkg")
    assert g["pkg.low"] == {"pkg.high"} and g["pkg.high"] == {"pkg.low", "pkg._names"}
    assert circles(g) == [["pkg.high", "pkg.low", "pkg.high"]]
    runs = import_graph(src, "pkg", type_checking=False)  # what runs: no circle
    assert runs["pkg.low"] == set() and runs["pkg.high"] == {"pkg.low"} and circles(runs) == []


def test_private_imports_are_found_at_every_level(tmp_path):
    src = _package(tmp_path, {
        "pkg/__init__.py": "from ._version import __version__\n",
        "pkg/_version.py": "__version__ = '1'\n",
        "pkg/a.py": "_x = 1\ndef y():\n    pass\n",
        "pkg/sub/__init__.py": "from . import _helper\n",
        "pkg/sub/_helper.py": "from ..a import y\n",
        "pkg/sub/b.py": ("from typing import TYPE_CHECKING\nfrom ._helper import y\nfrom .. import a\n"
                         "if TYPE_CHECKING:\n    from ..a import _x\n"),
        "pkg/c.py": "def f():\n    from .a import _x, y\n    from .sub import _helper\n    import pkg.sub._helper\n",
    })
    # a private name read from another module (a function-level import, one under TYPE_CHECKING), and
    # a private module imported from outside its package; a package's own private modules, dunders
    # and public names read through a private module are fine
    assert private_imports(src, "pkg") == {("pkg.c", "pkg.a", "_x"), ("pkg.sub.b", "pkg.a", "_x"),
                                           ("pkg.c", "pkg.sub", "_helper")}


# ------------------------------------------------------------------------------------ wsmap
def test_no_import_circles():
    """No circle of imports between the modules of wsmap, at module level, inside functions or under
    ``if TYPE_CHECKING:``."""
    graph = import_graph(SRC)
    found = [f"{' -> '.join(c)}  (a knot of {len(k)} modules: {', '.join(sorted(k))})"
             for c, k in zip(circles(graph), sorted(knots(graph), key=min))]
    assert not found, "import circles:\n" + "\n".join(found)


def test_the_classical_library_does_not_import_the_learned_one():
    graph = import_graph(SRC)
    learned = ("wsmap.learn", "wsmap.datasets", "wsmap.paper", "wsmap.design", "wsmap.morph_design", "wsmap.cli")
    for mod, targets in graph.items():
        if mod.startswith(("wsmap.workspace", "wsmap.kinematics")) or mod in ("wsmap.robots", "wsmap"):
            bad = sorted(t for t in targets if t.startswith(learned))
            assert not bad, f"{mod} imports {bad}"


@pytest.mark.parametrize("package", ["wsmap.kinematics", "wsmap.workspace", "wsmap.robots", "wsmap.collision"])
def test_type_checking_the_classical_library_needs_neither_torch_nor_the_learned_side(package):
    """Everything a module of ``package`` names, at any depth and under ``if TYPE_CHECKING:`` too: no
    torch, pandas or matplotlib, and no module of the learned side."""
    graph, modules = import_graph(SRC), _modules(SRC, "wsmap")
    seen = {m for m in graph if m == package or m.startswith(package + ".")}
    todo = list(seen)
    while todo:
        for target in graph[todo.pop()] - seen:
            seen.add(target)
            todo.append(target)
    learned = sorted(m for m in seen if m.startswith(("wsmap.learn", "wsmap.datasets", "wsmap.paper", "wsmap.cli")))
    assert not learned, f"{package} names {learned}"
    heavy = sorted({(m, name) for m in seen if modules.get(m) is not None for node in _statements(modules[m])
                    for name in ([a.name for a in node.names] if isinstance(node, ast.Import)
                                 else [] if node.level else [node.module or ""])
                    if name.split(".")[0] in ("torch", "pandas", "matplotlib")})
    assert not heavy, f"{package} needs {heavy}"


@pytest.mark.parametrize("module", ["wsmap", "wsmap.workspace", "wsmap.kinematics", "wsmap.robots"])
def test_the_classical_tool_stays_light(module):
    """A classical user's import loads neither torch nor the learned side (fresh interpreter)."""
    code = (f"import sys, json, {module}; "
            "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in ('torch', 'wsmap'))))")
    loaded = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                       check=True).stdout)
    assert module in loaded
    heavy = [m for m in loaded if m == "torch" or m.startswith(("torch.", "wsmap.learn", "wsmap.datasets",
                                                                 "wsmap.paper"))]
    assert not heavy, f"import {module} loads {heavy}"


def test_no_compatibility_modules():
    for old in ("wsmap.data", "wsmap.models", "wsmap.training", "wsmap.optim"):
        assert importlib.util.find_spec(old) is None, f"{old} is back: import wsmap.datasets / wsmap.learn"


def test_version_lives_in_its_own_module():
    from wsmap import _version
    import wsmap

    assert wsmap.__version__ == _version.__version__
    graph = import_graph(SRC)
    readers = sorted(m for m, t in graph.items() if "wsmap" in t)
    assert readers == [], f"these modules read names from the package root: {readers}"


def test_typing_names_are_generic():
    """``wsmap._typing`` imports nothing of wsmap and no heavy package: the bottom of the graph."""
    graph = import_graph(SRC)
    assert graph["wsmap._typing"] == set()
    tree = ast.parse((SRC / "wsmap" / "_typing.py").read_text())
    imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {(n.module or "").split(".")[0] for n in ast.walk(tree)
                 if isinstance(n, ast.ImportFrom) and not n.level}
    assert imported <= {"__future__", "os", "collections", "pathlib", "typing", "numpy"}, imported


def test_no_module_imports_another_modules_private_names():
    """``from .x import _name`` is refused everywhere (at any level); the allowlist holds today's,
    each deleted as it is mended."""
    new = sorted(private_imports(SRC) - PRIVATE_IMPORTS_TO_MEND)
    assert not new, ("private names imported from another module (make them public in the right module):\n"
                     + "\n".join(f"{m}: from {w} import {n}" for m, w, n in new))


def test_the_private_import_allowlist_is_not_stale():
    mended = sorted(PRIVATE_IMPORTS_TO_MEND - private_imports(SRC))
    assert not mended, ("mended: delete these from PRIVATE_IMPORTS_TO_MEND:\n"
                        + "\n".join(f"{m}: from {w} import {n}" for m, w, n in mended))
