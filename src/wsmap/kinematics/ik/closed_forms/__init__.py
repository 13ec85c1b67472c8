"""The closed forms: every module of this package is one closed form that registers itself with
`wsmap.kinematics.ik.registry` when imported (a recogniser and a solver, see `ClosedForm`). The
package discovers them (`wsmap._plugins.discover`), so a new closed form is one new module in
this folder and nothing else.

`closed_form_for` asks them by their `ClosedForm.priority` (lower first):

* `.spherical_wrist` (10) — the paper's spherical-wrist DH family (PUMA-type geometry);
* `.spherical_wrist_offset` (20) — spherical-wrist arms with a shoulder offset (axes 2 ∥ 3, the
  KUKA KR series, ABB IRB 140, PUMA's URDF), recognised and solved on the joint axes' geometry;
* `.ur` (30) — the UR family (three parallel axes, Universal Robots' geometry), also recognised
  from any description through its standard-DH equivalent (`wsmap.kinematics.ik.geometry`).

The paper's DH family is answered by `.spherical_wrist` before the more general
`.spherical_wrist_offset`.
"""

from ...._plugins import discover

discover(__name__, __path__)
