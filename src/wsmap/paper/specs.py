"""The paper's datasets: one `DatasetSpec` per experiment, and their files.

`PAPER_SPECS` holds one spec per experiment of the paper (NOTES "Datasets");
`wsmap.datasets.test_spec(s)` gives its independent 1000-sample test set. The pipeline keeps
dataset `NAME` in `data/NAME.npz` and its test set in `data/NAME.test.npz`
(`dataset_paths`, `build_pair`, `load_pair`; the command line is
`wsmap data build NAME --samples N --test-samples M --out data/NAME.npz`).

`EXTENSION_SPECS` are datasets beyond the paper (real-arm families, e.g. `panda7_tooldown`, and
its collision-free labels `panda7_tooldown_free`);
`DATASET_SPECS` is both catalogues, what `wsmap data build` and `wsmap data list` know
(`dataset_spec`).

The label audits take their specs from here too: `audit_specs` (every distinct
spherical-wrist spec) and `STARTS_STUDY_SPEC` (Table 3's arbitrary arms, on which
`wsmap.datasets.DEFAULT_STARTS` was chosen).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from .. import workspace as ws
from ..datasets import (
    DatasetSpec,
    build_dataset_files,
    distinct_specs,
    load_dataset_files,
)

__all__ = [
    "TABLE3_RPY",
    "PAPER_SPECS",
    "EXTENSION_SPECS",
    "DATASET_SPECS",
    "PANDA7_TOOLDOWN",
    "PANDA7_TOOLDOWN_FREE",
    "STARTS_STUDY_SPEC",
    "paper_spec",
    "dataset_spec",
    "audit_specs",
    "dataset_paths",
    "build_pair",
    "load_pair",
    "dataset_sizes",
    "whole_param",
]

#: Table 3's "no subspace" orientation (r1, r2, r3), radians.
TABLE3_RPY = (0.312, 5.6719, 5.936)


def _paper_specs() -> dict[str, DatasetSpec]:
    block5 = (ws.block_slice(4).start, ws.block_slice(4).stop)  # 0-based [5292, 6615)
    crop = (ws.CROP_3087.start, ws.CROP_3087.stop)  # 0-based [5292, 8379)
    r3 = dict(family="spherical_wrist", scope="R3", lo=-1.0, hi=1.0, fixed=(0.0, 0.0, 0.0), convention="paper")
    so3 = dict(family="spherical_wrist", scope="SO3", lo=0.0, hi=2 * math.pi, convention="paper")
    specs = [
        # section 6.1: the block-5 subspace, 1e5 arms
        DatasetSpec("sec61", **r3, step=0.1, select=block5, samples=100_000, seed=61),
        # section 6.2: the whole 21³ map (the 7 block models take their columns), 1e5 arms
        DatasetSpec("sec62", **r3, step=0.1, samples=100_000, seed=62),
        # Table 1
        DatasetSpec("table1_r3_step1", **r3, step=1.0, samples=60_000, seed=101),
        DatasetSpec("table1_r3_step05", **r3, step=0.5, samples=60_000, seed=102),
        DatasetSpec("table1_r3_block5", **r3, step=0.1, select=block5, samples=60_000, seed=103),
        DatasetSpec("table1_r3_crop3087", **r3, step=0.1, select=crop, samples=30_000, seed=104),
        DatasetSpec("table1_r3_full", **r3, step=0.1, samples=15_000, seed=105),
        DatasetSpec("table1_so3_pi3", **so3, step=math.pi / 3, fixed=(0.5, 0.5, 0.5), samples=60_000, seed=106),
        DatasetSpec("table1_so3_pi8", **so3, step=math.pi / 8, fixed=(1.0, 0.0, 0.0), samples=15_000, seed=107),
        DatasetSpec("table1_so3_pi10", **so3, step=math.pi / 10, fixed=(0.5, 0.5, 0.5), samples=15_000, seed=108),
        # Table 2: the 6.1 setup with 6e4 arms
        DatasetSpec("table2", **r3, step=0.1, select=block5, samples=60_000, seed=201),
        # Table 3: three embeddings on the same 84 inputs / 1323 outputs, so that every model can
        # be tested on every test set (the paper does that)
        DatasetSpec("table3_subspace", **r3, step=0.1, select=block5, samples=15_000, seed=301),
        DatasetSpec("table3_workspace", **{**r3, "fixed": "random"}, step=0.1, select=block5, samples=15_000, seed=302),
        DatasetSpec(
            "table3_nosubspace",
            **{**r3, "family": "arbitrary_6dof", "fixed": TABLE3_RPY},
            step=0.1,
            select=block5,
            method="numerical",
            samples=15_000,
            seed=303,
        ),
    ]
    return {s.name: s for s in specs}


#: One spec per experiment of the paper (NOTES "Datasets"); `test_spec(s)` gives its test set.
PAPER_SPECS: dict[str, DatasetSpec] = _paper_specs()
#: `panda7_tooldown`: the Franka Panda family `panda7` (`wsmap.robots.sample_family`: the
#: six non-zero DH lengths d1, d3, d5, a4, a5, a7 each scaled by U(0.7, 1.3), flange and joint
#: limits the Panda's), its constant-orientation map at tool-down, `R = Rx(pi)`, in the standard
#: convention (`T = transl(p)·R`, flange poses in the base frame), on the grid `[-1.2, 1.2]³` m
#: at 0.1 m (25³ = 15,625 nodes, first coordinate fastest). Features: the 6 scales, the grid axes,
#: the orientation (6 + 75 + 3 = 84); labels: the numerical map search
#: (`constant_orientation_map(arms, nodes, (pi, 0, 0), method="numerical", convention="standard")`,
#: `wsmap.kinematics.ik.search.MAP_SETTINGS`), whose `True` is confirmed by forward kinematics
#: inside the joint limits. About 12 % of the nodes are reachable (1268-2749 for the first arms,
#: 1883 for the Panda); the largest arms reach a little past the grid's top face (z = 1.2 m: 61
#: nodes of that face for all scales 1.3), nothing reaches its other faces.
#:
#: Recall against a denser reference (`benchmarks/learn/bench_panda7_labels.py`: `ikine_search` with
#: 64 independent starts per node on the nodes the map calls unreachable that the sound reach filter
#: does not exclude): 0 misses in 5 x 1000 sampled such nodes (arms 0-3 of the training stream and
#: the Panda; per-arm 95 % lower bounds 0.987-0.992), and on every such node of two arms (10,952
#: nodes) 1 miss: recall 1268/1269 = 0.9992 for arm 0, 1883/1883 = 1.0 for the Panda, 0.9997 pooled.
#: The reference confirmed 500/500 sampled map-reachable nodes. ~0.8 s per arm on one thread
#: (`benchmarks/learn/bench_panda7_build.py`: 1.24 arms/s in one process, 2.0 on a 2-worker LocalCluster
#: of a 2-core machine shared with another job).
PANDA7_TOOLDOWN = DatasetSpec(
    "panda7_tooldown",
    family="panda7",
    scope="R3",
    lo=-1.2,
    hi=1.2,
    step=0.1,
    fixed=(math.pi, 0.0, 0.0),
    convention="standard",
    method="numerical",
    samples=20_000,
    seed=1401,
)

#: `panda7_tooldown_free`: `PANDA7_TOOLDOWN` with collision-free labels
#: (`wsmap.datasets.collision`): a node counts only with a solution that is also free of
#: self-collision (the Panda's capsule model, `wsmap.collision.arm_model`, built on each arm's
#: own chain, so the capsules run along its scaled links; the radii are the Panda's housings) and of
#: the floor `z = 0` the arm stands on, with each arm's own allowed-collision matrix (10000 seeded
#: samples). Same seed, so the same arms, orientation and grid as `panda7_tooldown`: arm `b` of
#: one is arm `b` of the other, and its labels here are (in every arm measured) a subset of its
#: labels there. For the first four arms 1040, 1593, 841, 2033 nodes of the chain's 1269, 2232, 1310,
#: 2749; over the first 8, 0.711 of the chain's nodes and none outside them, 3.2 s per arm on one
#: thread against 4.2 s for `panda7_tooldown`'s labels in the same run of a loaded 2-core machine
#: (`benchmarks/collision/bench_panda7_free_labels.py`).
PANDA7_TOOLDOWN_FREE = PANDA7_TOOLDOWN.replace(name="panda7_tooldown_free", collision={"model": "panda"})

#: Datasets beyond the paper's experiments (not part of its pipeline); `test_spec(s)` as ever.
EXTENSION_SPECS: dict[str, DatasetSpec] = {s.name: s for s in (PANDA7_TOOLDOWN, PANDA7_TOOLDOWN_FREE)}
#: Every dataset `wsmap data build` knows: the paper's and the extensions.
DATASET_SPECS: dict[str, DatasetSpec] = {**PAPER_SPECS, **EXTENSION_SPECS}

#: The spec of the start-count studies (`wsmap.datasets.starts_study` / `starts_recall`).
STARTS_STUDY_SPEC: DatasetSpec = PAPER_SPECS["table3_nosubspace"]


def paper_spec(name: str) -> DatasetSpec:
    """The spec of the paper's dataset `name`; an unknown name is a `ValueError` listing the known."""
    if not isinstance(name, str) or name not in PAPER_SPECS:
        raise ValueError(f"unknown dataset {name!r}; choose one of {', '.join(sorted(PAPER_SPECS))}")
    return PAPER_SPECS[name]


def dataset_spec(name: str) -> DatasetSpec:
    """The spec of dataset `name` in `DATASET_SPECS` (the paper's or an extension); an
    unknown name is a `ValueError` listing the known."""
    if not isinstance(name, str) or name not in DATASET_SPECS:
        raise ValueError(f"unknown dataset {name!r}; choose one of {', '.join(sorted(DATASET_SPECS))}")
    return DATASET_SPECS[name]


def audit_specs() -> list[DatasetSpec]:
    """The specs the label audit covers: every spherical-wrist (exact-label) spec of
    `PAPER_SPECS`, one per distinct grid / node selection / orientation / convention."""
    return distinct_specs(s for s in PAPER_SPECS.values() if s.method == "exact")


def dataset_paths(name: str, data_dir) -> tuple[Path, Path]:
    """Where the pipeline keeps dataset `name`: `(data_dir/NAME.npz, data_dir/NAME.test.npz)`
    (training set, independent test set). `name` is any dataset of the catalogue
    (`DATASET_SPECS`: the paper's and the extensions such as `panda7_tooldown`)."""
    dataset_spec(name)
    data_dir = Path(data_dir)
    return data_dir / f"{name}.npz", data_dir / f"{name}.test.npz"


def build_pair(name: str, data_dir, samples: int | None = None, test_samples: int = 1000,
               progress: bool = True) -> tuple[Path, Path]:
    """Build paper dataset `name` (scaled to `samples` arms; `None`: the paper's count) and
    its independent test set of `test_samples` arms into `data_dir` (`dataset_paths`),
    both or neither (`wsmap.datasets.build_dataset_files`: every input checked first)."""
    train_path, test_path = dataset_paths(name, data_dir)
    if test_samples is None:
        raise ValueError("test_samples must be a positive integer (build_pair always builds the test set)")
    build_dataset_files(DATASET_SPECS[name], train_path, samples=samples, test_samples=test_samples,
                        test_out=test_path, progress=progress)
    return train_path, test_path


def load_pair(name: str, data_dir):
    """The training and test sets of `name` built by `build_pair`, checked: the test set
    must be the training spec's test stream (same family, grid, orientation and labels)."""
    return load_dataset_files(*dataset_paths(name, data_dir))


def whole_param(where: str, key: str, value, minimum: int = 0) -> int:
    """`value` (a parameter `key` of `where`) as an int: a whole number of at least `minimum`,
    else a `ValueError` naming the file, section and key (`int("many")` names none of them)."""
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        shown = repr(value) if len(repr(value)) <= 60 else f"a {type(value).__name__}"
        raise ValueError(f"{where}: {key} must be a whole number of at least {minimum}, got {shown}")
    return value


def dataset_sizes(names: Sequence[str], sizes, source: str = "the params file") -> dict[str, dict]:
    """`{name: {"samples": n, "test_samples": m}}` for `names` from a params file's `datasets`
    section `sizes`, checked: a mapping per dataset with whole `samples` and `test_samples` of at
    least 1 (`source` names the file in the `ValueError`)."""
    if not isinstance(sizes, dict):
        raise ValueError(f"{source} section 'datasets' must be a mapping of datasets, got {type(sizes).__name__}")
    out = {}
    for name in names:
        if not isinstance(name, str) or name not in sizes:
            raise ValueError(f"{source} section 'datasets' has no {name!r}")
        item = sizes[name]
        where = f"{source} section 'datasets', dataset {name!r}"
        if not isinstance(item, dict):
            raise ValueError(f"{where} must be a mapping with samples and test_samples, got {type(item).__name__}")
        for key in ("samples", "test_samples"):
            if key not in item:
                raise ValueError(f"{where} has no {key!r} (it needs samples and test_samples)")
        out[name] = {key: whole_param(where, key, item[key], 1) for key in ("samples", "test_samples")}
    return out
