"""Design by gradient (issue 14, part 5): when does the surrogate pay? Both families side by side.

For a 0.4 m box of task positions (8 corners + 12 edge midpoints, `wsmap.design.box_tasks`)
in front of the base, find the arm of the family with the smallest total link length that reaches
every task at the task orientation, three ways in one run (`wsmap.design.compare_designs`):

* ``gradient``: augmented-Lagrangian Adam through a map model, each candidate verified by the
  classical map at the tasks;
* ``cmaes`` and ``random``: gradient-free searches whose objective calls the classical map at the
  tasks directly; they stop at a verified design within ``--length-tol`` of the gradient's total
  length, or after ``--max-calls`` arms / ``--max-seconds``.

Families:

1. **spherical wrist** (the paper's: a2, a3, d3, d4 in [0, 0.5] m), model ``--sw-model`` (default
   ``models/improved_model.pt``, the whole 21³ grid, logits; the paper's orientation (0, 0, 0), which
   for this family with unlimited joints gives the same map as tool-down); the classical map is
   the closed form: instant.
2. **panda7** (six scales in [0.7, 1.3]), tool-down (rpy = (pi, 0, 0), standard convention), model
   ``--model`` (a ``panda7_tooldown`` model). Without one the gradient-free searches run alone
   (no length goal, to their budget), which times the classical side of the comparison.

The compiled kernels are compiled (or loaded) before the timings. Times are wall-clock seconds on
one thread (torch and the compiled IK)::

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_design.py --json bench/design.json
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_design.py --model models/panda7_map.pt
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_design.py --model models/panda7_map.pt --tasks region

With ``--tasks region`` the tasks are every point of the box on a ``--task-step`` grid (125 at the
defaults): a region to cover, where each classical call solves IK at every one of them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def _print_rows(title, rows, design, extra=""):
    print(f"\n## {title}\n")
    print(design.format_design_table(rows), end="")
    for r in rows:
        print(f"  {r['method']}: params {r['params']}")
    if extra:
        print(extra)


def _options():
    """The command line: the harness's common options and this benchmark's own."""
    from wsmap import paths

    ap = harness.parser(__doc__, seed=0, seed_help="seed of the searches (default 0)")
    ap.add_argument("--model", help="a panda7_tooldown map model (.pt): runs the panda7 study with it")
    ap.add_argument("--sw-model", default=str(paths.ROOT / "models" / "improved_model.pt"),
                    help="a spherical-wrist R3 map model of the whole grid (default models/improved_model.pt)")
    ap.add_argument("--skip-sw", action="store_true", help="no spherical-wrist study")
    ap.add_argument("--skip-panda7", action="store_true", help="no panda7 rows")
    ap.add_argument("--sw-centre", type=float, nargs=3, default=(0.4, 0.0, 0.2), help="box centre, m")
    ap.add_argument("--panda7-centre", type=float, nargs=3, default=(0.5, 0.0, 0.2),
                    help="box centre, m (its bottom face on the table plane z = 0 of the base)")
    ap.add_argument("--size", type=float, default=0.4, help="box edge, m")
    ap.add_argument("--tasks", choices=("box", "region"), default="box",
                    help="box: the 8 corners and 12 edge midpoints; region: every point of the box on a grid of "
                         "--task-step (a region to cover: many tasks, so every classical call costs more)")
    ap.add_argument("--task-step", type=float, default=0.1, help="grid step of --tasks region, m")
    ap.add_argument("--length-tol", type=float, default=0.02, help="relative length goal of the searches")
    ap.add_argument("--max-calls", type=int, default=3000, help="classical calls (arms) per search")
    ap.add_argument("--max-seconds", type=float, default=120.0, help="seconds per search")
    return ap


def main(argv=None):
    ap = _options()
    args = ap.parse_args(argv)

    import torch

    from wsmap import design, learn
    from wsmap.kinematics import lm_compiled

    torch.set_num_threads(1)
    lm_compiled.set_threads(1)
    out = {"info": {"python": sys.version.split()[0], "torch": torch.__version__, "cpus": os.cpu_count(),
                    "load_average_at_start": os.getloadavg(), "command": " ".join(sys.argv),
                    "threads": 1, "length_tol": args.length_tol, "max_calls": args.max_calls,
                    "max_seconds": args.max_seconds, "seed": args.seed, "box_size_m": args.size,
                    "tasks": args.tasks, "task_step_m": args.task_step}}

    def make_tasks(centre):
        if args.tasks == "box":
            return design.box_tasks(centre, args.size)
        k = int(round(args.size / args.task_step))
        axis = np.linspace(-args.size / 2, args.size / 2, k + 1)
        grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
        return np.asarray(centre, dtype=float) + grid

    def study(name, family, centre, model_path, methods):
        tasks = make_tasks(centre)
        model = None
        if model_path is not None:
            model, _ = learn.load(model_path)
        if model is not None:
            rows, res = design.compare_designs(family, tasks, model, methods=methods, length_tol=args.length_tol,
                                               max_calls=args.max_calls, max_seconds=args.max_seconds,
                                               seed=args.seed)
        else:  # no surrogate: the searches alone, to their budget
            fam = design.design_family(family)
            fam.classical(((fam.low + fam.high) / 2)[None], tasks)  # compile / load the kernels, untimed
            res = {"cmaes": design.design_by_cmaes(family, tasks, max_calls=args.max_calls,
                                                   max_seconds=args.max_seconds, seed=args.seed),
                   "random": design.design_by_random_search(family, tasks, max_calls=args.max_calls,
                                                            max_seconds=args.max_seconds, seed=args.seed)}
            rows = [r.row() for r in res.values()]
        far = float(np.linalg.norm(tasks, axis=1).max())
        extra = ""
        if family == "spherical_wrist":
            # reach <= a2 + a3 + d3 + d4 (triangle inequality, d1 = 0), so no design is shorter
            extra = f"  lower bound (farthest task from the shoulder): {far:.4f} m"
        _print_rows(name, rows, design, extra)
        out[name] = {"family": family, "model": model_path, "centre_m": list(centre), "tasks_m": tasks,
                     "farthest_task_m": far, "rows": rows,
                     "results": {k: {"params": r.params, "total_length_m": r.total_length, "verified": r.verified,
                                     "covered": r.covered, "rounds": r.rounds, "wall_s": r.wall_time,
                                     "path_every_10": r.path[::10]}
                                 for k, r in res.items()}}

    if not args.skip_sw:
        if not os.path.exists(args.sw_model):
            ap.error(f"no spherical-wrist model at {args.sw_model}: pass --sw-model PATH (e.g. a copy of "
                     "models/improved_model.pt)")
        study("spherical_wrist", "spherical_wrist", tuple(args.sw_centre), args.sw_model,
              ("gradient", "cmaes", "random"))
    if not args.skip_panda7:
        name = "panda7" if args.model else "panda7_searches_only"
        study(name, "panda7", tuple(args.panda7_centre), args.model, ("gradient", "cmaes", "random"))
    if args.json:
        print(f"\nwrote {harness.write_json(args, out)}")


if __name__ == "__main__":
    main()
