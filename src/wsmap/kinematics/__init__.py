"""Kinematics: rigid transforms, robot models, forward kinematics and Jacobians, inverse kinematics.

Forward kinematics (no module here imports the IK layer):

* `.transforms` — rotations, homogeneous transforms, pose error, input checks;
* `.arms` — what every arm class shares (batches, indexing, joint checks);
* `.dh` — `DHRobot`, standard-DH revolute arms batched over geometry (the paper's);
* `.chain` — `SerialChain`, any serial arm of revolute/prismatic joints (DH, modified
  DH, URDF), `as_chain`; coupled joints (URDF mimic, MJCF joint equality) through its
  `Coupling`;
* `.urdf` — chains from URDF files.

Inverse kinematics, `.ik` (every solver returns an `IKSolution`):

* closed forms, one module each in `.ik.closed_forms`, found through
  `closed_form_for` (`.ik.registry`);
* `ikine_LM` — the paper's Levenberg–Marquardt (`.ik.lm`);
* `ikine_search`, `map_search` — the reachability search for any arm (`.ik.search`);
* `.lm_lanes` — the lane (SIMD, C++) kernel that runs both numerical paths by default,
  several targets per instruction; `.lm_compiled` — the scalar (numba) kernel, its tested
  reference (`lm_lanes.set_kernel`), and the thread count of every compiled kernel
  (`lm_compiled.set_threads`); `.lm_coupled` — the same search on chains with coupled joints,
  which neither the lane kernel nor the closed forms take.
"""

from . import lm_compiled, lm_lanes  # noqa: F401  (the kernels' modules, reached as wsmap.kinematics.lm_*)
from .chain import PRISMATIC, REVOLUTE, Coupling, SerialChain, as_chain, from_dh
from .dh import DHRobot, arm_batch
from .ik import (
    SPHERICAL_WRIST_ALPHA,
    ClosedForm,
    IKReason,
    IKSolution,
    closed_form_for,
    closed_forms,
    ikine_LM,
    ikine_search,
    ikine_spherical_wrist,
    ikine_ur,
    is_spherical_wrist,
    is_ur_type,
    map_search,
    register,
    require_closed_form,
    require_spherical_wrist,
    require_ur_type,
    ur_parameters,
    ur_reachable,
    wrist_centre_reachable,
)
from .transforms import check_rigid, pose_error, rotx, roty, rotz, rpy2r, transl

__all__ = [
    "DHRobot",
    "PRISMATIC",
    "REVOLUTE",
    "SerialChain",
    "Coupling",
    "from_dh",
    "arm_batch",
    "as_chain",
    "IKSolution",
    "IKReason",
    "ClosedForm",
    "register",
    "closed_forms",
    "closed_form_for",
    "require_closed_form",
    "ikine_LM",
    "ikine_search",
    "map_search",
    "ikine_spherical_wrist",
    "is_spherical_wrist",
    "require_spherical_wrist",
    "wrist_centre_reachable",
    "SPHERICAL_WRIST_ALPHA",
    "ikine_ur",
    "is_ur_type",
    "require_ur_type",
    "ur_parameters",
    "ur_reachable",
    "check_rigid",
    "pose_error",
    "rotx",
    "roty",
    "rotz",
    "rpy2r",
    "transl",
]
