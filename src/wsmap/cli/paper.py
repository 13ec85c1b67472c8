"""`wsmap paper`: run the paper's notebooks (the DVC stages) and the paper-scale runner."""

from __future__ import annotations

import os
from pathlib import Path

from .._optional import MissingDependency, require
from .arguments import HelpFormatter, Parser, non_negative_int

#: The optional modules the paper's parts and runner import as they load (`pip install 'wsmap[paper]'`
#: brings them): checked first, so that a missing one is one line naming the extra, not a traceback.
PAPER_MODULES = ("pandas", "torch", "papermill", "nbformat")

def add_parser(sub):
    p = sub.add_parser("paper", help="reproduce the paper: run its notebooks (the DVC stages)",
                       description="Run the paper's notebooks with papermill. `dvc repro` runs each stage as "
                                   "`python -m wsmap.paper.notebook NAME`, the same run as `wsmap paper run NAME`; "
                                   "--all runs everything without DVC.")
    psub = p.add_subparsers(dest="paper_command", required=True, metavar="{run,list,full}", parser_class=Parser)
    r = psub.add_parser("run", help="run notebooks (stages) by name, or all of them",
                        formatter_class=HelpFormatter)
    r.add_argument("notebooks", nargs="*", help="notebook names (without .ipynb)")
    r.add_argument("--all", action="store_true",
                   help="build the datasets the root lacks, then run every notebook in order (no DVC)")
    r.add_argument("--params", help="parameters file (default params.yaml)")
    r.add_argument("--root", help="output root (default: the project root)")
    r.add_argument("--timeout", type=non_negative_int, default=3600,
                   help="per-cell execution timeout in seconds (0: none; use 0 for params.full.yaml)")
    r.set_defaults(run=_run_paper)
    ls = psub.add_parser("list", help="list the notebooks in pipeline order")
    ls.set_defaults(run=_run_paper_list)
    f = psub.add_parser(
        "full", help="the paper's scale, part by part, resumable, into results/full/",
        description="Run the paper-scale experiments (params.full.yaml) part by part: each Table 1 row, "
                    "section 6.1, section 6.2, Table 2's Rprop + MSE cell, each Table 3 embedding. Each part "
                    "writes OUT/PART.json; a part whose file holds the same settings hash is skipped, and an "
                    "interrupted part resumes at its next step (session or block). See wsmap.paper.full.",
        epilog="Examples: wsmap paper full --list; wsmap paper full table1; wsmap paper full sec61_subspace "
               "--device cuda; wsmap paper full --estimate.",
        formatter_class=HelpFormatter)
    f.add_argument("parts", nargs="*", metavar="PART",
                   help="parts to run: names, shell patterns (table1_*) or groups (sec61, sec62, table1, table2, "
                        "table3); none: all, in order")
    f.add_argument("--list", action="store_true", help="list the parts: done/pending, steps, measured or estimated time")
    f.add_argument("--estimate", action="store_true",
                   help="time a few epochs of each part that is not done, on random data of its exact shapes, into "
                        "OUT/estimates.json (minutes; --list then uses them)")
    f.add_argument("--params", help="parameters file (default params.full.yaml)")
    f.add_argument("--out", help="result folder (default results/full)")
    f.add_argument("--data", help="dataset folder, built on demand (default data/full)")
    f.add_argument("--device", help="auto, cpu or cuda for every part (default: each section's device setting)")
    f.set_defaults(run=_run_paper_full)


def _paper_modules(what: str, *names: str) -> list:
    """`wsmap.paper.<name>` for each name, once the checkout and the paper extra are found:
    `ValueError` (one line) for a missing checkout, `MissingDependency` naming the extra."""
    import importlib

    from .. import paths

    paths.require_checkout(what)
    for module in PAPER_MODULES:
        require(module, extra="paper", why=what)
    try:
        return [importlib.import_module(f"wsmap.paper.{name}") for name in names]
    except ModuleNotFoundError as e:  # a module the paper imports beyond PAPER_MODULES
        if e.name is None or e.name.split(".")[0] == "wsmap":
            raise
        raise MissingDependency(f"{what} needs {e.name}, which is not installed: pip install 'wsmap[paper]'") from None


def _run_paper(args) -> int:
    from .. import paths

    (pipeline,) = _paper_modules("wsmap paper run", "pipeline")
    if args.all and args.notebooks:
        raise ValueError("give notebook names or --all, not both")
    if not args.all and not args.notebooks:
        raise ValueError("name at least one notebook, or --all")
    params = Path(args.params) if args.params else paths.PARAMS
    names = pipeline.order() if args.all else args.notebooks
    for name in names:  # every name and section checked before anything runs
        pipeline.check_notebook(name)
        paths.notebook_params(name, params)
    if args.root:
        from ..io import check_output_path

        check_output_path(Path(args.root) / "results" / "x", "--root")
    # one process, two cores: keep torch and BLAS from oversubscribing inside the kernel
    os.environ.setdefault("OMP_NUM_THREADS", "2")
    os.environ.setdefault("MPLBACKEND", "Agg")
    if args.all:
        pipeline.run_all(params, args.root, args.timeout)
    else:
        for name in args.notebooks:
            pipeline.run_notebook(name, params, args.root, args.timeout)
    return 0


def _run_paper_full(args) -> int:
    (full,) = _paper_modules("wsmap paper full", "full")
    if args.list and args.estimate:
        raise ValueError("give --list or --estimate, not both")
    params = Path(args.params) if args.params else None
    if args.device is not None:
        from ..learn.device import check_device_name

        check_device_name(args.device, "--device")
    if args.list:
        for line in full.list_lines(params, args.out, args.data, device=args.device, names=args.parts):
            print(line)
        return 0
    log = lambda line: print(line, flush=True)  # noqa: E731
    if args.estimate:
        full.estimate(args.parts, params, args.out, device=args.device, log=log)
        return 0
    full.run(args.parts, params, args.out, args.data, device=args.device, log=log)
    return 0


def _run_paper_list(args) -> int:
    (pipeline,) = _paper_modules("wsmap paper list", "pipeline")
    for name in pipeline.order():
        print(name)
    return 0


