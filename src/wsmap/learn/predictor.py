"""The model as a stand-in for the classical map: maps of arms from a saved model file.

`predict_maps_from_file` is what `wsmap map --method model --model PATH` runs: it loads the
model (`wsmap.learn.files.load`, checksum verified), checks that the model maps the grid,
pose convention and coverage the caller wants, and returns
`predict_maps` of the arms -- which refuses arms outside the
model's training range (`wsmap.learn.training_range`) unless `allow_extrapolation=True`.
`predict_maps` is the same for a model in memory. Importing this module registers the
`"model"` method of `wsmap.workspace.grid_map` (`wsmap.workspace.maps.MAP_PREDICTORS`).
"""

from __future__ import annotations

import numpy as np
import torch

from ..workspace.maps import register_map_predictor
from .device import resolve_device
from .files import load
from .mapspec import grid_mismatch
from .network import SubspaceMLP
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, PathLike
    from wsmap.kinematics.chain import Arm

__all__ = ["predict_maps", "predict_maps_from_file", "check_model_grid", "MODEL_FORMATS", "register_model_format"]

#: Model files of other kinds than `wsmap.learn.files`' (their format tag -> the function
#: `method="model"` of `wsmap.workspace.grid_map` calls for such a file, with the arguments
#: of `_whole_grid_map` below); e.g. `"wsmap.morph_model"` (`wsmap.learn.morph_model`).
MODEL_FORMATS: dict = {}


def register_model_format(tag: str, predict) -> None:
    """Make `method="model"` answer a model file whose format tag is `tag` with `predict`."""
    if not callable(predict):
        raise TypeError(f"the predictor of model format {tag!r} must be callable, got {type(predict).__name__}")
    MODEL_FORMATS[tag] = predict


def _format_tag(path) -> str | None:
    """The format tag of the torch file at `path`; `None` when it has none or is unreadable
    (`wsmap.learn.files.load` then says what is wrong with it)."""
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # noqa: BLE001 -- any unreadable file: files.load names the problem
        return None
    return payload.get("format") if isinstance(payload, dict) else None


def predict_maps(model: SubspaceMLP, arms: Arm | ArrayLike, fixed: ArrayLike | None = None, *,
                 threshold: float | None = None, batch_size: int | None = None, allow_extrapolation: bool = False,
                 device: str | torch.device | None = None) -> np.ndarray:
    """`model.predict_maps(arms, fixed, ...)`: see `wsmap.learn.network.SubspaceMLP.predict_maps`.

    `device`: `None` (default): where the model is; else `"auto"`, `"cpu"`, `"cuda"`
    (`wsmap.learn.device.resolve_device`; `"cuda"` without a GPU is a `ValueError`
    before any work): the model is moved there (in place) and predicts there. The maps come back
    as numpy arrays either way.
    """
    if not isinstance(model, SubspaceMLP):
        raise TypeError(f"predict_maps needs a SubspaceMLP; got {type(model).__name__}")
    if device is not None:
        model.to(resolve_device(device))
    return model.predict_maps(arms, fixed, threshold=threshold, batch_size=batch_size,
                              allow_extrapolation=allow_extrapolation)


def _conventions_agree(spec) -> bool:
    """Whether both pose conventions give the model's poses: an R3 map at the identity orientation."""
    if spec.scope != "R3" or isinstance(spec.fixed, str):
        return False
    from ..kinematics import rpy2r

    return bool(np.allclose(rpy2r(np.asarray(spec.fixed, dtype=np.float64)), np.eye(3), rtol=0, atol=1e-12))


def check_model_grid(model: SubspaceMLP, *, grid: dict | None = None, convention: str | None = None,
                     whole_grid: bool = False, what: str = "the model") -> None:
    """Raise `ValueError` unless `model` has a `map_spec` whose grid is `grid` (a dict with
    `scope`, `lo`, `hi`, `step`, optionally `shape`; every difference is named), whose pose
    convention is `convention` (or one that gives the same poses: an R3 model at R = I, where
    `transl(p)·R` and `R·transl(p)` agree), and, with `whole_grid`, which covers every node of its
    grid."""
    if model.map_spec is None:
        raise ValueError(f"{what} has no map_spec (what grid and nodes it maps): set one with "
                         "model.set_map_spec(dataset_spec, ...) before saving it")
    plan = model._map_plan
    spec = plan.spec
    problems = grid_mismatch(spec, grid) if grid is not None else []
    if convention is not None and convention != spec.convention and not _conventions_agree(spec):
        problems.append(f"convention {convention} (model: {spec.convention})")
    if problems:
        nx, ny, nz = spec.grid_shape
        raise ValueError(f"{what} maps a different grid: {'; '.join(problems)}. The model was trained "
                         f"on dataset {spec.name!r}, {spec.scope} grid of {nx}x{ny}x{nz} nodes")
    if whole_grid and (plan.nodes.start, plan.nodes.stop) != (0, spec.grid_nodes):
        raise ValueError(f"{what} covers nodes [{plan.nodes.start}, {plan.nodes.stop}) of its grid's "
                         f"{spec.grid_nodes} only; a whole-grid map needs a model of every node (e.g. the 7 "
                         "block models assembled)")


def predict_maps_from_file(path: PathLike, arms: Arm | ArrayLike, fixed: ArrayLike | None = None, *,
                           threshold: float | None = None, batch_size: int | None = None, grid: dict | None = None,
                           convention: str | None = None, whole_grid: bool = False, allow_extrapolation: bool = False,
                           map_location: str | torch.device = "cpu", device: str | torch.device | None = None
                          ) -> np.ndarray:
    """`predict_maps` of the model saved at `path`.

    Parameters
    ----------
    path
        a model file written by `wsmap.learn.files.save` from a model with a
        `map_spec` (and a training range).
    arms, fixed, threshold, batch_size, allow_extrapolation
        as `predict_maps`.
    grid
        optional dict with `scope` (`"R3"`/`"SO3"`), `lo`, `hi`, `step` (scalars
        or 3 values; metres or radians) and optionally `shape` that the caller expects the
        map on; it must be the model's grid, else `ValueError` names every difference.
    convention
        optional pose convention (`"paper"`/`"standard"`) the caller expects; must
        be the model's.
    whole_grid
        require the model to cover every node of its grid (a flat map of the whole
        grid, as `wsmap map` writes), not a node slice of it.
    map_location
        the torch device the model is loaded onto (default the CPU; files always
        hold CPU tensors and are read and verified on the CPU).
    device
        the `device` setting instead (`"auto"`, `"cpu"`, `"cuda"`;
        `wsmap.learn.device.resolve_device`, checked before the file is read); when
        given it overrides `map_location`.

    Returns
    -------
    np.ndarray
        bool `(..., N)` maps in node order.

    Raises
    ------
    ModelFileError
        an unreadable, corrupt or old file (from `load`).
    ExtrapolationError
        arms outside the model's training range, or a model without one,
        unless `allow_extrapolation`.
    ValueError
        a model without `map_spec`; a grid, convention or coverage that does not
        match; bad arms, `fixed`, threshold or batch size.
    """
    if device is not None:
        map_location = resolve_device(device)
    model, _ = load(path, map_location=map_location)
    check_model_grid(model, grid=grid, convention=convention, whole_grid=whole_grid, what=f"model {path}")
    return model.predict_maps(arms, fixed, threshold=threshold, batch_size=batch_size,
                              allow_extrapolation=allow_extrapolation)


def _whole_grid_map(path, robot, fixed, *, grid: dict, convention: str, allow_extrapolation: bool) -> np.ndarray:
    """`method="model"` of `wsmap.workspace.grid_map`: the map `(N,)` of one arm on the whole
    grid `grid` from the model file at `path` (`predict_maps_from_file` with `whole_grid`),
    or from the predictor of its format (`MODEL_FORMATS`)."""
    other = MODEL_FORMATS.get(_format_tag(path))
    if other is not None:
        return other(path, robot, fixed, grid=grid, convention=convention, allow_extrapolation=allow_extrapolation)
    return predict_maps_from_file(path, robot, fixed, grid=grid, convention=convention, whole_grid=True,
                                  allow_extrapolation=allow_extrapolation)


register_map_predictor("model", _whole_grid_map)
