"""A part of the paper at the paper's scale: the record a part declares (`Scale`) and what its
entry points receive (`Unit`, `Data`, `Planner`).

`wsmap paper full` (`wsmap.paper.full`) runs the parts whose `Part` record carries a
`Scale` (their module's `SCALE`), cut into **units** (what the command calls a part: one
result file each, `table1_r3_step1.json`) and each unit into **steps** (a session or a block:
what an interrupted run resumes at). Everything that differs from one part to another is its
`Scale`: how it cuts its params section into units (`plan`), what one step computes
(`step`), how the finished steps make the unit's metrics (`finalize`), and a few flags. The
runner itself knows no part by name.

The steps of most parts are training sessions (`session_step`: session `k` trains with seed
`seed + k` and is scored on the unit's test sets); §6.2's are blocks (its module's own step).
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import paths
from .specs import dataset_sizes, whole_param

__all__ = ["RUNNER_VERSION", "Scale", "Unit", "Data", "Planner", "settings_hash", "step_hash", "session_step",
           "session_summary", "own_test_set", "step_runs", "save_model", "history", "relative"]

#: Bumped when what a part computes changes, so that old results are not taken for new ones.
RUNNER_VERSION = 1

Log = Callable[[str], Any]


def settings_hash(settings: dict) -> str:
    """`sha256:<hex>` of the canonical JSON of `settings` (sorted keys, no spaces)."""
    from ..io import jsonable

    text = json.dumps(jsonable(settings), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return "sha256:" + hashlib.sha256(text.encode()).hexdigest()


def step_hash(settings: dict) -> str:
    """`settings_hash` of `settings` without `section.sessions` (see `Unit.step_hash`)."""
    section = {k: v for k, v in settings.get("section", {}).items() if k != "sessions"}
    return settings_hash({**settings, "section": section})


# --------------------------------------------------------------------------------------------
# The unit of work and its data
# --------------------------------------------------------------------------------------------


@dataclass
class Unit:
    """One resumable unit of a part at the paper's scale (what `wsmap paper full` calls a part)
    and everything its result depends on.

    `settings` is hashed (`settings_hash`); `section` names the params file's section;
    `steps` are the unit's steps in order (`session_0`, ..., or `block_1`, ...);
    `datasets` the sizes of the datasets it reads (name -> `samples`, `test_samples`);
    `device` is the requested setting (`auto`, `cpu`, `cuda`) and `device_what` names where
    it came from, for error messages. `analysis`: settings of the summary drawn from the finished
    steps (§6.1's threshold sweep), not of the training: not hashed, so a change summarises the
    same steps again (no retraining); recorded in the result, and a result with other ones is not
    done. `scale`: the part's `Scale`, whose entry points run it.
    """

    name: str
    section: str
    settings: dict[str, Any]
    steps: list[str]
    datasets: dict[str, dict[str, int]]
    device: str
    device_what: str
    scale: Scale = field(repr=False)
    title: str = ""
    analysis: dict[str, Any] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        """The group the unit belongs to (`sec61`, `table1`, ...: `Scale.kind`)."""
        return self.scale.kind

    @property
    def values(self) -> dict[str, Any]:
        """The section's values the unit trains with (`settings["section"]`)."""
        return self.settings["section"]

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

    def model_file(self, out: Path, step: str) -> Path:
        """Where step `step`'s model goes under the result folder `out`."""
        return Path(out) / "models" / self.name / f"{step}.pt"


class Data:
    """The datasets of a unit, loaded (built first where missing or of other sizes): `pairs`
    (name -> (train, test) `wsmap.datasets.Dataset`) and `timings` (name -> seconds to
    load and, where built, to build)."""

    def __init__(self, unit: Unit, data_dir: Path, log: Log):
        self.pairs: dict[str, tuple] = {}
        self.timings: dict[str, dict[str, float]] = {}
        for name, sizes in unit.datasets.items():
            self.pairs[name] = self._ensure(name, sizes, unit.settings["datasets"][name]["spec"], data_dir, log)

    @staticmethod
    def _load(name, sizes, spec, data_dir, log):
        """The pair in `data_dir` when it is there, whole and of these sizes and spec; else None."""
        from .specs import dataset_paths, load_pair

        if not all(p.exists() for p in dataset_paths(name, data_dir)):
            return None
        try:
            pair = load_pair(name, data_dir)
        except ValueError as e:  # corrupt or inconsistent: rebuilt
            log(f"  dataset {name}: {e}; rebuilding")
            return None
        if (len(pair[0]) != sizes["samples"] or len(pair[1]) != sizes["test_samples"]
                or pair[0].spec.to_dict() != spec):
            log(f"  dataset {name}: {len(pair[0])}/{len(pair[1])} arms in {data_dir}, "
                f"need {sizes['samples']}/{sizes['test_samples']} (or another spec); rebuilding")
            return None
        return pair

    def _ensure(self, name, sizes, spec, data_dir, log):
        from .specs import build_pair, load_pair

        t0 = time.perf_counter()
        pair = self._load(name, sizes, spec, data_dir, log)
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
# Planning
# --------------------------------------------------------------------------------------------


class Planner:
    """What a part's `Scale.plan` makes its units with: the params file (`params_file`), its
    `datasets` section (read first: a bad entry is named before any part's section) and the
    `--device` setting for every unit (`None`: each section's own `device`)."""

    def __init__(self, params_file: Path, device: str | None = None):
        self.params_file = Path(params_file)
        self.sizes = paths.load_params("datasets", self.params_file)
        self.device = device

    def section(self, name: str):
        """The params section `name` (`wsmap.paths.notebook_params`: missing keys are errors
        naming the file and section)."""
        return paths.notebook_params(name, self.params_file)

    @staticmethod
    def train_config(optimizer: str, loss: str, max_epochs, max_fail, seed, where: str = "the params file") -> dict:
        """The hashed `TrainConfig` of a unit (as a dict, without the device: it is not hashed);
        the whole-number settings checked, naming `where`."""
        from ..learn.training import TrainConfig

        d = TrainConfig(optimizer=optimizer, loss=loss, max_epochs=whole_param(where, "max_epochs", max_epochs, 1),
                        max_fail=whole_param(where, "max_fail", max_fail, 1),
                        seed=whole_param(where, "seed", seed)).to_dict()
        d.pop("device")
        return d

    @staticmethod
    def sessions(cfg, n=None) -> list[str]:
        """The steps `session_0`, ... of `n` sessions (default: the section's `sessions`)."""
        n = cfg["sessions"] if n is None else n
        return [f"session_{k}" for k in range(whole_param(cfg.source, "sessions", n, 1))]

    def dataset_settings(self, names: Sequence[str]) -> dict[str, dict]:
        """Name -> `samples`, `test_samples` and the scaled spec (as a dict) of datasets `names`."""
        from ..datasets.spec import scaled
        from .specs import paper_spec

        return {name: {**s, "spec": scaled(paper_spec(name), s["samples"]).to_dict()}
                for name, s in dataset_sizes(names, self.sizes, self.params_file.name).items()}

    def unit(self, name: str, scale: Scale, cfg, steps: list[str], datasets: Sequence[str], values: dict,
             train_config: dict, title: str, analysis: Mapping | None = None) -> Unit:
        """The `Unit` `name` of the part whose `Scale` is `scale`, from its section `cfg`: its
        settings are the runner's version, the unit and its kind, the section's `values`, the
        `train_config` and the `datasets`' sizes and specs."""
        data = self.dataset_settings(datasets)
        settings = {"runner_version": RUNNER_VERSION, "part": name, "kind": scale.kind, "section": values,
                    "train_config": train_config, "datasets": data}
        device, what = (self.device, "--device") if self.device is not None else (cfg["device"],
                                                                                  f"{cfg.source} device")
        return Unit(name=name, section=cfg.source, settings=settings, steps=steps,
                    datasets={k: {"samples": v["samples"], "test_samples": v["test_samples"]} for k, v in data.items()},
                    device=device, device_what=what, scale=scale, title=title, analysis=dict(analysis or {}))


# --------------------------------------------------------------------------------------------
# The steps' shared pieces
# --------------------------------------------------------------------------------------------


def relative(path: Path, out: Path) -> str:
    """`path` relative to the result folder `out` when inside it (results stay valid when moved)."""
    try:
        return str(Path(path).resolve().relative_to(Path(out).resolve()))
    except ValueError:
        return str(path)


def history(result) -> dict[str, list]:
    """A training result's per-epoch record, rounded to 7 digits, non-finite values as None."""
    h = result.history.to_dict()
    return {k: [None if v is None or (isinstance(v, float) and not math.isfinite(v)) else round(float(v), 7)
                for v in vals] for k, vals in h.items() if vals}


def save_model(model, path: Path, spec, config, extra: dict, **map_spec) -> None:
    """`model` to `path` with its map spec (`map_spec`: `threshold`, `nodes`, ...), the
    dataset spec it learnt, its training config and `extra`."""
    from ..learn.files import save

    model.set_map_spec(spec, **map_spec)
    save(model, path, dataset_spec=spec, train_config=config, extra=extra)


def own_test_set(unit: Unit, data: Data) -> dict:
    """The test set of the unit's own dataset (`values["dataset"]`), by its name."""
    name = unit.values["dataset"]
    return {name: data.pairs[name][1]}


def session_step(unit: Unit, step: str, data: Data, out: Path) -> dict:
    """One session (`session_<k>`, seed `seed + k`) of a unit: train on the first
    `train_samples` arms of its dataset, score on its test sets (`Scale.test_sets`) at
    `threshold` (`wsmap.paper.tables.score_results` rows), save the model."""
    from . import fitting, tables

    k = int(step.split("_")[1])
    sec = unit.values
    train = data.pairs[sec["dataset"]][0].head(sec["train_samples"])
    config = unit.train_config.replace(seed=int(sec["seed"]) + k)
    t0 = time.perf_counter()
    (result,) = fitting.fit(train, config, sessions=1, hidden=sec["hidden"], **tables.mlp_options(config.loss))
    t1 = time.perf_counter()
    rows = tables.score_results([result], train, unit.scale.test_sets(unit, data), float(sec["threshold"]),
                                first_session=k)
    t2 = time.perf_counter()
    threshold = float(sec["threshold"])
    save_model(result.model, unit.model_file(out, step), train.spec, config,
               {"part": unit.name, "step": step, "settings_hash": unit.hash}, threshold=threshold)
    t3 = time.perf_counter()
    return {"metrics": {"rows": rows}, "history": history(result),
            "timings": {"train_s": t1 - t0, "score_s": t2 - t1, "save_s": t3 - t2,
                        "epochs": int(result.stop_epoch),
                        "seconds_per_epoch": (t1 - t0) / max(1, int(result.stop_epoch))}}


def session_summary(unit: Unit, done: dict) -> str:
    """A finished session in one line: the F of its first score row (its own test set)."""
    return f_line(done["metrics"]["rows"][0])


def f_line(row: Mapping) -> str:
    """`F 0.9714` of a score row, or `F undefined` where its F is not a finite number."""
    f = row.get("f")
    return f"F {f:.4f}" if isinstance(f, float) and math.isfinite(f) else "F undefined"


def step_runs(steps: Mapping[str, dict]):
    """Every session's score rows as one `pandas.DataFrame`, in step order."""
    import pandas as pd

    return pd.DataFrame([row for s in steps.values() for row in s["metrics"]["rows"]])


# --------------------------------------------------------------------------------------------
# The record
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Scale:
    """How `wsmap paper full` runs a part at the paper's scale (a part module's `SCALE`).

    `kind`: the units' group (`wsmap paper full table1` runs every unit of the group) and a
    hashed setting of theirs.
    `plan(cfg, planner) -> list[Unit]`: the part's units from its params section `cfg`
    (`Planner.unit` makes each).
    `finalize(unit, steps, data, out) -> (metrics, files)`: the unit's metrics from its finished
    steps (step name -> the step's record, in order) and the files it wrote beside them.
    `step(unit, step, data, out) -> dict`: one step's `metrics`, `history` and `timings`
    (default: one training session, `session_step`).
    `test_sets(unit, data)`: the test sets a session is scored on (default: its own dataset's).
    `summary(unit, done) -> str`: a finished step in one line, for the log and the result.
    `added_columns`: the columns `finalize` adds to the sessions' score rows (taken off again
    when a step is rebuilt from a finished result).
    `loads_models`: `finalize` reads the steps' models, so that a step without its model file
    (a fresh checkout: the models are not committed) runs again.
    `sessions`: the steps are sessions, which a finished result of another number of sessions
    gives back (`False`: §6.2's blocks).
    `step_metrics`: each step's metrics go into the result's `steps` too (§6.2's per block).
    `stops_early`: validation stopping ends most runs before `max_epochs` (the listing's time is
    an upper bound, `≤`).
    `step_nodes`: the outputs of one step's network (`None`: the dataset's nodes), for the
    estimates.
    """

    kind: str
    plan: Callable[[Any, Planner], list[Unit]]
    finalize: Callable[[Unit, dict[str, dict], Data, Path], tuple[dict, list[Path]]]
    step: Callable[[Unit, str, Data, Path], dict] = session_step
    test_sets: Callable[[Unit, Data], dict] = own_test_set
    summary: Callable[[Unit, dict], str] = session_summary
    added_columns: tuple[str, ...] = ()
    loads_models: bool = False
    sessions: bool = True
    step_metrics: bool = False
    stops_early: bool = False
    step_nodes: int | None = None
