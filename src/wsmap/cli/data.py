"""`wsmap data` (experience datasets) and `wsmap robots` (the named arms)."""

from __future__ import annotations

import time

from .arguments import HelpFormatter, Parser, non_negative_int, positive_float, positive_int, quiet_argument

def add_parser(sub):
    d = sub.add_parser("data", help="build and inspect experience datasets",
                       description="Experience datasets: features of random arms and their workspace maps.")
    dsub = d.add_subparsers(dest="data_command", required=True, metavar="{build,list,audit}", parser_class=Parser)
    b = dsub.add_parser("build", help="build one of the catalogue's datasets (and its test set)",
                        description="Build a dataset of the catalogue (`wsmap data list`: the paper's and the "
                                    "extensions such as panda7_tooldown) and, with --test-samples, its independent "
                                    "test set beside it (NAME.test.npz). The labels are computed in this process, "
                                    "or on Dask: --workers K starts a local cluster of K single-threaded "
                                    "processes, --scheduler ADDRESS uses a running cluster (`dask scheduler` and "
                                    "`dask worker ADDRESS` on its machines). The files are byte-identical either "
                                    "way.",
                        formatter_class=HelpFormatter)
    b.add_argument("name", help="a dataset of the catalogue (see `wsmap data list`)")
    b.add_argument("--out", required=True, help="output file (.npz)")
    b.add_argument("--samples", type=positive_int, help="number of arms (the first N of the spec's streams; default the paper's)")
    b.add_argument("--test-samples", type=positive_int,
                   help="also build the independent test set of this many arms (OUT with .test.npz)")
    b.add_argument("--test", action="store_true",
                   help="build only the spec's independent test set (of --samples arms, default 1000) into --out")
    b.add_argument("--workers", type=positive_int,
                   help="compute the labels on a Dask LocalCluster of this many worker processes (one thread "
                        "each; at most 4 per core); default: in this process")
    b.add_argument("--scheduler", metavar="ADDRESS",
                   help="compute the labels on the Dask cluster of this scheduler (e.g. tcp://head:8786)")
    b.add_argument("--connect-timeout", type=positive_float, default=5.0,
                   help="seconds to wait for --scheduler to answer (at most 3600)")
    quiet_argument(b)
    b.set_defaults(run=_run_data_build)
    ls = dsub.add_parser("list", help="list the catalogue's datasets (the paper's and the extensions)")
    ls.set_defaults(run=_run_data_list)
    a = dsub.add_parser("audit", help="exact labels against the paper's one-start numerical path")
    a.add_argument("names", nargs="*", help="datasets (default: every distinct spherical-wrist spec)")
    a.add_argument("--arms", type=positive_int, default=50)
    a.add_argument("--seed", type=non_negative_int, default=0)
    a.set_defaults(run=_run_data_audit)


def _paper_spec(name):
    from ..paper.specs import paper_spec

    return paper_spec(name)


def _run_data_build(args) -> int:
    from .. import datasets

    if args.test and args.test_samples is not None:
        raise ValueError("--test builds only a test set into --out; --test-samples builds one beside the "
                         "training set: give one of them")
    if args.workers is not None and args.scheduler is not None:
        raise ValueError("--workers sizes the local Dask cluster; a --scheduler's cluster has its own workers: "
                         "give one of them")
    from ..paper.specs import dataset_spec

    spec = dataset_spec(args.name)
    t0 = time.perf_counter()
    written = datasets.build_dataset_files(spec, args.out, samples=args.samples, test_samples=args.test_samples,
                                           test_only=args.test, progress=not args.quiet, workers=args.workers,
                                           scheduler=args.scheduler, connect_timeout=args.connect_timeout)
    if not args.quiet:
        for path in written:
            print(f"{path} ({time.perf_counter() - t0:.1f} s)")
    return 0


def _run_data_list(args) -> int:
    from ..paper.specs import DATASET_SPECS

    for name, s in DATASET_SPECS.items():
        print(f"{name:22s} {s.family:16s} {s.scope} nodes={s.n_nodes:5d} features={s.n_features:3d} "
              f"samples={s.samples} fixed={s.fixed} method={s.method}"
              + ("" if s.collision is None else " collision-free"))
    return 0


def _run_data_audit(args) -> int:
    import json

    from ..datasets import audit_table
    from ..paper.specs import audit_specs

    specs = [_paper_spec(n) for n in args.names] or audit_specs()
    rows = audit_table(specs, n_arms=args.arms, seed=args.seed, progress=True)
    print(json.dumps(rows, indent=1))
    return 0


# ---------------------------------------------------------------------------------- wsmap robots
def add_robots_parser(sub):
    r = sub.add_parser("robots", help="list the named arms", description="The arms `--robot NAME` knows, "
                       "with their joints, limits and the document their numbers come from.")
    r.set_defaults(run=_run_robots)


def _run_robots(args) -> int:
    from .. import robots

    for name in robots.ROBOTS:
        arm = robots.load(name)
        kinds = "".join(getattr(arm, "kinds", ("R",) * arm.n))
        limits = "no limits" if arm.qlim is None else "joint limits"
        print(f"{name:8s} {arm.n} joints ({kinds}), {limits}; {robots.SOURCES[name]}")
    return 0


# ----------------------------------------------------------------------------------- wsmap paper
