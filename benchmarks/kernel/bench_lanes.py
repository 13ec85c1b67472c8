"""The lane kernel's builds side by side: every instruction set this CPU runs times 4, 8 and 16 lanes,
beside the scalar numba kernel, on the raw single-start Panda IK of ``bench_peers.py`` (the same
2000 reachable poses, one start at the middle of the limits, tol 1e-10), one thread.

Each configuration is timed best of ``--repeats`` calls of ``ikine_search``, the configurations
interleaved round by round (``--rounds``) so that a drift of the machine's load reaches all of them;
solves per second, success rate, mean LM iterations per pose and nanoseconds per LM iteration.

``--other SO`` adds another build of the extension (``_lanes*.so`` built from another commit, for
example with cmake into a folder of its own) at every instruction set with ``lm_lanes.LANES``
lanes, timed in the same rounds as the installed one: a change of the kernel measured side by side
in one process. Its answers are checked against the installed build's (the same successes).

    NUMBA_NUM_THREADS=2 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/kernel/bench_lanes.py --json bench/lanes.json
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None):
    ap = harness.parser(__doc__, repeat=5, repeat_help="timed calls per configuration and round, best kept (default 5)")
    ap.add_argument("--poses", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--other", metavar="SO", help="another build of wsmap.kinematics._lanes to time beside the installed one")
    args = ap.parse_args(argv)
    if min(args.poses, args.rounds) < 1:
        ap.error("--poses and --rounds must be positive")
    if args.other and not Path(args.other).is_file():
        ap.error(f"--other: no such file {args.other}")
    if args.json:
        from wsmap.io import check_output_path

        check_output_path(args.json, "--json")

    from wsmap import robots
    from wsmap.kinematics import ikine_search, lm_compiled, lm_lanes

    lm_compiled.set_threads(1)
    panda = robots.load("panda")
    lim = np.array(panda.limits)
    q = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], size=(args.poses, panda.n))
    T = np.array(panda.fkine(q))
    mid = lim.mean(axis=1)
    best = lm_lanes.isa()
    isas = ["base"] + (["avx2"] if best in ("avx2", "avx512") else []) + (["avx512"] if best == "avx512" else [])
    configs = [("scalar", None, None)] + [("lanes", isa, lanes) for isa in isas for lanes in (4, 8, 16)]
    installed = lm_lanes._lanes
    builds = {"lanes": installed}
    if args.other:
        builds["other"] = load_other(args.other, lm_compiled.call_fields())
        configs += [("other", isa, lm_lanes.LANES) for isa in isas]
    run = lm_lanes.run_targets

    def solve(cfg):
        kernel, isa, lanes = cfg
        if kernel != "scalar":
            lm_lanes._lanes = builds[kernel]
            lm_lanes.run_targets = lambda *a: run(*a, lanes=lanes, isa=isa)
        try:
            with lm_lanes.use_kernel("scalar" if kernel == "scalar" else "lanes"):
                return ikine_search(panda, T, starts=1, q0=mid)
        finally:
            lm_lanes.run_targets = run
            lm_lanes._lanes = installed

    times = {c: [] for c in configs}
    sols = {c: solve(c) for c in configs}  # warm-up (and the answers)
    for c in configs:
        if c[0] == "other" and not np.array_equal(sols[c].success, sols[("lanes", c[1], c[2])].success):
            raise SystemExit(f"--other: its {c[1]} build solves other targets than the installed one")
    for _ in range(args.rounds):
        for c in configs:
            times[c].append(harness.best_of(lambda: solve(c), args.repeat)[0])  # noqa: B023 - called at once
    print(f"load average {os.getloadavg()}; this CPU's widest build: {best}\n")
    print("| kernel | build | lanes | solves/s | / scalar | success | iterations per pose | ns per iteration |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    out = {"info": {"cpus": os.cpu_count(), "isa": best, "command": " ".join(sys.argv),
                    "load_average": os.getloadavg()}, "rows": []}
    t_scalar = min(times[configs[0]])
    for c in configs:
        t, sol = min(times[c]), sols[c]
        its = float(sol.iterations.mean())
        row = {"kernel": c[0], "isa": c[1], "lanes": c[2], "seconds": t, "solves_per_s": len(T) / t,
               "vs_scalar": t_scalar / t, "success": float(sol.success.mean()), "iterations_mean": its,
               "ns_per_iteration": t / (len(T) * its) * 1e9}
        out["rows"].append(row)
        print(f"| {c[0] if c[0] != 'other' else 'lanes, --other'} | {c[1] or 'numba'} | {c[2] or 1} | {row['solves_per_s']:,.0f} | {row['vs_scalar']:.2f} | "
              f"{row['success']:.3f} | {its:.1f} | {row['ns_per_iteration']:.0f} |")
    harness.write_json(args, out)


def load_other(path, fields):
    """The extension built at `path`, loaded beside the installed one (under a name of its own; its
    init function is `PyInit__lanes`, so the module's last name must be `_lanes`)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("wsmap_other_build._lanes", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    differ = set(getattr(mod, "FIELDS", ())) ^ set(fields)
    if differ:
        raise SystemExit(f"--other: {path} was built from sources whose KernelCall fields differ by {sorted(differ)}")
    return mod


if __name__ == "__main__":
    main()
