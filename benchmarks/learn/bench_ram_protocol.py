"""RAM's evaluation protocol (wsmap.datasets.ram): wsmap's classical labels against RAM's label
definition, and RAM's FK-sampling labels against wsmap's IK labels.

Arms: RAM's random arms of 5, 6 and 7 joints (`sample_morphologies`, seeded); per arm RAM's random
poses (`random_poses`: its ball, uniform orientations) and its boundary set (`boundary_poses`:
poses along geodesics from a reachable to an unreachable pose). The reference labels are RAM's
definition computed by wsmap's search: `ik_labels` (self-collision by RAM's capsules, `--starts`
starts, 8 rounds of other first starts). F1 is RAM's: per arm, then the mean over arms.

(a) labels that differ from the reference in one respect, scored against it: no self-collision
(the kinematic reach), RAM's IK budget (10 starts, no extra rounds; RAM runs 10 random seeds),
`wsmap.reachable` as it is (`--starts` starts, no extra rounds), and the reference's recall on
the boundary set's reachable ends (FK poses of collision-free configurations: reachable by
construction).
(b) FK-sampling labels (`fk_labels`: configurations uniform over the full turn, collision-free
ones mark their SE(3) cell) at RAM's discretisation levels 1-3 and several sample budgets per
arm, scored against the reference. RAM's authors report their level-3 sampling labels at F1 0.91
against exact labels (a GPU sampling for 30-600 s per arm).
(c) with `--model FILE` (a `wsmap.learn.morph_model` file), or `--train-model DIR` (a model of
the `morphologies` stage's recipe in params.yaml, trained first into DIR: 2 x 50 arms per family
on the 0.3 m grid, 30 epochs, positives weighted 20): the tool-down morphology network on RAM's 6-
and 7-joint arms, asked in the frame of their first joint (RAM's row 0 comes before it), at
tool-down poses in RAM's ball (RAM's random poses have a uniform orientation: none of them is
tool-down), labelled by the reference. Not like for like.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_ram_protocol.py \\
        [--arms 45] [--poses 200] [--geodesics 20] [--per-geodesic 10] [--full] [--model FILE | --train-model DIR] \\
        [--json out.json]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

#: `--full`: the sizes of the documented larger run
FULL = {"arms": 150, "poses": 1000, "geodesics": 50, "per_geodesic": 20, "budgets": [10_000, 100_000, 1_000_000]}


def _options():
    p = harness.parser(__doc__, seed=0)
    p.add_argument("--arms", type=harness.positive_int, default=45, help="arms, a third of each joint count (5, 6, 7)")
    p.add_argument("--poses", type=harness.positive_int, default=200, help="random poses per arm")
    p.add_argument("--geodesics", type=harness.positive_int, default=20, help="boundary geodesics per arm")
    p.add_argument("--per-geodesic", type=int, default=10, help="poses per geodesic (at least 2)")
    p.add_argument("--starts", type=harness.positive_int, default=32, help="IK starts of the reference labels")
    p.add_argument("--budgets", type=int, nargs="+", default=[10_000, 100_000],
                   help="FK samples per arm (increasing; one stream, the labels after each)")
    p.add_argument("--levels", type=int, nargs="+", default=[1, 2, 3], help="RAM's discretisation levels (1-4)")
    p.add_argument("--model", metavar="FILE", help="a morphology model file, for (c)")
    p.add_argument("--train-model", metavar="DIR", help="(c): train a model of the stage's recipe into DIR first")
    p.add_argument("--tool-down-poses", type=harness.positive_int, default=200, help="(c): tool-down poses per arm")
    p.add_argument("--full", action="store_true", help=f"the larger run: {FULL}")
    return p


def _row(name, f, per, dofs):
    """One table row: the mean F1 over arms, the worst arm's, and the mean per joint count."""
    import numpy as np

    by = {int(d): round(float(per[dofs == d].mean()), 4) for d in np.unique(dofs)}
    return {"labels": name, "f1": round(f, 4), "f1_min": round(float(per.min()), 4), "arms": len(per), "f1_by_dof": by}


def main(argv=None) -> int:
    p = _options()
    args = p.parse_args(argv)
    if args.full:
        for k, v in FULL.items():
            setattr(args, k, v)
    if args.per_geodesic < 2:
        p.error(f"--per-geodesic must be at least 2, got {args.per_geodesic}")
    if any(b1 <= b0 for b0, b1 in zip(args.budgets, args.budgets[1:])) or min(args.budgets) < 1:
        p.error(f"--budgets must be increasing positive counts, got {args.budgets}")
    if any(v not in (1, 2, 3, 4) for v in args.levels):
        p.error(f"--levels must be among 1, 2, 3, 4, got {args.levels}")
    if args.model and args.train_model:
        p.error("give --model or --train-model, not both")
    if args.model and not Path(args.model).is_file():
        p.error(f"--model: no such file {args.model}")
    if args.train_model:
        args.model = _stage_like_model(args.train_model)

    import numpy as np

    from wsmap import datasets as ds

    per_dof = {d: args.arms // 3 + (1 if k < args.arms % 3 else 0) for k, d in enumerate(ds.RAM_DOFS)}
    morphs = [m for k, d in enumerate(ds.RAM_DOFS) if per_dof[d]
              for m in ds.sample_morphologies(per_dof[d], d, seed=args.seed + k)]
    lab, fk, reach_ends, spent = _label_arms(args, morphs)
    G = args.geodesics
    total_seconds = spent.pop("total")
    out = {"args": vars(args), "arms_per_dof": per_dof, "ram_published": ds.RAM_PUBLISHED, "a": {}, "b": {}}
    n = len(morphs)
    dofs = np.array([m.shape[0] - 1 for m in morphs])
    for name in ("random", "boundary"):
        ref = np.array(lab["ref"][name])
        rows = [{"labels": "reference (IK + self-collision)", "reachable_share": round(float(ref.mean()), 4),
                 "share_by_dof": {int(d): round(float(ref[dofs == d].mean()), 4) for d in np.unique(dofs)}}]
        for key, title in (("kinematic", "no self-collision"), ("ram_budget", "10 starts, no extra rounds"),
                           ("reachable", f"wsmap.reachable as it is ({args.starts} starts)")):
            f, per = ds.ram_f1(np.array(lab[key][name]), ref)
            rows.append(_row(title, f, per, dofs) | {"reachable_share": round(float(np.mean(lab[key][name])), 4)})
        out["a"][name] = rows
        F = np.array(fk[name])  # (arms, levels, budgets, poses)
        out["b"][name] = [
            _row(f"FK level {lv}, {b:,} samples", *ds.ram_f1(F[:, li, bi], ref), dofs)
            | {"level": lv, "samples": b, "reachable_share": round(float(F[:, li, bi].mean()), 4)}
            for li, lv in enumerate(args.levels) for bi, b in enumerate(args.budgets)]
    out["a"]["recall_on_reachable_ends"] = round(float(np.mean(reach_ends)), 4)
    out["seconds"] = {"total": round(total_seconds, 1)} | {k: round(v, 1) for k, v in spent.items()}
    if args.model:
        out["c"] = _model_part(args, [m for m in morphs if m.shape[0] - 1 in (6, 7)])

    print(f"\n{n} arms ({per_dof}), {args.poses} random poses and {G} x {args.per_geodesic} boundary poses each; "
          f"{total_seconds:.0f} s (reference labels {spent['reference_labels']:.0f} s, FK labels {spent['fk_labels']:.0f} s)")
    print(f"(a) recall of the reference on the boundary set's reachable ends: {out['a']['recall_on_reachable_ends']}")
    for name in ("random", "boundary"):
        print(f"\n{name} poses | F1 against the reference | worst arm | by joint count | reachable share")
        for r in out["a"][name] + out["b"][name]:
            by = r.get("f1_by_dof", r.get("share_by_dof"))
            print(f"{r['labels']} | {r.get('f1', '-')} | {r.get('f1_min', '-')} | "
                  f"{', '.join(f'{d}: {v}' for d, v in by.items())} | {r['reachable_share']}")
    if "c" in out:
        print(f"\n(c) {out['c']}")
    harness.write_json(args, out)
    return 0


def _label_arms(args, morphs):
    """Every arm's poses and labels: (labels {kind: {set: [per arm]}}, FK labels {set: [(levels,
    budgets, poses) per arm]}, the reference labels of the boundary set's reachable ends, seconds)."""
    import numpy as np

    from wsmap import datasets as ds

    lab = {key: {"random": [], "boundary": []} for key in ("ref", "kinematic", "ram_budget", "reachable")}
    fk = {"random": [], "boundary": []}
    reach_ends = []
    spent = {"reference_labels": 0.0, "fk_labels": 0.0}  # seconds, summed over the arms
    G = args.geodesics
    with harness.Stopwatch() as total:
        for i, m in enumerate(morphs):
            T, known = ds.random_poses(m, args.poses, seed=args.seed + i)
            Tb, _ = ds.boundary_poses(m, G, args.per_geodesic, seed=args.seed + i, starts=args.starts)
            check = ds.ram_collision(m)
            for name, P in (("random", T), ("boundary", Tb)):
                with harness.Stopwatch() as w:
                    ref = ds.ik_labels(m, P, starts=args.starts, collision=check)
                spent["reference_labels"] += w.seconds
                if name == "random":
                    ref = ref | known  # RAM labels its 5-joint arms' FK poses reachable without IK
                lab["ref"][name].append(ref)
                extra = known if name == "random" else np.zeros(len(P), dtype=bool)  # the same for every variant
                lab["kinematic"][name].append(ds.ik_labels(m, P, self_collision=False, starts=args.starts) | extra)
                lab["ram_budget"][name].append(ds.ik_labels(m, P, starts=10, rounds=0, collision=check) | extra)
                lab["reachable"][name].append(ds.ik_labels(m, P, starts=args.starts, rounds=0, collision=check) | extra)
            reach_ends.append(lab["ref"]["boundary"][-1][:G])
            with harness.Stopwatch() as w:
                L = ds.fk_labels(m, np.concatenate([T, Tb]), args.budgets, seed=args.seed + i, level=args.levels)
            spent["fk_labels"] += w.seconds
            fk["random"].append(L[:, :, : len(T)])
            fk["boundary"].append(L[:, :, len(T):])
            print(f"arm {i + 1}/{len(morphs)} ({m.shape[0] - 1} joints): reachable {ref.mean():.2f} of the boundary set, "
                  f"{lab['ref']['random'][-1].mean():.2f} of the random poses", flush=True)

    spent["total"] = total.seconds
    return lab, fk, reach_ends, spent


def _stage_like_model(out_dir) -> str:
    """Train a morphology model of the `morphologies` stage's recipe (params.yaml) into `out_dir`."""
    import torch

    from wsmap.learn import TrainConfig
    from wsmap.learn import morph_model as mm
    from wsmap.robots.morph import MORPH_GRID

    torch.set_num_threads(1)
    with harness.Stopwatch() as w:
        sets = [d for n in (6, 7) for d in mm.build_morph_shards(out_dir, n, 2, 50, step=0.3, box=MORPH_GRID)[0]]
        tc = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 1e-3}, loss="crossentropy", batch_size=8,
                         lr_decay="cosine", max_epochs=30, max_fail=1000, fractions=(0.95, 0.05, 0.0), seed=0,
                         pos_weight=20)
        model, _ = mm.fit_morph_model(sets, train_config=tc, seed=0)
    path = str(Path(out_dir) / "stage_like.pt")
    mm.save_morph_model(model, path)
    print(f"(c) trained {path} on {sum(len(d) for d in sets)} arms in {w.seconds:.0f} s", flush=True)
    return path


def _model_part(args, morphs) -> dict:
    """(c): the tool-down morphology network on RAM's arms at tool-down poses in RAM's ball."""
    import re
    import warnings

    import numpy as np

    from wsmap import datasets as ds
    from wsmap.learn import morph_model as mm
    from wsmap.learn.training_range import ExtrapolationError, ExtrapolationWarning
    from wsmap.workspace import target_poses

    model, _ = mm.load_morph_model(args.model)
    rng = np.random.default_rng(args.seed)
    preds, truths, skipped = [], [], []
    for m in morphs:
        # the network's arms turn joint 1 about their base z axis; RAM's row 0 (Rx(alpha_0) Tx(a_0)) comes
        # first: ask about the arm in that frame (the same reachable set, poses moved by F0)
        chain = ds.ram_arms(m)
        F0 = chain.fixed[0].copy()
        fixed = chain.fixed.copy()
        fixed[0] = np.eye(4)
        centre, radius = ds.reach_ball(m)
        centre = np.linalg.solve(F0, np.append(centre, 1.0))[:3]
        u = rng.standard_normal((args.tool_down_poses, 3))
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        p = centre + radius * rng.random((args.tool_down_poses, 1)) ** (1 / 3) * u
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", ExtrapolationWarning)
                pred = mm.predict_morph_map(model, chain.replace(fixed=fixed), p)
        except (ExtrapolationError, ExtrapolationWarning, ValueError) as err:
            why = str(err).split(":")[-1].split(";")[0].strip()  # outside the network's families: why
            skipped.append(re.sub(r"(?<![\w.])-?\d+(\.\d+)?", "#", why))  # the reason, without its numbers
            continue
        preds.append(pred)
        truths.append(ds.ik_labels(m, F0 @ target_poses(p, mm.TOOL_DOWN, "standard"), starts=args.starts))
    why = {w: skipped.count(w) for w in sorted(set(skipped))}
    if not preds:
        return {"arms": 0, "skipped": why, "note": "no RAM arm lies inside the network's training range"}
    f, per = ds.ram_f1(np.array(preds), np.array(truths))
    return {"arms": len(preds), "skipped": why, "f1": round(f, 4), "reachable_share": round(float(np.mean(truths)), 4),
            "note": "tool-down poses only; the network's labels have joint limits and no self-collision"}


if __name__ == "__main__":
    raise SystemExit(main())
