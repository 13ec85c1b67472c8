"""The parts of the paper's reproduction: one module per notebook (pipeline stage), each registering itself.

A part module `wsmap.paper.parts.<name>` holds everything its notebook computes and draws:

* `PART` — its `Part` record (name, `priority`: its place in the run order, the parts whose
  outputs it reads, the files it writes, and for the parts `wsmap paper full` runs at the paper's
  scale their `SCALE`), registered with `register` in `PARTS` (a `wsmap._plugins.Registry`)
  when the module is imported;
* `Metrics` — the schema of its `results/<name>.json` (a `typing.TypedDict`, every key
  documented once; `check_metrics` holds a metrics dict to it);
* `run(cfg, out, ...)` — the computation, from the notebook's params section `cfg`
  (`wsmap.paths.notebook_params`) and the run's folders `out` (`wsmap.paths.Outputs`:
  the datasets and the models of the parts it reads); returns a result whose `metrics` follow
  `Metrics`;
* `save(result, out)` — its metrics file, tables and model files; `figures(result, out)` — its
  figures (drawn with `wsmap.viz`), returning their paths.

The notebook `notebooks/<name>.ipynb` loads its params, calls these and narrates.
`order` (the pipeline order, `wsmap paper run --all` and `wsmap paper list`) and
`reads` (which parts a part reads; the smoke tests run those first) come from the registry;
DVC's `dvc.yaml` holds the same stages (`tests/test_paper_pipeline.py` compares them).

A new figure of the paper is one new module here (with its `PART`), one notebook and one stage.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..._plugins import Registry, discover
from ...io import write_json, write_table

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from matplotlib.figure import Figure
    import pandas as pd

    from wsmap._typing import Any, Callable, Path, PathLike, Sequence
    from wsmap.paths import Outputs

    from ..scale import Scale

__all__ = ["Part", "PARTS", "register", "registry", "part", "order", "reads", "metric_keys", "check_metrics",
           "save_tables", "save_figure", "knows_key"]


@dataclass(frozen=True)
class Part:
    """One part of the paper: a notebook, a DVC stage, a metrics file.

    `name`: the notebook, the params section and the stage (`results/<name>.json`).
    `priority`: its place in the run order (the paper's order; ties are not allowed).
    `reads`: the parts whose output files it reads (they run first).
    `outputs`: the files and folders it writes, relative to the output root (the executed
    notebook aside), as `dvc.yaml` lists them for the committed params.
    `scale`: how `wsmap paper full` runs it at the paper's scale, cut into resumable steps
    (a `wsmap.paper.scale.Scale` the part's module exports as `SCALE`); `None` for the parts
    that the paper-scale runner leaves to their notebook.
    """

    name: str
    title: str
    priority: int
    reads: tuple[str, ...] = ()
    outputs: tuple[str, ...] = ()
    scale: Scale | None = None

    @property
    def module(self) -> str:
        return f"{__name__}.{self.name}"


#: Every part of the paper, by `(priority, name)`; each part module registers its `PART`.
PARTS: Registry[Part] = Registry("part of the paper")


def register(p: Part) -> Part:
    """Add `p` to `PARTS` (a part module's last statement); returns it. The same record again
    changes nothing; another part of the same name or priority is a `ValueError`."""
    if not p.name.isidentifier():
        raise ValueError(f"a part's name must be a Python identifier (its module's), got {p.name!r}")
    if p.name in PARTS:
        if PARTS.get(p.name) != p:
            raise ValueError(f"part {p.name!r} registered twice")
        return PARTS.get(p.name)
    clash = [q.name for q in PARTS if q.priority == p.priority]
    if clash:
        raise ValueError(f"parts {p.name!r} and {clash[0]!r} share priority {p.priority}")
    return PARTS.register(p)


def registry() -> dict[str, Part]:
    """Every part, by name, in run order: each module of this package imported (it registers itself).

    The discovery runs here, when the registry is first asked, and not when the package is
    imported: running one notebook imports only its own part, so that a DVC stage depends on the
    code of its own part alone (`tools/stage_deps.py`). A part that reads an unknown part, or one
    placed before a part it reads, is a `ValueError`.
    """
    discover(__name__, __path__)
    for p in PARTS:
        for r in p.reads:
            if r not in PARTS:
                raise ValueError(f"part {p.name!r} reads unknown part {r!r}; known: {', '.join(PARTS.names())}")
            if PARTS.get(r).priority >= p.priority:
                raise ValueError(f"part {p.name!r} reads {r!r}, which runs after it")
    return {p.name: p for p in PARTS}


def part(name: str) -> Part:
    """The registered part `name`; an unknown name is a `ValueError` listing the known ones."""
    parts = registry()
    if name not in parts:
        raise ValueError(f"unknown part {name!r}; known: {', '.join(parts)}")
    return parts[name]


def order() -> list[str]:
    """The parts' names in run order (every part after those it reads)."""
    return list(registry())


def reads(name: str) -> list[str]:
    """The parts whose outputs part `name` reads, in run order."""
    p = part(name)
    return [n for n in order() if n in p.reads]


def metric_keys(schema: type) -> tuple[str, ...]:
    """The keys of a `Metrics` TypedDict, in declaration order."""
    return tuple(schema.__annotations__)


def check_metrics(metrics: dict, schema: type, what: str, *, beside: Callable[[str, Any], bool] | None = None,
                  other: str = "have keys not in the schema") -> dict:
    """`metrics` unchanged when it holds the schema's keys and no other key, or only others for
    which `beside(key, value)` is true (the parts with one entry per table cell or method); else a
    `ValueError` naming the keys missing and, after `other`, the keys not allowed (`what`:
    whose metrics)."""
    keys = metric_keys(schema)
    missing = [k for k in keys if k not in metrics]
    unknown = [k for k, v in metrics.items() if k not in keys and not (beside is not None and beside(k, v))]
    if missing or unknown:
        problems = ([f"lack {missing}"] if missing else []) + ([f"{other} {unknown}"] if unknown else [])
        raise ValueError(f"{what}: metrics {'; '.join(problems)}")
    return metrics


def save_tables(out: Outputs, name: str, table: pd.DataFrame, runs: pd.DataFrame, shown: pd.DataFrame, metrics: dict,
                whole: Sequence[str] = ()) -> None:
    """A table part's files: `tables/<name>`, `<name>_runs` and `<name>_display` (.csv and .md;
    `whole`: the columns written as whole numbers) and `results/<name>.json`."""
    write_table(table, out.tables / name, whole=whole)
    write_table(runs, out.tables / f"{name}_runs", whole=whole)
    write_table(shown, out.tables / f"{name}_display", whole=whole)
    write_json(metrics, out.results / f"{name}.json")


def save_figure(fig: Figure, path: PathLike) -> Path:
    """`wsmap.viz.save_figure` (the figure written, then closed), returning `path` so that
    `figures` can list what it wrote."""
    from ... import viz

    viz.save_figure(fig, path)
    return path


def knows_key(name: str, key: str) -> bool:
    """Whether part `name`'s metrics schema has the dotted `key` (`"f_mean"`,
    `"panda7.f"`, `"rprop_mse.f_mean"`): the first component a key of its `Metrics` (nested
    TypedDicts followed), or else a key its module's `is_cell_key` accepts (the parts whose
    metrics hold one entry per table cell or method)."""
    module = importlib.import_module(part(name).module)
    schema, rest = module.Metrics, key.split(".")
    while rest and rest[0] in schema.__annotations__:
        annotation = schema.__annotations__[rest.pop(0)]
        annotation = getattr(annotation, "__forward_arg__", annotation)  # TypedDict keeps strings as ForwardRefs
        nested = getattr(module, annotation, None) if isinstance(annotation, str) else annotation
        if not (isinstance(nested, type) and hasattr(nested, "__annotations__") and issubclass(nested, dict)):
            return True  # a plain value or a mapping of values
        schema = nested
    if not rest:
        return True
    return bool(getattr(module, "is_cell_key", lambda k: False)(key)) and schema is module.Metrics
