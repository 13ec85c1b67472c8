"""Shared fixtures: the smoke pipeline (params.smoke.yaml) run into one temporary root per session.

``smoke_root`` builds every dataset of the smoke configuration once; ``smoke_notebook(name)``
executes a pipeline notebook there (once per session, after the notebooks whose outputs it reads:
:func:`wsmap.paper.parts.reads`), so a notebook that reads another's models or metrics finds them,
as under ``dvc repro``.

``make test`` runs the tests on two pytest-xdist workers (``-n 2 --dist loadgroup``). Every test
that uses the smoke pipeline is put in one group, so one worker builds it once and runs the
notebooks in their dependency order while the other takes the rest; each worker runs torch, numba
and the notebooks' kernels on one thread, because two processes of two threads each on the two
cores run slower than one. The smoke-pipeline tests carry the mark ``smoke``: ``pytest -m smoke`` runs them
alone, ``pytest -m "not smoke"`` the rest.

Two things keep the two workers busy to the end:

* the group reaches the scheduler as a suffix of the test's id (``...::test@smoke``), which
  pytest-xdist 3.8 writes into an attribute pytest 9.2 no longer reads (pytest-xdist issue 1386):
  :func:`_join_group` writes it where pytest keeps the id now, and the run stops with an error if
  a grouped test still reaches the scheduler without it (each worker would otherwise build the
  smoke pipeline and run its notebooks again, unnoticed);
* xdist hands out the largest group first (the smoke pipeline, to one worker) and then single
  tests in collection order as each worker runs short. On a worker, :data:`HEAVY` (the tests
  that take tens of seconds, longest first) is moved to the front, so the other worker starts
  on them while the first runs the pipeline, and neither picks up a minute-long test near the
  end (longest-processing-time-first). The order of a run without workers is unchanged.
"""

from __future__ import annotations

import os

import pytest

try:  # pytest 9.2 on: a node's id is a structured NodeId (see _suffix_group)
    from _pytest.nodeid import NodeId
except ImportError:  # pragma: no cover - older pytest: xdist's own hook writes the suffix
    NodeId = None

from wsmap import paths
from wsmap.paper import parts
from wsmap.paper.pipeline import build_datasets, run_notebook

SMOKE_FIXTURES = {"smoke_root", "smoke_notebook"}


def pytest_configure(config):
    if os.environ.get("PYTEST_XDIST_WORKER"):
        # inherited by the notebooks' kernels (papermill starts them with this environment);
        # WSMAP_THREADS is what lm_compiled.set_threads() falls back to
        os.environ["OMP_NUM_THREADS"] = "1"
        os.environ["WSMAP_THREADS"] = "1"
        import torch

        torch.set_num_threads(1)
        from wsmap.kinematics import lm_compiled

        lm_compiled.set_threads(1)


#: Tests that take many seconds whichever worker runs them (a wheel, fresh compiles in empty numba
#: caches, notebooks run in their own folders, vendor meshes), by node-id prefix, with their seconds
#: in one two-worker run of the whole suite on a loaded machine (2026-12-06, load ~6, numba's cache
#: empty as in CI: about three times a quiet machine's; the wheel's after its build reused the
#: install's objects). Only the order matters: a worker moves them to the front, longest first,
#: and a test that is renamed only loses its place. Tests that are slow only where they happen to
#: compile numba's shared cache first are not listed. The smoke pipeline is one group and goes
#: first anyway.
HEAVY = {
    "tests/test_wheel.py::test_the_wheel_installs_a_working_tool": 117,
    "tests/kinematics/test_lm_compiled_cache.py::test_cached_kernel_gives_the_bits_of_a_fresh_compile[scalar]": 100,
    "tests/kinematics/test_ur_compile_notice.py::test_the_first_ur_build_is_announced_once": 75,
    "tests/kinematics/test_lm_coupled_cache.py::test_cached_coupled_kernel_gives_the_bits_of_a_fresh_compile": 70,
    "tests/paper/notebooks/test_nb_reach_study.py::test_reach_study_smoke": 65,
    "tests/paper/notebooks/test_nb_real_arms.py::test_real_arms_smoke": 26,
    "tests/test_hostile_files.py::test_sighup_leaves_no_temporary_file": 19,
    "tests/collision/test_vendor_judge.py::test_the_gen3s_grown_hulls_hold_kinovas_meshes": 19,
    "tests/test_io.py::test_sigterm_leaves_no_temporary_file": 14,
    "tests/datasets/test_ram.py::test_capsule_checker_agrees_with_rams_rules_by_brute_force": 12,
    "tests/paper/notebooks/test_nb_runtime_comparison.py::test_runtime_comparison_smoke": 12,
    "tests/paper/notebooks/test_notebooks.py::test_classical_workspace_smoke": 10,
    "tests/collision/test_vendor_judge.py::test_the_readme_tool_down_map_has_no_colliding_solution": 9,
}


def _cost(item) -> float:
    nodeid = item.nodeid
    return next((s for prefix, s in HEAVY.items() if nodeid.startswith(prefix)), 0.0)


def _group_of(item) -> str | None:
    """The xdist group of ``item`` as xdist names it: its ``xdist_group`` marks' names, sorted and
    joined by ``_`` (None: no group)."""
    names = {str(m.args[0]) if m.args else str(m.kwargs.get("name", "default"))
             for m in item.iter_markers("xdist_group")}
    return "_".join(sorted(names)) or None


def _suffix_group(item) -> None:
    """Append ``@group`` to ``item``'s id where pytest keeps it as a structured ``NodeId`` (pytest 9.2
    on), which xdist's own hook no longer reaches (it sets ``_nodeid``); older pytest versions get
    the suffix from xdist."""
    group = _group_of(item)
    if group and NodeId is not None and isinstance(getattr(item, "_id", None), NodeId) \
            and not item.nodeid.endswith(f"@{group}"):
        item._id = NodeId.parse(f"{item.nodeid}@{group}")


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups off the marks
def pytest_collection_modifyitems(config, items):
    for item in items:
        if SMOKE_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.xdist_group("smoke"))
            item.add_marker(pytest.mark.smoke)
        if getattr(config.option, "loadgroup", False):  # an xdist worker of --dist loadgroup
            _suffix_group(item)
    if os.environ.get("PYTEST_XDIST_WORKER"):
        items.sort(key=lambda item: -_cost(item))  # stable: the rest keep their order


#: Grouped tests that reached the scheduler without their group (see pytest_collection_finish).
_LOST_GROUP: set[str] = set()


@pytest.hookimpl(trylast=True)  # after xdist's own hook
def pytest_collection_finish(session):
    """Under ``--dist loadgroup``, every test marked with an xdist group must reach the scheduler
    with its group as the id's suffix, or xdist spreads the group over the workers in silence:
    such a test fails at its setup, saying so (an error here would end the worker without a word)."""
    if getattr(session.config.option, "loadgroup", False):
        _LOST_GROUP.update(item.nodeid for item in session.items
                           if _group_of(item) and not item.nodeid.endswith(f"@{_group_of(item)}"))


def pytest_runtest_setup(item):
    if item.nodeid in _LOST_GROUP:
        pytest.fail(f"xdist would not keep this test in its group {_group_of(item)!r}: the group no longer "
                    "reaches the scheduler (pytest-xdist issue 1386; tests/conftest.py _suffix_group)",
                    pytrace=False)


SMOKE = paths.ROOT / "params.smoke.yaml"

@pytest.fixture(scope="session")
def smoke_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("smoke")
    for _ in build_datasets(SMOKE, paths.Outputs(root).make().data):
        pass
    return root


@pytest.fixture(scope="session")
def smoke_notebook(smoke_root):
    done: dict[str, object] = {}

    def run(name: str):
        if name not in done:
            for dep in parts.reads(name):  # the parts whose outputs it reads (the registry's)
                if (paths.NOTEBOOKS / f"{dep}.ipynb").exists():
                    run(dep)
            done[name] = run_notebook(name, SMOKE, smoke_root, timeout=600)
        return paths.Outputs(smoke_root)

    return run


@pytest.fixture(scope="module")
def one_thread():
    """The compiled IK kernels and torch on one thread for a module (``pytestmark =
    pytest.mark.usefixtures("one_thread")``), restored after: a second thread is pure overhead on
    the small calls of the tests, and results must not depend on it."""
    import torch

    from wsmap.kinematics import lm_compiled

    kernels, nets = lm_compiled.threads(), torch.get_num_threads()
    lm_compiled.set_threads(1)
    torch.set_num_threads(1)
    yield
    lm_compiled.set_threads(kernels)
    torch.set_num_threads(nets)
