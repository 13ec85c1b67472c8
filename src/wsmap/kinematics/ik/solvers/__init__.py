"""The IK solvers: one module per solver, each registering a `Solver` record
(`wsmap.kinematics.ik.solver`, the protocol and the registry).

* `.closed_form` — `"closed_form"`, the registered closed forms (`method="exact"`);
* `.neighbour_search` — `"search"`, the maps' default: nodes started from their neighbours'
  solutions (`wsmap.kinematics.ik.search.map_search`);
* `.independent` — `"independent"`, every target alone (`wsmap.kinematics.ik.search.ikine_search`);
* `.paper_lm` — `"paper"`, the paper's one-start LM (`wsmap.kinematics.ik.lm.ikine_LM`).

A new solver is one new module here (a class with the `Solver` attributes and methods, and
`SOLVERS.register(...)` at its end); `SearchSettings(solver=NAME)` then selects it, with the
fields its `defaults` name.
"""

from ...._plugins import discover  # noqa: I001
from ..solver import SOLVERS, Solver, get_solver, numerical_solvers, per_node, solver_for

discover(__name__, __path__)

__all__ = ["SOLVERS", "Solver", "get_solver", "numerical_solvers", "per_node", "solver_for"]
