"""Compatibility module: the dataset code moved to :mod:`wsmap.datasets`, the paper's specs to
:mod:`wsmap.paper.specs`, the command line to ``wsmap data build|list|audit``.

Every public name of the old ``wsmap.data`` still works from here (``from wsmap import data as D``;
``D.load_dataset``, ``D.PAPER_SPECS``, ...). New code imports :mod:`wsmap.datasets` (the library)
and :mod:`wsmap.paper.specs` (the paper's catalogue). The audits keep their old defaults here (the
paper's specs); in :mod:`wsmap.datasets` they take the specs as arguments.
"""

from __future__ import annotations

from .datasets import (  # noqa: F401 -- re-exported
    CONVENTIONS,
    DEFAULT_STARTS,
    FAMILIES,
    FORMAT,
    FORMAT_VERSION,
    METHODS,
    SCOPES,
    STREAMS,
    Dataset,
    DatasetError,
    DatasetSpec,
    arms_from_features,
    audit_labels,
    build_dataset,
    build_dataset_files,
    draw_samples,
    feature_names,
    feature_slices,
    features_for,
    fixed_from_features,
    grid_axes,
    grid_nodes,
    labels_for,
    load_dataset,
    node_slice,
    possibly_reachable,
    rotation_to_rpy,
    scaled,
    spec_nodes,
    start_configurations,
    test_spec,
    uniform_rotations,
)
from .datasets import audit as _audit
from .paper.specs import (  # noqa: F401 -- re-exported
    PAPER_SPECS,
    TABLE3_RPY,
    audit_specs,
    build_pair,
    dataset_paths,
    load_pair,
    paper_spec,
)

__all__ = [
    "FAMILIES", "SCOPES", "STREAMS", "DEFAULT_STARTS", "DatasetSpec", "DatasetError", "Dataset", "PAPER_SPECS",
    "TABLE3_RPY", "test_spec", "scaled", "grid_axes", "grid_nodes", "spec_nodes", "node_slice", "feature_names",
    "feature_slices", "features_for", "arms_from_features", "fixed_from_features", "draw_samples",
    "start_configurations", "uniform_rotations", "rotation_to_rpy", "labels_for", "possibly_reachable",
    "build_dataset", "load_dataset", "starts_study", "starts_recall", "audit_labels", "audit_table",
    "dataset_paths", "build_pair", "load_pair",
]


def _specs(specs):
    return [paper_spec(s) if isinstance(s, str) else s for s in specs]


def starts_study(spec: DatasetSpec | None = None, n_arms: int = 200, counts=(1, 2, 3, 5, 9, 17), seed: int = 0,
                 chunk: int = 8, progress: bool = True) -> list[dict]:
    """:func:`wsmap.datasets.starts_study`; ``spec`` defaults to Table 3's arbitrary arms."""
    from .paper.specs import STARTS_STUDY_SPEC

    return _audit.starts_study(STARTS_STUDY_SPEC if spec is None else spec, n_arms, counts, seed, chunk, progress)


def starts_recall(spec: DatasetSpec | None = None, n_poses: int = 2000, counts=(1, 2, 3, 5, 9, 17),
                  seed: int = 0) -> list[dict]:
    """:func:`wsmap.datasets.starts_recall`; ``spec`` defaults to Table 3's arbitrary arms."""
    from .paper.specs import STARTS_STUDY_SPEC

    return _audit.starts_recall(STARTS_STUDY_SPEC if spec is None else spec, n_poses, counts, seed)


def audit_table(specs=None, n_arms: int = 50, seed: int = 0, progress: bool = False) -> list[dict]:
    """:func:`wsmap.datasets.audit_table`; ``specs`` may be paper dataset names and defaults to
    :func:`wsmap.paper.specs.audit_specs` (every distinct spherical-wrist spec)."""
    return _audit.audit_table(audit_specs() if specs is None else _specs(specs), n_arms=n_arms, seed=seed,
                              progress=progress)


if __name__ == "__main__":
    import sys

    sys.exit("python -m wsmap.data is gone: use `wsmap data build|list|audit` (see `wsmap data --help`)")
