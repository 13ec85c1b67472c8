"""Ablation of the improved model: which of its changes to the paper's setting carry the accuracy.

The improved model (notebook ``improved_model``) changes four things at once against the paper's
full-map network: inputs (the family's 4 free DH parameters, standardised, instead of all 84 raw
columns), width ([256, 256, 256] instead of [125, 100, 100, 125]), output and loss (logits with
cross entropy instead of a linear output with MSE) and the optimiser (Adam in minibatches with a
cosine schedule instead of full-batch Rprop). Each variant below undoes one of the first three,
trained exactly as the improved model (same arms, epochs, seed), and is scored on the same 1000
held-out arms of ``data/sec62.test.npz``. Needs the sec62 datasets (``dvc repro datasets@sec62``).
About 3–4 minutes per variant on 2 cores at the defaults.

    .venv/bin/python benchmarks/paper/ablate_improved.py --threads 2 --json bench/ablation.json
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

from wsmap import paths
from wsmap.learn import TrainConfig
from wsmap.paper import fitting
from wsmap.paper.specs import load_pair

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

PAPER_HIDDEN = [125, 100, 100, 125]
WIDE = [256, 256, 256]

#: name -> (hidden, inputs "free" | "all", input scaling, output kind, loss)
VARIANTS = {
    "improved": (WIDE, "free", "standardize", "logit", "crossentropy"),
    "paper width": (PAPER_HIDDEN, "free", "standardize", "logit", "crossentropy"),
    "all 84 raw inputs": (WIDE, "all", "none", "logit", "crossentropy"),
    "linear output + MSE": (WIDE, "free", "standardize", "linear", "mse"),
}


def main(argv=None) -> int:
    p = harness.parser(__doc__, threads=2, seed=0, threads_help="torch threads (default 2)",
                       seed_help="training seed of every variant (default 0)")
    p.add_argument("--variants", nargs="*", default=list(VARIANTS), help=f"any of {list(VARIANTS)}")
    p.add_argument("--train-samples", type=int, default=20000)
    p.add_argument("--epochs", type=int, default=40)
    args = p.parse_args(argv)
    unknown = [v for v in args.variants if v not in VARIANTS]
    if unknown:
        p.error(f"unknown variants {unknown}; choose from {list(VARIANTS)}")
    torch.set_num_threads(args.threads)

    train_all, test = load_pair("sec62", paths.DATA)
    train = train_all.head(args.train_samples)
    free = [int(c) for c in np.flatnonzero(np.ptp(train.features, axis=0) > 1e-9)]
    rows = []
    print(f"{len(train)} training arms, {len(test)} test arms, {train.n_nodes} nodes, {args.epochs} epochs, "
          f"{args.threads} threads")
    print("| variant | hidden | inputs | output / loss | F | precision | recall | train s |")
    print("|---|---|---|---|---:|---:|---:|---:|")
    for name in args.variants:
        hidden, inputs, scaling, output, loss = VARIANTS[name]
        cfg = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 1e-3}, lr_decay="cosine", batch_size=256,
                          loss=loss, max_epochs=args.epochs, max_fail=args.epochs, fractions=(0.95, 0.05, 0.0),
                          seed=args.seed)
        with harness.Stopwatch() as sw:
            (res,) = fitting.fit(train, cfg, hidden=hidden, input_columns=free if inputs == "free" else None,
                                 input_scaling=scaling, output_kind=output, init="torch")
        seconds = sw.seconds

        ev = fitting.evaluate(res.model, test)
        row = dict(variant=name, hidden=hidden, inputs=inputs, scaling=scaling, output=output, loss=loss,
                   f=ev["f"], precision=ev["precision"], recall=ev["recall"], train_seconds=seconds,
                   epochs=int(res.stop_epoch))
        rows.append(row)
        print(f"| {name} | {hidden} | {len(free) if inputs == 'free' else train.features.shape[1]} "
              f"({scaling}) | {output} / {loss} | {ev['f']:.4f} | {ev['precision']:.4f} | {ev['recall']:.4f} "
              f"| {seconds:.0f} |", flush=True)
    harness.write_json(args, {"train_samples": len(train), "epochs": args.epochs, "threads": args.threads,
                              "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
