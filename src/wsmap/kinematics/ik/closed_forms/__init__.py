"""The closed forms: every module of this package is one closed form that registers itself with
:mod:`wsmap.kinematics.ik.registry` when imported (a recogniser and a solver, see
:class:`~wsmap.kinematics.ik.registry.ClosedForm`). They are imported here, in name order, so a new
closed form is one new module in this folder and nothing else.

* :mod:`.spherical_wrist` — the paper's spherical-wrist DH family (PUMA-type geometry);
* :mod:`.ur` — the UR family (three parallel axes, Universal Robots' geometry).
"""

import importlib
import pkgutil

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__)):
    importlib.import_module(f"{__name__}.{_module}")
