"""Chains with coupled joints (URDF mimic, MJCF joint equality): the coupled kernel (``wsmap.kinematics.lm_coupled``)
against the uncoupled kernels on the same arm, side by side in one process.

Two rows. (1) The PUMA 560 as a chain, the numerical tool-down map (``MAP_SETTINGS``, rpy (pi, 0, 0), "standard")
on ``ws.cartesian_grid(-0.8, 0.8, 0.1)`` (17³ = 4913 nodes) three ways, interleaved, best of ``--repeats``: on the
lane kernel and on the scalar numba kernel (uncoupled, as every arm maps), and coupled by the identity
(``SerialChain.couple(range(6))``: the same arm through the coupled kernel); the reachable sets compared (the
same arithmetic as the scalar kernel, so the same nodes). (2) A palletiser (a parallelogram joint following
the shoulder at -1, a half-rate wrist turn, six variables on eight joints), its tool-down map on
``ws.cartesian_grid(-1, 1, 0.1)``, and the map of its relaxation (each joint free in its own limits, eight
variables; lane kernel), whose reach holds the coupled arm's.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_coupled.py --json bench/coupled.json
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain, lm_lanes
from wsmap.kinematics.urdf import from_urdf

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

#: j3 follows j2 at -1 (the parallelogram), j5 turns at half j1's rate; a two-joint wrist after the tool link (the
#: arm tests/kinematics/test_urdf_coupled.py checks against Pinocchio and yourdfpy)
PALLETISER = (Path(__file__).resolve().parents[2] / "tests" / "data" / "palletiser_wrist.urdf").read_text()


def tool_down(chain, nodes):
    return ws.constant_orientation_map(chain, nodes, rpy=(np.pi, 0, 0), convention="standard", method="numerical")


def puma_row(repeat):
    arm = as_chain(robots.load("puma560"))
    same = arm.couple(np.arange(arm.n))
    nodes = ws.cartesian_grid(-0.8, 0.8, 0.1)
    ways = {"lanes": (arm, "lanes"), "scalar": (arm, "scalar"), "coupled": (same, "scalar")}
    best = {k: np.inf for k in ways}
    reach = {}
    for k, (chain, kernel) in ways.items():  # warm: compile or load each kernel once
        with lm_lanes.use_kernel(kernel if lm_lanes.available() or kernel == "scalar" else "scalar"):
            tool_down(chain, nodes)
    for _ in range(repeat):
        for k, (chain, kernel) in ways.items():
            with lm_lanes.use_kernel(kernel if lm_lanes.available() or kernel == "scalar" else "scalar"):
                t, reach[k] = harness.timed(lambda: tool_down(chain, nodes))  # noqa: B023
            best[k] = min(best[k], t)
    same_nodes = bool(np.array_equal(reach["coupled"], reach["scalar"]))
    return {"arm": "puma560", "nodes": len(nodes), "reachable": {k: int(v.sum()) for k, v in reach.items()},
            "seconds": best, "coupled_over_scalar": best["coupled"] / best["scalar"], "same_nodes": same_nodes}


def palletiser_row(repeat):
    chain = from_urdf(PALLETISER, ee_link="w2")
    free = chain.uncoupled()
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.1)
    tool_down(chain, nodes)
    tool_down(free, nodes)
    t_c, reach_c = harness.best_of(lambda: tool_down(chain, nodes), repeat)
    t_f, reach_f = harness.best_of(lambda: tool_down(free, nodes), repeat)
    return {"arm": "palletiser", "variables": chain.n, "joints": chain.n_joints, "nodes": len(nodes),
            "reachable": int(reach_c.sum()), "relaxation_reachable": int(reach_f.sum()),
            "inside_relaxation": bool(np.all(reach_f[reach_c])), "seconds": t_c, "relaxation_seconds": t_f}


def main(argv=None):
    p = harness.parser(__doc__, repeat=3, repeat_help="timed maps per way, interleaved; best kept (default 3)")
    args = p.parse_args(argv)
    rows = [puma_row(args.repeat), palletiser_row(args.repeat)]
    for r in rows:
        print(r)
    harness.write_json(args, rows)


if __name__ == "__main__":
    main()
