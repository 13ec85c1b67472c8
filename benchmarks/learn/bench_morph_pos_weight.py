"""The morphology model's positive weight, measured: the same network, data and recipe as the
``morphologies`` stage (params.yaml), trained once per ``--weights`` value of ``TrainConfig.pos_weight``
(crossentropy with the reachable nodes' terms weighted; 1 is the unweighted loss), each scored on
the stage's held-out random arms (pooled F, precision, recall) and on the six named arms.

Reachable nodes are about 2 % of the morph box, so the unweighted model leans to "unreachable" and
predicts nothing at all for some arms. The experience is the stage's ``data/morph`` shards (built
here when missing, resumably). One thread::

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_morph_pos_weight.py --weights 1 5 20
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> None:
    from wsmap import paths

    ap = harness.parser(__doc__)
    ap.add_argument("--weights", type=float, nargs="+", default=[1.0, 5.0, 20.0])
    ap.add_argument("--data", default=str(paths.ROOT / "data" / "morph"))
    ap.add_argument("--params", default=str(paths.ROOT / "params.yaml"))
    a = ap.parse_args(argv)

    import numpy as np
    import torch

    from wsmap import robots, workspace
    from wsmap.learn import morph_model as mm
    from wsmap.learn.training_range import ExtrapolationWarning
    from wsmap.metrics import score_maps
    from wsmap.paper.parts import morphologies as stage
    from wsmap.robots.morph import HELD_OUT, MORPH_GRID

    torch.set_num_threads(1)
    cfg = paths.load_params("morphologies", a.params)
    step, seed = float(cfg["step"]), int(cfg["seed"])
    train, test = [], []
    for n in (6, 7):
        built, _ = mm.build_morph_shards(a.data, n, int(cfg["shards"]), int(cfg["arms_per_shard"]), step=step,
                                         box=MORPH_GRID, first_seed=seed, test_samples=int(cfg["test_arms"]))
        train += built[:-1]
        test.append(built[-1])
    test_F = np.concatenate([mm.morph_features(list(d.features[:, :d.spec.n_arm_features])) for d in test])
    test_Y = np.concatenate([d.labels for d in test])
    nodes = workspace.cartesian_grid(-MORPH_GRID, MORPH_GRID, step)
    named = {nm: workspace.constant_orientation_map(robots.load(nm), nodes, mm.TOOL_DOWN, convention="standard")
             for nm in HELD_OUT}
    model_cfg = mm.MorphModelConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg["model"].items()})
    t = cfg["train"]
    print(f"# {sum(len(d.features) for d in train)} training arms, {len(test_Y)} held-out random arms, "
          f"{len(nodes)} nodes ({step} m); reachable share of the held-out arms {test_Y.mean():.3f}\n")
    print("| pos_weight | threshold | pooled F | P | R | " + " | ".join(HELD_OUT) + " | named mean | train s |")
    print("|---" * (7 + len(HELD_OUT)) + "|")
    rows = []
    for w in a.weights:
        tc = stage._train_config({**t, "pos_weight": None if w == 1 else w}, seed)  # the stage's recipe
        secs, (model, _) = harness.timed(lambda: mm.fit_morph_model(train, model_cfg, tc, seed=seed))  # noqa: B023
        with torch.no_grad():
            pred = torch.sigmoid(model(torch.as_tensor(test_F, dtype=torch.float32))).numpy() > model.threshold
        s = score_maps(pred, test_Y)
        fs = []
        for nm, truth in named.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ExtrapolationWarning)
                p = mm.predict_morph_map(model, robots.load(nm), nodes, allow_extrapolation=True)
            fs.append(float(np.nan_to_num(score_maps(p[None], truth[None])["f"])))  # none predicted: 0
        print(f"| {w:g} | {model.threshold:.2f} | {s['f']:.3f} | {s['precision']:.3f} | {s['recall']:.3f} | "
              + " | ".join(f"{f:.3f}" for f in fs) + f" | {np.mean(fs):.3f} | {secs:.0f} |", flush=True)
        rows.append({"pos_weight": w, "threshold": model.threshold, "f": s["f"], "precision": s["precision"],
                     "recall": s["recall"], "named_f": dict(zip(named, fs)), "train_seconds": secs})
    harness.write_json(a, {"rows": rows})


if __name__ == "__main__":
    main()
