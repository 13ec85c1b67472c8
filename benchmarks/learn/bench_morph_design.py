"""Design across morphologies (issue 28, item 6): the shortest 6R arm of any twist pattern whose
tool-down map covers a box of task positions, three ways side by side in one run
(`wsmap.morph_design.compare_morph_designs`):

* ``gradient``: one batched augmented-Lagrangian descent through the morphology model over every
  twist pattern (243 for 6 joints, ``--starts`` starts each), the ``verify_top`` shortest designs
  the model says cover every task checked with the classical map each round;
* ``cmaes`` and ``random``: searches of the lengths and the twist codes together whose objective
  calls the classical map at the tasks; they stop at a verified design within ``--length-tol`` of
  the gradient's length, or after ``--max-calls`` arms / ``--max-seconds``.

The classical map is each task solved on its own with `wsmap.reachable`'s search (32
starts, every success confirmed by forward kinematics in the limits). Each verified answer is
checked again here with 128 starts of another seed. Beside them, the named 6-joint arms that cover
the same tasks and their total link lengths (``sum |a| + |d|`` of their modified-DH tables).

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_morph_design.py \\
        --model models/morph.pt --json bench/morph_design.json
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def _check(arm, tasks):
    """Per task: reachable() at tool down with 128 starts of another seed than the verification's."""
    import wsmap

    T = np.stack([wsmap.transl(p) for p in tasks])
    T[:, :3, :3] = wsmap.rpy2r((math.pi, 0, 0))
    return wsmap.reachable(arm, T, starts=128, seed=11)


def _named_lengths(tasks):
    import wsmap
    from wsmap.kinematics.morphology import describe

    rows = []
    for name in ("puma560", "ur5e", "ur10e", "gen3"):
        arm = wsmap.load(name)
        if arm.n != 6:
            continue
        m = describe(arm)
        ok = _check(arm, tasks)
        rows.append({"arm": name, "covered": f"{int(ok.sum())}/{len(ok)}",
                     "total_length_m": float(np.abs(m.mdh[:, 0]).sum() + np.abs(m.mdh[:, 2]).sum()
                                             + np.linalg.norm(m.tool[:3, 3]))})
    return rows


def main(argv=None):
    from wsmap import paths

    ap = harness.parser(__doc__, seed=0, seed_help="seed of the searches (default 0)")
    ap.add_argument("--model", default=str(paths.ROOT / "models" / "morph.pt"),
                    help="a morphology model (default models/morph.pt, from dvc repro morphologies)")
    ap.add_argument("--centre", type=float, nargs=3, default=(0.45, 0.0, 0.2), help="task box centre (m)")
    ap.add_argument("--size", type=float, default=0.3, help="task box edge (m)")
    ap.add_argument("--screen", type=int, default=64, help="model draws per twist pattern in the screen")
    ap.add_argument("--keep", type=int, default=64, help="twist patterns kept after the screen")
    ap.add_argument("--starts", type=int, default=2, help="gradient starts per kept pattern")
    ap.add_argument("--steps", type=int, default=300, help="descent steps per round")
    ap.add_argument("--verify-top", type=int, default=16)
    ap.add_argument("--length-tol", type=float, default=0.02)
    ap.add_argument("--max-calls", type=int, default=3000)
    ap.add_argument("--max-seconds", type=float, default=300.0)
    a = ap.parse_args(argv)

    import torch

    from wsmap import design
    from wsmap import morph_design as md
    from wsmap.learn.files import ModelFileError
    from wsmap.learn.morph_model import load_morph_model

    torch.set_num_threads(1)
    try:
        model, _ = load_morph_model(a.model)
    except (FileNotFoundError, ModelFileError) as e:
        sys.exit(f"bench_morph_design: {e}")
    tasks = design.box_tasks(a.centre, a.size)
    space = md.MorphDesignSpace()
    seconds, (rows, results) = harness.timed(lambda: md.compare_morph_designs(
        model, tasks, space, length_tol=a.length_tol, max_calls=a.max_calls, max_seconds=a.max_seconds,
        gradient={"screen": a.screen, "keep": a.keep, "starts_per_pattern": a.starts, "steps": a.steps,
                  "verify_top": a.verify_top}, seed=a.seed))
    print(f"# design across morphologies: {len(tasks)} tasks, box {a.size} m at {list(a.centre)} m, tool down; "
          f"{seconds:.1f} s in all\n")
    print(design.format_design_table(rows), end="")
    out = {"tasks": tasks.tolist(), "seconds": seconds, "rows": rows, "designs": {}}
    for name, r in results.items():
        table = space.tables(r.params)[0]
        again = _check(space.arms(r.params[None])[0], tasks)
        print(f"\n{name}: total length {r.total_length:.3f} m, verified {r.verified}, 128-start check "
              f"{int(again.sum())}/{len(again)}; modified DH (a, alpha, d):")
        for i, (aa, al, d, _) in enumerate(table, 1):
            print(f"  joint {i}: a = {aa:.3f} m, alpha = {math.degrees(al):+.0f} deg, d = {d:.3f} m")
        out["designs"][name] = {"table": table.tolist(), "check_128": f"{int(again.sum())}/{len(again)}"}
    named = _named_lengths(tasks)
    print("\nnamed 6-joint arms on the same tasks (128 starts):")
    for r in named:
        print(f"  {r['arm']}: covers {r['covered']}, total length {r['total_length_m']:.3f} m")
    out["named"] = named
    harness.write_json(a, out)


if __name__ == "__main__":
    main()
