"""Is the 0.5 threshold why a paper-scale row falls short of the paper? Scores the models that
``wsmap paper full`` saved (``results/full/models/<part>/session_0.pt``) on their test sets
(``data/full/<part>.test.npz``) at 0.5 and at the best threshold of the test set itself (an upper
bound on what any threshold can give), and prints the false negatives' scores. With ``--units``
also how many tanh units of each hidden layer are constant on the test arms
(`wsmap.learn.unit_saturation`: saturated at one sign on at least 95 % of them).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/paper/paper_scale_thresholds.py table1_r3_step1 table1_r3_step05 table1_so3_pi3
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/paper/paper_scale_thresholds.py --units table1_so3_pi10 table1_so3_pi8
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    p = harness.parser(__doc__)
    p.add_argument("parts", nargs="+", help="wsmap paper full parts (Table 1 rows)")
    p.add_argument("--units", action="store_true", help="also the constant (saturated) tanh units per hidden layer")
    args = p.parse_args(argv)

    import numpy as np
    import torch

    from wsmap import datasets, learn, metrics, paths
    from wsmap.learn import unit_saturation

    torch.set_num_threads(1)
    rows = []
    print("| part | F at 0.5 | best threshold | F there | false negatives (their highest scores) | false positives |")
    print("|---|---:|---:|---:|---|---:|")
    for part in args.parts:
        model, _ = learn.load(paths.ROOT / "results" / "full" / "models" / part / "session_0.pt")
        test = datasets.load_dataset(paths.ROOT / "data" / "full" / f"{part}.test.npz")
        s = model.score(test.features, key=0).cpu().numpy()
        t = test.labels
        f05 = metrics.precision_recall_f(s > 0.5, t).f
        thr, fbest = metrics.best_threshold(s, t)
        fn = np.sort(s[t & (s <= 0.5)])
        fp = int(((s > 0.5) & ~t).sum())
        rows.append(dict(part=part, f_at_05=f05, best_threshold=thr, f_best=fbest, false_negatives=int(fn.size),
                         highest_fn_scores=fn[-4:].tolist(), false_positives=fp))
        print(f"| {part} | {f05:.4f} | {thr:.3f} | {fbest:.4f} | {fn.size} ({', '.join(f'{v:.3f}' for v in fn[-4:])}) | {fp} |")
        if args.units:
            rows[-1]["units"] = unit_saturation(model, test.features)
    if args.units:
        print("\n| part | " + " | ".join(f"layer {r['layer']}: constant / units (saturated pairs)" for r in rows[0]["units"]) + " |")
        print("|---|" + "---:|" * len(rows[0]["units"]))
        for row in rows:
            print(f"| {row['part']} | " + " | ".join(f"{r['units'] - r['active_units']} / {r['units']} ({r['saturated']:.2f})"
                                                    for r in row["units"]) + " |")
    harness.write_json(args, {"rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
