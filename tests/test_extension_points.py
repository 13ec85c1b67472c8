"""The table "Where a new thing goes" (docs/layout.md) held by trial: each plug-in below is ONE new
file, dropped into its folder (a temporary folder added to the plug-in package's `__path__`, found by
the same `discover` the package's `__init__` runs), with nothing else edited, and the library and the
command line then use it end to end.

Each trial runs in a fresh interpreter, so that its registration never leaks into other tests.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

#: Put the trial file's folder on the plug-in package's path and discover it, as the package's
#: `__init__` does with its own folder.
_PRELUDE = """
import importlib, sys
package, folder = sys.argv[1], sys.argv[2]
pkg = importlib.import_module(package)
pkg.__path__.append(folder)
from wsmap._plugins import discover
assert discover(package, [folder]) == [sys.argv[3]], "the trial file is the one plug-in of its folder"
"""


def _trial(tmp_path, package: str, name: str, plugin: str, check: str) -> str:
    folder = tmp_path / "plugins"
    folder.mkdir()
    (folder / f"{name}.py").write_text(textwrap.dedent(plugin))
    script = tmp_path / "check.py"
    script.write_text(_PRELUDE + textwrap.dedent(check))
    run = subprocess.run([sys.executable, str(script), package, str(folder), name], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300,
                         env={**os.environ, "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg"})
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout


def test_a_new_map_kind_is_one_file(tmp_path):
    plugin = '''
        """Trial kind: reachable at one or more of --orientations (the index's bits, any)."""
        from wsmap.workspace.reach import reachability_index
        from wsmap.workspace.kinds.registry import orientation_set_kind, register


        def any_orientation_map(robot, nodes, orientations, **kw):
            _, bits = reachability_index(robot, nodes, orientations, return_bits=True, **kw)[:2]
            return bits.any(axis=1)


        KIND = register(orientation_set_kind("trial_any", bool, any_orientation_map,
                                             "reachable at one of --orientations", priority=90,
                                             from_bits=lambda bits: bits.any(axis=1), noun="trial"))
    '''
    check = '''
        import numpy as np
        from wsmap.cli import main
        from wsmap.workspace.files import load_map
        argv = ["map", "--robot", "ur5e", "--step", "0.4", "--orientations", "6", "-q"]
        assert main(argv + ["--kind", "trial_any", "--out", "any.npz"]) == 0
        assert main(argv + ["--kind", "index", "--out", "index.npz"]) == 0
        trial, index = load_map("any.npz")[0], load_map("index.npz")[0]
        assert trial.dtype == bool and np.array_equal(trial, index > 0)
        assert 0 < trial.sum() < trial.size
        print(int(trial.sum()), trial.size)
    '''
    reached, total = map(int, _trial(tmp_path, "wsmap.workspace.kinds", "trial_any", plugin, check).split())
    assert 0 < reached < total


def test_a_new_named_arm_is_one_file(tmp_path):
    # the PUMA 560's standard-DH table (Corke's mdl_puma560 lengths) under another name: the registry
    # builds it, `wsmap robots` lists it, the closed-form registry recognises its spherical wrist
    plugin = '''
        """Trial arm: a six-joint arm with a spherical wrist."""
        import math
        from wsmap.robots.registry import ArmTable, register

        TRIAL6 = ArmTable(
            name="trial6", title="Trial 6R", convention="standard",
            rows=((0.0, 0.0, math.pi / 2, 0.0), (0.0, 0.4318, 0.0, 0.0), (0.15005, 0.0203, -math.pi / 2, 0.0),
                  (0.4318, 0.0, math.pi / 2, 0.0), (0.0, 0.0, -math.pi / 2, 0.0), (0.0, 0.0, 0.0, 0.0)),
            limits=((-160, 160), (-225, 45), (-45, 225), (-110, 170), (-100, 100), (-266, 266)),
            limit_unit="deg", source="a test's table (the PUMA 560's lengths)")

        register(TRIAL6, priority=95)
    '''
    check = '''
        import contextlib, io
        import numpy as np
        import wsmap
        from wsmap.cli import main
        from wsmap.workspace.files import load_map
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            assert main(["robots"]) == 0
        assert "trial6" in out.getvalue()
        arm = wsmap.load("trial6")
        assert arm.n == 6 and np.allclose(np.rad2deg(arm.qlim[:, 1]), [160, 45, 225, 170, 100, 266])
        assert main(["map", "--robot", "trial6", "--step", "0.2", "-q", "--out", "m.npz"]) == 0
        values, nodes, meta, how = load_map("m.npz")
        print(how.get("method"), int(values.sum()))
    '''
    method, reached = _trial(tmp_path, "wsmap.robots.arms", "trial6", plugin, check).split()
    assert method == "exact" and int(reached) > 0


def test_a_new_solver_is_one_file(tmp_path):
    # a solver that delegates to "independent" and counts its calls: SearchSettings(solver=...) must
    # reach it from a map, and its map must be the delegate's
    plugin = '''
        """Trial solver: the independent multi-start search, counted."""
        from wsmap.kinematics.ik.solver import SOLVERS
        from wsmap.kinematics.ik.solvers.independent import IndependentSearch

        CALLS = []


        class Counted(IndependentSearch):
            name = "trial_counted"
            priority = 90

            def solve(self, arms, T, settings=None, accept=None, **kw):
                CALLS.append(T.shape)
                return super().solve(arms, T, settings.replace(solver="independent"), accept, **kw)


        SOLVER = SOLVERS.register(Counted())
    '''
    check = '''
        import importlib
        import numpy as np
        import wsmap
        from wsmap.kinematics.ik.settings import SearchSettings
        from wsmap.workspace import constant_orientation_map, grid_spec
        from wsmap.workspace.grids import cartesian_grid
        trial = importlib.import_module("wsmap.kinematics.ik.solvers.trial_counted")
        arm = wsmap.load("panda")
        nodes = cartesian_grid(-0.8, 0.8, 0.4)
        a = constant_orientation_map(arm, nodes, (np.pi, 0, 0), method="numerical",
                                     ik=SearchSettings(solver="trial_counted", starts=8, seed=3))
        b = constant_orientation_map(arm, nodes, (np.pi, 0, 0), method="numerical",
                                     ik=SearchSettings(solver="independent", starts=8, seed=3))
        assert trial.CALLS, "the map did not ask the registered solver"
        assert np.array_equal(a, b) and a.any()
        print(len(trial.CALLS))
    '''
    assert int(_trial(tmp_path, "wsmap.kinematics.ik.solvers", "trial_counted", plugin, check)) >= 1


@pytest.mark.parametrize("package", ["wsmap.workspace.kinds", "wsmap.robots.arms", "wsmap.kinematics.ik.solvers",
                                     "wsmap.collision.shapes", "wsmap.kinematics.ik.closed_forms",
                                     "wsmap.paper.parts"])
def test_every_plugin_folder_discovers_its_files(package):
    """The folders of the table use `discover` in their `__init__` (the trials above rely on it)."""
    import importlib
    import inspect

    source = inspect.getsource(importlib.import_module(package))
    assert "discover(__name__, __path__)" in source, f"{package} does not discover its plug-ins"
