"""Would MATLAB's default validation stopping (``max_fail`` 6) explain a paper-scale row? The
paper-scale runs (``params.full.yaml``) train their 1000 epochs with ``max_fail`` 1000 (§6.2: 100).
This replays each recorded run's per-epoch validation loss (``results/full/<part>.history.json``)
with `wsmap.learn.validation_stop` at other ``max_fail`` values: where the run would have
stopped and the validation loss of the epoch it would have kept. No training: up to the stop a
run does not depend on ``max_fail``.

``--retrained DIR`` adds the F-measure of the same rows trained with ``max_fail`` 6 (``wsmap paper
full ... --params results/full_extra/params.full.table1_max_fail6.yaml --out DIR``) beside the
1000-epoch F, and checks that each retrained run stopped where the replay says.

    .venv/bin/python benchmarks/paper/paper_scale_stopping.py
    .venv/bin/python benchmarks/paper/paper_scale_stopping.py --retrained results/full_extra/max_fail6 --max-fail 6
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def main(argv=None) -> int:
    from wsmap import paths

    full = paths.ROOT / "results" / "full"
    p = harness.parser(__doc__)
    p.add_argument("parts", nargs="*", help="wsmap paper full parts (default: every part with a history in --full)")
    p.add_argument("--max-fail", type=int, nargs="+", default=[6, 20, 100], help="max_fail values to replay")
    p.add_argument("--full", type=Path, default=full, help="the paper-scale results (default results/full)")
    p.add_argument("--retrained", type=Path, help="results of the same parts trained with the first --max-fail")
    args = p.parse_args(argv)
    if any(m < 1 for m in args.max_fail):
        p.error(f"--max-fail values must be >= 1, got {args.max_fail}")
    names = args.parts or sorted(f.name[: -len(".history.json")] for f in args.full.glob("*.history.json"))
    if not names:
        p.error(f"no *.history.json in {args.full}")
    missing = [n for n in names if not (args.full / f"{n}.history.json").is_file()]
    if missing:
        p.error(f"no history in {args.full} for: {', '.join(missing)}")

    from wsmap.io import read_json
    from wsmap.learn import validation_stop

    def result(folder: Path, name: str) -> dict:
        path = folder / f"{name}.json"
        return read_json(path) if path.is_file() else {}

    rows = []
    head = " | ".join(f"max_fail {m}: stop, val MSE kept (× best)" for m in args.max_fail)
    print(f"| part | step | run's max_fail | epochs | best epoch | val MSE kept | {head} |")
    print("|---|---|---:|---:|---:|---:|" + "---|" * len(args.max_fail))
    for name in names:
        hist = read_json(args.full / f"{name}.history.json")
        own = result(args.full, name).get("settings", {}).get("section", {}).get("max_fail")
        for step, h in hist["steps"].items():
            v = h["val_loss"]
            mine = validation_stop(v, own if own else 10**9)
            row = {"part": name, "step": step, "max_fail": own, "epochs": mine["stop_epoch"],
                   "best_epoch": mine["best_epoch"], "best_val_loss": mine["best_val_loss"], "replay": {}}
            cells = []
            for m in args.max_fail:
                r = validation_stop(v, m)
                row["replay"][m] = r
                ratio = r["best_val_loss"] / mine["best_val_loss"]
                cells.append(f"{r['stop_epoch'] if r['stopped'] else '—'}, {r['best_val_loss']:.4g} (× {ratio:.2f})")
            rows.append(row)
            print(f"| {name} | {step} | {own} | {row['epochs']} | {row['best_epoch']} | {row['best_val_loss']:.4g} | "
                  + " | ".join(cells) + " |")

    if args.retrained is not None:
        m = args.max_fail[0]
        print(f"\n| part | F, max_fail {rows[0]['max_fail'] if rows else '?'} | F, max_fail {m} | stopped at "
              "(replay) | val MSE kept |")
        print("|---|---:|---:|---|---:|")
        first = {}  # a Table 1 part's one session
        for r in rows:
            first.setdefault(r["part"], r)
        for name in names:
            a, b = result(args.full, name), result(args.retrained, name)
            if not a or "runs" not in b.get("metrics", {}):
                print(f"| {name} | — | not retrained | | |")
                continue
            run, row = b["metrics"]["runs"][0], first[name]
            replay = row["replay"][m]
            agree = "=" if (run["epochs"], run["best_epoch"]) == (replay["stop_epoch"], replay["best_epoch"]) else "≠"
            row["retrained"] = {"f": b["metrics"]["f"], "f_full": a["metrics"]["f"], "epochs": run["epochs"],
                                "best_epoch": run["best_epoch"], "best_val_loss": run["best_val_loss"],
                                "agrees_with_replay": agree == "="}
            print(f"| {name} | {a['metrics']['f']:.4f} | {b['metrics']['f']:.4f} | {run['epochs']} {agree} "
                  f"({replay['stop_epoch']}) | {run['best_val_loss']:.4g} |")
    harness.write_json(args, {"rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
