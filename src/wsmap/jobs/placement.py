"""The placement job: where to put an arm's base so that it reaches a set of target poses.

`PlacementJob` holds what `wsmap place` takes — the arm, the collision geometry, the targets (a
pose CSV, `wsmap.workspace.targets.read_target_csv`, or an array), the base region and headings
— and runs `wsmap.workspace.base_placement` on it: `check()` (every input, before any work),
`run()` (a `PlacementResult`), `save(result)` (the ranking CSV, through a temporary file).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..collision.sources import CollisionSource
from ..io import atomic_path, check_outputs
from ..robots.sources import ArmSource
from ..workspace import base_placement
from ..workspace.targets import read_target_csv
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..workspace import Placement

__all__ = ["PlacementJob", "PlacementPlan", "PlacementResult"]


@dataclass
class PlacementPlan:
    """A checked `PlacementJob`: the arm, the targets (M, 4, 4) in the world frame, the checker and
    the output path."""

    robot: object
    targets: np.ndarray
    checker: object
    out: Path | None


@dataclass
class PlacementResult:
    """A computed placement: the ranking (`wsmap.workspace.Placement`, best first) and its time."""

    plan: PlacementPlan
    placement: Placement
    seconds: float


@dataclass(frozen=True)
class PlacementJob:
    """Rank candidate base poses on the floor by the fraction of the targets they reach; see the
    module notes. Fields as `wsmap place`'s options.

    Parameters
    ----------
    targets : path or (M, 4, 4) array
        A pose CSV (6 or 16 columns) or the poses themselves, world frame, metres.
    arm, collision
        The arm and its collision geometry (`ArmSource`, `CollisionSource`).
    x, y : (lo, hi)
        The base position's ranges (m), sampled at `step` (both ends included).
    z0 : float
        Height of the floor the base stands on (m).
    step : float
        Base position step (m).
    yaws : int
        Base headings, `2π j / yaws`.
    method : {"auto", "exact", "numerical"}
    out : path, optional
        The ranking (every candidate) as CSV.
    progress : bool
        A progress bar on stderr.
    """

    targets: str | np.ndarray
    arm: ArmSource = field(default_factory=ArmSource)
    collision: CollisionSource = field(default_factory=CollisionSource)
    x: Sequence[float] = (-1.0, 1.0)
    y: Sequence[float] = (-1.0, 1.0)
    z0: float = 0.0
    step: float = 0.1
    yaws: int = 8
    method: str = "auto"
    out: str | None = None
    progress: bool = False

    def check(self) -> PlacementPlan:
        """Every input checked (the output path, the ranges, the targets file, the arm, the
        collision geometry); nothing computed, nothing written."""
        target_file = None if isinstance(self.targets, np.ndarray) else str(self.targets)
        out = check_outputs({"--out": self.out}, inputs={"--targets": target_file, "--urdf": self.arm.urdf,
                                                         "--mjcf": self.arm.mjcf, "--scene": self.collision.scene}
                            ).get("--out")
        for name in ("x", "y"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise ValueError(f"--{name}: lo ({lo}) is above hi ({hi})")
        T = read_target_csv(target_file) if target_file is not None else np.asarray(self.targets, dtype=np.float64)
        robot = self.arm.build()
        checker = self.collision.build(robot, self.arm)
        return PlacementPlan(robot=robot, targets=T, checker=checker, out=out)

    def run(self, plan: PlacementPlan | None = None) -> PlacementResult:
        """The ranking (`check()` first unless its `plan` is given)."""
        plan = self.check() if plan is None else plan
        t0 = time.perf_counter()
        pl = base_placement(plan.robot, plan.targets, x=tuple(self.x), y=tuple(self.y), step=self.step,
                            yaws=self.yaws, z0=self.z0, method=self.method, progress=self.progress,
                            collision=plan.checker)
        return PlacementResult(plan=plan, placement=pl, seconds=time.perf_counter() - t0)

    def save(self, result: PlacementResult) -> list[Path]:
        """Write the ranking CSV (rank, x (m), y (m), yaw (rad), score, the tie-break
        `mean_manipulability` and one 0/1 column per target; best first,
        `wsmap.workspace.placement.RANKING`), if `out` was given; returns the paths written."""
        out = result.plan.out
        if out is None:
            return []
        pl, M = result.placement, len(result.plan.targets)
        with atomic_path(out, suffix=".csv") as tmp:
            with open(tmp, "w") as f:
                f.write("rank,x_m,y_m,yaw_rad,score,mean_manipulability,"
                        + ",".join(f"target_{m}" for m in range(M)) + "\n")
                for r in range(len(pl.score)):
                    # rounded as written, -0.0 made 0.0: no "-0.000000" for a value below 5e-7
                    x, y, yaw = (round(float(v), 6) + 0.0 for v in (pl.x[r], pl.y[r], pl.yaw[r]))
                    f.write(f"{r + 1},{x:.6f},{y:.6f},{yaw:.6f},{pl.score[r]:.6f},{pl.manipulability[r]:.6g},"
                            + ",".join(str(int(b)) for b in pl.reached[r]) + "\n")
        return [out]
