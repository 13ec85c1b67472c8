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

Every part trains with the package's own code (`wsmap.paper.fitting.fit`, scored by
`wsmap.paper.tables.score_results` / `wsmap.paper.fitting.evaluate`), summarised by
the code the notebooks' parts use (`wsmap.paper.parts.sec61_subspace.summarise`,
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
import hashlib
import json
import math
import os
import platform
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import paths
from . import fitting, tables
from .parts import check_metrics, sec61_subspace, sec62_puma560
from .specs import dataset_sizes
from .specs import whole_param as _whole

__all__ = [
    "RUNNER_VERSION",
    "CPU_GFLOPS",
    "Part",
    "plan",
    "select",
    "settings_hash",
    "part_state",
    "run_part",
    "run",
    "list_lines",
    "estimate_part",
    "estimate",
    "data_estimate",
    "default_out",
    "default_data",
]

#: Bumped when what a part computes changes, so that old results are not taken for new ones.
RUNNER_VERSION = 1
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


@dataclass
class Part:
    """One resumable unit of work and everything its result depends on.

    `settings` is hashed (`settings_hash`); `device` is the requested setting (`auto`,
    `cpu`, `cuda`) and `device_what` names where it came from, for error messages.
    `analysis`: settings of the summary drawn from the finished steps (§6.1's threshold sweep),
    not of the training: not hashed, so a change summarises the same steps again (no retraining);
    recorded in the result, and a result with other ones is not done.
    """

    name: str
    kind: str  # sec61, sec62, table1, table2, table3
    section: str
    settings: dict[str, Any]
    steps: list[str]
    datasets: dict[str, dict[str, int]]  # name -> {"samples", "test_samples"}
    device: str
    device_what: str
    title: str = ""
    analysis: dict[str, Any] = field(default_factory=dict)

    @property
    def hash(self) -> str:
        return settings_hash(self.settings)

    @property
    def step_hash(self) -> str:
        """The hash a finished step is matched by: the settings without the number of sessions
        (session `k` trains with seed `seed + k` whatever their number), so that raising
        `sessions` reuses the sessions already run."""
        return step_hash(self.settings)

    @property
    def train_config(self):
        from ..learn.training import TrainConfig

        return TrainConfig.from_dict({**self.settings["train_config"], "device": self.device})


def settings_hash(settings: dict) -> str:
    """`sha256:<hex>` of the canonical JSON of `settings` (sorted keys, no spaces)."""
    from ..io import jsonable

    text = json.dumps(jsonable(settings), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


def step_hash(settings: dict) -> str:
    """`settings_hash` of `settings` without `section.sessions` (see `Part.step_hash`)."""
    section = {k: v for k, v in settings.get("section", {}).items() if k != "sessions"}
    return settings_hash({**settings, "section": section})


def _dataset_settings(names: Sequence[str], sizes: dict, source: str = "the params file") -> dict[str, dict]:
    from ..datasets.spec import scaled
    from .specs import paper_spec

    return {name: {**s, "spec": scaled(paper_spec(name), s["samples"]).to_dict()}
            for name, s in dataset_sizes(names, sizes, source).items()}


def plan(params_file=None, *, device: str | None = None) -> list[Part]:
    """Every part of the params file (default `params.full.yaml`), in run order.

    `device`: one `device` setting for every part (`--device`); `None`: each section's.
    Missing sections or keys are errors naming the file and section (nothing has run yet).
    """
    from ..learn.training import TrainConfig
    from ..workspace import N_BLOCKS

    params_file = Path(params_file) if params_file else paths.ROOT / "params.full.yaml"
    sizes = paths.load_params("datasets", params_file)

    def section(name):
        return paths.notebook_params(name, params_file)

    def dev(cfg):
        if device is not None:
            return device, "--device"
        return cfg["device"], f"{cfg.source} device"

    def train_config(optimizer, loss, max_epochs, max_fail, seed, where="the params file") -> dict:
        d = TrainConfig(optimizer=optimizer, loss=loss, max_epochs=_whole(where, "max_epochs", max_epochs, 1),
                        max_fail=_whole(where, "max_fail", max_fail, 1), seed=_whole(where, "seed", seed)).to_dict()
        d.pop("device")
        return d

    def sessions(cfg, n=None) -> list[str]:
        n = cfg["sessions"] if n is None else n
        return [f"session_{k}" for k in range(_whole(cfg.source, "sessions", n, 1))]

    def make(name, kind, cfg, steps, datasets, values, tc, title, analysis=None):
        data = _dataset_settings(datasets, sizes, params_file.name)
        settings = {"runner_version": RUNNER_VERSION, "part": name, "kind": kind, "section": values,
                    "train_config": tc, "datasets": data}
        d, what = dev(cfg)
        return Part(name=name, kind=kind, section=cfg.source, settings=settings, steps=steps,
                    datasets={k: {"samples": v["samples"], "test_samples": v["test_samples"]} for k, v in data.items()},
                    device=d, device_what=what, title=title, analysis=dict(analysis or {}))

    parts: list[Part] = []
    c = section("sec61_subspace")
    values = {k: c[k] for k in ("dataset", "train_samples", "sessions", "max_epochs", "max_fail", "hidden", "seed",
                                "threshold")}
    parts.append(make("sec61_subspace", "sec61", c, sessions(c),
                      [c["dataset"]], values,
                      train_config("rprop", "mse", c["max_epochs"], c["max_fail"], c["seed"], c.source),
                      "§6.1: block-5 subspace, Rprop + MSE sessions",
                      analysis={"sweep_points": _whole(c.source, "sweep_points", c["sweep_points"], 2)}))
    c = section("sec62_puma560")
    values = {k: c[k] for k in ("dataset", "train_samples", "max_epochs", "max_fail", "hidden", "seed", "threshold")}
    parts.append(make("sec62_puma560", "sec62", c, [f"block_{k + 1}" for k in range(N_BLOCKS)], [c["dataset"]],
                      values, train_config("rprop", "mse", c["max_epochs"], c["max_fail"], c["seed"], c.source),
                      "§6.2: 7 block subspaces, stacked; PUMA560"))
    c = section("table1_workspaces")
    for name in c["datasets"]:
        max_epochs = _whole(f"{c.source}, dataset {name!r}", "max_epochs",
                            tables.per_dataset(c["max_epochs"], name), 1)
        n_sessions = _whole(f"{c.source}, dataset {name!r}", "sessions", tables.per_dataset(c["sessions"], name), 1)
        values = {"dataset": name, "train_samples": tables.per_dataset(c["train_samples"], name), "sessions": n_sessions,
                  "max_epochs": max_epochs, "max_fail": c["max_fail"], "hidden": c["hidden"], "seed": c["seed"],
                  "optimizer": c["optimizer"], "loss": c["loss"], "threshold": 0.5}
        parts.append(make(name, "table1", c, sessions(c, n_sessions), [name], values,
                          train_config(c["optimizer"], c["loss"], max_epochs, c["max_fail"], c["seed"], c.source),
                          f"Table 1 row {name}"))
    c = section("table2_optimisers")
    values = {k: c[k] for k in ("dataset", "train_samples", "sessions", "max_epochs", "max_fail", "hidden", "seed")}
    values.update(optimizer="rprop", loss="mse", threshold=0.5)
    parts.append(make("table2_rprop_mse", "table2", c, sessions(c),
                      [c["dataset"]], values,
                      train_config("rprop", "mse", c["max_epochs"], c["max_fail"], c["seed"], c.source),
                      "Table 2: Rprop + MSE cell"))
    c = section("table3_embeddings")
    embeddings = dict(c["embeddings"])
    for emb, dataset in embeddings.items():
        values = {"embedding": emb, "dataset": dataset, "embeddings": embeddings,
                  "train_samples": tables.per_dataset(c["train_samples"], emb), "sessions": c["sessions"],
                  "max_epochs": c["max_epochs"], "max_fail": c["max_fail"], "hidden": c["hidden"], "seed": c["seed"],
                  "optimizer": c["optimizer"], "loss": c["loss"], "threshold": 0.5}
        parts.append(make(f"table3_{emb}", "table3", c, sessions(c),
                          list(embeddings.values()), values,
                          train_config(c["optimizer"], c["loss"], c["max_epochs"], c["max_fail"], c["seed"], c.source),
                          f"Table 3: {emb} model on the three test sets"))
    names = [p.name for p in parts]
    if len(set(names)) != len(names):
        raise ValueError(f"two parts share a name: {names}")
    return parts


def select(parts: Sequence[Part], names: Sequence[str]) -> list[Part]:
    """The parts named by `names` (exact names, shell patterns such as `table1_*`, or a group:
    `sec61`, `sec62`, `table1`, `table2`, `table3`), in run order; none given: all.

    Raises `ValueError` (one line, listing the known parts) for a name that matches nothing.
    """
    if not names:
        return list(parts)
    chosen: set[str] = set()
    for n in names:
        hits = [p.name for p in parts if p.name == n or p.kind == n or fnmatch.fnmatchcase(p.name, n)]
        if not hits:
            raise ValueError(f"unknown part {n!r}; known: {', '.join(p.name for p in parts)} "
                             f"(or a group: {', '.join(dict.fromkeys(p.kind for p in parts))})")
        chosen.update(hits)
    return [p for p in parts if p.name in chosen]


# --------------------------------------------------------------------------------------------
# State on disk
# --------------------------------------------------------------------------------------------


def _part_file(out: Path, part: Part) -> Path:
    return out / f"{part.name}.json"


def _history_file(out: Path, part: Part) -> Path:
    return out / f"{part.name}.history.json"


def _step_file(out: Path, part: Part, step: str) -> Path:
    return out / "steps" / part.name / f"{step}.json"


def _model_file(out: Path, part: Part, step: str) -> Path:
    return out / "models" / part.name / f"{step}.pt"


def _read_json(path: Path) -> dict | None:
    try:
        with open(path) as f:
            data = json.load(f)
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


# parts whose finalisation loads the steps' models (§6.2 stacks its 7 block models into one file;
# §6.1 sweeps the threshold of its best session, known only once every session is done)
_FINALIZE_LOADS_MODELS = {"sec61", "sec62"}


# the columns _finalize adds to the steps' score rows (a step's rows are without them)
_FINALIZE_COLUMNS = {"table1": ("dataset",), "table2": ("optimizer", "loss"), "table3": ("embedding",)}


def _step_matches(data: dict, part: Part) -> bool:
    # step files before step_hash carry only the hash of their part's settings
    return data.get("step_hash", data.get("settings_hash")) in (part.step_hash, part.hash)


def _done_step(out: Path, part: Part, step: str) -> dict | None:
    """A finished step's record, or None: its step file, else its record in a finished result of
    the same settings but another number of sessions (`Part.step_hash`). The step files are
    committed and the models are not, so on a fresh checkout a step whose model the part's
    finalisation needs counts as not done."""
    data = _read_json(_step_file(out, part, step))
    if data is None or data.get("step") != step or not _step_matches(data, part):
        data = _step_from_result(out, part, step)
    if data is None:
        return None
    if part.kind in _FINALIZE_LOADS_MODELS and not _model_file(out, part, step).is_file():
        return None
    return data


def _step_from_result(out: Path, part: Part, step: str) -> dict | None:
    """Step `step` (`session_<k>`) rebuilt from the part's finished `<part>.json` and its
    history when that result's settings differ from `part`'s in the number of sessions only: its
    score rows, timings and training record, as its step file held them."""
    result = _read_json(_part_file(out, part))
    if (result is None or part.kind == "sec62" or not isinstance(result.get("settings"), dict)
            or step_hash(result["settings"]) != part.step_hash or not step.startswith("session_")):
        return None
    k = int(step.split("_")[1])
    added = _FINALIZE_COLUMNS.get(part.kind, ())
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


def _is_done(result: dict | None, part: Part) -> bool:
    return (result is not None and result.get("settings_hash") == part.hash
            and result.get("analysis", {}) == part.analysis)


def part_state(part: Part, out) -> dict[str, Any]:
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
# Data
# --------------------------------------------------------------------------------------------


class _Data:
    """The datasets of a part, loaded (built first where missing or of other sizes)."""

    def __init__(self, part: Part, data_dir: Path, log: Log):
        self.pairs: dict[str, tuple] = {}
        self.timings: dict[str, dict[str, float]] = {}
        for name, sizes in part.datasets.items():
            self.pairs[name] = self._ensure(name, sizes, part.settings["datasets"][name]["spec"], data_dir, log)

    def _ensure(self, name, sizes, spec, data_dir, log):
        from .specs import build_pair, dataset_paths, load_pair

        t0 = time.perf_counter()
        pair = None
        if all(p.exists() for p in dataset_paths(name, data_dir)):
            try:
                pair = load_pair(name, data_dir)
            except ValueError as e:  # corrupt or inconsistent: rebuilt below
                log(f"  dataset {name}: {e}; rebuilding")
            if pair is not None and (len(pair[0]) != sizes["samples"] or len(pair[1]) != sizes["test_samples"]
                                     or pair[0].spec.to_dict() != spec):
                log(f"  dataset {name}: {len(pair[0])}/{len(pair[1])} arms in {data_dir}, "
                    f"need {sizes['samples']}/{sizes['test_samples']} (or another spec); rebuilding")
                pair = None
        timing = {"load_s": time.perf_counter() - t0}
        if pair is None:
            log(f"  dataset {name}: building {sizes['samples']} + {sizes['test_samples']} arms into {data_dir} ...")
            t1 = time.perf_counter()
            build_pair(name, data_dir, sizes["samples"], sizes["test_samples"], progress=False)
            timing["build_s"] = time.perf_counter() - t1
            t2 = time.perf_counter()
            pair = load_pair(name, data_dir)
            timing["load_s"] += time.perf_counter() - t2
            log(f"  dataset {name}: built in {timing['build_s']:.1f} s")
        self.timings[name] = {k: round(v, 3) for k, v in timing.items()}
        return pair


# --------------------------------------------------------------------------------------------
# Steps and finalisation per kind
# --------------------------------------------------------------------------------------------


def _relative(path: Path, out: Path) -> str:
    """`path` relative to the result folder `out` when inside it (results stay valid when moved)."""
    try:
        return str(Path(path).resolve().relative_to(Path(out).resolve()))
    except ValueError:
        return str(path)


def _history(result) -> dict[str, list]:
    h = result.history.to_dict()
    return {k: [None if v is None or (isinstance(v, float) and not math.isfinite(v)) else round(float(v), 7)
                for v in vals] for k, vals in h.items() if vals}


def _save_model(model, path: Path, spec, config, extra: dict, **map_spec) -> None:
    from ..learn.files import save

    model.set_map_spec(spec, **map_spec)
    save(model, path, dataset_spec=spec, train_config=config, extra=extra)


def _tests(part: Part, data: _Data) -> dict:
    if part.kind == "table3":
        return {emb: data.pairs[name][1] for emb, name in part.settings["section"]["embeddings"].items()}
    name = part.settings["section"]["dataset"]
    return {name: data.pairs[name][1]}


def _session_step(part: Part, step: str, data: _Data, out: Path) -> dict:
    """One session (seed `seed + k`) of a sec61/table1/table2/table3 part: train, score, save."""

    k = int(step.split("_")[1])
    sec = part.settings["section"]
    train = data.pairs[sec["dataset"]][0].head(sec["train_samples"])
    config = part.train_config.replace(seed=int(sec["seed"]) + k)
    t0 = time.perf_counter()
    (result,) = fitting.fit(train, config, sessions=1, hidden=sec["hidden"], **tables.mlp_options(config.loss))
    t1 = time.perf_counter()
    rows = tables.score_results([result], train, _tests(part, data), float(sec["threshold"]), first_session=k)
    t2 = time.perf_counter()
    threshold = float(sec["threshold"])
    _save_model(result.model, _model_file(out, part, step), train.spec, config,
                {"part": part.name, "step": step, "settings_hash": part.hash}, threshold=threshold)
    t3 = time.perf_counter()
    return {"metrics": {"rows": rows}, "history": _history(result),
            "timings": {"train_s": t1 - t0, "score_s": t2 - t1, "save_s": t3 - t2,
                        "epochs": int(result.stop_epoch),
                        "seconds_per_epoch": (t1 - t0) / max(1, int(result.stop_epoch))}}


def _block_step(part: Part, step: str, data: _Data, out: Path) -> dict:
    """One §6.2 block (`block_k`, 1-based): as `wsmap.paper.fitting.fit_blocks` trains it."""
    from .. import workspace

    k = int(step.split("_")[1]) - 1
    sec = part.settings["section"]
    train_all, test = data.pairs[sec["dataset"]]
    train = train_all.head(sec["train_samples"])
    block = workspace.block_slice(k)
    config = part.train_config
    t0 = time.perf_counter()
    (result,) = fitting.fit(train, config, nodes=block, sessions=1, hidden=sec["hidden"])
    t1 = time.perf_counter()
    ev = fitting.evaluate(result.model, test, nodes=block, key=0, threshold=float(sec["threshold"]))
    t2 = time.perf_counter()
    _save_model(result.model, _model_file(out, part, step), train.spec, config,
                {"part": part.name, "step": step, "block": [block.start, block.stop], "settings_hash": part.hash},
                nodes=(block.start, block.stop), threshold=float(sec["threshold"]))
    t3 = time.perf_counter()
    metrics = {"block": k + 1, "nodes": [block.start, block.stop], "precision": ev["precision"],
               "recall": ev["recall"], "f": ev["f"], "f_per_sample": ev["f_mean"],
               "reachable": float(ev["truth"].mean()), "epochs": int(result.stop_epoch),
               "best_epoch": int(result.best_epoch), "stop_reason": result.stop_reason,
               "best_val_loss": float(result.best_val_loss), "train_samples": len(train),
               "seconds": float(result.history.time[-1])}
    return {"metrics": metrics, "history": _history(result),
            "timings": {"train_s": t1 - t0, "score_s": t2 - t1, "save_s": t3 - t2, "epochs": int(result.stop_epoch),
                        "seconds_per_epoch": (t1 - t0) / max(1, int(result.stop_epoch))}}


def _runs(steps: dict[str, dict]):
    import pandas as pd

    return pd.DataFrame([row for s in steps.values() for row in s["metrics"]["rows"]])


def _finalize(part: Part, steps: dict[str, dict], data: _Data, out: Path) -> tuple[dict, list[Path]]:
    """The part's metrics from its steps' (and, for §6.2, the stacked model file)."""

    sec = part.settings["section"]
    if part.kind == "sec62":
        return _finalize_sec62(part, steps, data, out)
    runs = _runs(steps)
    if part.kind == "sec61":
        best = int(runs.best_val_loss.to_numpy(dtype=float).argmin())
        sweep = _sec61_sweep(part, f"session_{int(runs.session.iloc[best])}", data, out)
        metrics = {**sec61_subspace.summarise(runs.to_dict("records"), sweep, threshold=float(sec["threshold"]),
                                              max_epochs=int(sec["max_epochs"]),
                                              train_samples=int(runs.train_samples.iloc[0])),
                   "sweep": sweep.to_dict()}
    elif part.kind == "table1":
        runs.insert(0, "dataset", sec["dataset"])
        row = tables.table1_summary(runs).iloc[0].to_dict()
        metrics = {**row, "sessions": int(len(runs))}
    elif part.kind == "table2":
        runs.insert(0, "loss", sec["loss"])
        runs.insert(0, "optimizer", sec["optimizer"])
        metrics = tables.table2_summary(runs).iloc[0].to_dict()
    elif part.kind == "table3":
        runs.insert(0, "embedding", sec["embedding"])
        summary = tables.table3_summary(runs)
        metrics = {"embedding": sec["embedding"],
                   "tests": {r["test"]: {k: v for k, v in r.items() if k not in ("embedding", "test")}
                             for r in summary.to_dict("records")}}
        own = metrics["tests"].get(sec["embedding"], {})
        metrics.update(f_own=own.get("f"), precision_own=own.get("precision"), recall_own=own.get("recall"))
    else:  # pragma: no cover - plan() makes no other kind
        raise ValueError(f"unknown part kind {part.kind!r}")
    metrics["runs"] = runs.to_dict("records")
    if part.kind == "sec61":
        check_metrics(metrics, sec61_subspace.PaperScaleMetrics, f"{part.name} (paper scale)")
    return metrics, []


def _sec61_sweep(part: Part, step: str, data: _Data, out: Path):
    """The threshold sweep of §6.1's best session (lowest validation loss), as the paper's: its
    model scored on the test set at `sweep_points` thresholds evenly from 0 to 1
    (`wsmap.paper.parts.sec61_subspace.sweep_of`)."""
    from ..learn.device import resolve_device
    from ..learn.files import load

    sec = part.settings["section"]
    model, _ = load(_model_file(out, part, step), map_location=resolve_device(part.device, part.device_what))
    evaluation = fitting.evaluate(model, data.pairs[sec["dataset"]][1], threshold=float(sec["threshold"]))
    return sec61_subspace.sweep_of(evaluation, part.analysis["sweep_points"])


def _finalize_sec62(part: Part, steps: dict[str, dict], data: _Data, out: Path) -> tuple[dict, list[Path]]:
    from ..learn import SubspaceMLP
    from ..learn.device import resolve_device
    from ..learn.files import load, save

    sec = part.settings["section"]
    device = resolve_device(part.device, part.device_what)
    models = [load(_model_file(out, part, s), map_location=device)[0] for s in part.steps]
    model = SubspaceMLP.from_models(models)
    train_all, test = data.pairs[sec["dataset"]]
    spec = train_all.head(sec["train_samples"]).spec
    threshold = float(sec["threshold"])
    full = fitting.evaluate(model, test, assemble=True, threshold=threshold)
    puma = sec62_puma560.puma560_map(model, spec, threshold)
    model.set_map_spec(spec, assemble=True, threshold=threshold)
    stacked = out / "models" / f"{part.name}.pt"
    save(model, stacked, dataset_spec=spec, train_config=part.train_config,
         extra={"part": part.name, "settings_hash": part.hash, "threshold": threshold})
    blocks = [steps[s]["metrics"] for s in part.steps]
    metrics = {
        **sec62_puma560.summarise(blocks, full, puma, train_samples=blocks[0]["train_samples"],
                                  test_samples=len(test), max_fail=int(sec["max_fail"])),
        "max_epochs": int(sec["max_epochs"]), "model_file": _relative(stacked, out),
    }
    return check_metrics(metrics, sec62_puma560.PaperScaleMetrics, f"{part.name} (paper scale)"), [stacked]


_STEP = {"sec61": _session_step, "table1": _session_step, "table2": _session_step, "table3": _session_step,
         "sec62": _block_step}


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------


def run_part(part: Part, out=None, data_dir=None, *, log: Log = print) -> dict:
    """Run `part` (skipped when done; finished steps reused) and write `<out>/<part>.json`.

    Returns the result dict (the file's content), or the existing one when the part was done.
    """
    from ..io import atomic_path, atomic_paths, jsonable
    from ..learn.device import device_facts, resolve_device

    out = Path(out) if out is not None else default_out()
    data_dir = Path(data_dir) if data_dir is not None else default_data()
    existing = _read_json(_part_file(out, part))
    if _is_done(existing, part):
        log(f"{part.name}: done ({_fmt_seconds(existing.get('wall_seconds'))}), skipped")
        return existing
    device = resolve_device(part.device, part.device_what)  # before any work
    started, t_start = _now(), time.perf_counter()
    machine = machine_facts()
    log(f"{part.name}: {part.title}; {len(part.steps)} step(s) on {device}")
    data = _Data(part, data_dir, log)
    step_results: dict[str, dict] = {}
    histories: dict[str, dict] = {}
    for step in part.steps:
        done = _done_step(out, part, step)
        if done is not None:
            if done.pop("from_result", False):  # its own file from now on: the result is about to be replaced
                with atomic_path(_step_file(out, part, step)) as tmp:
                    Path(tmp).write_text(json.dumps(jsonable(done), allow_nan=False) + "\n")
            log(f"  {step}: done earlier ({_fmt_seconds(done.get('seconds'))}), reused")
        else:
            log(f"  {step}: running ...")
            t0 = time.perf_counter()
            result = _STEP[part.kind](part, step, data, out)
            seconds = time.perf_counter() - t0
            done = {"part": part.name, "step": step, "settings_hash": part.hash, "step_hash": part.step_hash,
                    "seconds": seconds,
                    "finished": _now(), "device": str(device), **result}
            with atomic_path(_step_file(out, part, step)) as tmp:
                Path(tmp).write_text(json.dumps(jsonable(done), allow_nan=False) + "\n")
            log(f"  {step}: {_fmt_seconds(seconds)}; {_step_summary(part, done)}")
        histories[step] = done.pop("history", {})
        step_results[step] = done
    t0 = time.perf_counter()
    metrics, extra_files = _finalize(part, step_results, data, out)
    finalize_s = time.perf_counter() - t0
    data_s = sum(sum(t.values()) for t in data.timings.values())
    steps_s = sum(float(s["seconds"]) for s in step_results.values())
    result = {
        "part": part.name, "title": part.title, "kind": part.kind, "settings_hash": part.hash,
        "settings": part.settings, "analysis": part.analysis, "params_section": part.section,
        "metrics": metrics,
        # per step: its timings (the per-session scores are metrics["runs"]; a block's are here)
        "steps": [{"step": name, "seconds": s["seconds"], "finished": s["finished"], "device": s["device"],
                   "summary": _step_summary(part, s), "timings": s["timings"],
                   **({"metrics": s["metrics"]} if part.kind == "sec62" else {})}
                  for name, s in step_results.items()],
        "timings": {"datasets": data.timings, "steps": {k: s["seconds"] for k, s in step_results.items()},
                    "finalize_s": finalize_s},
        "wall_seconds": steps_s + data_s + finalize_s,
        "wall_seconds_this_run": time.perf_counter() - t_start,
        "device": {"setting": part.device, "from": part.device_what, "used": str(device), **device_facts(device)},
        "machine": {**machine, "load_average_end": list(os.getloadavg())},
        "files": [_relative(p, out) for p in extra_files],
        "started": started, "finished": _now(),
    }
    text = json.dumps(jsonable(result), indent=1, allow_nan=False) + "\n"
    history_text = json.dumps(jsonable({"part": part.name, "settings_hash": part.hash, "steps": histories}),
                              allow_nan=False) + "\n"
    # both files or neither; the result file last of all marks the part done
    with atomic_paths([_history_file(out, part), _part_file(out, part)]) as (h, r):
        Path(h).write_text(history_text)
        Path(r).write_text(text)
    log(f"{part.name}: done in {_fmt_seconds(result['wall_seconds'])} -> {_part_file(out, part)}")
    return result


def _step_summary(part: Part, done: dict) -> str:
    m = done["metrics"]
    if part.kind == "sec62":
        return f"F {m['f']:.4f}, {m['epochs']} epochs ({m['stop_reason']})"
    own = m["rows"][0] if part.kind != "table3" else next(
        (r for r in m["rows"] if r["test"] == part.settings["section"]["embedding"]), m["rows"][0])
    f = own.get("f")
    return f"F {f:.4f}" if isinstance(f, float) and math.isfinite(f) else "F undefined"


def run(names: Sequence[str] = (), params_file=None, out=None, data_dir=None, *, device: str | None = None,
        log: Log = print) -> list[dict]:
    """Run the selected parts (`select`) of `params_file` in order. Every name, section,
    key and device is checked before anything is built, loaded or written."""
    from ..io import check_output_path
    from ..learn.device import resolve_device

    parts = select(plan(params_file, device=device), names)
    for p in parts:
        resolve_device(p.device, p.device_what)
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


def _shape(part: Part) -> dict[str, int]:
    """Inputs, outputs, training and validation samples of one step of `part`."""
    from ..workspace import BLOCK_NODES
    from .specs import paper_spec

    sec = part.settings["section"]
    spec = paper_spec(sec["dataset"])
    samples = part.datasets[sec["dataset"]]["samples"]
    n = min(int(sec["train_samples"] or samples), samples)
    fr = part.settings["train_config"]["fractions"]
    n_val, n_test = int(round(fr[1] * n)), int(round(fr[2] * n))
    m = BLOCK_NODES if part.kind == "sec62" else spec.n_nodes
    return {"n": n, "n_train": n - n_val - n_test, "n_val": n_val, "f": spec.n_features, "m": m}


def flop_estimate(part: Part, gflops: float = CPU_GFLOPS) -> float:
    """Seconds of `part`'s training at `gflops`: per epoch a forward and backward pass over the
    training split (3 x 2 x MACs) and a forward pass over the validation split, x `max_epochs`
    x steps."""
    s = _shape(part)
    macs = _layer_macs(s["f"], part.settings["section"]["hidden"], s["m"])
    per_epoch = 2 * macs * (3 * s["n_train"] + s["n_val"]) / (gflops * 1e9)
    return per_epoch * int(part.settings["section"]["max_epochs"]) * len(part.steps)


def data_estimate(part: Part, data_dir=None, counted: set | None = None) -> float:
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


def estimate_part(part: Part, epochs: int = 4) -> dict[str, Any]:
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

    device = resolve_device(part.device, part.device_what)
    s = _shape(part)
    sec = part.settings["section"]
    rng = np.random.default_rng(0)
    X = rng.uniform(0.0, 0.5, size=(s["n"], s["f"]))
    Y = torch.rand(s["n"], s["m"], generator=torch.Generator().manual_seed(0)) < 0.3
    Y = Y.to(torch.float32)
    cfg = part.train_config.replace(max_epochs=int(epochs), max_fail=10**6)
    split = split_indices(s["n"], cfg.fractions, cfg.seed)
    mlp = MLPConfig(n_inputs=s["f"], n_outputs=s["m"], hidden=list(sec["hidden"]), **tables.mlp_options(cfg.loss))
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
    from ..learn.device import resolve_device

    parts = select(plan(params_file, device=device), names)
    for p in parts:
        resolve_device(p.device, p.device_what)
    out = Path(out) if out is not None else default_out()
    known = _read_json(_estimates_file(out)) or {}
    for p in parts:
        if part_state(p, out)["state"] == "done":
            continue
        e = estimate_part(p, epochs)
        known[p.name] = e
        log(f"{p.name}: {e['seconds_per_epoch']:.3f} s per epoch on {e['device']} -> ≈ {_fmt_seconds(e['estimate_s'])} "
            f"for {p.settings['section']['max_epochs']} epochs x {len(p.steps)} step(s)")
        write_json(known, _estimates_file(out))
    return known


def _fmt_seconds(s) -> str:
    if s is None or (isinstance(s, float) and not math.isfinite(s)):
        return "?"
    s = float(s)
    if s < 120:
        return f"{s:.0f} s"
    if s < 2 * 3600:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


def list_lines(params_file=None, out=None, data_dir=None, *, device: str | None = None,
               names: Sequence[str] = ()) -> list[str]:
    """The `--list` table: one line per part (state, steps done, time), then the totals.

    Time: `measured` for a finished part (its wall time); otherwise `timed` (from
    `estimates.json`, matching settings) or `flops` (`flop_estimate`, CPU only) for the
    steps still to run, plus `data` for datasets still to build. Changes nothing on disk.
    """
    from ..learn.device import resolve_device

    parts = select(plan(params_file, device=device), names)
    out = Path(out) if out is not None else default_out()
    estimates = _read_json(_estimates_file(out)) or {}
    rows = [("part", "state", "steps", "time", "how", "device")]
    pending_total, unknown, counted = 0.0, [], set()
    for p in parts:
        st = part_state(p, out)
        try:
            dev = str(resolve_device(p.device, p.device_what))
        except ValueError:
            dev = f"{p.device} (unavailable)"
        steps = f"{st['steps_done']}/{len(p.steps)}"
        if st["state"] == "done":
            rows.append((p.name, "done", steps, _fmt_seconds(st["seconds"]), "measured", st.get("device") or dev))
            continue
        left = (len(p.steps) - st["steps_done"]) / len(p.steps)
        e = estimates.get(p.name)
        if isinstance(e, dict) and e.get("settings_hash") == p.hash and e.get("device") == dev:
            seconds, how = float(e["estimate_s"]) * left, "timed"
        elif dev == "cpu":
            seconds, how = flop_estimate(p) * left, "flops"
        else:
            seconds, how = None, "run --estimate"
        data_s = data_estimate(p, data_dir, counted)  # each missing dataset with the first part needing it
        if seconds is not None:
            seconds += data_s
            pending_total += seconds
            if data_s > 0:
                how += f" + data {_fmt_seconds(data_s)}"
        else:
            unknown.append(p.name)
        bound = "≤ " if p.kind == "sec62" else "≈ "  # §6.2 stops at max_fail 100: its epochs are a bound
        rows.append((p.name, st["state"], steps, bound + _fmt_seconds(seconds) if seconds is not None else "?",
                     how, dev))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    done = sum(1 for r in rows[1:] if r[1] == "done")
    tail = f"{done} of {len(parts)} parts done; still to run ≈ {_fmt_seconds(pending_total)}"
    if unknown:
        tail += f" + {len(unknown)} part(s) without an estimate"
    lines.append(tail)
    return lines

