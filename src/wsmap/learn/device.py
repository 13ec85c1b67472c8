"""Where the networks run: the `device` setting (`auto`, `cpu`, `cuda`) as a torch device.

Every place that trains or runs a network takes one setting, `device` (the params files' key of
the same name, `wsmap.learn.training.TrainConfig.device`, `runtime_comparison(device=...)`,
`predict_maps(..., device=...)`, `wsmap paper full --device`):

==========  =================================================================================
value       device
==========  =================================================================================
`auto`    `cuda` when `torch.cuda.is_available()`, else `cpu`
`cpu`     the CPU (the committed pipeline's setting)
`cuda`    the current CUDA GPU; `cuda:N` GPU `N`. Without a usable GPU this is an error
            (`DeviceUnavailableError`, a `ValueError` naming the setting), raised by
            `resolve_device` before any work -- never a silent fall-back to the CPU
==========  =================================================================================

Names are case-insensitive; a `torch.device` of type `cpu` or `cuda` is accepted too. Any
other name (`gpu`, `mps`, `cuda:x`, ...) is a `ValueError` listing the accepted ones.

The networks are always *built* (and initialised, from CPU random generators) on the CPU and then
moved, so a model trained with `device: cuda` starts from the same weights as on the CPU; model
files always store CPU tensors and load on the CPU (`wsmap.learn.files.load(map_location=...)`).
"""

from __future__ import annotations

import re

import torch

__all__ = ["DEVICES", "DeviceUnavailableError", "check_device_name", "resolve_device", "device_facts"]

#: The accepted values of the `device` setting (plus `cuda:N`).
DEVICES = ("auto", "cpu", "cuda")
_CUDA_INDEX = re.compile(r"^cuda:(\d+)$")


class DeviceUnavailableError(ValueError):
    """The `device` setting asks for a GPU that this machine (or this torch build) does not have."""


def check_device_name(name: str, what: str = "device") -> str:
    """The canonical spelling of a `device` setting (`"auto"`, `"cpu"`, `"cuda"` or
    `"cuda:N"`), checking only the name, not whether the device exists. `what` names the
    setting in the error (e.g. `"params.yaml section 'sec61_subspace' device"`).

    Raises
    ------
    ValueError
        anything else (including `None`, numbers, `"gpu"`, `"mps"`).
    """
    if isinstance(name, torch.device):
        if name.type not in ("cpu", "cuda"):
            raise ValueError(f"{what} {str(name)!r} is not supported; choose one of auto, cpu, cuda, cuda:N")
        return str(name)
    if not isinstance(name, str):
        raise ValueError(f"{what} must be one of auto, cpu, cuda (or cuda:N); got {name!r}")
    key = name.strip().lower()
    if key in DEVICES or _CUDA_INDEX.match(key):
        return key
    raise ValueError(f"unknown {what} {name!r}; choose one of auto, cpu, cuda (or cuda:N for GPU N)")


def resolve_device(name: str = "auto", what: str = "device") -> torch.device:
    """The `torch.device` a `device` setting means on this machine (module docstring).

    `auto` is `cuda` if `torch.cuda.is_available()` else `cpu`; `cuda` / `cuda:N`
    must name a usable GPU. `what` names the setting in error messages.

    Raises
    ------
    ValueError
        an unknown name (`check_device_name`).
    DeviceUnavailableError
        (a `ValueError`) `cuda` without a usable CUDA GPU, or `cuda:N`
        beyond the GPUs present.
    """
    key = check_device_name(name, what)
    if key == "cpu":
        return torch.device("cpu")
    available = torch.cuda.is_available()
    if key == "auto":
        return torch.device("cuda" if available else "cpu")
    if not available:
        build = torch.version.cuda
        why = ("this torch build has no CUDA support (torch " + torch.__version__ + ")" if build is None
               else "torch.cuda.is_available() is False (no GPU or no driver)")
        raise DeviceUnavailableError(f"{what} {key!r} asks for a CUDA GPU, but {why}; use auto (the GPU when "
                                     "present, else the CPU) or cpu")
    m = _CUDA_INDEX.match(key)
    if m is not None:
        index, count = int(m.group(1)), torch.cuda.device_count()
        if index >= count:
            raise DeviceUnavailableError(f"{what} {key!r}: this machine has {count} CUDA GPU(s), "
                                         f"cuda:0..cuda:{count - 1}")
        return torch.device("cuda", index)
    return torch.device("cuda")


def device_facts(device) -> dict:
    """Plain facts about a resolved device, for result files: `type`, `name` (the GPU's
    name, or `"cpu"`), and for a GPU its memory in GiB and the CUDA version of torch."""
    device = torch.device(device)
    if device.type != "cuda":
        return {"type": "cpu", "name": "cpu", "torch_threads": torch.get_num_threads()}
    index = device.index if device.index is not None else torch.cuda.current_device()
    props = torch.cuda.get_device_properties(index)
    return {"type": "cuda", "index": index, "name": props.name,
            "memory_gib": round(props.total_memory / 2**30, 1), "cuda": torch.version.cuda}
