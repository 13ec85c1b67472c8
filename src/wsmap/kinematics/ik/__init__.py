"""Inverse kinematics: closed forms, the paper's Levenberg–Marquardt, the reachability search.

Every solver returns one answer type, `IKSolution` (`q`, `success`,
`iterations`, `residual`, `reason`; batched arrays).

* `.solution` — `IKSolution` and `IKReason`, why a target failed;
* `.registry` — the closed-form extension point: `ClosedForm`, `register`,
  `closed_form_for` (which closed form solves an arm, or None), the shared branch numbering;
* `.closed_forms` — one module per closed form, each registering itself
  (`.closed_forms.spherical_wrist`, `.closed_forms.spherical_wrist_offset`,
  `.closed_forms.ur`); a new closed form is a new module there;
* `.geometry` — an arm's joint axes as lines in the base frame at `q = 0` and its
  standard-DH equivalent, whatever frames describe it (how closed forms recognise a URDF);
* `.lm` — `ikine_LM`, the paper's one-start LM (DH arms);
* `.search` — `ikine_search` and `map_search`, the multi-start reachability search
  with joint limits inside it, every success confirmed by forward kinematics;
* `.settings` — `SearchSettings`, the numerical search's settings as one typed record (its
  `digest` the settings hash);
* `.solver` — the `Solver` protocol and its registry `SOLVERS` (`get_solver`,
  `solver_for`): one interface for the closed forms and the numerical solvers;
* `.solvers` — one module per solver, each registering itself (closed form, neighbour search,
  independent search, the paper's LM); a new solver is a new module there;
* `.reach_filter` — the search's sound pre-filters (targets proven out of reach);
* `.kernel` — the bridge to the compiled LM kernel (`wsmap.kinematics.lm_compiled`);
* `.memo` — content-keyed memos of what the solvers derive from an arm;
* `.lm_reference` — the LM iteration in numpy, the reference the tests compare the kernel with.
"""

from . import closed_forms as _closed_form_modules  # noqa: F401  (imports and so registers every closed form)
from .closed_forms.spherical_wrist import (
    SPHERICAL_WRIST_ALPHA,
    ikine_spherical_wrist,
    is_spherical_wrist,
    require_spherical_wrist,
    spherical_wrist_reachable,
    wrist_centre_reachable,
)
from .closed_forms.ur import UR_ALPHA, URParameters, ikine_ur, is_ur_type, require_ur_type, ur_parameters, ur_reachable
from .lm import ikine_LM
from .registry import ELBOW, SHOULDER, WRIST, ClosedForm, closed_form_for, closed_forms, register, require_closed_form
from .search import DEFAULT_STARTS, FK_CONFIRM_TOL, MAP_SETTINGS, ikine_search, map_search
from .settings import SearchSettings
from .solution import IKReason, IKSolution
from .solver import SOLVERS, Solver, get_solver, solver_for
from . import solvers  # noqa: E402, F401, I001  (imports and so registers every solver)

__all__ = [
    "IKSolution", "IKReason",
    "ClosedForm", "register", "closed_forms", "closed_form_for", "require_closed_form", "SHOULDER", "WRIST", "ELBOW",
    "SPHERICAL_WRIST_ALPHA", "ikine_spherical_wrist", "is_spherical_wrist", "require_spherical_wrist",
    "spherical_wrist_reachable", "wrist_centre_reachable",
    "UR_ALPHA", "URParameters", "ikine_ur", "is_ur_type", "require_ur_type", "ur_parameters", "ur_reachable",
    "ikine_LM", "ikine_search", "map_search", "DEFAULT_STARTS", "FK_CONFIRM_TOL", "MAP_SETTINGS",
    "SearchSettings", "Solver", "SOLVERS", "get_solver", "solver_for",
]
