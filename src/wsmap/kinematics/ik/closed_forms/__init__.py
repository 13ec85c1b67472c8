"""The closed forms: every module of this package is one closed form that registers itself with
`wsmap.kinematics.ik.registry` when imported (a recogniser and a solver, see
`ClosedForm`). They are imported here, in name order, so a new
closed form is one new module in this folder and nothing else.

* `.spherical_wrist` — the paper's spherical-wrist DH family (PUMA-type geometry);
* `.spherical_wrist_offset` — spherical-wrist arms with a shoulder offset (axes 2 ∥ 3, the
  KUKA KR series, ABB IRB 140, PUMA's URDF), recognised and solved on the joint axes' geometry;
* `.ur` — the UR family (three parallel axes, Universal Robots' geometry), also recognised
  from any description through its standard-DH equivalent (`wsmap.kinematics.ik.geometry`).

Modules are imported in name order, which is the order `closed_form_for`
asks them in: the paper's DH family is answered by `.spherical_wrist` before the more general
`.spherical_wrist_offset`.
"""

import importlib
import pkgutil

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__)):
    importlib.import_module(f"{__name__}.{_module}")
