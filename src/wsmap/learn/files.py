"""Model files: `save` and `load`, with a SHA-256 checksum over everything stored.

Format (`FORMAT_VERSION = 2`)
-------------------------------
One `torch.save` file holding a dict of plain containers, numbers, strings and tensors (so
`load` reads it with `torch.load(weights_only=True)`; nothing in it can run code)::

    {"format": "wsmap.subspace_mlp", "version": 2, "wsmap_version": "0.1.0",
     "config": MLPConfig.to_dict(),
     "state_dict": {name: CPU tensor},          # weights, biases, input_mean, input_std
     "map_spec": dict | None,                   # what the outputs map (wsmap.learn.mapspec)
     "training_range": dict | None,             # TrainingRange.to_dict(): per-feature low/high,
                                                #   names, samples, fixed features and their values
     "dataset_spec", "train_config", "extra",   # provenance, as given to save()
     "checksum": "sha256:<64 hex digits>"}

`checksum` is the SHA-256 of a canonical encoding of every other entry (`payload_checksum`:
dict keys sorted, each value tagged with its type; floats exactly, via `float.hex`; a tensor as
its dtype, shape and raw bytes). `load` recomputes it from what it read and refuses the file
(`ModelFileError`) when it differs, so a flipped bit anywhere in the stored content -- a
weight, the config, the map spec, the training range -- is an error, never a silently different
model. (Bits of the zip container that do not reach the content, such as record padding, can
change without changing what loads: the model is then identical.) The file is written atomically:
a temporary file beside the target renamed over it.

Files of format version 1 (written before the checksum existed) are refused by default, with a
message saying how to re-save them; `load(path, allow_unverified=True)` reads one with an
`UnverifiedModelWarning`.

Errors
------
`load` raises `ModelFileError` (a `ValueError`) `"cannot load model <path>:
<problem>"` for a missing path, a directory, an unreadable file (permissions), an empty,
truncated or corrupt file, a file that is not a wsmap model, a checksum mismatch, an old or newer
format, an invalid config, map spec or training range, and a state that does not match the config.
`save` raises `TypeError` for a model or provenance it cannot store, `ModelFileError`
for a path that cannot be a file (a directory, below a regular file), and `OSError` (naming the
path) when writing fails.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import os
import struct
import warnings
from pathlib import Path
from collections.abc import Callable
from typing import Any, NoReturn

import numpy as np
import torch

from .._version import __version__
from ..io import atomic_path
from .mapspec import spec_feature_names
from .network import MLPConfig, SubspaceMLP, training_range_of
from .training_range import TrainingRange
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import PathLike

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "ModelFileError",
    "UnverifiedModelWarning",
    "payload_checksum",
    "to_plain",
    "write_model_payload",
    "read_model_payload",
    "save",
    "load",
]

FORMAT = "wsmap.subspace_mlp"
#: 2: a checksum and the training range; 1: neither (read only with `allow_unverified=True`).
FORMAT_VERSION = 2
_CHECKSUM_PREFIX = "sha256:"


class ModelFileError(ValueError):
    """A model file that cannot be used: missing, unreadable, corrupt, not a model, or not this format."""


class UnverifiedModelWarning(UserWarning):
    """A model file without a checksum (format version 1) was loaded with `allow_unverified=True`."""


# --------------------------------------------------------------------------------------------
# Plain content and its checksum
# --------------------------------------------------------------------------------------------


def to_plain(value, where: str):
    """`value` as content `torch.load(weights_only=True)` loads: dicts (str keys), lists, str,
    int, float, bool, None and tensors.

    Parameters
    ----------
    value : object
        Tuples become lists, numpy scalars and arrays Python numbers and lists, paths `str`,
        dataclasses and objects with `to_dict()` dicts; tensors are detached copies on the CPU.
    where : str
        What `value` is (`"train_config"`), named by the `TypeError` with the path to the
        offending item (`"extra['a'][2]"`).

    Returns
    -------
    object
        The plain content.

    Raises
    ------
    TypeError
        A dict key that is not a string, or a value of any other type.
    """
    if isinstance(value, np.generic):  # before the builtins: np.float64 is a float subclass
        value = value.item()
    if value is None:
        return None
    # Exact builtin types: subclasses (numpy scalars, enums) would need unsafe globals to load.
    for kind in (bool, int, float, str):
        if isinstance(value, kind):
            return kind(value)
    if isinstance(value, torch.Tensor):
        return value.detach().cpu().clone()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise TypeError(f"cannot save {where}: key {k!r} is not a string")
            out[k] = to_plain(v, f"{where}[{k!r}]")
        return out
    if isinstance(value, (list, tuple)):
        return [to_plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if hasattr(value, "to_dict") and callable(value.to_dict):
        return to_plain(value.to_dict(), where)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return to_plain(dataclasses.asdict(value), where)
    raise TypeError(f"cannot save {where}: {type(value).__name__} is not a plain value")


def _feed(h, value) -> None:
    """Feed a canonical, type-tagged encoding of `value` to the hash `h`."""
    def put(tag: bytes, data: bytes) -> None:
        h.update(tag + struct.pack("<Q", len(data)) + data)

    if value is None:
        put(b"N", b"")
    elif isinstance(value, bool):  # before int: bool is an int subclass
        put(b"B", b"1" if value else b"0")
    elif isinstance(value, int):
        put(b"I", str(value).encode())
    elif isinstance(value, float):
        put(b"F", value.hex().encode())
    elif isinstance(value, str):
        put(b"S", value.encode("utf-8", "surrogatepass"))
    elif isinstance(value, torch.Tensor):
        t = value.detach().cpu().contiguous()
        put(b"T", f"{t.dtype}|{list(t.shape)}".encode())
        put(b"D", t.reshape(-1).view(torch.uint8).numpy().tobytes() if t.numel() else b"")
    elif isinstance(value, dict):
        keys = list(value)
        if not all(isinstance(k, str) for k in keys):
            raise ValueError("a dict key is not a string")
        put(b"M", str(len(keys)).encode())
        for k in sorted(keys):
            _feed(h, k)
            _feed(h, value[k])
    elif isinstance(value, (list, tuple)):
        put(b"L", str(len(value)).encode())
        for v in value:
            _feed(h, v)
    else:
        raise ValueError(f"unexpected content of type {type(value).__name__}")


def payload_checksum(payload: dict) -> str:
    """`"sha256:<hex>"` of every entry of a model-file payload except `"checksum"`.

    The encoding is canonical (sorted dict keys, type tags, lengths, floats via `float.hex`,
    tensors as dtype, shape and little-endian bytes), so equal content gives equal checksums.
    Raises `ValueError` for content a model file cannot hold.
    """
    if not isinstance(payload, dict):
        raise ValueError(f"a model payload is a dict; got {type(payload).__name__}")
    h = hashlib.sha256()
    _feed(h, {k: v for k, v in payload.items() if k != "checksum"})
    return _CHECKSUM_PREFIX + h.hexdigest()


# --------------------------------------------------------------------------------------------
# save
# --------------------------------------------------------------------------------------------


def _check_output_path(path) -> Path:
    if path is None or not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    if str(path).strip() == "":
        raise ModelFileError("cannot save model: the path is empty")
    p = Path(path)
    if p.is_dir() or str(path).endswith(os.sep):
        raise ModelFileError(f"cannot save model to {path}: it is a directory; give a file name")
    parent = p.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if parent.exists() and not parent.is_dir():
        raise ModelFileError(f"cannot save model to {path}: {parent} is a file, not a directory")
    return p


def save(model: SubspaceMLP, path: PathLike, *, dataset_spec: dict | None = None, train_config: dict | None = None,
         extra: dict | None = None, training_data: Any | None = None) -> Path:
    """Write `model` and its provenance to `path` atomically (module docstring); returns the path.

    Parameters
    ----------
    model
        a `SubspaceMLP`.
    path
        the file to write (folders are created).
    dataset_spec, train_config, extra
        provenance: dicts, dataclasses or objects with
        `to_dict()` (e.g. `DatasetSpec`, `TrainConfig`), stored as plain values.
    training_data
        what the model was trained on, to record its training range: training
        features `(n, n_inputs)`, a dataset (`.features`) or a
        `TrainingRange`. `None`: the model's own
        `training_range` (set by `configure`). A
        model with a `map_spec` but no range at all is saved with a `UserWarning`: its
        maps will be refused unless `allow_extrapolation=True`.

    Notes
    -----
    The stored range gets feature names (`d_1`, ..., `r_3`) from the map spec's dataset or
    `dataset_spec` when one has the model's feature layout.
    """
    if not isinstance(model, SubspaceMLP):
        raise TypeError(f"save needs a SubspaceMLP; got {type(model).__name__}")
    p = _check_output_path(path)
    rng = model.training_range if training_data is None else training_range_of(training_data)
    if rng is not None:
        if rng.n_features != model.config.n_inputs:
            raise ValueError(f"training data has {rng.n_features} features, the model expects {model.config.n_inputs}")
        if rng.names is None:
            spec = model.map_spec["dataset"] if model.map_spec is not None else dataset_spec
            names = spec_feature_names(spec, rng.n_features)
            if names is None and spec is not dataset_spec:
                names = spec_feature_names(dataset_spec, rng.n_features)
            if names is not None:
                rng = rng.with_names(names)
    elif model.map_spec is not None:
        warnings.warn(f"saving model to {path} without a training range: predict_maps will refuse its arms unless "
                      "allow_extrapolation=True; configure the model on its training features or pass "
                      "save(..., training_data=features)", UserWarning, stacklevel=2)
    payload = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "wsmap_version": __version__,
        "config": model.config.to_dict(),
        "state_dict": {k: v.detach().cpu().clone() for k, v in model.state_dict().items()},
        "dataset_spec": to_plain(dataset_spec, "dataset_spec"),
        "train_config": to_plain(train_config, "train_config"),
        "extra": to_plain(extra, "extra"),
        "map_spec": to_plain(model.map_spec, "map_spec"),
        "training_range": None if rng is None else rng.to_dict(),
    }
    payload["checksum"] = payload_checksum(payload)
    try:
        with atomic_path(p) as tmp:
            torch.save(payload, tmp)
    except OSError as e:
        # wsmap.io names the outputs of a full disk's error itself; say it this module's way
        cause = e.__cause__ if isinstance(e.__cause__, OSError) and e.errno == e.__cause__.errno else e
        if cause is e and str(path) in str(e):
            raise
        raise type(e)(e.errno, f"cannot save model to {path}: {cause.strerror or cause}") from e
    except RuntimeError as e:  # torch's stream writer (a full disk, a vanished folder)
        raise OSError(f"cannot save model to {path}: {e}") from e
    return p


# --------------------------------------------------------------------------------------------
# load
# --------------------------------------------------------------------------------------------


def _read(path, fail) -> bytes:
    if path is None or not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = Path(path)
    if str(path).strip() == "":
        fail("the path is empty")
    if p.is_dir():
        fail("it is a directory, not a model file")
    if not p.exists():
        fail("no such file")
    try:
        data = p.read_bytes()
    except OSError as e:
        fail(f"cannot read it ({e.strerror or e})", e)
    if not data:
        fail("the file is empty (0 bytes)")
    return data


def _shown(value, limit: int = 60) -> str:
    """A value read from a file, for a message: its type and repr, cut to `limit` characters (a
    list of 10^5 numbers as a format tag made a 700 kB line; a 400-digit version too)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**limit:
        return f"an integer of about {int(value.bit_length() * 0.30103) + 1} digits"  # str() refuses 4300+
    text = repr(value)
    text = text if len(text) <= limit else text[:limit] + "..."
    return text if isinstance(value, (str, int, float)) else f"{text} (a {type(value).__name__})"


def _read_payload(data: bytes, fail: Callable[..., NoReturn]) -> dict:
    """The payload dict of a model file's bytes, read with `weights_only=True` on the CPU;
    `fail` for anything that is not a torch zip of this `FORMAT`."""
    if not data.startswith(b"PK\x03\x04"):
        fail("not a wsmap model file (not a torch zip archive; truncated or corrupt, or another kind of file)")
    try:
        payload = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as e:  # truncated zip, flipped bits, a pickle with non-plain content
        fail("not a readable torch file (truncated or corrupt)", e)
    if not isinstance(payload, dict) or "format" not in payload:
        fail("not a wsmap model file (no format tag)")
    if not isinstance(payload["format"], str) or payload["format"] != FORMAT:
        fail(f"format tag {_shown(payload['format'])} is not {FORMAT!r}")
    return payload


def _verified_version(payload: dict, path, fail: Callable[..., NoReturn], allow_unverified: bool) -> int:
    """The payload's format version, after checking its checksum (version 2) or, for version 1
    (no checksum), refusing it unless `allow_unverified` (then an `UnverifiedModelWarning`
    attributed to `load`'s caller)."""
    version = payload.get("version")
    if isinstance(version, bool) or not isinstance(version, int) or not 1 <= version <= FORMAT_VERSION:
        fail(f"format version {_shown(version)} is not supported (this wsmap reads 1..{FORMAT_VERSION})")
    if version >= 2:
        checksum = payload.get("checksum")
        if not isinstance(checksum, str) or not checksum.startswith(_CHECKSUM_PREFIX):
            fail("it has no valid checksum (corrupt)")
        try:
            actual = payload_checksum(payload)
        except ValueError as e:
            fail(f"corrupt content ({e})", e)
        if actual != checksum:
            fail("checksum mismatch: the file is corrupt (its content differs from what was saved)")
        return version
    message = "written by an older wsmap (format version 1) without a checksum, so its integrity cannot be verified"
    if not allow_unverified:
        fail(message + ". Re-create it (make paper), or, if you trust it, re-save it in the current format: "
             "model, meta = wsmap.learn.load(path, allow_unverified=True); wsmap.learn.save(model, path, "
             "training_data=<training features>, dataset_spec=meta['dataset_spec'], ...)")
    warnings.warn(f"model {path}: {message}; loaded anyway (allow_unverified=True)", UnverifiedModelWarning,
                  stacklevel=3)
    return version


def _state_problems(expected: dict[str, torch.Tensor], state: dict) -> list[str]:
    """What keeps the stored `state` from loading into a model whose state dict is `expected`:
    missing or unexpected keys, non-tensors, wrong shapes, non-floating dtypes (empty: it fits)."""
    problems = []
    if sorted(set(expected) - set(state)):
        problems.append(f"missing {sorted(set(expected) - set(state))}")
    if sorted(set(state) - set(expected)):
        problems.append(f"unexpected {sorted(set(state) - set(expected))}")
    for k in sorted(set(expected) & set(state)):
        v = state[k]
        if not isinstance(v, torch.Tensor):
            problems.append(f"{k} is not a tensor")
        elif tuple(v.shape) != tuple(expected[k].shape):
            problems.append(f"{k} has shape {tuple(v.shape)}, config needs {tuple(expected[k].shape)}")
        elif not v.is_floating_point():
            problems.append(f"{k} has dtype {v.dtype}, not a floating-point type")
    return problems


def _model_from_payload(payload: dict, fail: Callable[..., NoReturn]) -> SubspaceMLP:
    """The `SubspaceMLP` a verified payload describes (on the CPU, in the stored dtype), with
    its map spec and training range; `fail` for an invalid config, state, spec or range."""
    missing = [k for k in ("config", "state_dict") if not isinstance(payload.get(k), dict)]
    if missing:
        fail(f"missing {missing}")
    try:
        config = MLPConfig.from_dict(payload["config"])
    except (TypeError, ValueError) as e:
        fail(f"invalid config: {e}", e)
    model = SubspaceMLP(config, _init=False)
    state = payload["state_dict"]
    problems = _state_problems(model.state_dict(), state)
    if problems:
        fail("state does not match config: " + "; ".join(problems))
    if payload.get("map_spec") is not None:
        try:
            model.map_spec = payload["map_spec"]
        except (TypeError, ValueError) as e:
            fail(f"invalid map_spec: {e}", e)
    if payload.get("training_range") is not None:
        try:
            model.training_range = TrainingRange.from_dict(payload["training_range"])
        except (TypeError, ValueError) as e:
            fail(f"invalid training_range: {e}", e)
    dtypes = {v.dtype for v in state.values()}
    try:
        if len(dtypes) == 1:
            model.to(dtype=dtypes.pop())  # keep what was saved (float32 for the networks)
        model.load_state_dict(state)
    except (RuntimeError, TypeError, ValueError) as e:
        fail(f"cannot use its state ({e})", e)
    return model


def load(path: PathLike, *, map_location: str | torch.device = "cpu",
         allow_unverified: bool = False) -> tuple[SubspaceMLP, dict[str, Any]]:
    """Read a file written by `save` -> `(model, meta)`.

    `meta`: `path` (str), `format`, `version`, `wsmap_version`, `dataset_spec`,
    `train_config`, `extra`, `map_spec`, `training_range` (the stored dict, `None` where
    absent), `checksum` (`None` for version-1 files). The model is in eval mode and has its
    `map_spec` and `training_range` back (`None` where the file has none).

    Parameters
    ----------
    path
        the model file.
    map_location
        device for the parameters (the file is read and verified on the CPU).
    allow_unverified
        read a format-1 file (no checksum) with an
        `UnverifiedModelWarning` instead of refusing it.

    Raises
    ------
    ModelFileError
        (a `ValueError`) `"cannot load model <path>: <problem>"`; see the
        module docstring.
    TypeError
        `path` is not a str or path.
    """
    def fail(problem: str, cause: BaseException | None = None) -> NoReturn:
        raise ModelFileError(f"cannot load model {path}: {problem}") from cause

    payload = _read_payload(_read(path, fail), fail)
    version = _verified_version(payload, path, fail, allow_unverified)
    model = _model_from_payload(payload, fail)
    model.to(map_location)
    model.eval()
    meta = {"path": str(path), "format": payload["format"], "version": version,
            "wsmap_version": payload.get("wsmap_version"), "dataset_spec": payload.get("dataset_spec"),
            "train_config": payload.get("train_config"), "extra": payload.get("extra"),
            "map_spec": model.map_spec, "training_range": payload.get("training_range"),
            "checksum": payload.get("checksum") if version >= 2 else None}
    return model, meta


def write_model_payload(path: PathLike, payload: dict) -> Path:
    """Write a model file's `payload` (plain content, `format` and `version` among it) to `path`
    atomically with its `payload_checksum` added; returns the path. The writer of the model kinds
    that have their own format (`wsmap.learn.morph_model`, `wsmap.learn.pose_model`)."""
    p = Path(path)
    if p.is_dir():
        raise ModelFileError(f"cannot save model {path}: it is a directory")
    payload = {**payload, "checksum": payload_checksum(payload)}
    p.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(p) as tmp:
        torch.save(payload, tmp)
    return p


def read_model_payload(path: PathLike, fmt: str, version: int, what: str) -> dict:
    """The payload of a file of `write_model_payload` whose format tag is `fmt` at `version`.

    A missing file, one that is not a torch archive, a truncated or corrupt one, another format (the
    message names it and `what` this one is: `"a morphology model"`), another version and a checksum
    that does not match are each a one-line `ModelFileError` `"cannot load model <path>: <problem>"`."""
    def fail(problem, cause=None):
        raise ModelFileError(f"cannot load model {path}: {problem}") from cause

    p = Path(path)
    if not p.is_file():
        fail("no such file")
    data = p.read_bytes()
    if not data.startswith(b"PK\x03\x04"):
        fail("not a wsmap model file (not a torch zip archive)")
    try:
        payload = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as e:  # a truncated zip, flipped bits
        fail("not a readable torch file (truncated or corrupt)", e)
    if not isinstance(payload, dict) or "format" not in payload:
        fail("not a wsmap model file (no format tag)")
    if payload["format"] != fmt:
        other = " (a family map model)" if payload["format"] == FORMAT else ""
        fail(f"it is a {payload['format']!r} file{other}, not {what} ({fmt!r})")
    if payload.get("version") != version:
        fail(f"format version {payload.get('version')!r} is not supported (this wsmap reads {version})")
    if payload_checksum(payload) != payload.get("checksum"):
        fail("checksum mismatch: the file is corrupt (its content differs from what was saved)")
    return payload
