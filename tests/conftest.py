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
"""

from __future__ import annotations

import os

import pytest

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


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups off the marks
def pytest_collection_modifyitems(config, items):
    for item in items:
        if SMOKE_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.xdist_group("smoke"))
            item.add_marker(pytest.mark.smoke)


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
