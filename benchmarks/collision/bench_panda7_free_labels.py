"""Time per arm of the ``panda7_tooldown_free`` labels (collision-free) beside ``panda7_tooldown``'s.

For the first ``--arms`` arms (default 8) of `wsmap.paper.specs.PANDA7_TOOLDOWN_FREE` (25³ =
15,625 tool-down nodes, the numerical map search), one numba thread, after a warm-up arm:

* ``chain``: ``labels_for`` of `wsmap.paper.specs.PANDA7_TOOLDOWN` (the same arms), per arm;
* ``free``: ``labels_for`` of the collision spec, per arm, split into the checker's construction
  (capsules on the arm's chain, its allowed-collision matrix of 10000 samples) and the map;
* the labels: chain and free reachable nodes, free nodes the chain labels lack (the subset check).

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/collision/bench_panda7_free_labels.py --arms 8
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> None:
    p = harness.parser(__doc__)
    p.add_argument("--arms", type=int, default=8)
    args = p.parse_args(argv)

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
        chain_s, chain = harness.timed(lambda: datasets.labels_for(arm, chain_spec)[0])  # noqa: B023
        free_s, free = harness.timed(lambda: datasets.labels_for(arm, free_spec)[0])  # noqa: B023
        checker_s, _ = harness.timed(lambda: free_spec.collision.checker(robots.family_arm("panda7", scales[b])))  # noqa: B023
        row = dict(arm=b, chain_nodes=int(chain.sum()), free_nodes=int(free.sum()),
                   free_not_in_chain=int((free & ~chain).sum()), chain_s=round(chain_s, 3), free_s=round(free_s, 3),
                   checker_s=round(checker_s, 3))
        rows.append(row)
        print(row, flush=True)
    mean = {k: round(float(np.mean([r[k] for r in rows])), 3) for k in ("chain_s", "free_s", "checker_s")}
    print(f"mean seconds per arm: chain {mean['chain_s']}, free {mean['free_s']} (of which the checker "
          f"{mean['checker_s']}); free / chain nodes {sum(r['free_nodes'] for r in rows) / sum(r['chain_nodes'] for r in rows):.3f}; "
          f"free nodes outside the chain labels: {sum(r['free_not_in_chain'] for r in rows)}")
    harness.write_json(args, {"rows": rows, "mean": mean})


if __name__ == "__main__":
    main()
