"""Compatibility module: the subspace networks, their files and map predictions now live in :mod:`wsmap.learn`.

``wsmap.models.X`` is ``wsmap.learn.X`` for every name this module had (``MLPConfig``,
``SubspaceMLP``, ``save``, ``load``, ``make_map_spec``, ``predict_maps_from_file``, the
initialisers, ...) plus the new ones of the model files and the training range
(``ModelFileError``, ``TrainingRange``, ``ExtrapolationError``, ``ExtrapolationWarning``). New code
should import from :mod:`wsmap.learn` (``wsmap.learn.network``, ``.files``, ``.predictor``, ...).
"""

from .learn.files import FORMAT, FORMAT_VERSION, ModelFileError, UnverifiedModelWarning, load, save
from .learn.init import matlab_rands_, nguyen_widrow_, torch_default_
from .learn.mapspec import MapPlan as _MapPlan  # noqa: F401 -- the old private names
from .learn.mapspec import make_map_spec
from .learn.mapspec import map_plan as _map_plan  # noqa: F401
from .learn.network import (
    ACTIVATIONS,
    INITS,
    INPUT_SCALINGS,
    OUTPUT_KINDS,
    MLPConfig,
    SubspaceMLP,
    check_features,
)
from .learn.predictor import predict_maps_from_file
from .learn.training_range import ExtrapolationError, ExtrapolationWarning, TrainingRange

__all__ = [
    "ACTIVATIONS",
    "INITS",
    "INPUT_SCALINGS",
    "OUTPUT_KINDS",
    "FORMAT",
    "FORMAT_VERSION",
    "MLPConfig",
    "SubspaceMLP",
    "nguyen_widrow_",
    "matlab_rands_",
    "torch_default_",
    "check_features",
    "save",
    "load",
    "make_map_spec",
    "predict_maps_from_file",
    "ModelFileError",
    "UnverifiedModelWarning",
    "TrainingRange",
    "ExtrapolationError",
    "ExtrapolationWarning",
]
