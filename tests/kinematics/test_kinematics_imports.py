"""wsmap.kinematics has no import circle at any level, imports inside functions and under
``if TYPE_CHECKING:`` included, and its forward-kinematics modules do not import the
inverse-kinematics layer (not even for their annotations)."""

import ast
from pathlib import Path

import wsmap.kinematics

PKG = Path(wsmap.kinematics.__file__).parent
NAME = "wsmap.kinematics"


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def _is_module(name: str) -> bool:
    rel = Path(*name.split(".")[1:])
    base = PKG.parent / rel
    return base.with_suffix(".py").exists() or (base / "__init__.py").exists()


def _imports(path: Path, name: str) -> set[str]:
    """Every wsmap.kinematics module that ``path`` imports, at any depth of its code."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            # "from X import Y" imports the module X.Y where there is one, else X
            targets = [f"{base}.{a.name}" if _is_module(f"{base}.{a.name}") else base for a in node.names]
        else:
            continue
        out |= {t for t in targets if t == NAME or t.startswith(NAME + ".")}
    return out


def _graph():
    graph = {}
    for f in PKG.rglob("*.py"):
        n = _module_name(f)
        # a module importing its own package (its __init__ re-exporting it) is not an edge
        graph[n] = {m for m in _imports(f, n) if m != n and not n.startswith(m + ".")}
    return graph


def test_no_import_circle_in_kinematics_at_any_level():
    graph = _graph()
    assert "wsmap.kinematics.ik.search" in graph and "wsmap.kinematics.ik.closed_forms.ur" in graph
    state = {}

    def visit(n, stack):
        state[n] = 1
        for m in sorted(graph.get(n, ())):
            assert state.get(m) != 1, f"import circle: {' -> '.join(stack[stack.index(m):] + [m])}"
            if not state.get(m):
                visit(m, stack + [m])
        state[n] = 2

    for n in sorted(graph):
        if not state.get(n):
            visit(n, [n])


def test_forward_kinematics_does_not_import_the_ik_layer():
    graph = _graph()
    for fk in ("transforms", "arms", "dh", "chain", "urdf"):
        name = f"{NAME}.{fk}"
        seen, todo = set(), [name]
        while todo:
            n = todo.pop()
            for m in graph.get(n, ()):
                if m not in seen:
                    seen.add(m)
                    todo.append(m)
        assert not any(m.startswith(f"{NAME}.ik") for m in seen), (name, sorted(seen))
