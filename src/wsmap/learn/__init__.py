"""Learned workspace maps: the paper's subspace networks, their training, files and predictions.

Where things are (each module's docstring has the details):

=====================  ==========================================================================
module                 contents
=====================  ==========================================================================
`network`            `MLPConfig`, `SubspaceMLP` (S stacked tanh MLPs: forward,
                       score/predict, `configure`, `predict_maps`), `check_features`
`init`               weight initialisation: Nguyen–Widrow (MATLAB `initnw`), MATLAB
                       `rands`, torch's default
`optim`              the paper's full-batch trainers (Table 2): Rprop as the paper, SCG, CGB,
                       OSS, GDX, and `make_optimizer`
`training`           `train` with MATLAB-style early stopping, `train_sessions`,
                       `TrainConfig`, losses, splits, Adam minibatches
`mapspec`            the `map_spec` (which grid and nodes the outputs are): validation, arm /
                       grid / threshold checks, features of arms
`training_range`     `TrainingRange`: what inputs the model was trained on; the
                       extrapolation check (`ExtrapolationError`, `ExtrapolationWarning`)
`predictor`          `predict_maps_from_file` (`wsmap map --method model`),
                       `predict_maps`
`files`              `save` / `load`: the model file format, with a SHA-256
                       checksum (`ModelFileError`)
`device`             `resolve_device`: the `device` setting (`auto`, `cpu`,
                       `cuda`) as a `torch.device`, with a clear error without a GPU
`morph_model`        one implicit map model for every 6/7R arm, f(morphology, point) -> logit:
                       `fit_morph_model`, files, the nearest-arm baseline
`verified`           `verified_morph_grid`: the morphology network's map with the nodes it is
                       unsure of (margin, boundary shell, grown from corrections) decided by the
                       classical map (`VerifiedMap`)
`screening`          `screen_arms`: many arms ranked for tool-down targets, mapped classically
                       best-first by an upper bound on their coverage (`Screening`)
`pose_model`         RAM's query, f(RAM table, pose) -> logit for any pose of a 5-7-joint RAM
                       arm, trained on exact IK labels: `build_pose_shards`, `fit_pose_model`,
                       `predict_poses`, files
`manipulability`     the spherical-wrist family's manipulability map (m³) learned from
                       `(d3, d4, a2, a3)`: `manipulability_dataset`,
                       `train_manipulability_model`, `predict_manipulability`,
                       `regression_metrics`, files
=====================  ==========================================================================

Imports go one way: `device`, `init`, `training_range`, `mapspec` and `optim` depend on nothing here;
`network` on those; `files` on `network`; `predictor` on `files`; `training` on `optim`
(and `predictor` and `training` on `device`); `manipulability` on `network`, `training` and
`files`. `mapspec` reads the dataset layout from `wsmap.datasets`. The classical library
never imports this package: `predictor` registers the `"model"` method of
`wsmap.workspace.grid_map` when it is imported.

A typical round trip::

    from wsmap import learn
    model = learn.SubspaceMLP(learn.MLPConfig(n_inputs=84, n_outputs=9261)).configure(X[split.train])
    learn.train(model, X, Y, learn.TrainConfig(), split=split)
    model.set_map_spec(dataset_spec)              # what the outputs are
    learn.save(model, "m.pt", dataset_spec=dataset_spec)
    maps = learn.predict_maps_from_file("m.pt", arms)   # refuses arms outside the training range
"""

from .device import DEVICES, DeviceUnavailableError, check_device_name, resolve_device
from .files import FORMAT, FORMAT_VERSION, ModelFileError, UnverifiedModelWarning, load, payload_checksum, save
from .init import matlab_rands_, nguyen_widrow_, torch_default_
from .mapspec import make_map_spec
from .network import (
    ACTIVATIONS,
    INITS,
    INPUT_SCALINGS,
    OUTPUT_KINDS,
    MLPConfig,
    SubspaceMLP,
    check_features,
    unit_saturation,
)
from .optim import (
    ALIASES,
    CGB,
    ELEMENTWISE,
    GDX,
    OPTIMIZERS,
    OSS,
    SCG,
    canonical_name,
    charalambous_search,
    make_optimizer,
    paper_rprop,
)
from .predictor import predict_maps, predict_maps_from_file
from .training import (
    LOSSES,
    LR_DECAYS,
    MINIBATCH_OPTIMIZERS,
    STOP_REASONS,
    History,
    Loss,
    Split,
    TrainConfig,
    TrainResult,
    make_loss,
    optimizer_name,
    split_indices,
    train,
    train_mlp_sessions,
    train_sessions,
    validation_stop,
)
from .manipulability import (
    FAMILY_RANGE,
    MANIPULABILITY_KIND,
    MANIPULABILITY_TARGETS,
    PARAM_NAMES,
    ManipulabilityModel,
    ManipulabilityTrainConfig,
    load_manipulability_model,
    manipulability_dataset,
    manipulability_grid,
    manipulability_params,
    manipulability_targets,
    predict_manipulability,
    regression_metrics,
    save_manipulability_model,
    train_manipulability_model,
)
from .training_range import ExtrapolationError, ExtrapolationWarning, TrainingRange
from . import morph_model  # noqa: E402, F401 -- registers the morphology model's file format with method="model"
from .verified import VERIFY_MARGIN, VERIFY_SHELL, VerifiedMap, verified_morph_grid  # noqa: E402
from .screening import Screening, predicted_coverage, screen_arms  # noqa: E402
from .pose_model import (  # noqa: E402
    PoseMapModel,
    PoseModelConfig,
    PoseShard,
    build_pose_shards,
    fit_pose_model,
    load_pose_model,
    pose_inputs,
    pose_training_set,
    predict_pose_logits,
    predict_poses,
    ram_inputs,
    save_pose_model,
)

__all__ = [
    # network
    "MLPConfig", "SubspaceMLP", "check_features", "unit_saturation", "ACTIVATIONS", "INITS", "INPUT_SCALINGS", "OUTPUT_KINDS",
    # initialisation
    "nguyen_widrow_", "matlab_rands_", "torch_default_",
    # optimisers
    "OPTIMIZERS", "ALIASES", "ELEMENTWISE", "canonical_name", "make_optimizer", "paper_rprop",
    "SCG", "CGB", "OSS", "GDX", "charalambous_search",
    # training
    "TrainConfig", "TrainResult", "History", "Split", "Loss", "LOSSES", "STOP_REASONS", "MINIBATCH_OPTIMIZERS",
    "LR_DECAYS", "make_loss", "split_indices", "train", "train_sessions", "train_mlp_sessions", "optimizer_name",
    "validation_stop",
    # what the model maps, and on which inputs
    "make_map_spec", "TrainingRange", "ExtrapolationError", "ExtrapolationWarning",
    # predictions and files
    "predict_maps", "predict_maps_from_file", "save", "load", "FORMAT", "FORMAT_VERSION", "ModelFileError",
    "UnverifiedModelWarning", "payload_checksum",
    # where networks run
    "resolve_device", "check_device_name", "DEVICES", "DeviceUnavailableError",
    # the manipulability map of the spherical-wrist family
    "ManipulabilityModel", "ManipulabilityTrainConfig", "manipulability_dataset", "manipulability_targets",
    "manipulability_params", "manipulability_grid", "train_manipulability_model", "predict_manipulability",
    "regression_metrics", "save_manipulability_model", "load_manipulability_model", "PARAM_NAMES", "FAMILY_RANGE",
    "MANIPULABILITY_TARGETS", "MANIPULABILITY_KIND",
    # the morphology network's maps with its unsure nodes decided by the classical search
    "VerifiedMap", "verified_morph_grid", "VERIFY_MARGIN", "VERIFY_SHELL",
    # a catalogue of arms ranked by the network, its best decided classically
    "Screening", "screen_arms", "predicted_coverage",
    # RAM's query: one network for every RAM arm and any pose, f(morphology, pose) -> logit
    "PoseModelConfig", "PoseMapModel", "PoseShard", "ram_inputs", "pose_inputs", "pose_training_set",
    "build_pose_shards", "fit_pose_model", "predict_pose_logits", "predict_poses", "save_pose_model", "load_pose_model",
]
