"""The closed-form extension point: each closed form registers a recogniser and a solver here.

A closed form is one module of `wsmap.kinematics.ik.closed_forms` that ends with
`register(ClosedForm(...))`; that package discovers every module in it (`wsmap._plugins.discover`),
so adding a closed form is one new file there (and its tests). The registry asks them by their
`priority` (lower first), then their name. Whoever needs to decide "closed form or numerical", or which
closed form, asks `closed_form_for` (the maps, the reach maps, base placement, the dataset
labels, the command line).

Branch numbering, shared by every 6R closed form with 8 branches (`q` of shape `(..., 8, 6)`):
branch `k = 4·shoulder + 2·wrist + elbow` (bit 2 `SHOULDER`, bit 1 `WRIST`, bit 0
`ELBOW`), each bit defined on the closed form's canonical joint angles `θ`:

* shoulder 0: `θ1 = φ + asin(o/r)`, 1: `θ1 = φ + pi − asin(o/r)`, with `(r, φ)` the polar
  coordinates of the wrist point in the base plane and `o` the arm's lateral offset (`d3` of
  the spherical-wrist family, `d4` of the UR family);
* wrist 0: `sin θ5 >= 0`, 1: `sin θ5 <= 0`;
* elbow 0: `sin ψ >= 0`, 1: `sin ψ <= 0`, with `ψ` the elbow angle of the planar two-link
  arm of joints 2 and 3 (`θ3` for the UR family, `θ3 + atan2(d4, a3)` for the spherical-wrist
  family, whose forearm is pitched by that angle).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..._plugins import Registry
from ..arms import ArmBatch
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap.kinematics.chain import Arm

__all__ = ["SHOULDER", "WRIST", "ELBOW", "ClosedForm", "CLOSED_FORMS", "register", "unregister", "closed_forms", "closed_form_for",
           "require_closed_form"]

#: Bits of a closed-form branch index (see the module notes).
SHOULDER, WRIST, ELBOW = 4, 2, 1


@dataclass(frozen=True)
class ClosedForm:
    """A closed-form inverse kinematics for a family of arms.

    name : short identifier (`"spherical_wrist"`, `"ur"`), also the family's name in messages
        and map settings
    description : the family in words, for messages (`"the UR family"`)
    recognise : `robot -> bool array` of the robot's batch shape, True for each arm the closed form
        solves (False, not an error, for any other arm or robot type)
    require : `robot -> None`, raises `ValueError` naming the first arm and what differs
    solve : `(robot, T) -> IKSolution`, every branch (a branch axis before the joints), joint
        limits honoured (a branch outside them fails with `OUTSIDE_LIMITS`)
    reachable : `(robot, T) -> bool array`, some branch of `solve` succeeds (a faster path
        where the closed form has one); the shape of `T.shape[:-2]` broadcast with the batch
    priority : int, the order in which `closed_form_for` asks the closed forms (lower first): a
        family's own closed form before a more general one that also solves it
    """

    name: str
    description: str
    recognise: Callable
    require: Callable
    solve: Callable
    reachable: Callable
    priority: int


#: The registered closed forms, by `(priority, name)`.
CLOSED_FORMS: Registry[ClosedForm] = Registry("closed form")


def register(closed_form: ClosedForm) -> ClosedForm:
    """Add `closed_form` to the registry (asked by priority); returns it. A name that is already
    registered, or a priority that is not an int, is a `ValueError`."""
    if not isinstance(closed_form, ClosedForm):
        raise TypeError(f"register takes a ClosedForm, got {type(closed_form).__name__}")
    return CLOSED_FORMS.register(closed_form)


def unregister(name: str) -> None:
    """Remove the closed form `name` (`KeyError` if none is registered under it)."""
    CLOSED_FORMS.unregister(name)


def closed_forms() -> tuple[ClosedForm, ...]:
    """The registered closed forms, by priority."""
    return CLOSED_FORMS.records()


def closed_form_for(robot: Arm) -> ClosedForm | None:
    """The registered closed form that recognises every arm of `robot` (the first by priority,
    should two), or None; None for anything that is not an arm (a `DHRobot` or a
    `SerialChain`)."""
    if not isinstance(robot, ArmBatch):
        return None
    for cf in CLOSED_FORMS.records():
        if bool(np.all(cf.recognise(robot))):
            return cf
    return None


def _names() -> str:
    words = [cf.description for cf in CLOSED_FORMS.records()]
    return " and ".join(words) if len(words) <= 2 else ", ".join(words[:-1]) + " and " + words[-1]


def require_closed_form(robot: Arm, what: str = "method 'exact'") -> ClosedForm:
    """`closed_form_for`, or a `ValueError` saying that `what` has no closed form for the
    arm, which closed forms there are, and to use method 'numerical'."""
    cf = closed_form_for(robot)
    if cf is None:
        raise ValueError(f"{what} has no closed form for {getattr(robot, 'name', None) or 'this arm'} "
                         f"(closed forms: {_names()}); use method 'numerical'")
    return cf
