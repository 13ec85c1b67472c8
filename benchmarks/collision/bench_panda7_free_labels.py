"""Time per arm of the ``panda7_tooldown_free`` labels (collision-free) beside ``panda7_tooldown``'s.

For the first ``--arms`` arms (default 8) of :data:`wsmap.paper.specs.PANDA7_TOOLDOWN_FREE` (25³ =
15,625 tool-down nodes, the numerical map search), one numba thread, after a warm-up arm:

* ``chain``: ``labels_for`` of :data:`~wsmap.paper.specs.PANDA7_TOOLDOWN` (the same arms), per arm;
* ``free``: ``labels_for`` of the collision spec, per arm, split into the checker's construction
  (capsules on the arm's chain, its allowed-collision matrix of 10000 samples) and the map;
* the labels: chain and free reachable nodes, free nodes the chain labels lack (the subset check).

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/bench_panda7_free_labels.py --arms 8
"""

from __future__ import annotations

import argparse
import json
import time


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--arms", type=int, default=8)
    p.add_argument("--json", help="write the rows here")
    args = p.parse_args()

    import numpy as np

    from wsmap import datasets, robots
    from wsmap.kinematics import lm_compiled
    from wsmap.paper.specs import PANDA7_TOOLDOWN, PANDA7_TOOLDOWN_FREE

    lm_compiled.set_threads(1)
    free_spec = datasets.scaled(PANDA7_TOOLDOWN_FREE, args.arms + 1)
    chain_spec = datasets.scaled(PANDA7_TOOLDOWN, args.arms + 1)
    scales = datasets.draw_scales(free_spec)
    datasets.labels_for(scales[-1:], free_spec)  # warm-up: numba cache loads, coal, trimesh imports
    datasets.labels_for(scales[-1:], chain_spec)
    rows = []
    for b in range(args.arms):
        arm = scales[b : b + 1]
        t0 = time.perf_counter()
        chain = datasets.labels_for(arm, chain_spec)[0]
        t1 = time.perf_counter()
        free = datasets.labels_for(arm, free_spec)[0]
        t2 = time.perf_counter()
        free_spec.collision.checker(robots.family_arm("panda7", scales[b]))
        t3 = time.perf_counter()
        row = dict(arm=b, chain_nodes=int(chain.sum()), free_nodes=int(free.sum()),
                   free_not_in_chain=int((free & ~chain).sum()), chain_s=round(t1 - t0, 3), free_s=round(t2 - t1, 3),
                   checker_s=round(t3 - t2, 3))
        rows.append(row)
        print(row, flush=True)
    mean = {k: round(float(np.mean([r[k] for r in rows])), 3) for k in ("chain_s", "free_s", "checker_s")}
    print(f"mean seconds per arm: chain {mean['chain_s']}, free {mean['free_s']} (of which the checker "
          f"{mean['checker_s']}); free / chain nodes {sum(r['free_nodes'] for r in rows) / sum(r['chain_nodes'] for r in rows):.3f}; "
          f"free nodes outside the chain labels: {sum(r['free_not_in_chain'] for r in rows)}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows, "mean": mean}, f, indent=1)


if __name__ == "__main__":
    main()
