"""Kinematics: rigid transforms, robot models, forward kinematics and Jacobians, inverse kinematics.

* :mod:`.transforms` — rotations, homogeneous transforms, pose error, input checks;
* :mod:`.dh` — :class:`DHRobot`, standard-DH revolute arms batched over geometry (the paper's);
* :mod:`.chain` — :class:`SerialChain`, any serial arm of revolute/prismatic joints (DH, modified DH, URDF);
* :mod:`.ik` — the paper's Levenberg–Marquardt IK, batched over targets (kernel in :mod:`.lm_kernel`);
* :mod:`.search` — reachability search for any arm: multi-start LM, joint limits inside the search,
  every success confirmed by forward kinematics;
* :mod:`.lm_compiled` — the compiled (numba) kernel behind both LM paths;
* :mod:`.closed_form` — closed-form IK of the spherical-wrist family (all 8 branches);
* :mod:`.closed_form_ur` — closed-form IK of the UR family (three parallel axes, all 8 branches).
"""

from .closed_form import (
    SPHERICAL_WRIST_ALPHA,
    ikine_spherical_wrist,
    is_spherical_wrist,
    require_spherical_wrist,
    wrist_centre_reachable,
)
from . import lm_compiled
from .closed_form_ur import ikine_ur, is_ur_type, require_ur_type, ur_parameters, ur_reachable
from .chain import PRISMATIC, REVOLUTE, SerialChain, from_dh
from .dh import DHRobot, arm_batch
from .ik import IKResult, ikine_LM
from .search import SearchResult, as_chain, ikine_search, map_search
from .transforms import check_rigid, pose_error, rotx, roty, rotz, rpy2r, transl

__all__ = [
    "DHRobot",
    "PRISMATIC",
    "REVOLUTE",
    "SerialChain",
    "from_dh",
    "arm_batch",
    "IKResult",
    "SearchResult",
    "as_chain",
    "ikine_search",
    "map_search",
    "ikine_ur",
    "is_ur_type",
    "require_ur_type",
    "ur_parameters",
    "ur_reachable",
    "SPHERICAL_WRIST_ALPHA",
    "check_rigid",
    "ikine_LM",
    "ikine_spherical_wrist",
    "is_spherical_wrist",
    "pose_error",
    "require_spherical_wrist",
    "rotx",
    "roty",
    "rotz",
    "rpy2r",
    "transl",
    "wrist_centre_reachable",
]
