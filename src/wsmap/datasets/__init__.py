"""Experience datasets: random arms, the features the paper's networks read, and their workspace maps.

A dataset is `samples` random arms, one row each: a feature vector (the arm's DH parameters, the
grid's axes and the fixed orientation or point) and the labels of the grid's nodes (reachable or
not). Everything that determines a dataset is a `DatasetSpec`; the same spec always gives
the same, byte-identical file.

Where things are:

* `.spec` -- `DatasetSpec` and its checks, the choices (`FAMILIES`,
  `SCOPES`, ...), `test_spec` (the independent test set), `scaled`;
* `.features` -- the feature and label layout: grid nodes, column names and ranges,
  `features_for` (what a trained model is asked about);
* `.sampling` -- the random streams, uniform rotations, `draw_samples`,
  `start_configurations`;
* `.labels` -- `labels_for` (exact closed form, or multi-start LM) and the
  `possibly_reachable` pre-filter;
* `.collision` -- collision-free labels of a chain family (the spec's `collision` field,
  `LabelCollision`);
* `.store` -- the file format, `build_dataset`, `build_dataset_files` (training
  and test file, all or nothing; in this process or on Dask: `workers=`, `scheduler=`),
  `load_dataset` (checked), `Dataset`;
* `.audit` -- the IK label audits: `starts_study`, `starts_recall`,
  `audit_labels`, `audit_table`;
* `.ram` -- RAM's evaluation protocol (its random arms, poses, boundary set, IK and FK-sampling
  labels, F1): `sample_morphologies`, `ram_arms`, `ik_labels`, `fk_labels`, `ram_f1`, ...

The paper's datasets (one spec per experiment) are `wsmap.paper.specs.PAPER_SPECS`.

Example::

    from wsmap import datasets
    spec = datasets.DatasetSpec("demo", step=0.5, samples=100, seed=1)
    datasets.build_dataset_files(spec, "demo.npz", test_samples=50)  # demo.npz, demo.test.npz
    train, test = datasets.load_dataset_files("demo.npz")
    train.features.shape, train.labels.shape                          # (100, 36), (100, 125)
"""

from .collision import LabelCollision, label_collision
from .audit import audit_labels, audit_table, distinct_specs, starts_recall, starts_study
from .features import (
    arms_from_features,
    feature_names,
    scales_for,
    feature_slices,
    features_for,
    fixed_from_features,
    grid_axes,
    grid_nodes,
    node_slice,
    spec_nodes,
)
from .labels import labels_for, possibly_reachable
from .ram import (
    RAM_DOFS,
    RAM_LINK_RADIUS,
    RAM_PUBLISHED,
    RAM_R3_DIVISIONS,
    RAM_SO3_DIVISIONS,
    boundary_poses,
    fk_labels,
    fk_samples,
    ik_labels,
    ram_arms,
    ram_collision,
    ram_f1,
    random_poses,
    reach_ball,
    sample_morphologies,
    se3_cells,
)
from .sampling import draw_samples, draw_scales, rotation_to_rpy, start_configurations, uniform_rotations
from .spec import (
    CHAIN_FAMILIES,
    CHAIN_FAMILY_GRID,
    CONVENTIONS,
    DEFAULT_STARTS,
    FAMILIES,
    MAX_GRID_NODES,
    MAX_LM_ITERATIONS,
    MAX_SAMPLES,
    MAX_STARTS,
    MAX_TOL,
    METHODS,
    SCOPES,
    STREAMS,
    DatasetSpec,
    scaled,
    test_spec,
)
from .store import (
    CONNECT_TIMEOUT,
    FORMAT,
    WORKER_TIMEOUT,
    FORMAT_VERSION,
    Dataset,
    DatasetError,
    SchedulerError,
    build_dataset,
    build_dataset_files,
    load_dataset,
    load_dataset_files,
    test_path_for,
)

__all__ = [
    # spec
    "FAMILIES", "CHAIN_FAMILIES", "CHAIN_FAMILY_GRID", "SCOPES", "STREAMS", "CONVENTIONS", "METHODS", "DEFAULT_STARTS",
    "MAX_GRID_NODES", "MAX_SAMPLES", "MAX_STARTS", "MAX_LM_ITERATIONS", "MAX_TOL",
    "DatasetSpec", "test_spec", "scaled", "LabelCollision", "label_collision",
    # features
    "grid_axes", "grid_nodes", "spec_nodes", "node_slice", "feature_names", "feature_slices",
    "features_for", "scales_for", "arms_from_features", "fixed_from_features",
    # sampling
    "draw_samples", "draw_scales", "start_configurations", "uniform_rotations", "rotation_to_rpy",
    # labels
    "labels_for", "possibly_reachable",
    # store
    "FORMAT", "FORMAT_VERSION", "DatasetError", "SchedulerError", "CONNECT_TIMEOUT", "WORKER_TIMEOUT", "Dataset",
    "build_dataset", "build_dataset_files",
    "load_dataset", "load_dataset_files", "test_path_for",
    # audit
    "starts_study", "starts_recall", "audit_labels", "audit_table", "distinct_specs",
    # RAM's protocol
    "RAM_DOFS", "RAM_LINK_RADIUS", "RAM_PUBLISHED", "RAM_R3_DIVISIONS", "RAM_SO3_DIVISIONS", "sample_morphologies",
    "ram_arms", "ram_collision", "reach_ball", "random_poses", "fk_samples", "boundary_poses", "ik_labels",
    "se3_cells", "fk_labels", "ram_f1",
]
