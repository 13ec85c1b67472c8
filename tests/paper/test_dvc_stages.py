"""DVC stages depend on exactly the package code they run, and on the lock.

``tools/stage_deps.py`` computes each stage's code dependencies: the static import closure (imports
inside functions included) of the module its ``python -m`` command runs and of the imports of its
notebook. These tests hold dvc.yaml to it, check that the closure finder misses nothing Python
loads, and that the classical stages do not depend on the learning code (a change inside
``wsmap/learn`` leaves them up to date).
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from wsmap import paths

ROOT = paths.ROOT
PKG = ROOT / "src" / "wsmap"
STAGES = yaml.safe_load((ROOT / "dvc.yaml").read_text())["stages"]

_spec = importlib.util.spec_from_file_location("stage_deps", ROOT / "tools" / "stage_deps.py")
stage_deps = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(stage_deps)
_module_file = stage_deps.module_file
_wsmap_imports = stage_deps.wsmap_imports
import_closure = stage_deps.import_closure


def _body(name):
    return STAGES[name].get("do", STAGES[name])


def _deps(name) -> list[str]:
    return [d if isinstance(d, str) else next(iter(d)) for d in _body(name)["deps"]]


def _covered(path: Path, deps: list[str]) -> bool:
    return any(path == ROOT / d or (ROOT / d) in path.parents for d in deps)


@pytest.mark.parametrize("name", sorted(STAGES))
def test_stage_depends_on_its_code_and_the_lock(name):
    deps = _deps(name)
    assert "environment.lock" in deps, f"stage {name} does not depend on environment.lock"
    closure = import_closure(stage_deps.stage_roots(_body(name)["cmd"]))
    assert len(closure) > 3
    missing = sorted(str(p.relative_to(ROOT)) for p in closure if not _covered(p, deps))
    assert not missing, f"stage {name} runs code it does not depend on: {missing}"
    # the compiled lane kernel runs every IK search: its C++ sources are deps wherever it loads
    if ROOT / "src/wsmap/kinematics/lm_lanes.py" in closure:
        assert "src/wsmap/kinematics/_lanes" in deps, f"stage {name} runs the lane kernel without its sources as deps"


def test_dvc_yaml_holds_the_generated_deps():
    """Nothing more than the closure either: a stage reruns only when code it runs changed
    (regenerate with ``python tools/stage_deps.py``)."""
    stale = stage_deps.stale((ROOT / "dvc.yaml").read_text())
    assert not stale, f"dvc.yaml deps differ from the stages' import closures (run tools/stage_deps.py): {stale}"


def test_the_rewrite_keeps_everything_but_the_code_deps():
    text = (ROOT / "dvc.yaml").read_text()
    new = yaml.safe_load(stage_deps.rewrite(text))["stages"]
    for name, stage in yaml.safe_load(text)["stages"].items():
        old_body, new_body = stage.get("do", stage), new[name].get("do", new[name])
        assert {k: v for k, v in old_body.items() if k != "deps"} == {k: v for k, v in new_body.items() if k != "deps"}
        keep = [d for d in old_body["deps"] if not (isinstance(d, str) and d.startswith("src/"))]
        assert [d for d in new_body["deps"] if not (isinstance(d, str) and d.startswith("src/"))] == keep


def test_a_change_inside_learn_leaves_the_classical_stages_up_to_date():
    for name in ("classical_workspace", "real_arms", "datasets"):
        deps = _deps(name)
        learn = sorted(p.relative_to(ROOT).as_posix() for p in (PKG / "learn").rglob("*.py") if _covered(p, deps))
        assert not learn, f"stage {name} depends on the learning code: {learn}"


def test_the_closure_finder_sees_lazy_imports():
    # the CLI imports wsmap.viz only inside a function: a closure from the CLI must cover it
    closure = import_closure({"wsmap.cli"})
    assert PKG / "viz.py" in closure and PKG / "workspace" / "maps.py" in closure


def test_the_closure_matches_what_python_loads():
    """What a fresh interpreter loads for the stage runners and the CLI is inside the static closure."""
    code = ("import sys, json, wsmap.cli, wsmap.paper.notebook, wsmap.paper.dataset; "
            "print(json.dumps(sorted(m.__file__ for n, m in sys.modules.items() "
            "if n.split('.')[0] == 'wsmap' and getattr(m, '__file__', None))))")
    loaded = {Path(p) for p in json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True,
                                                         text=True, check=True).stdout)}
    static = import_closure({"wsmap.cli", "wsmap.paper.notebook", "wsmap.paper.dataset", "wsmap.__main__"})
    # a compiled extension is no source file: tools/stage_deps.py names its sources (EXTENSIONS)
    compiled = {p for p in loaded if p.suffix != ".py"}
    assert {p.name.split(".")[0] for p in compiled} <= {Path(f).name for f in stage_deps.EXTENSIONS.values()}
    assert {p.resolve() for p in loaded - compiled} <= {p.resolve() for p in static}
