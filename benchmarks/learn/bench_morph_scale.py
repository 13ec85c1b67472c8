"""The morphology model at scale: experience labelled in parallel processes, networks trained on a
GPU, each run scored on the same held-out arms as the ``morphologies`` stage.

What it measures: how the held-out F of `wsmap.learn.morph_model.MorphMapModel` moves with
the number of training arms and with the network's size, at equal training time per run. It builds
the ``morph6``/``morph7`` shards of the stage (`wsmap.learn.morph_model.build_morph_shards`:
shard ``k`` is seed ``k``, the tool-down map on ``[-1.5, 1.5]³`` at ``--step`` m by the map
search; the files are the stage's, so the first 40 shards of 250 arms are the headline's 20,000
training arms and shard 0's test files its 200 held-out arms), one shard per process on
``--procs`` processes (one numba thread each), the shards a run needs first. A shard not built by
``--label-seconds`` is left out (the JSON says how many arms each run had). Then each ``--run``
trains a network with the stage's recipe (Adam, binary cross-entropy with positives weighted
``--pos-weight``, 5 % of the arms for validation and the epoch of lowest validation loss kept,
the threshold of best validation F), its learning rate decaying on a cosine over its time budget
(``cosine-time``), and is scored against the map-search labels of the held-out random arms
(pooled F, precision, recall, per-arm mean F) and of the six named arms
(`wsmap.robots.morph.HELD_OUT`), beside the nearest-training-arm baseline of the same
training set. Last, one map of 31³ = 29,791 nodes (0.1 m) of the iiwa14 by each model on one CPU
thread (median of 5). The first run's shards are labelled first, and it trains while the other
shards are labelled.

A run: ``name=big,shards=200,encoder=512x512x512,latent=256,decoder=256x256x256,batch=32,lr=1e-3,seconds=120``
(``shards`` per family, of ``--arms`` arms each). The results go to ``--json`` after every run.

On the lent H200 machine (16 cores), from the repository root (its python3 has torch, numba, numpy):

    PYTHONPATH=src python3 benchmarks/learn/bench_morph_scale.py --data /tmp/morph --procs 15 --device cuda \\
        --label-seconds 170 --json $OUT/morph_scale.json --save $OUT \\
        --run name=headline20k,shards=40,seconds=45 --run name=headline100k,shards=200,seconds=110 \\
        --run name=big100k,shards=200,encoder=512x512x512,latent=256,decoder=256x256x256,seconds=130

A small run on this machine (checks the script, numbers meaningless):

    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 .venv/bin/python benchmarks/learn/bench_morph_scale.py --data /tmp/ms \\
        --procs 2 --arms 20 --test-arms 10 --step 0.5 --device cpu --label-seconds 120 \\
        --run name=a,shards=2,seconds=5 --run name=b,shards=4,encoder=64x64,latent=32,decoder=64,seconds=5
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

RUN_KEYS = {"name": str, "shards": int, "encoder": str, "latent": int, "decoder": str, "batch": int, "lr": float,
            "seconds": float}
RUN_DEFAULTS = {"encoder": "256x256", "latent": 128, "decoder": "128x128", "batch": 32, "lr": 1e-3}


def parse_run(text: str) -> dict:
    """``key=value,...`` -> a run (module notes); a bad key or value is an ``argparse`` error."""
    run = dict(RUN_DEFAULTS)
    for part in text.split(","):
        key, sep, value = part.partition("=")
        if not sep or key not in RUN_KEYS:
            raise argparse.ArgumentTypeError(f"--run {text!r}: {part!r} is not one of {', '.join(RUN_KEYS)}=VALUE")
        try:
            run[key] = RUN_KEYS[key](value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"--run {text!r}: {key} must be a {RUN_KEYS[key].__name__}") from None
    missing = [k for k in ("name", "shards", "seconds") if k not in run]
    if missing:
        raise argparse.ArgumentTypeError(f"--run {text!r}: give {', '.join(missing)}")
    for k in ("encoder", "decoder"):
        try:
            run[k] = tuple(int(h) for h in run[k].split("x"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"--run {text!r}: {k} is widths joined by x, e.g. 256x256") from None
    if run["shards"] < 1 or run["seconds"] <= 0 or run["batch"] < 1 or run["lr"] <= 0:
        raise argparse.ArgumentTypeError(f"--run {text!r}: shards, batch, seconds and lr must be positive")
    return run


def _label_shard(job):
    """One shard (``n`` joints, seed ``k``) in a worker process; returns ``(n, k, seconds)``."""
    n, k, arms, test_arms, step, data = job
    from wsmap.learn import morph_model as mm
    from wsmap.robots.morph import MORPH_GRID

    seconds, _ = harness.timed(lambda: mm.build_morph_shards(data, n, 1, arms, step=step, box=MORPH_GRID, first_seed=k,
                                                             test_samples=test_arms if k == 0 else None))
    return n, k, seconds


def _options():
    """The command line: the harness's common options and this benchmark's own."""
    p = harness.parser(__doc__)
    p.add_argument("--data", required=True, help="folder of the experience shards (reused when there)")
    p.add_argument("--arms", type=int, default=250, help="arms per shard (the stage's full scale: 250)")
    p.add_argument("--test-arms", type=int, default=100, help="held-out random arms per family (shard 0's test set)")
    p.add_argument("--step", type=float, default=0.3, help="label grid step (m) on [-1.5, 1.5]^3")
    p.add_argument("--procs", type=int, default=max(1, (os.cpu_count() or 2) - 1), help="labelling processes")
    p.add_argument("--label-seconds", type=float, default=600.0, help="stop labelling new shards after this")
    p.add_argument("--device", default="auto", help="where the networks train: auto, cpu, cuda")
    p.add_argument("--pos-weight", type=float, default=20.0, help="weight of a reachable node's loss term")
    p.add_argument("--run", type=parse_run, action="append", required=True, help="a training run (module notes)")
    p.add_argument("--save", help="folder to save each run's model in (NAME.pt)")
    return p


class _Labelling:
    """The experience shards labelled in worker processes (one shard per process, one numba thread
    each), the shards of the runs in order of need, new ones started until `--label-seconds`."""

    def __init__(self, args):
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        need = max(r["shards"] for r in args.run)
        order = [(n, k) for k in range(need) for n in (6, 7)]
        self.label_seconds = args.label_seconds
        self.arms = args.arms
        self.done: dict[int, set] = {6: set(), 7: set()}
        self.seconds: list[float] = []
        self.collected: set = set()
        self.pool = ProcessPoolExecutor(args.procs, mp_context=mp.get_context("spawn"))
        self.futures = {self.pool.submit(_label_shard, (n, k, args.arms, args.test_arms, args.step, args.data)): (n, k)
                        for n, k in order}
        self.clock = harness.Stopwatch().start()

    def prefix(self, n: int) -> int:
        """Shards 0, 1, ... of family `n` joints done without a gap."""
        k = 0
        while k in self.done[n]:
            k += 1
        return k

    def collect(self, until_shards: int | None, drain: bool = False) -> None:
        """Gather finished shards until both families have ``until_shards`` (None: every shard) or
        the deadline; ``drain``: only those finished by now (after the pool has shut down)."""
        from concurrent.futures import FIRST_COMPLETED, wait

        while True:
            if until_shards is not None and min(self.prefix(6), self.prefix(7)) >= until_shards:
                return
            pending = [f for f in self.futures if f not in self.collected and not f.cancelled()]
            left = 0.0 if drain else self.label_seconds - self.clock.elapsed()
            if not pending or (left <= 0 and not drain):
                return
            finished, _ = wait(pending, timeout=max(left, 0.0), return_when=FIRST_COMPLETED)
            if not finished:
                return
            for f in finished:
                n, k, secs = f.result()
                self.done[n].add(k)
                self.seconds.append(secs)
                self.collected.add(f)

    def finish(self) -> dict:
        """Stop labelling (shards not started are cancelled), gather what finished; the labelling's facts."""
        import numpy as np

        self.pool.shutdown(wait=True, cancel_futures=True)
        self.collect(None, drain=True)
        arms = sum(len(self.done[n]) for n in (6, 7)) * self.arms
        wall = self.clock.elapsed()
        return {"shards_done": {f"morph{n}": self.prefix(n) for n in (6, 7)}, "arms_labelled": arms,
                "wall_seconds": wall, "arms_per_second": arms / wall if wall > 0 else None,
                "seconds_per_shard_median": float(np.median(self.seconds)) if self.seconds else None}


def _score(pred, y) -> dict:
    from wsmap.metrics import score_maps

    s = score_maps(pred, y)
    return {k: float(s[k]) for k in ("f", "precision", "recall", "f_mean")}


def _held_out(args) -> dict:
    """Shard 0's test sets and the six named arms, labelled by the same search: their features, labels
    and the record of them."""
    import numpy as np

    import wsmap
    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm
    from wsmap.robots.morph import HELD_OUT

    test_sets = []
    for n in (6, 7):
        built, _ = mm.build_morph_shards(args.data, n, 1, args.arms, step=args.step, first_seed=0,
                                         test_samples=args.test_arms)
        test_sets.append(built[-1])
    spec = test_sets[0].spec
    nodes = ws.cartesian_grid(spec.lo, spec.hi, spec.step)
    test_X = np.concatenate([mm.morph_features(list(d.features[:, :d.spec.n_arm_features])) for d in test_sets])
    test_Y = np.concatenate([d.labels for d in test_sets])
    named = {name: wsmap.load(name) for name in HELD_OUT}
    truth = {name: ws.constant_orientation_map(arm, nodes, mm.TOOL_DOWN, convention="standard")
             for name, arm in named.items()}
    record = {"random_arms": int(len(test_Y)), "nodes": int(len(nodes)), "reachable_share": float(test_Y.mean()),
              "named_reachable": {k: int(v.sum()) for k, v in truth.items()}}
    return {"nodes": nodes, "X": test_X, "Y": test_Y, "named": named, "truth": truth, "record": record}


def _train_run(run, shards, args, device, held):
    """One `--run`: its network trained on the first `shards` shards of each family, scored on the
    held-out arms beside the nearest-training-arm baseline; (model, row)."""
    import warnings

    import numpy as np
    import torch

    from wsmap.kinematics.morphology import describe
    from wsmap.learn import TrainConfig
    from wsmap.learn import morph_model as mm
    from wsmap.learn.training_range import ExtrapolationWarning

    train_sets = []
    for n in (6, 7):
        built, _ = mm.build_morph_shards(args.data, n, shards, args.arms, step=args.step,
                                         test_samples=args.test_arms)
        train_sets += built[:-1]
    n_train = sum(len(d.features) for d in train_sets)
    tc = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": run["lr"]}, loss="crossentropy",
                     batch_size=run["batch"], lr_decay="cosine-time", time_limit_s=run["seconds"],
                     max_epochs=100_000, max_fail=10 ** 6, fractions=(0.95, 0.05, 0.0), seed=0,
                     pos_weight=args.pos_weight, device=str(device))
    cfg = mm.MorphModelConfig(encoder=run["encoder"], latent=run["latent"], decoder=run["decoder"])
    train_s, (model, result) = harness.timed(lambda: mm.fit_morph_model(train_sets, cfg, tc))
    train_X = np.concatenate([mm.morph_features(list(d.features[:, :d.spec.n_arm_features])) for d in train_sets])
    train_Y = np.concatenate([d.labels for d in train_sets])
    nodes, test_X, test_Y = held["nodes"], held["X"], held["Y"]
    with torch.no_grad():
        logits = model.logits_at(torch.as_tensor(test_X, dtype=torch.float32),
                                 torch.as_tensor(nodes, dtype=torch.float32)).numpy()
    pred = logits > np.log(model.threshold / (1 - model.threshold))
    nn_pred, nn_dist = mm.nearest_arm_maps(train_X, train_Y, test_X)
    row = {**{k: (list(v) if isinstance(v, tuple) else v) for k, v in run.items()},
           "shards_used": shards, "train_arms": n_train,
           "parameters": int(sum(p.numel() for p in model.parameters())),
           "train_seconds": train_s, "epochs": int(len(result.history.epoch) - 1),
           "best_epoch": int(result.best_epoch), "best_val_loss": float(np.nanmin(result.history.val_loss)),
           "threshold": float(model.threshold),
           "pooled": {"model": _score(pred, test_Y), "nearest_arm": _score(nn_pred, test_Y),
                      "nearest_distance_median": float(np.median(nn_dist))},
           "named": {}}
    for name, arm in held["named"].items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ExtrapolationWarning)
            mp_ = mm.predict_morph_map(model, arm, nodes, allow_extrapolation=True)
        nb, nd = mm.nearest_arm_maps(train_X, train_Y, describe(arm).features()[None])
        truth = held["truth"][name][None]
        row["named"][name] = {"model": _score(mp_[None], truth), "nearest_arm": _score(nb, truth),
                              "nearest_distance": float(nd[0]),
                              "in_range": not any(issubclass(w.category, ExtrapolationWarning) for w in caught)}
    # an arm with no node predicted has F undefined (NaN): counted as 0, as the stage does
    row["named_mean_f"] = float(np.mean(np.nan_to_num([v["model"]["f"] for v in row["named"].values()])))
    print(f"{run['name']}: {n_train} arms, {row['parameters']} parameters, {row['epochs']} epochs in "
          f"{train_s:.0f} s (best {row['best_epoch']}): pooled F {row['pooled']['model']['f']:.3f} "
          f"(P {row['pooled']['model']['precision']:.3f}, R {row['pooled']['model']['recall']:.3f}), "
          f"nearest {row['pooled']['nearest_arm']['f']:.3f}; named "
          + ", ".join(f"{k} {v['model']['f']:.3f}" for k, v in row["named"].items()), flush=True)
    if args.save:
        mm.save_morph_model(model, os.path.join(args.save, f"{run['name']}.pt"),
                            extra={"bench_morph_scale": {k: row[k] for k in ("name", "train_arms", "epochs")}})
    return model, row


def _map_speed(rows, models, iiwa14):
    """One 29,791-node map of the iiwa14 by each run's model, one CPU thread, median of 5 (into each row)."""
    import warnings

    import numpy as np
    import torch

    from wsmap import workspace as ws
    from wsmap.learn import morph_model as mm
    from wsmap.learn.training_range import ExtrapolationWarning

    torch.set_num_threads(1)
    big = ws.cartesian_grid(-1.5, 1.5, 0.1)
    for row in rows:
        model = models[row["name"]]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ExtrapolationWarning)
            reps, _ = harness.timings(lambda: mm.predict_morph_map(model, iiwa14, big,  # noqa: B023
                                                                   allow_extrapolation=True), 5, warmup=1)
        row["map_ms_one_thread"] = 1e3 * float(np.median(reps.values))
        print(f"{row['name']}: one {len(big)}-node map {row['map_ms_one_thread']:.1f} ms on one CPU thread", flush=True)


def main(argv=None) -> int:
    args = _options().parse_args(argv)
    # one numba thread per process, set before numba is imported (the workers inherit it)
    for var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "WSMAP_THREADS"):
        os.environ[var] = "1"
    import numpy as np
    import torch

    from wsmap.kinematics.ik.warmup import ensure_compiled
    from wsmap.learn import resolve_device

    device = resolve_device(args.device, "--device")  # before any work
    run_clock = harness.Stopwatch().start()
    facts = {"device": str(device), "gpu": torch.cuda.get_device_name(device) if device.type == "cuda" else None,
             "cpus": os.cpu_count(), "procs": args.procs, "torch": torch.__version__, "numpy": np.__version__,
             "python": sys.version.split()[0]}
    print(json.dumps(facts), flush=True)
    out = {"facts": facts, "args": {k: v for k, v in vars(args).items() if k != "run"}, "runs": []}
    compile_s = ensure_compiled(joints=(6, 7))  # once here; the workers load the cache
    print(f"kernels compiled in {compile_s:.0f} s", flush=True)

    labelling = _Labelling(args)
    labelling.collect(1)
    held = _held_out(args)
    out["held_out"] = held["record"]
    torch.set_num_threads(1)  # the labelling processes hold the other cores
    models = {}
    for i, run in enumerate(args.run):
        labelling.collect(run["shards"] if i == 0 else None)
        if i == 1:  # the rest train after the labelling
            out["labels"] = labelling.finish()
            print(f"labels: {out['labels']}", flush=True)
            torch.set_num_threads(max(1, (os.cpu_count() or 2) - 1))
        shards = min(run["shards"], labelling.prefix(6), labelling.prefix(7))
        models[run["name"]], row = _train_run(run, shards, args, device, held)
        out["runs"].append(row)
        harness.write_json(args, out)  # after every run
    if len(args.run) == 1:
        out["labels"] = labelling.finish()

    _map_speed(out["runs"], models, held["named"]["iiwa14"])
    out["total_seconds"] = run_clock.elapsed()
    harness.write_json(args, out)
    print(f"total {out['total_seconds']:.0f} s", flush=True)
    return 0

if __name__ == "__main__":
    sys.exit(main())
