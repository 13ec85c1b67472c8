"""The paper's scale, part by part and resumable: `wsmap paper full [PART ...] [--list] [--estimate]`.

`wsmap paper run --all --params params.full.yaml` runs the notebooks at the paper's scale in one
go (README "Scale": about 90 hours on 2 cores, all of Table 2 included). This runner cuts that work into **parts** that each end in one
result file, so that a run can stop (a crash, Ctrl-C, a reboot) and go on where it stopped:

=====================  ==========================================================================
part                   what (settings from the params file's section, default params.full.yaml)
=====================  ==========================================================================
`sec61_subspace`     §6.1: `sessions` Rprop + MSE sessions on block 5 (1323 nodes); one step
                       per session; F mean ± σ over the sessions (`sec61_subspace`)
`sec62_puma560`      §6.2: the 7 block subspaces of the 21³ map, one step per block, then the
                       stacked model on the whole map and on the PUMA560 (`sec62_puma560`)
`table1_<dataset>`   Table 1, one row per part (`table1_workspaces`: `table1_r3_step1`, ...)
`table2_rprop_mse`   Table 2's Rprop + MSE cell, one step per session (`table2_optimisers`)
`table3_<embedding>` Table 3, one model (embedding) per part, tested on all three test sets
                       (`table3_embeddings`: `table3_subspace`, `table3_workspace`,
                       `table3_nosubspace`)
=====================  ==========================================================================

The parts are those of the paper's parts (`wsmap.paper.parts`) whose record carries a
`wsmap.paper.scale.Scale` (their module's `SCALE`), in the registry's order: the part's
module plans its units from its params section, runs one step and summarises the finished steps
(`Scale.plan`, `Scale.step`, `Scale.finalize`); this runner knows no part by name. Every part
trains with the package's own code (`wsmap.paper.fitting.fit`, scored by
`wsmap.paper.tables.score_results` / `wsmap.paper.fitting.evaluate`), summarised by
the code the notebooks use (`wsmap.paper.parts.sec61_subspace.summarise`,
`wsmap.paper.parts.sec62_puma560.summarise` and `puma560_map`, the `tables` summaries),
at exactly the params file's settings; §6.1's and §6.2's `metrics` follow the parts'
`PaperScaleMetrics` schemas. The command is `wsmap paper full` (`python -m wsmap paper full`):
this module has no entry point of its own, so that it never imports the command line. The datasets are
built on demand at the params file's sizes (`datasets` section) into `data/full/` (not a DVC
output; git-ignored) with `wsmap.paper.specs.build_pair`, and rebuilt when a file there is of
another size or spec.

Files (`--out`, default `results/full/`)
-------------------------------------------
`<part>.json`
    `settings` (everything the result depends on: the section's values, the full
    `TrainConfig`, each dataset's spec and sizes), `settings_hash`
    (SHA-256 of their canonical JSON), `analysis` (not hashed: how the finished steps are
    summarised, §6.1's `sweep_points`; another value summarises them again without training),
    `metrics` (with every session's scores, `runs`; §6.1 also its best session's threshold sweep),
    `steps` (each step's timings and a one-line summary; a §6.2 block's scores too),
    `timings` (datasets, steps, finalisation), `wall_seconds` (all steps, also those of
    earlier, interrupted runs, plus this run's data and finalisation), `device`, `machine`.
`<part>.history.json`
    every step's per-epoch training record (loss, validation loss, gradient norm, time).
`steps/<part>/<step>.json`, `models/<part>/<step>.pt`
    a finished step (one session or block, with its scores and training record) and its model:
    what lets an interrupted part resume with its next step. The step files are small and
    committed, so a part resumes on a fresh checkout too (a long part outlives a work session);
    the models are not (git-ignored): a §6.2 block (its model goes into the stacked model) or a
    §6.1 session (the best one's model is swept) runs again without its model.
    `models/sec62_puma560.pt` is the stacked 7-block model.
`estimates.json`
    `--estimate`: measured seconds per epoch of each part.

Resuming
--------
A part whose `<part>.json` holds the same `settings_hash` is skipped; a changed setting (or a
changed dataset size) gives another hash, and the part runs again (its old file stays until the
new one replaces it). Within a part, finished steps with the same hash are reused. Every file is
written atomically (`wsmap.io`): a run killed at any moment leaves the files it had finished
and no partial one. The `device` setting is recorded but not hashed: a result does not depend
on where it was computed beyond float rounding, so a CPU result is not recomputed on a GPU.
Delete `<part>.json` and `steps/<part>/` to force a rerun.

Devices
-------
Every section's `device` (`auto`: the GPU when torch sees one) or `--device` for all; it is
resolved (`cuda` without a GPU: an error) before any dataset is built or loaded.

Estimates
---------
`--list` shows each part's state, steps done, and its time: measured for finished parts; for
the others the estimate from `estimates.json` (`--estimate`: a few epochs of each part timed
on random data of the part's exact shapes, on the part's device), else a rough count of floating-
point operations at `CPU_GFLOPS` (measured on the 2-core development machine). Both scale
the epoch time by `max_epochs × steps`: an upper bound where validation stopping ends a run
early (§6.2's `max_fail` 100). Dataset builds come on top (`data_estimate`).
"""

from __future__ import annotations

import datetime as _dt
import fnmatch
import json
import math
import os
import platform
import subprocess
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .. import paths
from . import parts as paper_parts
from .scale import RUNNER_VERSION, Data, Planner, Unit, relative, settings_hash, step_hash

__all__ = [
    "RUNNER_VERSION",
    "CPU_GFLOPS",
    "Unit",
    "plan",
    "select",
    "settings_hash",
    "step_hash",
    "part_state",
    "run_step",
    "run_part",
    "run",
    "list_lines",
    "flop_estimate",
    "estimate_part",
    "estimate",
    "data_estimate",
    "fmt_seconds",
    "machine_facts",
    "default_out",
    "default_data",
]

#: Sustained float32 GFLOP/s of full-batch Rprop epochs on the development machine (2 cores, no
#: GPU, nothing else running): 70-92 in `--estimate` runs of the paper's shapes (§6.1, Table 2,
#: Table 1 rows). `--list` uses it for parts without a timed estimate; smaller networks (Table 3)
#: run below it, a loaded machine far below.
CPU_GFLOPS = 80.0
#: Seconds per label of an exact (closed-form) dataset build and per arm of a numerical one
#: (README "Scale": 1e5 arms x 9261 nodes in 12 s; the no-subspace arms: 812 s for 16 000 arms
#: on two threads in `wsmap paper full table3_subspace`, 2026-12-02, the machine otherwise idle).
EXACT_SECONDS_PER_LABEL = 1.3e-8
NUMERICAL_SECONDS_PER_ARM = 0.051

Log = Callable[[str], Any]


def default_out() -> Path:
    return paths.RESULTS / "full"


def default_data() -> Path:
    return paths.DATA / "full"


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


# --------------------------------------------------------------------------------------------
# Parts
# --------------------------------------------------------------------------------------------


def plan(params_file=None, *, device: str | None = None) -> list[Unit]:
    """Every part of the params file (default `params.full.yaml`), in run order: the units
    each paper part with a `Scale` plans from its params section (`Scale.plan`).

    `device`: one `device` setting for every part (`--device`); `None`: each section's.
    Missing sections or keys are errors naming the file and section (nothing has run yet).
    """
    params_file = Path(params_file) if params_file else paths.ROOT / "params.full.yaml"
    planner = Planner(params_file, device)
    units = [unit for part in paper_parts.registry().values() if part.scale is not None
             for unit in part.scale.plan(planner.section(part.name), planner)]
    names = [u.name for u in units]
    if len(set(names)) != len(names):
        raise ValueError(f"two parts share a name: {names}")
    return units


def select(parts: Sequence[Unit], names: Sequence[str]) -> list[Unit]:
    """The parts named by `names` (exact names, shell patterns such as `table1_*`, or a group:
    `sec61`, `sec62`, `table1`, `table2`, `table3`), in run order; none given: all.

    Raises `ValueError` (one line, listing the known parts) for a name that matches nothing.
    """
    if not names:
        return list(parts)
    chosen: set[str] = set()
    for n in names:
        hits = [p.name for p in parts if n in (p.name, p.kind) or fnmatch.fnmatchcase(p.name, n)]
        if not hits:
            raise ValueError(f"unknown part {n!r}; known: {', '.join(p.name for p in parts)} "
                             f"(or a group: {', '.join(dict.fromkeys(p.kind for p in parts))})")
        chosen.update(hits)
    return [p for p in parts if p.name in chosen]


# --------------------------------------------------------------------------------------------
# State on disk
# --------------------------------------------------------------------------------------------


def _part_file(out: Path, part: Unit) -> Path:
    return out / f"{part.name}.json"


def _history_file(out: Path, part: Unit) -> Path:
    return out / f"{part.name}.history.json"


def _step_file(out: Path, part: Unit, step: str) -> Path:
    return out / "steps" / part.name / f"{step}.json"


def _read_json(path: Path) -> dict | None:
    try:
        with open(path) as f:
            data = json.load(f)
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def _write_json(path: Path, data: dict) -> None:
    """`data` to `path` atomically, as the step files are written (one line)."""
    from ..io import atomic_path, jsonable

    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(jsonable(data), allow_nan=False) + "\n")


def _step_matches(data: dict, part: Unit) -> bool:
    # step files before step_hash carry only the hash of their part's settings
    return data.get("step_hash", data.get("settings_hash")) in (part.step_hash, part.hash)


def _done_step(out: Path, part: Unit, step: str) -> dict | None:
    """A finished step's record, or None: its step file, else its record in a finished result of
    the same settings but another number of sessions (`Unit.step_hash`). The step files are
    committed and the models are not, so on a fresh checkout a step whose model the part's
    finalisation needs (`Scale.loads_models`) counts as not done."""
    data = _read_json(_step_file(out, part, step))
    if data is None or data.get("step") != step or not _step_matches(data, part):
        data = _step_from_result(out, part, step)
    if data is None:
        return None
    if part.scale.loads_models and not part.model_file(out, step).is_file():
        return None
    return data


def _step_from_result(out: Path, part: Unit, step: str) -> dict | None:
    """Step `step` (`session_<k>`) rebuilt from the part's finished `<part>.json` and its
    history when that result's settings differ from `part`'s in the number of sessions only: its
    score rows (without the columns `Scale.finalize` added), timings and training record, as its
    step file held them."""
    result = _read_json(_part_file(out, part))
    if (result is None or not part.scale.sessions or not isinstance(result.get("settings"), dict)
            or step_hash(result["settings"]) != part.step_hash or not step.startswith("session_")):
        return None
    k = int(step.split("_")[1])
    added = part.scale.added_columns
    rows = [{c: v for c, v in r.items() if c not in added}
            for r in result.get("metrics", {}).get("runs", []) if r.get("session") == k]
    entry = next((s for s in result.get("steps", []) if s.get("step") == step), None)
    history = (_read_json(_history_file(out, part)) or {})
    if not rows or entry is None or history.get("settings_hash") != result.get("settings_hash"):
        return None
    return {"part": part.name, "step": step, "settings_hash": result["settings_hash"], "step_hash": part.step_hash,
            "seconds": entry["seconds"], "finished": entry["finished"], "device": entry["device"],
            "metrics": {"rows": rows}, "history": history.get("steps", {}).get(step, {}), "timings": entry["timings"],
            "from_result": True}


def _is_done(result: dict | None, part: Unit) -> bool:
    return (result is not None and result.get("settings_hash") == part.hash
            and result.get("analysis", {}) == part.analysis)


def part_state(part: Unit, out) -> dict[str, Any]:
    """`state`: `done` (a result with this part's settings hash), `partial` (some steps
    done), `stale` (a result from other settings; no step of the current ones yet) or
    `pending`; `steps_done`; `seconds` (measured: the result's `wall_seconds`, or the
    finished steps' sum)."""
    out = Path(out)
    data = _read_json(_part_file(out, part))
    if _is_done(data, part):
        return {"state": "done", "steps_done": len(part.steps), "seconds": data.get("wall_seconds"),
                "device": (data.get("device") or {}).get("used")}
    steps = [d for s in part.steps if (d := _done_step(out, part, s)) is not None]
    seconds = sum(float(d.get("seconds", 0.0)) for d in steps)
    state = "partial" if steps else ("stale" if data is not None else "pending")
    return {"state": state, "steps_done": len(steps), "seconds": seconds if steps else None, "device": None}


# --------------------------------------------------------------------------------------------
# Facts about the run
# --------------------------------------------------------------------------------------------


def _git_commit() -> str | None:
    try:
        r = subprocess.run(["git", "rev-parse", "HEAD"], cwd=paths.ROOT, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() or None if r.returncode == 0 else None


def machine_facts() -> dict[str, Any]:
    """The machine a part ran on: host, platform, CPUs, memory (GiB), load, the versions of
    Python, torch, numpy and wsmap, torch's threads, whether CUDA is there, the git commit."""
    import numpy as np
    import torch

    from .._version import __version__

    try:
        memory_gib = round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)
    except (ValueError, OSError, AttributeError):
        memory_gib = None
    return {
        "host": platform.node(), "platform": platform.platform(), "processor": platform.processor() or None,
        "cpus": os.cpu_count(), "memory_gib": memory_gib, "load_average": list(os.getloadavg()),
        "python": platform.python_version(), "torch": torch.__version__, "numpy": np.__version__,
        "torch_threads": torch.get_num_threads(), "cuda_available": torch.cuda.is_available(),
        "wsmap": __version__, "git_commit": _git_commit(),
    }


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------


def run_step(part: Unit, step: str, data: Data, out: Path, device) -> dict:
    """Run step `step` of `part` (its `Scale.step`) and write its step file (atomically);
    returns the step's record (its `metrics`, `history`, `timings`, `seconds`, hashes)."""
    t0 = time.perf_counter()
    result = part.scale.step(part, step, data, out)
    seconds = time.perf_counter() - t0
    done = {"part": part.name, "step": step, "settings_hash": part.hash, "step_hash": part.step_hash,
            "seconds": seconds, "finished": _now(), "device": str(device), **result}
    _write_json(_step_file(out, part, step), done)
    return done


def _run_steps(part: Unit, data: Data, out: Path, device, log: Log) -> tuple[dict[str, dict], dict[str, dict]]:
    """Every step of `part`, those finished earlier reused: (step -> record, step -> training
    record), in step order."""
    step_results: dict[str, dict] = {}
    histories: dict[str, dict] = {}
    for step in part.steps:
        done = _done_step(out, part, step)
        if done is not None:
            if done.pop("from_result", False):  # its own file from now on: the result is about to be replaced
                _write_json(_step_file(out, part, step), done)
            log(f"  {step}: done earlier ({fmt_seconds(done.get('seconds'))}), reused")
        else:
            log(f"  {step}: running ...")
            done = run_step(part, step, data, out, device)
            log(f"  {step}: {fmt_seconds(done['seconds'])}; {part.scale.summary(part, done)}")
        histories[step] = done.pop("history", {})
        step_results[step] = done
    return step_results, histories


def _steps_entries(part: Unit, step_results: dict[str, dict]) -> list[dict]:
    # per step: its timings (the per-session scores are metrics["runs"]; a block's are here)
    return [{"step": name, "seconds": s["seconds"], "finished": s["finished"], "device": s["device"],
             "summary": part.scale.summary(part, s), "timings": s["timings"],
             **({"metrics": s["metrics"]} if part.scale.step_metrics else {})}
            for name, s in step_results.items()]


def _write_result(part: Unit, out: Path, result: dict, histories: dict[str, dict]) -> None:
    """The result file and the history file: both or neither; the result file, last of all,
    marks the part done."""
    from ..io import atomic_paths, jsonable

    text = json.dumps(jsonable(result), indent=1, allow_nan=False) + "\n"
    history_text = json.dumps(jsonable({"part": part.name, "settings_hash": part.hash, "steps": histories}),
                              allow_nan=False) + "\n"
    with atomic_paths([_history_file(out, part), _part_file(out, part)]) as (h, r):
        Path(h).write_text(history_text)
        Path(r).write_text(text)


def run_part(part: Unit, out=None, data_dir=None, *, log: Log = print) -> dict:
    """Run `part` (skipped when done; finished steps reused) and write `<out>/<part>.json`.

    Returns the result dict (the file's content), or the existing one when the part was done.
    """
    from ..learn.device import device_facts, resolve_device

    out = Path(out) if out is not None else default_out()
    data_dir = Path(data_dir) if data_dir is not None else default_data()
    existing = _read_json(_part_file(out, part))
    if _is_done(existing, part):
        log(f"{part.name}: done ({fmt_seconds(existing.get('wall_seconds'))}), skipped")
        return existing
    device = resolve_device(part.device, part.device_what)  # before any work
    started, t_start = _now(), time.perf_counter()
    machine = machine_facts()
    log(f"{part.name}: {part.title}; {len(part.steps)} step(s) on {device}")
    data = Data(part, data_dir, log)
    step_results, histories = _run_steps(part, data, out, device, log)
    t0 = time.perf_counter()
    metrics, extra_files = part.scale.finalize(part, step_results, data, out)
    finalize_s = time.perf_counter() - t0
    data_s = sum(sum(t.values()) for t in data.timings.values())
    steps_s = sum(float(s["seconds"]) for s in step_results.values())
    result = {
        "part": part.name, "title": part.title, "kind": part.kind, "settings_hash": part.hash,
        "settings": part.settings, "analysis": part.analysis, "params_section": part.section,
        "metrics": metrics, "steps": _steps_entries(part, step_results),
        "timings": {"datasets": data.timings, "steps": {k: s["seconds"] for k, s in step_results.items()},
                    "finalize_s": finalize_s},
        "wall_seconds": steps_s + data_s + finalize_s,
        "wall_seconds_this_run": time.perf_counter() - t_start,
        "device": {"setting": part.device, "from": part.device_what, "used": str(device), **device_facts(device)},
        "machine": {**machine, "load_average_end": list(os.getloadavg())},
        "files": [relative(p, out) for p in extra_files],
        "started": started, "finished": _now(),
    }
    _write_result(part, out, result, histories)
    log(f"{part.name}: done in {fmt_seconds(result['wall_seconds'])} -> {_part_file(out, part)}")
    return result


def _checked(names: Sequence[str], params_file, device: str | None) -> list[Unit]:
    """The selected parts, every name, section, key and device checked (nothing built yet)."""
    from ..learn.device import resolve_device

    parts = select(plan(params_file, device=device), names)
    for p in parts:
        resolve_device(p.device, p.device_what)
    return parts


def run(names: Sequence[str] = (), params_file=None, out=None, data_dir=None, *, device: str | None = None,
        log: Log = print) -> list[dict]:
    """Run the selected parts (`select`) of `params_file` in order. Every name, section,
    key and device is checked before anything is built, loaded or written."""
    from ..io import check_output_path

    parts = _checked(names, params_file, device)
    out = Path(out) if out is not None else default_out()
    data_dir = Path(data_dir) if data_dir is not None else default_data()
    check_output_path(out / "x.json", "--out")
    check_output_path(data_dir / "x.npz", "--data")
    return [run_part(p, out, data_dir, log=log) for p in parts]


# --------------------------------------------------------------------------------------------
# Estimates and the listing
# --------------------------------------------------------------------------------------------


def _layer_macs(n_inputs: int, hidden: Sequence[int], n_outputs: int) -> int:
    sizes = [n_inputs, *hidden, n_outputs]
    return sum(a * b for a, b in zip(sizes[:-1], sizes[1:]))


def _shape(part: Unit) -> dict[str, int]:
    """Inputs, outputs (`Scale.step_nodes`, else the dataset's nodes), training and validation
    samples of one step of `part`."""
    from .specs import paper_spec

    sec = part.values
    spec = paper_spec(sec["dataset"])
    samples = part.datasets[sec["dataset"]]["samples"]
    n = min(int(sec["train_samples"] or samples), samples)
    fr = part.settings["train_config"]["fractions"]
    n_val, n_test = int(round(fr[1] * n)), int(round(fr[2] * n))
    m = part.scale.step_nodes if part.scale.step_nodes is not None else spec.n_nodes
    return {"n": n, "n_train": n - n_val - n_test, "n_val": n_val, "f": spec.n_features, "m": m}


def flop_estimate(part: Unit, gflops: float = CPU_GFLOPS) -> float:
    """Seconds of `part`'s training at `gflops`: per epoch a forward and backward pass over the
    training split (3 x 2 x MACs) and a forward pass over the validation split, x `max_epochs`
    x steps."""
    s = _shape(part)
    macs = _layer_macs(s["f"], part.values["hidden"], s["m"])
    per_epoch = 2 * macs * (3 * s["n_train"] + s["n_val"]) / (gflops * 1e9)
    return per_epoch * int(part.values["max_epochs"]) * len(part.steps)


def data_estimate(part: Unit, data_dir=None, counted: set | None = None) -> float:
    """Seconds to build the part's datasets missing from `data_dir` (file existence only):
    `EXACT_SECONDS_PER_LABEL` per label for closed-form labels,
    `NUMERICAL_SECONDS_PER_ARM` per arm for numerical ones. `counted`: names already
    counted for an earlier part (a dataset is built once for all parts); this part's are added."""
    from .specs import dataset_paths, paper_spec

    data_dir = Path(data_dir) if data_dir is not None else default_data()
    counted = set() if counted is None else counted
    total = 0.0
    for name, sizes in part.datasets.items():
        if name in counted or all(p.exists() for p in dataset_paths(name, data_dir)):
            continue
        counted.add(name)
        spec = paper_spec(name)
        arms = sizes["samples"] + sizes["test_samples"]
        total += (arms * NUMERICAL_SECONDS_PER_ARM if spec.method == "numerical"
                  else arms * spec.n_nodes * EXACT_SECONDS_PER_LABEL)
    return total


def estimate_part(part: Unit, epochs: int = 4) -> dict[str, Any]:
    """Time `epochs` epochs of one step of `part` on random data of its exact shapes (features,
    nodes, training and validation samples, network, optimiser) on its device; no dataset needed.

    Returns `seconds_per_epoch` (the fastest of epochs 2..`epochs`: the first step's set-up and
    a GPU's warm-up left out, and on a shared machine as little of the other processes' load as
    possible; `seconds_per_epoch_median` beside it, and the load average) and `estimate_s` =
    that x `max_epochs` x steps.
    """
    import numpy as np
    import torch

    from ..learn import MLPConfig, SubspaceMLP
    from ..learn.device import resolve_device
    from ..learn.training import split_indices, train
    from .tables import mlp_options

    device = resolve_device(part.device, part.device_what)
    s = _shape(part)
    sec = part.values
    rng = np.random.default_rng(0)
    X = rng.uniform(0.0, 0.5, size=(s["n"], s["f"]))
    Y = torch.rand(s["n"], s["m"], generator=torch.Generator().manual_seed(0)) < 0.3
    Y = Y.to(torch.float32)
    cfg = part.train_config.replace(max_epochs=int(epochs), max_fail=10**6)
    split = split_indices(s["n"], cfg.fractions, cfg.seed)
    mlp = MLPConfig(n_inputs=s["f"], n_outputs=s["m"], hidden=list(sec["hidden"]), **mlp_options(cfg.loss))
    model = SubspaceMLP(mlp, seeds=[0]).configure(X[split.train], seeds=[0])
    res = train(model, X, Y, cfg, split=split)
    t = np.asarray(res.history.time)
    deltas = np.diff(t[1:]) if len(t) > 2 else np.diff(t)  # epoch e's step + evaluation, e >= 2
    per_epoch = float(deltas.min())
    del res, model, Y
    total = per_epoch * int(sec["max_epochs"]) * len(part.steps)
    return {"settings_hash": part.hash, "device": str(device), "seconds_per_epoch": per_epoch,
            "seconds_per_epoch_median": float(np.median(deltas)), "estimate_s": total, "epochs_timed": int(epochs),
            "shape": s, "measured": _now(), "load_average": list(os.getloadavg()), "cpus": os.cpu_count(),
            "torch_threads": torch.get_num_threads()}


def _estimates_file(out: Path) -> Path:
    return out / "estimates.json"


def estimate(names: Sequence[str] = (), params_file=None, out=None, *, device: str | None = None,
             epochs: int = 4, log: Log = print) -> dict[str, dict]:
    """`estimate_part` for every selected part that is not done; merged into
    `<out>/estimates.json` (written atomically)."""
    from ..io import write_json

    parts = _checked(names, params_file, device)
    out = Path(out) if out is not None else default_out()
    known = _read_json(_estimates_file(out)) or {}
    for p in parts:
        if part_state(p, out)["state"] == "done":
            continue
        e = estimate_part(p, epochs)
        known[p.name] = e
        log(f"{p.name}: {e['seconds_per_epoch']:.3f} s per epoch on {e['device']} -> ≈ {fmt_seconds(e['estimate_s'])} "
            f"for {p.values['max_epochs']} epochs x {len(p.steps)} step(s)")
        write_json(known, _estimates_file(out))
    return known


def fmt_seconds(s) -> str:
    """A wall time as the listing prints it: `"45 s"`, `"4 min"`, `"3.2 h"`; `"?"` for none."""
    if s is None or (isinstance(s, float) and not math.isfinite(s)):
        return "?"
    s = float(s)
    if s < 120:
        return f"{s:.0f} s"
    if s < 2 * 3600:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


def _device_name(part: Unit) -> str:
    from ..learn.device import resolve_device

    try:
        return str(resolve_device(part.device, part.device_what))
    except ValueError:
        return f"{part.device} (unavailable)"


def _pending_time(part: Unit, state: dict, dev: str, estimates: dict, data_dir, counted: set
                  ) -> tuple[float | None, str]:
    """Seconds still to run for a part not done, and how they were found (`timed`, `flops`
    or `run --estimate` where there is no estimate), the datasets still to build included."""
    left = (len(part.steps) - state["steps_done"]) / len(part.steps)
    e = estimates.get(part.name)
    if isinstance(e, dict) and e.get("settings_hash") == part.hash and e.get("device") == dev:
        seconds, how = float(e["estimate_s"]) * left, "timed"
    elif dev == "cpu":
        seconds, how = flop_estimate(part) * left, "flops"
    else:
        seconds, how = None, "run --estimate"
    data_s = data_estimate(part, data_dir, counted)  # each missing dataset with the first part needing it
    if seconds is not None:
        seconds += data_s
        if data_s > 0:
            how += f" + data {fmt_seconds(data_s)}"
    return seconds, how


def list_lines(params_file=None, out=None, data_dir=None, *, device: str | None = None,
               names: Sequence[str] = ()) -> list[str]:
    """The `--list` table: one line per part (state, steps done, time), then the totals.

    Time: `measured` for a finished part (its wall time); otherwise `timed` (from
    `estimates.json`, matching settings) or `flops` (`flop_estimate`, CPU only) for the
    steps still to run, plus `data` for datasets still to build. Changes nothing on disk.
    """
    parts = select(plan(params_file, device=device), names)
    out = Path(out) if out is not None else default_out()
    estimates = _read_json(_estimates_file(out)) or {}
    rows = [("part", "state", "steps", "time", "how", "device")]
    pending_total, unknown, counted = 0.0, [], set()
    for p in parts:
        st, dev = part_state(p, out), _device_name(p)
        steps = f"{st['steps_done']}/{len(p.steps)}"
        if st["state"] == "done":
            rows.append((p.name, "done", steps, fmt_seconds(st["seconds"]), "measured", st.get("device") or dev))
            continue
        seconds, how = _pending_time(p, st, dev, estimates, data_dir, counted)
        if seconds is None:
            unknown.append(p.name)
        else:
            pending_total += seconds
        bound = "≤ " if p.scale.stops_early else "≈ "  # validation stopping: the epochs are a bound
        rows.append((p.name, st["state"], steps, bound + fmt_seconds(seconds) if seconds is not None else "?",
                     how, dev))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    done = sum(1 for r in rows[1:] if r[1] == "done")
    tail = f"{done} of {len(parts)} parts done; still to run ≈ {fmt_seconds(pending_total)}"
    if unknown:
        tail += f" + {len(unknown)} part(s) without an estimate"
    lines.append(tail)
    return lines
