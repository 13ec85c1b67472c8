"""Where an arm comes from: a named arm, a URDF file, an MJCF file or DH columns, in one record.

`ArmSource` is the arm of a job (`wsmap.jobs.MapJob`, `wsmap.jobs.PlacementJob`) and of the
command line's `--robot`, `--urdf`, `--mjcf`, `--d/--a/--alpha` options: `check()` says what is
wrong with the combination before any file is read, `build()` reads the file and returns the
chain, with the joint limits the source asks for.

Messages name a field as the command line spells it (`qlim_deg` is `--qlim-deg`), so one message
serves the Python user and the command-line user alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..kinematics import DHRobot
from ..kinematics.chain import from_dh
from ..kinematics.mjcf import from_mjcf
from ..kinematics.urdf import from_urdf
from .registry import load
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..kinematics import SerialChain

__all__ = ["ArmSource", "DEFAULT_ARM"]

#: The arm of a source that names none: the paper's PUMA560.
DEFAULT_ARM = "puma560"


def _floats(values) -> tuple[float, ...] | None:
    return None if values is None else tuple(float(v) for v in np.ravel(np.asarray(values, dtype=float)))


@dataclass(frozen=True)
class ArmSource:
    """One arm, from exactly one of: a named arm, a URDF file, an MJCF file, DH columns.

    Parameters
    ----------
    robot : str, optional
        A named arm (`wsmap.robots.ROBOTS`); the default when no other source is given is
        `DEFAULT_ARM`.
    urdf, mjcf : path, optional
        The arm as a URDF file (meshes are never read) or an MJCF (MuJoCo) file.
    ee : str, optional
        URDF: the end link (default: the chain's only leaf); MJCF: the tool's site or body (required).
    base : str, optional
        URDF: the first link of the chain (default: the URDF's root).
    d, a, alpha, offset : sequence of float, optional
        DH columns: link offsets and lengths (m), twists and joint offsets (rad), one per joint.
    modified : bool
        The DH columns are modified DH (Craig), as Franka and Kinova publish them.
    joint_limits : bool, optional
        Honour the arm's joint limits; None: the arm's own default (on for real arms and files,
        off for the paper's PUMA560).
    qlim_deg : sequence of float, optional
        Joint limits in degrees, `lo_1 hi_1 lo_2 hi_2 ...`; they replace the arm's own unless
        `joint_limits` is False.
    """

    robot: str | None = None
    urdf: str | None = None
    mjcf: str | None = None
    ee: str | None = None
    base: str | None = None
    d: Sequence[float] | None = None
    a: Sequence[float] | None = None
    alpha: Sequence[float] | None = None
    offset: Sequence[float] | None = None
    modified: bool = False
    joint_limits: bool | None = None
    qlim_deg: Sequence[float] | None = None

    def __post_init__(self) -> None:
        for name in ("d", "a", "alpha", "offset", "qlim_deg"):
            object.__setattr__(self, name, _floats(getattr(self, name)))
        for name in ("urdf", "mjcf"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, str(getattr(self, name)))

    @property
    def has_dh(self) -> bool:
        """Whether any DH column is given."""
        return any(x is not None for x in (self.d, self.a, self.alpha))

    @property
    def name(self) -> str:
        """The named arm this source builds (`DEFAULT_ARM` when nothing else is given)."""
        return self.robot or DEFAULT_ARM

    def check(self) -> None:
        """Raise a one-line `ValueError` naming what is wrong with the combination of fields
        (before any file is read)."""
        given = [label for label, v in (("--robot", self.robot), ("--urdf", self.urdf), ("--mjcf", self.mjcf),
                                        ("the DH columns", self.has_dh or None)) if v is not None]
        if len(given) > 1:
            raise ValueError(f"give one arm: {' and '.join(given)} were both given")
        if self.ee is not None and self.urdf is None and self.mjcf is None:
            raise ValueError("--ee names the end link of a --urdf arm (or the site of a --mjcf arm)")
        if self.base is not None and self.urdf is None:
            raise ValueError("--base names the first link of a --urdf arm")
        if self.mjcf is not None and self.ee is None:
            raise ValueError("--mjcf needs the tool's site or body: --ee NAME")
        if (self.modified or self.offset is not None) and not self.has_dh:
            raise ValueError("--mdh and --offset describe DH columns (--d/--a/--alpha)")
        if self.has_dh:
            if any(x is None for x in (self.d, self.a, self.alpha)):
                raise ValueError("the DH columns need all three of --d, --a and --alpha")
            if self.joint_limits and self.qlim_deg is None:
                raise ValueError("--joint-limits on DH columns needs the limits: --qlim-deg lo_1 hi_1 ...")
        if self.urdf is not None and not Path(self.urdf).is_file():
            raise ValueError(f"--urdf {self.urdf!r}: no such file")

    def _limits(self, n: int) -> np.ndarray:
        q = np.asarray(self.qlim_deg, dtype=float)
        if q.size != 2 * n:
            raise ValueError(f"--qlim-deg needs 2 values per joint ({2 * n}), got {q.size}")
        return np.deg2rad(q.reshape(-1, 2))

    @property
    def _override(self) -> bool:
        return self.qlim_deg is not None and self.joint_limits is not False

    def build(self) -> DHRobot | SerialChain:
        """The arm (one `DHRobot` or `SerialChain`), files read and limits applied; `check()` first."""
        self.check()
        if self.mjcf is not None:
            robot = from_mjcf(self.mjcf, self.ee)
        elif self.has_dh:
            return self._from_dh()
        elif self.urdf is not None:
            robot = from_urdf(self.urdf, ee_link=self.ee, base_link=self.base)
        else:
            robot = load(self.name, joint_limits=self.joint_limits)
        if (self.mjcf is not None or self.urdf is not None) and self.joint_limits is False:
            robot = robot.replace(qlim=None)
        if self._override:
            q = self._limits(robot.n)
            robot = (DHRobot(robot.d, robot.a, robot.alpha, qlim=q, tool=robot.tool, name=robot.name)
                     if isinstance(robot, DHRobot) else robot.replace(qlim=q))
        return robot

    def _from_dh(self) -> DHRobot | SerialChain:
        qlim = self._limits(len(self.d)) if self._override else None
        if self.modified or self.offset is not None:
            return from_dh(self.d, self.a, self.alpha, offset=self.offset, qlim=qlim, modified=self.modified,
                           name="custom (modified DH)" if self.modified else "custom")
        return DHRobot(self.d, self.a, self.alpha, qlim=qlim, name="custom")

    def describe(self) -> dict:
        """The source as a JSON-ready dict (the map file's provenance)."""
        return {"robot": self.robot, "urdf": self.urdf, "mjcf": self.mjcf, "ee": self.ee, "base": self.base}
