"""Running the paper's notebooks (`wsmap paper run NOTEBOOK [--params FILE] [--root DIR]`).

Each notebook under `notebooks/` is one DVC stage. This runner checks that the parameters file
has the notebook's section (same name as the notebook), passes the file's path to papermill (the
notebook reads its section through `wsmap.paths.notebook_params`, as it does when opened by
hand), and writes the executed copy to `<root>/results/notebooks/` — never over the source
notebook. papermill runs with the `python3` kernel (a saved kernel name may not exist) from the
project root.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from .. import paths
from . import parts


class NotebookError(RuntimeError):
    """A notebook raised while it ran: names the notebook, the cell's error, and the executed copy
    (`<name>.failed.ipynb`) that holds its traceback."""


def check_notebook(name: str) -> Path:
    """The source notebook of `name`; an unknown name is a `ValueError` listing the known ones."""
    src = paths.NOTEBOOKS / f"{name}.ipynb"
    if not src.is_file():
        known = sorted(p.stem for p in paths.NOTEBOOKS.glob("*.ipynb"))
        raise ValueError(f"unknown notebook {name!r}; known: {', '.join(known)}")
    return src


def run_notebook(name: str, params_file=None, root=None, timeout: int | None = 3600,
                 extra: dict | None = None) -> Path:
    """Execute `notebooks/<name>.ipynb` with its params section; returns the executed copy's path.

    `timeout`: seconds any one cell may run (`None` or 0: no limit, for the paper's scale).

    Raises `NotebookError` when a cell raises: the partly executed copy goes to
    `<name>.failed.ipynb` beside it and the previous executed copy, if any, stays in place.
    """
    import papermill as pm
    from papermill.exceptions import PapermillExecutionError

    src = check_notebook(name)
    params_file = (Path(params_file) if params_file else paths.PARAMS).resolve()
    paths.notebook_params(name, params_file)  # a missing file or section fails here, before any work
    out = paths.Outputs(root).make()
    parameters = {"params_file": str(params_file), "output_root": str(out.root), **(extra or {})}
    dest = out.executed / f"{name}.ipynb"
    failed = out.executed / f"{name}.failed.ipynb"
    # papermill writes to its output path as cells run (and records that path in the notebook), so
    # the last good copy waits aside until this run has succeeded
    kept = out.executed / f".{name}.ipynb.kept"
    if dest.exists():
        os.replace(dest, kept)
    t0 = time.perf_counter()
    try:
        pm.execute_notebook(
            str(src), str(dest), parameters=parameters, kernel_name="python3", cwd=str(paths.ROOT),
            execution_timeout=timeout or None, progress_bar=False, log_output=False,
        )
    except BaseException as e:
        if dest.exists():
            os.replace(dest, failed)
        if kept.exists():
            os.replace(kept, dest)
        if isinstance(e, PapermillExecutionError):
            error = (str(e.evalue).strip().splitlines() or [""])[0]
            raise NotebookError(f"notebook {name} failed in cell {e.exec_count}: {e.ename}: {error} "
                                f"(its traceback: {failed})") from None
        raise
    kept.unlink(missing_ok=True)
    failed.unlink(missing_ok=True)
    print(f"{name}: executed in {time.perf_counter() - t0:.1f} s -> {dest}")
    return dest


def order() -> list[str]:
    """The notebooks in run order (as dvc.yaml runs them): the parts' registry
    (`wsmap.paper.parts.order`), every part after the parts whose outputs it reads."""
    return parts.order()


def build_datasets(params_file, data_dir, *, rebuild: bool = False):
    """Build every dataset (and its test set) of the params file's `datasets` section into
    `data_dir`, skipping pairs already there unless `rebuild`; yields `(name, seconds)` for
    each one built, as it is built (the dvc stages `datasets@NAME` do the same one by one)."""
    from .specs import build_pair, dataset_paths, dataset_sizes

    sizes = paths.load_params("datasets", params_file)
    # every entry checked (a mapping of whole samples and test_samples) before the first is built
    sizes = dataset_sizes(list(sizes) if isinstance(sizes, dict) else [], sizes,
                          Path(params_file or paths.PARAMS).name)
    for name, item in sizes.items():
        if not rebuild and all(p.exists() for p in dataset_paths(name, data_dir)):
            continue
        t0 = time.perf_counter()
        build_pair(name, data_dir, item["samples"], item["test_samples"], progress=False)
        yield name, time.perf_counter() - t0


def run_all(params_file=None, root=None, timeout: int | None = 3600) -> list[Path]:
    """Without DVC: build every dataset of the params file's `datasets` section that `root`
    lacks, then execute every notebook in `order`. For runs outside the committed
    configuration (the paper's full scale: `params.full.yaml`) into their own root, so that the
    committed results stay what `params.yaml` produces. The wall time of every dataset and
    notebook goes to `<root>/results/pipeline_timings.json` (rewritten after each step)."""
    import json

    from ..io import atomic_path

    params_file = Path(params_file) if params_file else paths.PARAMS
    out = paths.Outputs(root).make()
    timings = {"params": str(params_file), "cpus": os.cpu_count(), "seconds": {}}

    def record(step: str, seconds: float) -> None:
        timings["seconds"][step] = round(seconds, 2)
        with atomic_path(out.results / "pipeline_timings.json") as tmp:
            Path(tmp).write_text(json.dumps(timings, indent=1))

    for name, seconds in build_datasets(params_file, out.data):
        record(f"datasets@{name}", seconds)
        print(f"dataset {name}: built in {seconds:.1f} s", flush=True)
    executed = []
    for n in order():
        if (paths.NOTEBOOKS / f"{n}.ipynb").exists():
            t0 = time.perf_counter()
            executed.append(run_notebook(n, params_file, out.root, timeout))
            record(n, time.perf_counter() - t0)
    return executed
