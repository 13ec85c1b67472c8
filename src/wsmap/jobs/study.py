"""The reach study job: can this arm, placed here, do this job on this workpiece without hitting anything.

A study file (YAML or JSON; `docs/study.md` has the whole format) names the arm or a catalogue of
arms, the TCP, the targets (a workpiece mesh or point cloud with normals, or a pose CSV), the
orientation freedom of the tool, the scores, the base (one pose or a region to search) and the
outputs. `StudyJob.from_file(path)` reads and checks every field (one line naming the file and the
key for every problem, before any work); `run()` evaluates every arm (`wsmap.workspace.study`);
`save(result)` writes the study file (`.npz`, `wsmap.workspace.study_files.load_study`) and the
pictures. The same file and seed give the same bytes.

Example::

    robot: ur5e                       # or {urdf: arm.urdf, ee: tool0}, {mjcf: ..., ee: ...}, {name: panda},
                                      # or {urdf: arm.urdf, srdf: arm.srdf, group: manipulator}
    tcp: [0, 0, 0.1, 0, 0, 0]         # x y z (m) r1 r2 r3 (rad) of the TCP in the arm's end frame
    targets: {poses: picks.csv}       # or {mesh: part.ply, spacing: 0.02, pose: [...], standoff: 0}
                                      # or {points: part.pcd, tool_z: along} (REACH's rule: z = +n)
    orientation: {turns: 8}           # the tool free about its axis, every 45 degrees
    base: {region: {x: [-1, 1], y: [-1, 1], step: 0.1, yaws: 8}, top: 5}
    collision: {workpiece: part.ply}  # the workpiece an obstacle, tested on its triangles; floor: 0 or false
    outputs: {study: study.npz}

A URDF arm's entry may name MoveIt's SRDF of the arm (`srdf`, and a planning `group`): its
`<disable_collisions>` pairs go into the allowed-collision matrix, and its group's chain and end
effector (`wsmap.collision.srdf.Srdf.ends`) give the end and base links that `ee` and `base` do
not. The SRDF is read and checked against the URDF's links by `check()`, before any work.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..collision.sources import CollisionSource
from ..collision.srdf import SRDFError, load_srdf
from .._progress import progress_bar
from ..io import check_outputs
from ..robots.sources import ArmSource
from ..workspace.maps import target_poses
from ..workspace.scores import SCORES
from ..workspace.study import BaseRegion, evaluate_targets, rank_bases, tool_variants
from ..workspace.study_files import StudyResult, save_study
from ..workspace.targets import read_target_csv
from .config import ConfigError, check_keys, load_config

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..collision import Obstacle
    from ..workspace.workpiece import TargetSet

__all__ = ["StudyJob", "TargetSpec", "OrientationSpec", "BaseSpec", "MAX_STUDY_TARGETS"]

#: The most targets one study takes (each is K IK problems per candidate base).
MAX_STUDY_TARGETS = 100_000
_TOP = ("robot", "robots", "tcp", "targets", "orientation", "scores", "base", "collision", "search", "outputs", "seed")


def _pose(values, label: str) -> np.ndarray:
    """A pose from `[x, y, z, r1, r2, r3]` (m, rad; `R = Rx Ry Rz`) or a 4x4 list."""
    a = np.asarray(values, dtype=np.float64) if isinstance(values, (list, tuple)) else None
    if a is None or a.shape not in ((6,), (4, 4)) or not np.all(np.isfinite(a)):
        raise ConfigError(f"{label}: a pose is [x, y, z, r1, r2, r3] (m, rad) or a 4x4 matrix, got {values!r:.80}")
    return target_poses(a[:3], a[3:], "standard") if a.shape == (6,) else a


def _number(value, label: str, *, lo: float = -np.inf, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise ConfigError(f"{label}: must be a finite number, got {value!r:.40}")
    if (positive and value <= 0) or value < lo:
        raise ConfigError(f"{label}: must be {'positive' if positive else f'at least {lo}'}, got {value!r}")
    return float(value)


def _count(value, label: str, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        raise ConfigError(f"{label}: must be an integer of at least {lo}, got {value!r:.40}")
    return value


def _range(value, label: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ConfigError(f"{label}: a range is [lo, hi] (m), got {value!r:.60}")
    lo, hi = (_number(v, label) for v in value)
    if lo > hi:
        raise ConfigError(f"{label}: lo ({lo}) is above hi ({hi})")
    return lo, hi


def _arm(spec, label: str, root: Path) -> tuple[ArmSource, str | None, str | None]:
    """`(arm, srdf, group)` of a study's `robot` entry: a name, or a mapping (the SRDF's path
    relative to the study file; both None without one)."""
    if isinstance(spec, str):
        return ArmSource(robot=spec), None, None
    check_keys(spec, ("name", "urdf", "mjcf", "srdf", "group", "ee", "base", "dh", "joint_limits", "qlim_deg"),
               label=label)
    dh = spec.get("dh") or {}
    if dh:
        check_keys(dh, ("d", "a", "alpha", "offset", "modified"), label=f"{label}.dh", required=("d", "a", "alpha"))
    for key, what in (("srdf", "MoveIt's SRDF file of the URDF arm"), ("group", "a planning group of the arm's SRDF")):
        if key in spec and (not isinstance(spec[key], str) or not spec[key]):
            raise ConfigError(f"{label}.{key}: {what}, got {spec[key]!r:.60}")
    path = {k: str(root / spec[k]) if spec.get(k) is not None else None for k in ("urdf", "mjcf", "srdf")}
    arm = ArmSource(robot=spec.get("name"), urdf=path["urdf"], mjcf=path["mjcf"], ee=spec.get("ee"),
                    base=spec.get("base"), d=dh.get("d"), a=dh.get("a"), alpha=dh.get("alpha"),
                    offset=dh.get("offset"), modified=bool(dh.get("modified", False)),
                    joint_limits=spec.get("joint_limits"), qlim_deg=spec.get("qlim_deg"))
    return arm, path["srdf"], spec.get("group")


def _srdf_arm(arm: ArmSource, srdf: str | None, group: str | None, key: str) -> ArmSource:
    """`arm` with the end and base links its SRDF picks where `ee`/`base` are not given; every
    problem a one-line `ConfigError` naming `key` (the arm's entry), before any work."""
    if srdf is None:
        if group is not None:
            raise ConfigError(f"{key}.group: {group[:80]!r} names a planning group of the arm's SRDF: give srdf: FILE")
        return arm
    if arm.urdf is None:
        given = ("an MJCF file" if arm.mjcf is not None else "DH columns" if arm.has_dh else f"the named arm {arm.name!r}")
        raise ConfigError(f"{key}.srdf: MoveIt's SRDF describes a URDF arm (urdf: FILE); this arm is {given}")
    if group is not None and arm.ee is not None and arm.base is not None:
        raise ConfigError(f"{key}.group: the group picks the end and base links that ee and base do not give; "
                          "both are given")
    try:
        arm.check()
    except ValueError as e:
        raise ConfigError(f"{key}: {e}") from None
    try:
        description = load_srdf(srdf, urdf=arm.urdf)
    except SRDFError as e:
        raise ConfigError(f"{key}.srdf: {e}") from None
    if arm.ee is not None and arm.base is not None:
        return arm
    try:
        base, ee = description.ends(group, options=("ee", "base", "group"))
    except SRDFError as e:
        raise ConfigError(f"{key}.{'srdf' if group is None else 'group'}: {e}") from None
    if group is not None and ee is None and base is None:
        chains = ", ".join(g for g, c in description.groups.items() if c is not None) or "none"
        raise ConfigError(f"{key}.group: group {group[:80]!r} of SRDF {srdf!r} has no <chain> and no end effector; "
                          f"the groups with a chain: {chains}")
    return replace(arm, ee=arm.ee if arm.ee is not None else ee, base=arm.base if arm.base is not None else base)


@dataclass(frozen=True)
class TargetSpec:
    """Where the targets come from: exactly one of a workpiece `mesh` (sampled every `spacing` m), a
    point cloud `points` with normals, or a pose CSV `poses`; `pose` places the workpiece in the
    world; the tool stands `standoff` m off the surface along the normal. `tool_z` says which way
    a cloud's normals point: `"against"` (default: out of the workpiece; the tool's z axis is
    `-n`, into the surface) or `"along"` (REACH's rule: the tool's z axis is `+n`, for clouds
    whose normals point towards the tool, as REACH's demo `part.pcd`)."""

    mesh: str | None = None
    points: str | None = None
    poses: str | None = None
    pose: tuple | None = None
    spacing: float | None = None
    standoff: float = 0.0
    tool_z: str = "against"

    @classmethod
    def from_dict(cls, d, label: str, root: Path) -> TargetSpec:
        check_keys(d, ("mesh", "points", "poses", "pose", "spacing", "standoff", "tool_z"), label=label)
        given = [k for k in ("mesh", "points", "poses") if d.get(k) is not None]
        if len(given) != 1:
            raise ConfigError(f"{label}: give exactly one of mesh, points, poses (got {', '.join(given) or 'none'})")
        if "mesh" in given and "spacing" not in d:
            raise ConfigError(f"{label}: a mesh needs its sampling spacing: spacing (m)")
        tool_z = d.get("tool_z", "against")
        if tool_z not in ("against", "along"):
            raise ConfigError(f"{label}.tool_z: against (z = -n, the default) or along (z = +n, REACH's rule), "
                              f"got {tool_z!r:.40}")
        if "tool_z" in d and "points" not in given:
            raise ConfigError(f"{label}.tool_z: says which way a point cloud's normals point; a {given[0]} has none")
        pose = None if d.get("pose") is None else tuple(_pose(d["pose"], f"{label}.pose").reshape(-1))
        return cls(tool_z=tool_z, mesh=_path(d, "mesh", root), points=_path(d, "points", root), poses=_path(d, "poses", root),
                   pose=pose, spacing=None if d.get("spacing") is None else _number(d["spacing"], f"{label}.spacing",
                                                                                    positive=True),
                   standoff=_number(d.get("standoff", 0.0), f"{label}.standoff", lo=0.0))

    def load(self) -> TargetSet:
        """The targets (`wsmap.workspace.workpiece.TargetSet`), files read and checked."""
        from ..workspace import workpiece

        pose = None if self.pose is None else np.asarray(self.pose).reshape(4, 4)
        if self.mesh is not None:
            return workpiece.targets_from_mesh(self.mesh, self.spacing, pose=pose, standoff=self.standoff,
                                               max_targets=MAX_STUDY_TARGETS)
        if self.points is not None:
            return workpiece.targets_from_points(self.points, pose=pose, standoff=self.standoff,
                                                 max_targets=MAX_STUDY_TARGETS, flip=self.tool_z == "along")
        T = read_target_csv(self.poses, "targets.poses")
        if pose is not None:
            T = pose @ T
        return workpiece.TargetSet(points=T[:, :3, 3].copy(), normals=-T[:, :3, 2].copy(), poses=T,
                                   moved=np.zeros(len(T)), vertices=None, faces=None, source=str(self.poses))


def _path(d, key, root: Path) -> str | None:
    return None if d.get(key) is None else str(root / str(d[key]))


@dataclass(frozen=True)
class OrientationSpec:
    """The tool's freedom: `turns` samples about its axis (every `2π / turns`), tilts within a cone
    of half-angle `cone_deg` on `rings` rings of `per_ring` azimuths (`wsmap.workspace.study.tool_variants`)."""

    turns: int = 1
    cone_deg: float = 0.0
    rings: int = 0
    per_ring: int = 6

    @classmethod
    def from_dict(cls, d, label: str) -> OrientationSpec:
        check_keys(d, ("turns", "cone_deg", "rings", "per_ring"), label=label)
        spec = cls(turns=_count(d.get("turns", 1), f"{label}.turns", 1),
                   cone_deg=_number(d.get("cone_deg", 0.0), f"{label}.cone_deg", lo=0.0),
                   rings=_count(d.get("rings", 0), f"{label}.rings", 0),
                   per_ring=_count(d.get("per_ring", 6), f"{label}.per_ring", 1))
        try:
            spec.variants()
        except ValueError as e:
            raise ConfigError(f"{label}: {e}") from None
        return spec

    def variants(self) -> np.ndarray:
        return tool_variants(self.turns, np.radians(self.cone_deg), self.rings, self.per_ring)


@dataclass(frozen=True)
class BaseSpec:
    """One base `pose`, or a `region` to search for the `top` best."""

    pose: tuple | None = None
    region: BaseRegion | None = None
    top: int = 5

    @classmethod
    def from_dict(cls, d, label: str) -> BaseSpec:
        check_keys(d, ("pose", "region", "top"), label=label)
        if (d.get("pose") is None) == (d.get("region") is None):
            raise ConfigError(f"{label}: give one of pose (one base) and region (bases to search)")
        if d.get("pose") is not None:
            return cls(pose=tuple(_pose(d["pose"], f"{label}.pose").reshape(-1)))
        r, rl = d["region"], f"{label}.region"
        check_keys(r, ("x", "y", "step", "yaws", "z0", "keep_out"), label=rl, required=("x", "y"))
        keep = r.get("keep_out", [])
        if not isinstance(keep, list) or any(not isinstance(b, list) or len(b) != 4 for b in keep):
            raise ConfigError(f"{rl}.keep_out: a list of boxes [x_lo, x_hi, y_lo, y_hi] (m)")
        boxes = tuple(_range(b[:2], f"{rl}.keep_out") + _range(b[2:], f"{rl}.keep_out") for b in keep)
        region = BaseRegion(x=_range(r["x"], f"{rl}.x"), y=_range(r["y"], f"{rl}.y"),
                            step=_number(r.get("step", 0.1), f"{rl}.step", positive=True),
                            yaws=_count(r.get("yaws", 8), f"{rl}.yaws", 1), z0=_number(r.get("z0", 0.0), f"{rl}.z0"),
                            keep_out=boxes)
        try:
            n = len(region.candidates())
        except ValueError as e:
            raise ConfigError(f"{rl}: {e}") from None
        if n > 10**6:
            raise ConfigError(f"{rl}: {n} candidate bases (at most 1000000); a coarser step or fewer yaws")
        return cls(region=region, top=_count(d.get("top", 5), f"{label}.top", 1))


@dataclass(frozen=True)
class StudyJob:
    """A reach study; see the module notes. Build it with `from_file` (or the fields directly).

    `arms` are `ArmSource`s; `srdfs` and `groups` (empty, or one entry per arm, None where an arm
    has none) MoveIt's SRDF file of a URDF arm and the planning group that picks its chain."""

    arms: tuple
    targets: TargetSpec
    srdfs: tuple = ()
    groups: tuple = ()
    tcp: tuple = tuple(np.eye(4).reshape(-1))
    orientation: OrientationSpec = field(default_factory=OrientationSpec)
    scores: tuple = ("manipulability", "joint_margin")
    base: BaseSpec = field(default_factory=lambda: BaseSpec(pose=tuple(np.eye(4).reshape(-1))))
    collision: CollisionSource = field(default_factory=CollisionSource)
    method: str = "auto"
    starts: int = 8
    seed: int = 0
    workpiece: str | None = None
    study_file: str | None = None
    views: dict = field(default_factory=dict)
    source: str | None = None

    @classmethod
    def from_file(cls, path) -> StudyJob:
        """The job of a study file; every field checked (one-line `ConfigError` naming file and key)."""
        d = load_config(path, "study file")
        return cls.from_dict(d, label=f"study file {str(path)!r}", root=Path(path).resolve().parent, source=str(path))

    @classmethod
    def from_dict(cls, d, *, label: str = "study", root: Path = Path("."), source: str | None = None) -> StudyJob:
        check_keys(d, _TOP, label=label, required=("targets",))
        if ("robot" in d) == ("robots" in d):
            raise ConfigError(f"{label}: give robot (one arm) or robots (a catalogue), not {'both' if 'robot' in d else 'neither'}")
        specs = [d["robot"]] if "robot" in d else d["robots"]
        if not isinstance(specs, list) or not specs:
            raise ConfigError(f"{label}.robots: a non-empty list of arms")
        keys = [f"{label}.robot"] if "robot" in d else [f"{label}.robots[{i}]" for i in range(len(specs))]
        arms, srdfs, groups = zip(*(_arm(s, k, root) for s, k in zip(specs, keys)))
        scores = d.get("scores", ["manipulability", "joint_margin"])
        if not isinstance(scores, list) or any(s not in SCORES for s in scores):
            raise ConfigError(f"{label}.scores: a list of {', '.join(SCORES)}, got {scores!r:.80}")
        search = d.get("search", {})
        check_keys(search, ("method", "starts"), label=f"{label}.search")
        method = search.get("method", "auto")
        if method not in ("auto", "exact", "numerical"):
            raise ConfigError(f"{label}.search.method: one of auto, exact, numerical, got {method!r:.40}")
        needs = [s for s in scores if SCORES[s].needs_collision]
        if needs and not d.get("collision"):
            raise ConfigError(f"{label}.scores: {needs[0]} measures the distance to collision: give collision "
                              "(true, or a scene, or a workpiece)")
        return cls(arms=arms, srdfs=srdfs if any(srdfs) else (), groups=groups if any(groups) else (),
                   targets=TargetSpec.from_dict(d["targets"], f"{label}.targets", root),
                   tcp=tuple(_pose(d.get("tcp", [0, 0, 0, 0, 0, 0]), f"{label}.tcp").reshape(-1)),
                   orientation=OrientationSpec.from_dict(d.get("orientation", {}), f"{label}.orientation"),
                   scores=tuple(scores), base=BaseSpec.from_dict(d.get("base", {"pose": [0, 0, 0, 0, 0, 0]}),
                                                                 f"{label}.base"),
                   collision=_collision(d.get("collision"), f"{label}.collision", root),
                   workpiece=_workpiece(d.get("collision"), f"{label}.collision", root),
                   method=method, starts=_count(search.get("starts", 8), f"{label}.search.starts", 1),
                   seed=_count(d.get("seed", 0), f"{label}.seed", 0), study_file=_outputs(d, label, root),
                   views=_views(d, label, root),
                   source=source)

    def check(self) -> StudyPlan:
        """Every input read and checked: the arms built, the targets generated, the output checked."""
        out = check_outputs({"outputs.study": self.study_file}).get("outputs.study")
        if out is not None and out.suffix != ".npz":
            raise ConfigError(f"outputs.study {str(out)!r}: a study file is .npz")
        check_outputs({f"outputs.{k}": v for k, v in self.views.items() if k != "score"} | {"outputs.study": out})
        arms = self.arm_sources()
        robots = [a.build() for a in arms]
        collision = self.collision
        if self.workpiece is not None:
            collision = replace(collision, obstacles=collision.obstacles + (self.workpiece_obstacle(),))
        checkers = [replace(collision, srdf=s).build(r, a) for r, a, s in zip(robots, arms, self._per_arm("srdfs"))]
        targets = self.targets.load()
        return StudyPlan(robots=robots, checkers=checkers, targets=targets, out=out, arms=arms)

    def _per_arm(self, name: str) -> tuple:
        """`srdfs` or `groups`, one entry per arm (None where an arm has none)."""
        values = getattr(self, name)
        if len(values) not in (0, len(self.arms)):
            raise ConfigError(f"{name}: one entry per arm ({len(self.arms)}), got {len(values)}")
        return tuple(values) or (None,) * len(self.arms)

    def arm_sources(self) -> list[ArmSource]:
        """The arms, each with the end and base links its SRDF picks where `ee`/`base` are not
        given (the SRDF read and checked against the URDF); a one-line `ConfigError` naming the
        arm's entry for an SRDF beside an arm that is not a URDF, a group that the SRDF does not
        have, an SRDF naming a link the URDF does not have, a group without an SRDF."""
        label = "study" if self.source is None else f"study file {self.source!r}"
        keys = [f"{label}.robot"] if len(self.arms) == 1 else [f"{label}.robots[{i}]" for i in range(len(self.arms))]
        return [_srdf_arm(a, s, g, k) for a, s, g, k in zip(self.arms, self._per_arm("srdfs"), self._per_arm("groups"),
                                                            keys)]

    def workpiece_obstacle(self) -> Obstacle:
        """The workpiece as a world-frame obstacle at the targets' `pose`, tested on its triangles
        (`wsmap.collision.shapes.surface`: a concave part is never replaced by its convex hull)."""
        from ..collision import CollisionError, Obstacle, Shape
        from ..collision.shapes.mesh import read_mesh

        pose = np.eye(4) if self.targets.pose is None else np.asarray(self.targets.pose).reshape(4, 4)
        try:
            v, f = read_mesh(self.workpiece, "collision.workpiece")
            return Obstacle("workpiece", Shape("surface", (), pose, v, f, source=self.workpiece), frame="world")
        except CollisionError as e:
            raise ConfigError(str(e)) from None

    def run(self, plan: StudyPlan | None = None, *, progress=False) -> StudyResult:
        """Evaluate every arm: at the base pose, or the best bases of the region. `progress`: a bar
        on stderr (True) or a callable `progress(n)` told of each arm done (`wsmap._progress`)."""
        plan = self.check() if plan is None else plan
        with progress_bar(progress, len(plan.robots), unit="arm", desc="study") as update:
            return self._run(plan, update)

    def _run(self, plan: StudyPlan, update) -> StudyResult:
        variants, tcp = self.orientation.variants(), np.asarray(self.tcp).reshape(4, 4)
        kw = dict(variants=variants, tcp=tcp, method=self.method, starts=self.starts, seed=self.seed,
                  scores=self.scores)
        per_arm = []
        for robot, checker in zip(plan.robots, plan.checkers):
            if self.base.region is None:
                res = evaluate_targets(robot, plan.targets.poses, base=np.asarray(self.base.pose).reshape(4, 4),
                                       collision=checker, **kw)
                per_arm.append([res])
            else:
                ranking = rank_bases(robot, plan.targets.poses, self.base.region, top=self.base.top,
                                     collision=checker, **kw)
                per_arm.append(ranking.results)
            if update is not None:
                update(1)
        return StudyResult(names=[r.name or f"arm {i}" for i, r in enumerate(plan.robots)], targets=plan.targets,
                           results=per_arm, variants=variants, settings=self.settings(plan))

    def settings(self, plan: StudyPlan | None = None) -> dict:
        """The job as the study file records it (no timings: the same job gives the same bytes).
        Each arm's record names its SRDF and group; with the `plan`, its end and base links as
        the SRDF picked them and `floor`: the height (m, world frame) of the floor its collision
        check used, None for none (or no collision check)."""
        arms = self.arms if plan is None else plan.arms
        records = [a.describe() | {"dh": a.has_dh, "srdf": s, "group": g}
                   for a, s, g in zip(arms, self._per_arm("srdfs"), self._per_arm("groups"))]
        if plan is not None:
            for record, checker in zip(records, plan.checkers):
                record["floor"] = None if checker is None else checker.scene.floor
        return {"arms": records, "targets": self.targets.__dict__,
                "tcp": list(self.tcp), "orientation": self.orientation.__dict__, "scores": list(self.scores),
                "base": {"pose": self.base.pose, "top": self.base.top,
                         "region": None if self.base.region is None else self.base.region.__dict__},
                "collision": {"wanted": self.collision.wanted or self.workpiece is not None,
                              **self.collision.describe(), "workpiece": self.workpiece, "floor": self.collision.floor},
                "method": self.method, "starts": self.starts, "seed": self.seed, "source": self.source}

    def save(self, result: StudyResult, plan: StudyPlan) -> list[Path]:
        """Write the study file and the heat maps of the first arm at its best base (`outputs.png`,
        `html`, `ply`: `wsmap.study_views`); returns the paths written."""
        paths = []
        if plan.out is not None:
            paths.append(save_study(plan.out, result))
        views = {k: v for k, v in self.views.items() if k != "score"}
        if views:
            from ..study_views import save_views

            paths += save_views(result, score=self.views.get("score"), **views)
        return paths


@dataclass
class StudyPlan:
    """A checked `StudyJob`: the arms, their collision checkers, the targets, the study file's path,
    the arms' sources (their SRDF's chain ends filled in)."""

    robots: list
    checkers: list
    targets: TargetSet
    out: Path | None
    arms: list = field(default_factory=list)


def _collision(d, label: str, root: Path) -> CollisionSource:
    if d is None or d is False:
        return CollisionSource()
    if d is True:
        return CollisionSource(collision=True)
    check_keys(d, ("scene", "allow", "acm_samples", "link_radius", "workpiece", "floor"), label=label)
    return CollisionSource(collision=True, scene=_path(d, "scene", root), allow=d.get("allow"),
                           acm_samples=d.get("acm_samples"), link_radius=d.get("link_radius"),
                           floor=_floor(d, f"{label}.floor"))


def _floor(d, label: str) -> float | bool | None:
    """The explicit floor of a `collision` mapping: a height (m, world frame), False for none, or
    None when the key is absent (a named arm's floor at z = 0, a scene file's floor)."""
    if "floor" not in d or d["floor"] is False:
        return d.get("floor")
    z = d["floor"]
    if isinstance(z, bool) or not isinstance(z, (int, float)) or not np.isfinite(z) or abs(z) > 1000:
        raise ConfigError(f"{label}: the floor's height (m, world frame; a finite number of magnitude at most 1000) "
                          f"or false for no floor, got {z!r:.40}")
    return float(z)


def _workpiece(d, label: str, root: Path) -> str | None:
    if not isinstance(d, dict) or d.get("workpiece") is None:
        return None
    if not isinstance(d["workpiece"], str) or not d["workpiece"]:
        raise ConfigError(f"{label}.workpiece: the workpiece's mesh file (STL, OBJ, PLY), got {d['workpiece']!r:.60}")
    return _path(d, "workpiece", root)


def _outputs(d, label: str, root: Path) -> str | None:
    out = d.get("outputs", {})
    check_keys(out, ("study", "png", "html", "ply", "score"), label=f"{label}.outputs")
    return _path(out, "study", root)


def _views(d, label: str, root: Path) -> dict:
    out = d.get("outputs", {})
    views = {k: _path(out, k, root) for k in ("png", "html", "ply") if out.get(k) is not None}
    for k, p in views.items():
        if Path(p).suffix.lower() != f".{k}":
            raise ConfigError(f"{label}.outputs.{k}: the {k} heat map's file must end in .{k}, got {out[k]!r:.60}")
    score = out.get("score")
    if score is not None and score not in SCORES:
        raise ConfigError(f"{label}.outputs.score: the score the heat map shows, one of {', '.join(SCORES)} "
                          f"(default: the product of the study's scores), got {score!r:.40}")
    return views | ({"score": score} if score is not None else {})
