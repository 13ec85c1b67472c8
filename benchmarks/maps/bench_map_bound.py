"""The joint-limit bound of the map search (``map_search(..., limit_bound=True)``, the default) against the
reference path without it (``limit_bound=False``), side by side in one process.

Per arm, the default numerical tool-down map (``MAP_SETTINGS``, border search on, rpy (pi, 0, 0),
"standard" convention) on the grid of ``ws.cartesian_grid(-1, 1, 0.1)`` (21³ = 9261 nodes) for the
named arms, and on a 21³ cube around the first joint (half-width the links' length) for the URDF
arm: on and off alternating, best of ``--repeats``; reachable counts and solutions compared (they
must be identical: the bound is a proof of unreachability); LM iterations, which do not depend on
the load. Also the bound's build time (once per arm and process, memoised) and the map with the
bound on 1 and 2 kernel threads (alternating, best of ``--repeats``).

    NUMBA_NUM_THREADS=2 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/maps/bench_map_bound.py --json bench/map_bound.json

(``NUMBA_NUM_THREADS`` at least 2 for the thread rows; the on/off rows run on one thread.)
``--index``: also the Panda's reachability index (``INDEX_SETTINGS``, ``--index-step`` 0.05 m over
[-0.95, 0.95]³, 50 orientations), with the bound and without (``ik={"limit_bound": False}``), on one
thread, each once (alternating ``--index-repeats`` times), its bits compared.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

from wsmap import robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain, lm_compiled
from wsmap.kinematics.ik import reach_filter
from wsmap.kinematics.ik.search import MAP_SETTINGS, map_search
from wsmap.kinematics.ik.solution import IKReason

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def urdf_arm():
    """YuMi's right arm from rtbdata's URDF (the border search's test arm), or None without rtbdata."""
    try:
        import rtbdata
    except ImportError:
        return None
    path = os.path.join(os.path.dirname(rtbdata.__file__), "xacro/yumi_description/urdf/yumi.urdf")
    return robots.from_urdf(path, base_link="yumi_body", ee_link="yumi_link_7_r")


def cube(chain, k=21):
    frames, tool = chain.joint_frames(np.zeros(chain.n))
    pts = np.concatenate([frames[:, :3, 3], tool[None, :3, 3]])
    R = float(np.linalg.norm(np.diff(pts, axis=0), axis=-1).sum())
    axes = [np.linspace(pts[0, i] - R, pts[0, i] + R, k) for i in range(3)]
    return np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=-1)



def bench_arm(label, arm, nodes, repeats):
    chain = as_chain(arm)
    nb = ws.node_neighbours(nodes)
    T = ws.target_poses(nodes, (math.pi, 0.0, 0.0), "standard")
    reach_filter._LIMIT_BOUNDS.items.clear()
    t_build, b = harness.timed(lambda: reach_filter.limit_bounds(chain))
    lm_compiled.set_threads(1)
    map_search(arm, T, nb, **MAP_SETTINGS)  # warm
    times = {True: [], False: []}
    res = {}
    for _ in range(repeats):
        for on in (True, False):
            t, res[on] = harness.timed(lambda: map_search(arm, T, nb, **MAP_SETTINGS, limit_bound=on))  # noqa: B023
            times[on].append(t)
    on, off = res[True], res[False]
    same = bool(np.array_equal(on.success, off.success) and np.array_equal(on.q[on.success], off.q[off.success]))
    threads = {}
    if lm_compiled.set_threads(2) >= 2:
        t = {1: [], 2: []}
        for _ in range(repeats):
            for k in (1, 2):
                lm_compiled.set_threads(k)
                t[k].append(harness.timed(lambda: map_search(arm, T, nb, **MAP_SETTINGS))[0])
        threads = {"seconds_1_thread": min(t[1]), "seconds_2_threads": min(t[2])}
    lm_compiled.set_threads(1)
    row = dict(arm=label, nodes=len(nodes), reachable_on=int(on.success.sum()), reachable_off=int(off.success.sum()),
               identical=same, seconds_on=min(times[True]), seconds_off=min(times[False]),
               iterations_on=int(on.iterations.sum()), iterations_off=int(off.iterations.sum()),
               proven_out_on=int((on.reason == IKReason.OUT_OF_REACH).sum()),
               proven_out_off=int((off.reason == IKReason.OUT_OF_REACH).sum()),
               bound_build_seconds=t_build, bound=None if b is None else dict(lo=b["lo"].tolist(), hi=b["hi"].tolist()),
               **threads)
    print(f"{label}: on {row['seconds_on']:.3f} s, off {row['seconds_off']:.3f} s "
          f"({row['seconds_off'] / row['seconds_on']:.2f}x); iterations {row['iterations_on']:,} / "
          f"{row['iterations_off']:,}; proven out {row['proven_out_on']} / {row['proven_out_off']}; reachable {row['reachable_on']} / {row['reachable_off']}, identical {same}; "
          f"bound built in {t_build:.2f} s"
          + (f"; 1 thread {threads['seconds_1_thread']:.3f} s, 2 threads {threads['seconds_2_threads']:.3f} s "
             f"({threads['seconds_1_thread'] / threads['seconds_2_threads']:.2f}x)" if threads else ""),
          file=sys.stderr, flush=True)
    return row


def bench_index(step, k, repeats):
    from wsmap.workspace import orientation_samples, reachability_index

    panda = robots.load("panda")
    nodes = ws.cartesian_grid(-0.95, 0.95, step)
    R = orientation_samples(k)
    lm_compiled.set_threads(1)
    reachability_index(panda, nodes[:64], R[:4])  # compiled, caches and the bound filled
    times = {True: [], False: []}
    bits = {}
    for _ in range(repeats):
        for on in (True, False):
            t, (_, bits[on]) = harness.timed(
                lambda: reachability_index(panda, nodes, R, return_bits=True, ik={"limit_bound": on}))  # noqa: B023
            times[on].append(t)
    row = dict(nodes=len(nodes), orientations=k, step=step, seconds_on=min(times[True]), seconds_off=min(times[False]),
               reachable_poses_on=int(bits[True].sum()), reachable_poses_off=int(bits[False].sum()),
               identical=bool(np.array_equal(bits[True], bits[False])))
    print(f"Panda index, {step} m x {k} orientations ({len(nodes)} nodes): on {row['seconds_on']:.1f} s, off "
          f"{row['seconds_off']:.1f} s ({row['seconds_off'] / row['seconds_on']:.2f}x); reachable poses "
          f"{row['reachable_poses_on']} / {row['reachable_poses_off']}, identical {row['identical']}",
          file=sys.stderr, flush=True)
    return row


def main(argv=None):
    p = harness.parser(__doc__, repeat=5, repeat_help="timed maps with the bound on and off, interleaved; best kept "
                                                      "(default 5)")
    p.add_argument("--index", action="store_true", help="also the Panda's reachability index on and off")
    p.add_argument("--index-step", type=float, default=0.05)
    p.add_argument("--index-orientations", type=int, default=50)
    p.add_argument("--index-repeats", type=int, default=1)
    p.add_argument("--no-maps", action="store_true", help="only the index")
    args = p.parse_args(argv)
    grid = ws.cartesian_grid(-1, 1, 0.1)
    arms = [("Panda (wsmap.robots.load)", robots.load("panda"), grid),
            ("iiwa14 (wsmap.robots.load)", robots.load("iiwa14"), grid)]
    yumi = urdf_arm()
    if yumi is not None:
        arms.append(("YuMi right arm (rtbdata URDF)", yumi, cube(as_chain(yumi))))
    rows = [] if args.no_maps else [bench_arm(label, arm, nodes, args.repeat) for label, arm, nodes in arms]
    if args.index:
        rows.append(dict(arm="Panda index", **bench_index(args.index_step, args.index_orientations, args.index_repeats)))
    if not all(r["identical"] for r in rows):
        print("MAPS DIFFER with and without the bound", file=sys.stderr)
    if args.json:
        os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    harness.write_json(args, dict(load_average=os.getloadavg(), rows=rows))
    return 0 if all(r["identical"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
