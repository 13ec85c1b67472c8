"""Build rate of the ``panda7_tooldown`` dataset: in one process, and on Dask with 1 and 2 workers.

Builds the first ``--arms`` arms (default 20) of `wsmap.paper.specs.PANDA7_TOOLDOWN` (25³ =
15,625 tool-down nodes per arm, numerical map search) into temporary files:

* ``single``: the single-process build (this process, one numba thread);
* ``dask K cold``: ``build_dataset(..., workers=K)``, the LocalCluster started and closed by the
  build (its start, the workers' imports and numba's cache loads included);
* ``dask K warm``: ``build_dataset(..., scheduler=client)`` on a LocalCluster of K workers already
  running and warmed up by a 2-arm build (the throughput of a long build).

Every file is compared byte for byte with the single-process one. Prints arms per second.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_panda7_build.py --arms 20 --json bench/panda7_build.json
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> None:
    p = harness.parser(__doc__)
    p.add_argument("--arms", type=int, default=20)
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = p.parse_args(argv)

    from wsmap import datasets
    from wsmap.datasets.store import _dask_client
    from wsmap.kinematics import lm_compiled
    from wsmap.paper.specs import PANDA7_TOOLDOWN

    lm_compiled.set_threads(1)
    spec = datasets.scaled(PANDA7_TOOLDOWN, args.arms)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)

        def timed(label, n_workers, **kw):
            out = tmp / f"{label.replace(' ', '_')}.npz"
            dt, _ = harness.timed(lambda: datasets.build_dataset(kw.pop("spec", spec), out, progress=False, **kw))
            row = dict(build=label, workers=n_workers, arms=args.arms, seconds=round(dt, 2),
                       arms_per_s=round(args.arms / dt, 3))
            return row, out.read_bytes()

        datasets.build_dataset(datasets.scaled(PANDA7_TOOLDOWN, 1), tmp / "warmup.npz", progress=False)  # numba cache loads
        row, ref = timed("single", 0)
        rows.append(row)
        print(row, flush=True)
        for k in args.workers:
            row, raw = timed(f"dask {k} cold", k, workers=k)
            row["identical"] = raw == ref
            rows.append(row)
            print(row, flush=True)
            with _dask_client(k, None, 5.0) as client:
                datasets.build_dataset(datasets.scaled(PANDA7_TOOLDOWN, 2), tmp / "warm.npz", progress=False, scheduler=client)
                row, raw = timed(f"dask {k} warm", k, scheduler=client)
            row["identical"] = raw == ref
            rows.append(row)
            print(row, flush=True)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    harness.write_json(args, dict(rows=rows))


if __name__ == "__main__":
    main()
