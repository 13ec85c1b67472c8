"""Two threads against one: the lane kernel alone (the machine's ceiling) and the work around it
(single-start IK, the Panda tool-down map, the Panda index), each variant of the code in a process
of its own, the variants interleaved round by round, best of ``--repeat`` calls per round and the
best over ``--rounds`` rounds; ``uptime``'s load average beside every round (the machine is shared).

Measures (the Panda, ``wsmap.load("panda")``):

* ``kernel``: one call of the extension (``wsmap.kinematics._lanes.run_targets``) on ``--poses``
  single-start poses (forward kinematics of uniform joint values inside the limits, one start at
  the middle of the limits), no Python between the threads: the extension's own threads
  (``threads=``), and, beside them, two Python threads calling it at once with one counter (how
  builds before ``threads=`` ran). Its process CPU time too: solves per CPU-second, 2 threads
  against 1, is what the hardware gives each thread when both run (shared L3, memory, clock),
  whatever the scheduler does; the wall ratio also counts the cores that other processes held.
* ``ik``: ``ikine_search(panda, T, starts=1, q0=mid)`` on 2000 of those poses (``bench_peers.py``'s section 1).
* ``map``: the tool-down map, 21³ nodes, ``constant_orientation_map(method="numerical")``.
* ``index`` (``--index``): the reachability index, 5 cm x 50 orientations (59,319 nodes).

``--other SO`` adds another build of the extension (``_lanes*.so``, e.g. built with cmake from an
earlier commit into a folder of its own), ``--other-src DIR`` another source tree of the package
(``DIR/wsmap``, e.g. ``git archive`` of an earlier commit's ``src``): the variant "other" runs
the same measures on them, so that old and new code are timed side by side in one run (a build
without ``threads=`` runs its blocks on Python threads, as it did).

    NUMBA_NUM_THREADS=2 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/kernel/bench_threads.py --json bench/threads.json
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

MEASURES = ("kernel", "ik", "map", "index")


def main(argv=None) -> int:
    ap = harness.parser(__doc__, repeat=5, repeat_help="timed calls per measure, thread count and round, best kept "
                                                       "(default 5; the index: 1)")
    ap.add_argument("--rounds", type=harness.positive_int, default=3, help="rounds over the variants (default 3)")
    ap.add_argument("--poses", type=harness.positive_int, default=20000,
                    help="poses of the kernel measure's one call (default 20000)")
    ap.add_argument("--index", action="store_true", help="also the index, 5 cm x 50 orientations (about 10 s a call)")
    ap.add_argument("--other", metavar="SO", help="another build of wsmap.kinematics._lanes, timed as variant 'other'")
    ap.add_argument("--other-src", metavar="DIR", help="another source tree of the package (DIR/wsmap) for 'other'")
    ap.add_argument("--worker", help=argparse_hidden())
    args = ap.parse_args(argv)
    if args.worker:
        return worker(json.loads(args.worker))
    for name, path, kind in (("--other", args.other, "file"), ("--other-src", args.other_src, "dir")):
        if path and not (Path(path).is_file() if kind == "file" else (Path(path) / "wsmap").is_dir()):
            ap.error(f"{name}: no such {'file' if kind == 'file' else 'package folder'} {path}"
                     f"{'' if kind == 'file' else '/wsmap'}")
    if args.json:
        from wsmap.io import check_output_path

        check_output_path(args.json, "--json")
    measures = [m for m in MEASURES if m != "index" or args.index]
    variants = {"installed": {"so": None, "src": None}}
    if args.other or args.other_src:
        variants["other"] = {"so": args.other, "src": args.other_src}
    rounds = {v: [] for v in variants}
    for r in range(args.rounds):
        for v, where in variants.items():
            job = dict(where, measures=measures, repeat=args.repeat, poses=args.poses)
            p = subprocess.run([sys.executable, __file__, "--worker", json.dumps(job)], capture_output=True, text=True)
            if p.returncode:
                sys.stderr.write(p.stderr[-3000:])
                return 1
            got = json.loads(p.stdout.strip().splitlines()[-1])
            rounds[v].append(got)
            print(f"round {r}, {v}: load average {got['load_before'][0]:.2f} before, {got['load_after'][0]:.2f} after; "
                  + ", ".join(f"{k} {t['seconds'] * 1e3:.1f} ms" for k, t in got["times"].items()), flush=True)
    out = {"variants": variants, "rounds": rounds, "rows": []}
    print("\n| variant | measure | 1 thread | 2 threads | 2 / 1 | per CPU-second, 2 / 1 | load average |")
    print("|---|---|---:|---:|---:|---:|---|")
    for v in variants:
        loads = [x for g in rounds[v] for x in (g["load_before"][0], g["load_after"][0])]
        for key in rounds[v][0]["times"]:
            if not key.endswith("@1"):
                continue
            m = key[:-2]
            for two in (m + "@2", m + "@py2"):
                if two not in rounds[v][0]["times"]:
                    continue
                best = {k: min(g["times"][k]["seconds"] for g in rounds[v]) for k in (key, two)}
                cpu = {k: min(g["times"][k]["cpu_seconds"] for g in rounds[v]) for k in (key, two)}
                unit, scale = ("solves/s", rounds[v][0]["times"][key]["items"]) if m in ("kernel", "ik") else ("s", None)
                fmt = (lambda s: f"{scale / s:,.0f} solves/s") if scale else (lambda s: f"{s:.3f} s")  # noqa: E731
                row = {"variant": v, "measure": m if two.endswith("@2") else m + ", two Python threads",
                       "seconds_1": best[key], "seconds_2": best[two], "ratio": best[key] / best[two],
                       "cpu_ratio": cpu[key] / cpu[two], "unit": unit, "load_average": [min(loads), max(loads)]}
                out["rows"].append(row)
                print(f"| {v} | {row['measure']} | {fmt(best[key])} | {fmt(best[two])} | {row['ratio']:.2f}x | "
                      f"{row['cpu_ratio']:.2f}x | {min(loads):.1f}-{max(loads):.1f} |")
    harness.write_json(args, out)
    return 0


def argparse_hidden():
    import argparse

    return argparse.SUPPRESS


def worker(job) -> int:
    """One variant's measures in this process: `job` {"so", "src", "measures", "repeat", "poses"};
    prints one JSON line {"times": {"MEASURE@THREADS": {"seconds", "cpu_seconds", "items"}}, ...}."""
    import importlib.util

    if job["src"]:  # the other tree before the installed one (the editable install's finder goes first)
        sys.meta_path[:] = [f for f in sys.meta_path if "ScikitBuild" not in type(f).__name__]
        sys.path.insert(0, str(Path(job["src"]).resolve()))
        for name in [k for k in sys.modules if k == "wsmap" or k.startswith("wsmap.")]:  # the harness's import
            del sys.modules[name]
    if job["so"]:  # the other build under the extension's own name, before wsmap imports it
        spec = importlib.util.spec_from_file_location("wsmap.kinematics._lanes", job["so"])
        mod = importlib.util.module_from_spec(spec)
        sys.modules["wsmap.kinematics._lanes"] = mod
        spec.loader.exec_module(mod)
    load_before = os.getloadavg()
    import numpy as np

    import wsmap
    from wsmap import robots
    from wsmap import workspace as ws
    from wsmap.kinematics import ikine_search, lm_compiled, lm_lanes
    from wsmap.kinematics.ik.kernel import arm_arrays, pose_keys, unsolved
    from wsmap.kinematics.lm_compiled import Answers, KernelCall, Targets, lm_settings

    if job["src"] and not Path(wsmap.__file__).resolve().is_relative_to(Path(job["src"]).resolve()):
        raise SystemExit(f"--other-src: wsmap was imported from {wsmap.__file__}")
    ext = lm_lanes._lanes
    panda = robots.load("panda")
    lim = np.array(panda.limits)
    mid = lim.mean(axis=1)
    T = np.array(panda.fkine(np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], size=(job["poses"], panda.n))))
    aa = arm_arrays(panda)
    nodes = ws.cartesian_grid(-1, 1, 0.1)
    inodes, R = ws.cartesian_grid(-0.95, 0.95, 0.05), ws.orientation_samples(50)

    def kernel_call(threads, python_threads=False):
        P = len(T)
        settings = lm_settings(mode=0, k_first=1, k_last=1, ilimit=100, rlimit=20, tol=1e-10, lam0=0.1, gtol=0.0,
                               confirm_tol=1e-8, free_pass=True)
        targets = Targets(arm=np.zeros(P, dtype=np.int64), Rt=np.ascontiguousarray(T[:, :3, :3]),
                          pt=np.ascontiguousarray(T[:, :3, 3]), keys=pose_keys(0, T),
                          qexp=np.ascontiguousarray(np.broadcast_to(mid, (P, 1, panda.n))), nexp=np.ones(P, dtype=np.int64))
        call, counter = KernelCall(targets, aa, settings, Answers(*unsolved(P, panda.n))), np.zeros(1, dtype=np.int64)
        if python_threads:
            lm_compiled.on_threads(threads, lambda: ext.run_targets(call, counter, lm_lanes.LANES, "auto"))
        else:
            ext.run_targets(call, counter, lm_lanes.LANES, "auto", threads)
        return call.out.ok

    work = {
        "kernel": (lambda th: kernel_call(th), len(T)),
        "kernel_py": (lambda th: kernel_call(th, python_threads=True), len(T)),
        "ik": (lambda th: ikine_search(panda, T[:2000], starts=1, q0=mid), min(2000, len(T))),
        "map": (lambda th: ws.constant_orientation_map(panda, nodes, (np.pi, 0, 0), method="numerical",
                                                       convention="standard"), len(nodes)),
        "index": (lambda th: ws.reachability_index(panda, inodes, R), len(inodes) * len(R)),
    }
    times = {}
    for m in job["measures"]:
        plan = [(m, "@1", 1), (m, "@2", 2)]
        if m == "kernel":
            plan = ([(m, "@1", 1), (m, "@2", 2)] if getattr(ext, "THREADS", False) else []) + \
                   [("kernel_py", "@py2", 2)] + ([] if getattr(ext, "THREADS", False) else [("kernel_py", "@1", 1)])
        for name, tag, th in plan:
            fn, items = work[name]
            lm_compiled.set_threads(th)
            fn(th)  # warm-up: compile or load the kernels, build the memos
            best = None
            for _ in range(1 if m == "index" else job["repeat"]):
                with harness.Stopwatch() as watch:
                    fn(th)
                t, c = watch.seconds, watch.cpu_seconds
                if best is None or t < best[0]:
                    best = (t, c)
            times[m + tag] = {"seconds": best[0], "cpu_seconds": best[1], "items": items}
    print(json.dumps({"times": times, "load_before": load_before, "load_after": os.getloadavg(),
                      "threads_inside": bool(getattr(ext, "THREADS", False))}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
