"""The public API a roboticist reads first is importable from ``wsmap`` itself, as the README says;
the README's and the documentation pages' examples (docs/*.md) name only what exists; the README
links resolve; the package is typed (where a new thing goes: tests/test_docs.py, docs/layout.md)."""

from __future__ import annotations

import ast
import re

import pytest

import wsmap
from wsmap import paths

README = (paths.ROOT / "README.md").read_text()
#: The README and every documentation page (the README's long sections moved there, examples included).
PAGES = {"README.md": README, **{f"docs/{p.name}": p.read_text() for p in sorted((paths.ROOT / "docs").glob("*.md"))}}

#: What the README's front page promises at the top level (issue 25, item 8).
FIRST_READ = ["load", "from_urdf", "from_dh", "reachable", "base_placement", "constant_orientation_map",
              "orientation_map", "reachability_index", "position_map", "dexterous_map", "manipulability_map",
              "cartesian_grid", "map_to_volume", "save_map", "load_map", "SerialChain", "DHRobot"]


@pytest.mark.parametrize("name", FIRST_READ)
def test_the_first_names_a_roboticist_reads_are_at_the_top(name):
    assert name in wsmap.__all__
    assert callable(getattr(wsmap, name))


def test_every_name_in_all_exists():
    missing = [n for n in wsmap.__all__ if not hasattr(wsmap, n)]
    assert not missing


def _python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


@pytest.mark.parametrize("page", sorted(PAGES))
def test_every_wsmap_attribute_the_docs_use_exists(page):
    """``wsmap.X`` (and ``wsmap.X.Y``) in the README's and the docs' Python examples and prose resolve."""
    used = set(re.findall(r"\bwsmap\.([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)", PAGES[page]))
    assert used or page != "README.md"
    missing = []
    for dotted in sorted(used):
        obj = wsmap
        for part in dotted.split("."):
            if not hasattr(obj, part):
                try:  # a submodule not imported by its package
                    obj = __import__(f"{obj.__name__}.{part}", fromlist=[part]) if hasattr(obj, "__path__") else None
                except ImportError:
                    obj = None
                if obj is None:
                    missing.append(dotted)
                    break
            else:
                obj = getattr(obj, part)
    assert not missing, f"{page} names wsmap attributes that do not exist: {missing}"


@pytest.mark.parametrize("page", sorted(PAGES))
def test_the_examples_are_valid_python(page):
    for block in _python_blocks(PAGES[page]):
        ast.parse(block)


def test_the_readme_links_resolve():
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README):
        if not target.startswith("http"):
            assert (paths.ROOT / target).exists(), target


def test_the_package_is_typed():
    import tomllib

    assert (paths.ROOT / "src" / "wsmap" / "py.typed").is_file()
    project = tomllib.loads((paths.ROOT / "pyproject.toml").read_text())
    # scikit-build-core ships every file of the package folder, py.typed with it (tests/test_wheel.py
    # finds it in the wheel)
    assert project["tool"]["scikit-build"]["wheel"]["packages"] == ["src/wsmap"]


#: The library's public namespaces: the package, its subpackages (their ``__all__``) and the drawing modules.
PUBLIC = ["wsmap", "wsmap.kinematics", "wsmap.kinematics.ik", "wsmap.workspace", "wsmap.workspace.kinds",
          "wsmap.robots", "wsmap.learn", "wsmap.datasets", "wsmap.paper.parts", "wsmap.viz", "wsmap.views"]


def _public_functions():
    import importlib
    import inspect

    seen = {}
    for name in PUBLIC:
        module = importlib.import_module(name)
        for attr in module.__all__:
            obj = getattr(module, attr)
            if inspect.isfunction(obj):
                seen.setdefault(obj.__qualname__ + obj.__module__, (f"{name}.{attr}", obj))
            elif inspect.isclass(obj) and obj.__module__.startswith("wsmap"):
                for key, member in vars(obj).items():
                    if inspect.isfunction(member) and (not key.startswith("_") or key == "__init__"):
                        seen.setdefault(member.__qualname__ + member.__module__, (f"{name}.{attr}.{key}", member))
    return sorted(seen.values(), key=lambda item: item[0])


def test_every_public_function_is_annotated_with_types_that_exist():
    """Every parameter and return of the public API carries a type hint, and every hint resolves
    (the annotation-only names are what each module imports under ``if TYPE_CHECKING:``, run here)."""
    import ast
    import functools
    import inspect
    import sys
    import typing

    @functools.cache
    def annotation_names(module_name: str) -> dict:
        module = sys.modules[module_name]
        namespace = dict(vars(module))
        for node in ast.parse(inspect.getsource(module)).body:
            if isinstance(node, ast.If) and getattr(node.test, "id", None) == "TYPE_CHECKING":
                exec(compile(ast.Module(body=node.body, type_ignores=[]), module.__file__, "exec"), namespace)
        return namespace

    unannotated, unresolved = [], []
    for dotted, fn in _public_functions():
        fn = inspect.unwrap(fn)
        sig = inspect.signature(fn)
        for p in sig.parameters.values():
            if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) \
                    and p.annotation is inspect.Parameter.empty:
                unannotated.append(f"{dotted}({p.name})")
        if sig.return_annotation is inspect.Signature.empty and fn.__name__ != "__init__":
            unannotated.append(f"{dotted} -> ?")
        namespace = annotation_names(fn.__module__)
        try:
            typing.get_type_hints(fn, globalns=namespace)
        except Exception as e:  # noqa: BLE001 - any failure is a hint that names nothing
            unresolved.append(f"{dotted}: {type(e).__name__}: {e}")
    assert not unannotated, unannotated
    assert not unresolved, unresolved


def test_the_three_answers_and_coupled_joints_are_at_the_top():
    """A map file's node answers (`load_status`) and a chain's coupled joints (`Coupling`) are
    reachable from ``wsmap`` as docs/maps.md and docs/library.md use them."""
    from wsmap.kinematics.chain import Coupling
    from wsmap.workspace.files import load_status

    assert wsmap.load_status is load_status and wsmap.workspace.load_status is load_status
    assert wsmap.Coupling is Coupling and wsmap.kinematics.Coupling is Coupling
    assert {"load_status", "Coupling"} <= set(wsmap.__all__)
