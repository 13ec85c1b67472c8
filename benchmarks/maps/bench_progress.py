"""What a progress bar costs: the same maps with ``progress`` off, a counting callable and a tqdm bar.

    python benchmarks/maps/bench_progress.py [--repeats 3] [--step 0.1]

The Panda tool-down constant-orientation map (the neighbour search, which now reports per pass
and wave) and the UR5e reachability index over 20 orientations (closed form, per block of
orientations), best of ``--repeats``, side by side in one run; the maps must be identical.
"""

from __future__ import annotations

import contextlib
import io
import math
import sys
from pathlib import Path

import numpy as np

from wsmap import robots
from wsmap import workspace as ws

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None):
    ap = harness.parser(__doc__, repeat=3, repeat_help="timed maps per progress setting, best kept (default 3)")
    ap.add_argument("--step", type=float, default=0.1)
    args = ap.parse_args(argv)
    record = []
    panda, ur5e = robots.load("panda"), robots.load("ur5e")
    grid = ws.grid_spec("R3", -1, 1, args.step)
    nodes = ws.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    R = ws.orientation_samples(20, seed=0)
    cases = {
        "panda tool-down map (numerical)": lambda p: ws.grid_map(panda, grid, rpy=(math.pi, 0, 0), method="numerical",
                                                                 progress=p),
        "ur5e index, 20 orientations (exact)": lambda p: ws.reachability_index(ur5e, nodes, R, progress=p),
    }
    for case, fn in cases.items():
        fn(False)  # warm-up: compiled kernels, caches
        rows = []
        for label, progress in (("off", False), ("callable", lambda n: None), ("tqdm bar", True)):
            with contextlib.redirect_stderr(io.StringIO()):
                t, out = harness.best_of(lambda: fn(progress), args.repeat)  # noqa: B023 - called at once
            rows.append((label, t, out))
        for label, t, out in rows:
            assert np.array_equal(out, rows[0][2]), f"{case}: progress {label} changed the map"
            print(f"{case:40s} progress {label:9s} {t:8.3f} s  ({t / rows[0][1] - 1:+.1%})")
            record.append({"case": case, "progress": label, "seconds": t, "overhead": t / rows[0][1] - 1})
    harness.write_json(args, {"step": args.step, "rows": record})


if __name__ == "__main__":
    main()
