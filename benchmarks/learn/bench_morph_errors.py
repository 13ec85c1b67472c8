"""Where a morphology model is wrong: its F at its own label grid and on a finer one, and where on the
map its errors lie.

For each model file: (1) the pooled F, precision and recall on the six named arms and on the first
``--random`` held-out arms of each family (shard 0's test sets in ``--data``, built there when
missing, as the ``morphologies`` stage builds them), against the map search, at the model's label
grid (``--step``, 0.3 m) and at ``--fine`` (0.1 m: nodes none of its labels was on);
(2) over all of shard 0's held-out arms at the label grid: how many reach no node, the pooled F by
map size, and the errors split into missed nodes on the true map's boundary shell (a node of the
map with a 6-neighbour outside it) or inside it, and false nodes next to the map (within one node,
26-neighbourhood) or farther.

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_morph_errors.py \\
        --models headline100k.pt big100k.pt headline20k.pt --data /tmp/ms_full [--random 25] [--json out.json]
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def _options():
    """The command line: the harness's common options and this benchmark's own."""
    p = harness.parser(__doc__)
    p.add_argument("--models", nargs="+", required=True, metavar="FILE", help="morphology model files")
    p.add_argument("--data", required=True, help="folder of the stage's shards (shard 0's test sets built if missing)")
    p.add_argument("--arms", type=int, default=250, help="arms per shard of the stage (names the shard files)")
    p.add_argument("--test-arms", type=int, default=100, help="held-out arms per family (the stage's test_arms)")
    p.add_argument("--step", type=float, default=0.3, help="the models' label grid step (m)")
    p.add_argument("--fine", type=float, default=0.1, help="the finer grid step (m)")
    p.add_argument("--random", type=int, default=25, help="held-out arms per family scored on both grids")
    return p


def main(argv=None) -> int:
    p = _options()
    args = p.parse_args(argv)

    import numpy as np
    import torch
    from scipy import ndimage

    import wsmap
    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm
    from wsmap.learn.training_range import ExtrapolationWarning
    from wsmap.metrics import score_maps
    from wsmap.robots import FAMILIES
    from wsmap.robots.morph import HELD_OUT, MORPH_GRID

    torch.set_num_threads(1)
    warnings.simplefilter("ignore", ExtrapolationWarning)
    tests = []
    for n in (6, 7):
        built, _ = mm.build_morph_shards(args.data, n, 1, args.arms, step=args.step, box=MORPH_GRID,
                                         test_samples=args.test_arms)
        tests.append(built[-1])
    grids = {g: ws.cartesian_grid(-MORPH_GRID, MORPH_GRID, g) for g in (args.step, args.fine)}
    arms = {name: wsmap.load(name) for name in HELD_OUT}
    for d in tests:
        fam = FAMILIES[d.spec.family]
        for i in range(min(args.random, len(d.features))):
            arms[f"{d.spec.family}#{i}"] = fam.arms(d.features[i, :d.spec.n_arm_features], allow_extrapolation=True)
    truth = {g: {k: ws.constant_orientation_map(a, nodes, mm.TOOL_DOWN, convention="standard")
                 for k, a in arms.items()} for g, nodes in grids.items()}
    groups = {"named": list(HELD_OUT), "random": [k for k in arms if "#" in k]}
    out = {"args": vars(args), "models": {}}

    def pooled(pred, y) -> dict:
        s = score_maps(pred, y)
        return {k: float(s[k]) for k in ("f", "precision", "recall")}

    for path in args.models:
        model, _ = mm.load_morph_model(path)
        res = {"grids": {}, "errors": {}}
        for g, nodes in grids.items():
            for group, keys in groups.items():
                P = np.array([mm.predict_morph_map(model, arms[k], nodes, allow_extrapolation=True) for k in keys])
                Y = np.array([truth[g][k] for k in keys])
                row = pooled(P, Y)
                if group == "named":
                    row["per_arm"] = {k: float(score_maps(p[None], y[None])["f"]) for k, p, y in zip(keys, P, Y)}
                res["grids"][f"{group}@{g:g}"] = row
                print(f"{os.path.basename(path)} {group} at {g:g} m: F {row['f']:.3f} (P {row['precision']:.3f}, "
                      f"R {row['recall']:.3f})" + ("" if group != "named" else "  " + ", ".join(
                          f"{k} {v:.3f}" for k, v in row["per_arm"].items())), flush=True)
        shape = tuple(int(c) for c in ws.grid_counts(-MORPH_GRID, MORPH_GRID, args.step))[::-1]
        for d in tests:
            X = mm.morph_features(list(d.features[:, :d.spec.n_arm_features]))
            with torch.no_grad():
                prob = torch.sigmoid(model(torch.as_tensor(X, dtype=torch.float32))).numpy()
            pred, Y = prob > model.threshold, d.labels
            sizes = Y.sum(axis=1)
            by_size = {}
            for lo, hi in ((1, 10), (10, 30), (30, 100), (100, 10 ** 9)):
                m = (sizes >= lo) & (sizes < hi)
                if m.any():
                    by_size[f"{lo}-{hi - 1 if hi < 10 ** 9 else 'more'}"] = {"arms": int(m.sum()), **pooled(pred[m], Y[m])}
            vol, pv = Y.reshape((-1,) + shape), pred.reshape((-1,) + shape)
            inner = np.array([ndimage.binary_erosion(v) for v in vol])
            near = np.array([ndimage.binary_dilation(v, structure=np.ones((3, 3, 3))) for v in vol])
            fn, fp = vol & ~pv, pv & ~vol
            e = {"arms": int(len(Y)), "empty_maps": int(np.sum(sizes == 0)), "pooled": pooled(pred, Y),
                 "by_size": by_size, "missed_on_boundary": int((fn & ~inner).sum()), "missed_inside": int((fn & inner).sum()),
                 "false_next_to_map": int((fp & near).sum()), "false_farther": int((fp & ~near).sum())}
            res["errors"][d.spec.family] = e
            print(f"  {d.spec.family}: {e['empty_maps']} of {e['arms']} held-out arms reach no node; pooled F "
                  f"{e['pooled']['f']:.3f}; missed {e['missed_on_boundary']} on the boundary shell, "
                  f"{e['missed_inside']} inside; false {e['false_next_to_map']} next to the map, {e['false_farther']} "
                  f"farther; by size " + ", ".join(f"{k}: {v['arms']} arms F {v['f']:.3f}" for k, v in by_size.items()),
                  flush=True)
        out["models"][path] = res
    harness.write_json(args, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
