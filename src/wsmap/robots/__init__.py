"""Named arms and the families of arms.

* `load` — a named arm by name (`ROBOTS`): the paper's `puma560` (a
  `DHRobot`) and real arms from their manufacturers' published kinematics
  (`SerialChain`), each one `ArmTable` in `NAMED` with the
  document it comes from (`SOURCES`); `ARMS` holds every arm's record (`NamedArm`: its
  constructor, table, capsule collision model `ArmCapsules`, and whether the morphology
  families hold it out), listed by priority;
* `from_dh` (standard or modified DH), `from_urdf` and `from_mjcf` (MuJoCo) — any
  other serial arm;
* `puma560` and `spherical_wrist` — the paper's arms from their DH lengths;
* `ArmFamily` and `FAMILIES` — the families of random arms (`.families`).

Where things are:

* `.registry` — the `NamedArm`, `ArmTable` and `ArmCapsules` records and the registry
  (`ARMS`, `register`, `register_constructor`, `load`);
* `.arms` — one module per named arm (`arms/panda.py` is `load("panda")`), each a short
  table of the manufacturer's numbers with its source, its capsule model and whether the
  morphology families hold it out, ending with its registration (an explicit priority: the order
  `wsmap robots` lists). A new named arm is one new module there (found by
  `wsmap._plugins.discover`) plus its tests in `tests/robots/`;
* `.families` — the families of arms and their samplers;
* `.morph` — the `morph6` / `morph7` families (random 6R / 7R arms over the range of real
  arms, the held-out named arms excepted), registered into `FAMILIES` on import.

Every named arm has its base at the manufacturer's base (mounting flange) frame and its end at the
tool flange (no gripper), its joint zero and signs as the manufacturer's controller, and its joint
limits in radians (`±inf` for a continuous joint; `qlim` is `None` when no joint is limited).
"""

from __future__ import annotations

from ..kinematics.chain import from_dh
from ..kinematics.mjcf import MJCFError, from_mjcf
from ..kinematics.urdf import URDFError, from_urdf
from .registry import (ARMS, NAMED, ROBOTS, SOURCES, ArmCapsules, ArmTable, NamedArm, from_name, load, register,
                       register_constructor)

# Importing the arms registers them; ROBOTS lists them by priority (the paper's puma560 first).
from . import arms  # noqa: E402, F401, I001
from .arms.puma560 import PUMA560_QLIM_DEG, puma560  # noqa: E402
from . import families  # noqa: E402
from . import morph  # noqa: E402, F401 -- registers the morph6 and morph7 families
from .families import *  # noqa: E402, F401, F403 -- the families' public names, listed once in families.__all__

__all__ = [
    "PUMA560_QLIM_DEG", "puma560", "ArmTable", "ArmCapsules", "NamedArm", "ARMS", "NAMED", "ROBOTS", "SOURCES",
    "register", "register_constructor",
    "load", "from_name", "from_dh", "from_urdf", "URDFError", "from_mjcf", "MJCFError", *families.__all__,
]
