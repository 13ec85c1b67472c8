"""The map job: one workspace map of one arm, checked, computed and written with its provenance.

`MapJob` holds everything `wsmap map` takes — the arm (`wsmap.robots.sources.ArmSource`), the kind
and its inputs, the grid, the method and search settings, the collision geometry
(`wsmap.collision.sources.CollisionSource`) and the outputs (`MapOutputs`) — and does what the
command line does, in three steps a Python user can call alone:

* `check()` — every input checked (before any work and before any file is written), the arm and
  the collision checker built: a `MapPlan`;
* `run()` — the map computed: a `MapResult` (values in node order, the grid, the settings and
  provenance recorded in the map file, the Reuleaux poses where asked, and each node's answer —
  reached, certified unreachable, not found — with its counts, for every kind computed by the
  closed form or the search);
* `save(result)` — the outputs written, each through a temporary file, all put in place together
  once every one was written (an error leaves every file as it was); the 3-D views of a map with
  no reachable node are skipped with a warning, the map itself written.

The command line parses its options into a `MapJob` and prints; a job built in Python writes the
same bytes as the command with the same options.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from .._optional import require
from ..collision.sources import CollisionSource
from ..io import atomic_paths, check_outputs
from ..kinematics import closed_form_for
from ..robots.sources import ArmSource
from ..workspace import grid_spec, orientation_samples, resolve_method, save_map, save_reuleaux
from ..workspace.maps import MAP_PREDICTORS
from ..workspace.status import status_counts
from ..workspace.kinds import MapRequest, default_kind, get_kind, kinds, kinds_taking
from ..workspace.orientations import MAX_ORIENTATIONS
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

__all__ = ["MapJob", "MapOutputs", "MapPlan", "MapResult", "OUTPUTS"]

#: The outputs of a map besides the `.npz` map file: option, the optional modules it needs, its suffix.
OUTPUTS = {"png": ((), ".png"), "html": (("plotly",), ".html"), "ply": ((), ".ply"),
           "glb": (("trimesh", "skimage"), ".glb"), "h5": (("h5py",), ".h5")}
#: The options that feed a kind's inputs (`wsmap.workspace.kinds.INPUTS`): given with a kind that does
#: not read them, they are refused instead of ignored.
INPUT_FLAGS = {"rpy": "--rpy", "point": "--point", "orientations": "--orientations", "convention": "--convention"}
#: The 3-D views: skipped, with a warning, for a map with no reachable node (nothing to draw).
VIEWS = ("html", "ply", "glb")


@dataclass(frozen=True)
class MapOutputs:
    """The files of a map job (paths, or None): `out` the `.npz` map file (`wsmap.load_map`), `png`
    its z-slices, `html` an interactive 3-D view, `ply` the reachable nodes as a point cloud, `glb`
    iso-surfaces as a glTF scene, `h5` a Reuleaux reachability map for ROS."""

    out: str | None = None
    png: str | None = None
    html: str | None = None
    ply: str | None = None
    glb: str | None = None
    h5: str | None = None

    def given(self) -> dict[str, str]:
        """`{"--flag": path}` of every output given, the map file first."""
        return {f"--{f.name}": str(getattr(self, f.name)) for f in fields(self) if getattr(self, f.name) is not None}


@dataclass
class MapPlan:
    """A checked `MapJob`: the kind, the arm, the grid, the method, the checker and the request the
    kind's `compute` is given, and the output paths (`{"--flag": Path}`)."""

    kind: object
    robot: object
    grid: dict
    method: str
    request: MapRequest
    checker: object
    orientations: np.ndarray | None
    paths: dict[str, Path]


@dataclass
class MapResult:
    """A computed map: `values` (N,) in node order (bool or float64 as the kind says), the `grid`,
    the `settings` recorded in the map file (the arm, its source and limits, the method and how it
    ran, the search settings, the collision geometry, `seconds`), the orientation set (K, 3, 3) of a
    map over orientations, for a Reuleaux file the per-orientation bits and rotations, and for
    every map computed by the closed form or the search (not a network's prediction) each node's
    answer `status` (N,) int8 (`wsmap.workspace.status`: reached, certified unreachable, not found;
    the kind's `MapKind.status`), for a kind over a set of orientations the answer at each node
    and orientation `pose_status` (N, K) int8, both stored in the map file, and the seconds the
    certificates took, `status_seconds` (not in `seconds`, the map's own time)."""

    plan: MapPlan
    values: np.ndarray
    settings: dict
    summary: str
    seconds: float
    bits: np.ndarray | None = None
    rotations: np.ndarray | None = None
    status: np.ndarray | None = None
    pose_status: np.ndarray | None = None
    status_seconds: float | None = None

    @property
    def grid(self) -> dict:
        return self.plan.grid

    @property
    def counts(self) -> dict[str, int] | None:
        """The nodes' answers, `{"reached", "certified unreachable", "not found": count}`
        (`wsmap.workspace.STATUS` order), or None without a status."""
        return None if self.status is None else status_counts(self.status)

    @property
    def pose_counts(self) -> dict[str, int] | None:
        """The same counts over every node and orientation of a map over a set of orientations,
        or None."""
        return None if self.pose_status is None else status_counts(self.pose_status)


def _arg3(values, name):
    if values is None:
        return None
    if np.isscalar(values):
        return float(values)
    values = tuple(values)
    if len(values) not in (1, 3):
        raise ValueError(f"{name} takes one value or three, got {len(values)}")
    return values[0] if len(values) == 1 else values


@dataclass(frozen=True)
class MapJob:
    """One workspace map of one arm; see the module notes. Fields as `wsmap map`'s options
    (`wsmap map --help`), messages naming them as the command line spells them.

    Parameters
    ----------
    arm : ArmSource
        The arm (default: the paper's PUMA560).
    kind : str, optional
        A registered map kind (`wsmap.workspace.kinds`); default: the paper's map of `scope`.
    scope : {"R3", "SO3"}, optional
        Positions at a fixed orientation, or orientations at a fixed point.
    lo, hi, step : float or 3 floats, optional
        The grid (m for R3, rad for SO3; default -1..1 by 0.1 m, or 0..2π by π/10).
    rpy : 3 floats, optional
        The fixed orientation of R3 kinds, `R = Rx(r1)·Ry(r2)·Rz(r3)` (rad; default 0 0 0).
    point : 3 floats, optional
        The fixed point of SO3 kinds (m; default 0.5 0.5 0.5).
    orientations : int, optional
        Kinds over a set of orientations: its size K (super-Fibonacci; default 50).
    convention : {"standard", "paper"}, optional
        `T = transl(p)·R` (default) or the paper's `T = R·transl(p)`.
    method : {"auto", "exact", "numerical", "model"}
    starts, retry, seed, paper_lm, tol, ilimit, rlimit
        The numerical search's settings (`wsmap.workspace.MAP_SETTINGS` where None).
    model, allow_extrapolation
        A trained model file for `method="model"`.
    status_budget : int, optional
        Boxes per pose of the certificate's branch and bound for each node's answer (0: the sound
        filters and the closed form's certificate only; default: the kind's
        `MapKind.status_budget`). Recorded in the map file's settings when given.
    collision : CollisionSource
        Self-collision and obstacles (none by default).
    outputs : MapOutputs
        The files to write (at least one for `save`).
    progress : bool
        Progress bars on stderr.
    """

    arm: ArmSource = field(default_factory=ArmSource)
    kind: str | None = None
    scope: str | None = None
    lo: float | Sequence[float] | None = None
    hi: float | Sequence[float] | None = None
    step: float | Sequence[float] | None = None
    rpy: Sequence[float] | None = None
    point: Sequence[float] | None = None
    orientations: int | None = None
    convention: str | None = None
    method: str = "auto"
    starts: int | None = None
    retry: int | None = None
    seed: int = 0
    paper_lm: bool = False
    tol: float = 1e-10
    ilimit: int | None = None
    rlimit: int | None = None
    model: str | None = None
    allow_extrapolation: bool = False
    collision: CollisionSource = field(default_factory=CollisionSource)
    outputs: MapOutputs = field(default_factory=MapOutputs)
    progress: bool = False
    status_budget: int | None = None

    def __post_init__(self) -> None:
        for name in ("lo", "hi", "step", "rpy", "point"):
            v = getattr(self, name)
            if v is not None and not np.isscalar(v):
                object.__setattr__(self, name, tuple(float(x) for x in v))

    # ------------------------------------------------------------------------------ check
    def check(self, *, need_output: bool = True) -> MapPlan:
        """Every input checked, the arm and the collision checker built; nothing computed, nothing
        written. `need_output`: refuse a job with no output file (the command line's rule; a Python
        user who only wants the values passes False). Problems are one-line `ValueError`s."""
        paths = self._check_outputs(need_output)
        kind = self._check_kind(paths)
        self._check_method(kind)
        robot = self.arm.build()
        grid = grid_spec(kind.scope, _arg3(self.lo, "--lo"), _arg3(self.hi, "--hi"), _arg3(self.step, "--step"))
        if not kind.batch and robot.batch_shape != ():
            raise ValueError(f"--kind {kind.name} maps one arm")
        method = self._resolve_method(kind, robot)
        checker = self._checker(kind, robot)
        R = orientation_samples(self.orientations or 50, seed=self.seed) if "orientations" in kind.inputs else None
        if "--h5" in paths and self._convention(kind) != "standard":
            raise ValueError("--h5 writes poses T = transl(p)·R, the standard convention; drop --convention paper")
        request = MapRequest(method=method, convention=self._convention(kind), rpy=self._rpy, point=self._point,
                             orientations=R, ik=self._ik(kind, method), seed=self.seed, model=self.model,
                             allow_extrapolation=self.allow_extrapolation, progress=self.progress, collision=checker)
        return MapPlan(kind=kind, robot=robot, grid=grid, method=method, request=request, checker=checker,
                       orientations=R, paths=paths)

    @property
    def _rpy(self) -> tuple:
        return (0.0, 0.0, 0.0) if self.rpy is None else tuple(float(v) for v in self.rpy)

    @property
    def _point(self) -> tuple:
        return (0.5, 0.5, 0.5) if self.point is None else tuple(float(v) for v in self.point)

    def _convention(self, kind) -> str:
        return kind.convention or self.convention or "standard"

    def _check_outputs(self, need_output: bool) -> dict[str, Path]:
        given = self.outputs.given()
        if need_output and not given:
            raise ValueError(f"nothing to write: give --out FILE.npz and/or {', '.join('--' + k for k in OUTPUTS)}")
        paths = check_outputs(given, inputs={"--urdf": self.arm.urdf, "--mjcf": self.arm.mjcf,
                                             "--model": self.model, "--scene": self.collision.scene})
        out = paths.get("--out")
        if out is not None and out.suffix != ".npz":
            raise ValueError(f"--out {self.outputs.out!r}: a map file is .npz (numpy writes that format whatever "
                             "the name)")
        for flag, path in paths.items():
            suffix = OUTPUTS.get(flag[2:], (None, ".npz"))[1]
            if flag != "--out" and path.suffix.lower() != suffix:
                raise ValueError(f"{flag} {str(path)!r}: the file name must end in {suffix}")
        return paths

    def _check_kind(self, paths: dict):
        kind = get_kind(self.kind) if self.kind else default_kind(self.scope or "R3")
        if self.scope is not None and kind.scope != self.scope:
            raise ValueError(f"--scope {self.scope} does not go with --kind {kind.name} (a {kind.scope} map)")
        for name, flag in INPUT_FLAGS.items():  # the registry says what each kind reads
            if getattr(self, name) is not None and name not in kind.inputs:
                users = "/".join(k.name for k in kinds_taking(name)) or "no kind"
                raise ValueError(f"--kind {kind.name} does not read {flag} (it is read by --kind {users})")
        if "--h5" in paths and kind.poses is None:
            takers = "/".join(k.name for k in kinds() if k.poses is not None)
            raise ValueError(f"--h5 writes reachability over orientations (--kind {takers}), which the {kind.name} "
                             "map is not")
        for flag in paths:
            for module in OUTPUTS.get(flag[2:], ((), ""))[0]:
                require(module, why=flag)
        if self.orientations is not None and self.orientations > MAX_ORIENTATIONS:
            raise ValueError(f"--orientations must be at most {MAX_ORIENTATIONS} (neighbouring orientations are "
                             f"then 3.6° apart, and each is one more IK solve per node), got {self.orientations}")
        return kind

    def _check_method(self, kind) -> None:
        if self.method == "model":
            self._check_model(kind)
        elif self.model:
            raise ValueError(f"--model is only used with --method model (method is {self.method!r})")
        if self.allow_extrapolation and self.method != "model":
            raise ValueError("--allow-extrapolation is only used with --method model")
        budget = self.status_budget
        if budget is not None:
            if isinstance(budget, bool) or not isinstance(budget, (int, np.integer)) or budget < 0:
                raise ValueError(f"--status-budget must be a non-negative integer (boxes per pose), got {budget!r}")
            if self.method == "model":
                raise ValueError("--status-budget certifies the nodes of a map by the closed form or the search; "
                                 "--method model predicts a map and gives no status")
        if self.paper_lm and not kind.paper_solver:
            takers = " or ".join(k.name for k in kinds() if k.paper_solver)
            raise ValueError(f"--paper-lm is the paper's solver of its own maps (--kind {takers}), not {kind.name!r}")

    def _check_model(self, kind) -> None:
        if "model" not in kind.methods:
            predicted = " or ".join(k.name for k in kinds() if "model" in k.methods)
            raise ValueError(f"--method model predicts the paper's maps (--kind {predicted}), not {kind.name!r}")
        if not self.model:
            raise ValueError("--method model needs a model file (--model PATH)")
        if not Path(self.model).is_file():
            raise ValueError(f"--model {self.model!r}: no such file")
        require("torch", why="--method model")
        if "model" not in MAP_PREDICTORS:  # the classical library never imports the learned one
            raise ValueError("--method model is supplied by wsmap.learn (trained networks, needs torch): "
                             "import wsmap.learn first")

    def _resolve_method(self, kind, robot) -> str:
        method = self.method if self.method == "model" else resolve_method(robot, self.method)
        if method == "exact" and "exact" not in kind.methods:
            method = "numerical"  # no closed form of the kind's own (reach: the position search)
        for flag, value in (("--starts", self.starts), ("--retry", self.retry), ("--paper-lm", self.paper_lm or None)):
            if value is not None and method != "numerical":
                raise ValueError(f"{flag} is used by the numerical method (method is {method!r})")
        if self.paper_lm and (self.starts is not None or self.retry is not None):
            raise ValueError("--paper-lm is the paper's one-start LM; it takes no --starts or --retry")
        return method

    def _checker(self, kind, robot):
        if self.collision.wanted:
            if not kind.collision:
                takers = ", ".join(k.name for k in kinds() if k.collision)
                raise ValueError(f"--collision/--scene are used by --kind {takers} (kind is {kind.name!r})")
            if self.method == "model":
                raise ValueError("--method model predicts the chain's map; --collision/--scene need method exact or "
                                 "numerical")
            if self.paper_lm:
                raise ValueError("--paper-lm has one start and cannot look for another solution; drop it for "
                                 "--collision")
        return self.collision.build(robot, self.arm)

    def _ik(self, kind, method: str) -> dict:
        """The numerical settings as the map file records them: the kind's own search defaults with
        what the job set on top."""
        given = {k: v for k, v in dict(tol=self.tol, ilimit=self.ilimit, rlimit=self.rlimit).items() if v is not None}
        if method != "numerical":
            return given
        if self.paper_lm:
            return {**given, "solver": "paper"}
        mine = dict(tol=self.tol, ilimit=self.ilimit, rlimit=self.rlimit, starts=self.starts, retry=self.retry)
        return {**given, **kind.search_settings, **{k: v for k, v in mine.items() if v is not None}, "seed": self.seed}

    # -------------------------------------------------------------------------------- run
    def run(self, plan: MapPlan | None = None, *, notify: Callable[[str], None] | None = None) -> MapResult:
        """Compute the map (`check()` first unless its `plan` is given). `notify(line)` hears a
        one-line notice when the numerical kernels compile on this first run."""
        plan = self.check(need_output=False) if plan is None else plan
        if plan.method == "numerical" and notify is not None:
            from ..kinematics.ik.warmup import ensure_compiled

            ensure_compiled(notify=notify, joints=plan.robot.n, coupled=getattr(plan.robot, "coupling", None) is not None)
        kind = plan.kind
        want_status = kind.status is not None and plan.method in ("exact", "numerical")
        # a kind over orientations certifies each node and orientation: its bits come with the map
        want_bits = want_status and kind.over is not None
        t0 = time.perf_counter()
        bits = rotations = None
        if "--h5" in plan.paths or want_bits:
            flat, bits, rotations = kind.poses(plan.robot, plan.grid, plan.request)  # map and poses at once
        else:
            flat = kind.compute(plan.robot, plan.grid, plan.request)
        seconds = time.perf_counter() - t0
        status = pose_status = status_seconds = None
        if want_status:
            t1 = time.perf_counter()
            budget = kind.status_budget if self.status_budget is None else self.status_budget
            status, pose_status = kind.status(plan.robot, plan.grid, plan.request, flat, bits, budget)
            status_seconds = time.perf_counter() - t1
        if "--h5" not in plan.paths:
            bits = rotations = None
        settings = self._settings(plan, seconds)
        return MapResult(plan=plan, values=flat, settings=settings, summary=kind.summary(flat), seconds=seconds,
                         bits=bits, rotations=rotations, status=status, pose_status=pose_status,
                         status_seconds=status_seconds)

    def _how(self, plan: MapPlan) -> str:
        """How the map was computed, in words (the settings' `how`)."""
        ik = plan.request.ik
        how = {"exact": "closed form", "model": f"network {self.model}",
               "numerical": ("the paper's LM, one start at q = 0" if self.paper_lm else
                             f"start at q = 0, {ik.get('starts')} random, neighbours' solutions, {ik.get('retry')} "
                             f"retries, seed {self.seed}")}[plan.method]
        if plan.method == "exact":
            how += f" ({closed_form_for(plan.robot).name.replace('_', '-')} family)"
        how += f", joint limits {'on' if plan.robot.qlim is not None else 'off'}"
        if plan.orientations is not None:
            how += f", {len(plan.orientations)} orientations (super-Fibonacci, seed {self.seed})"
        checker = plan.checker
        if checker is not None:
            st = checker.stats
            how += (f", collision-free ({len(checker.pairs)} link pairs, {len(checker.scene.obstacles)} obstacles"
                    f"{_floor_words(checker.scene.floor)}; {st.configurations} configurations "
                    f"checked, {st.fast_fraction:.0%} by the spheres alone)")
        return how

    def _settings(self, plan: MapPlan, seconds: float) -> dict:
        """The settings and provenance the map file records."""
        robot, request = plan.robot, plan.request
        settings = {
            "kind": plan.kind.name, "robot": robot.name, "source": getattr(robot, "source", None),
            "urdf": self.arm.urdf, "mjcf": self.arm.mjcf, "ee": self.arm.ee, "n": robot.n,
            "qlim": None if robot.qlim is None else np.asarray(robot.qlim).tolist(),
            "method": plan.method, "how": self._how(plan), "convention": request.convention,
            "rpy": list(request.rpy), "point": list(request.point), "model": self.model, "ik": request.ik,
            "seconds": seconds,
        }
        if self.status_budget is not None:  # only when given: a file made without it keeps its bytes
            settings["status_budget"] = self.status_budget
        checker = plan.checker
        if checker is not None:
            settings["collision"] = {**checker.describe(), **self.collision.describe(), "floor": checker.scene.floor,
                                     "stats": {"configurations": checker.stats.configurations,
                                               "decided_fast": checker.stats.decided_fast,
                                               "exact_tests": checker.stats.exact_tests}}
        if hasattr(robot, "d"):  # a DH arm: its table
            settings.update(d=robot.d.tolist(), a=robot.a.tolist(), alpha=robot.alpha.tolist())
        return settings

    # ------------------------------------------------------------------------------- save
    def save(self, result: MapResult, *, warn: Callable[[str], None] | None = None) -> list[Path]:
        """Write the job's outputs; returns the paths written, the map file first.

        Every output is written to a temporary file and all are put in place together, so an
        error leaves every file as it was. A map with no reachable node (all values 0) is a valid
        map: its `.npz`, slices and Reuleaux file are written, while the 3-D views (--html, --ply,
        --glb), which would draw nothing, are skipped with one line to `warn` (default:
        `warnings.warn`), and any old file at their paths is left as it was.
        """
        paths = result.plan.paths
        views = {flag: p for flag, p in paths.items() if flag[2:] in VIEWS}
        if views and not np.any(np.asarray(result.values, dtype=np.float64) > 0):
            plural = "s were" if len(views) > 1 else " was"
            line = (f"{' and '.join(views)}: nothing to draw, no node of the map is reachable (its values are "
                    f"all 0); the view{plural} not written")
            if warn is None:
                import warnings

                warnings.warn(line, stacklevel=2)
            else:
                warn(line)
            views = {}
        written = {flag: p for flag, p in paths.items() if flag[2:] not in VIEWS} | views
        fig = self._figure(result) if "--png" in written else None
        flag = None
        try:
            with atomic_paths(list(written.values())) as tmps:
                for flag, tmp in zip(written, tmps):
                    self._write(flag, tmp, result, fig)
        except ValueError as e:  # a view that cannot be drawn: nothing was put in place
            raise ValueError(f"{flag} {str(written[flag])!r}: {e}; no file was written") from None
        finally:
            if fig is not None:
                import matplotlib.pyplot as plt

                plt.close(fig)
        return list(written.values())

    @staticmethod
    def _write(flag: str, tmp: Path, result: MapResult, fig) -> None:
        plan = result.plan
        if flag == "--out":
            save_map(tmp, result.values, plan.grid, result.settings, orientations=plan.orientations,
                     status=result.status, pose_status=result.pose_status)
        elif flag == "--h5":
            save_reuleaux(tmp, plan.grid, result.bits, result.rotations)
        elif flag[2:] in VIEWS:
            _write_view(flag, tmp, result)
        else:
            fig.savefig(tmp, format="png", dpi=120, bbox_inches="tight", metadata=fig.wsmap_metadata)

    def _figure(self, result: MapResult):
        """The z-slices figure: a short title a reader can take in; every setting in its metadata."""
        from ..collision.sources import map_picture
        from ..viz import map_title, plot_slices, plot_value_slices, png_metadata

        plan, kind, grid = result.plan, result.plan.kind, result.plan.grid
        labels = ("x", "y", "z") if kind.scope == "R3" else ("r1", "r2", "r3")
        K = len(plan.orientations) if plan.orientations is not None else None
        collision, obstacles = map_picture(plan.checker, result.settings.get("collision"))
        obstacles = obstacles if kind.scope == "R3" else None  # obstacles live in metres, not angles
        title = map_title(plan.robot.name or "arm", kind, rpy=self.rpy, point=self.point,
                          convention=plan.request.convention, orientations=K,
                          summary=f"{result.summary} ({plan.method})" + _counts_line(result), collision=collision)
        meta = png_metadata({**result.settings, "grid": grid}, title=title)
        if kind.value_type is float:
            vmin, vmax = kind.value_range
            return plot_value_slices(result.values, grid["shape"], grid["lo"], grid["step"], label=kind.label,
                                     title=title, labels=labels, vmin=vmin, vmax=vmax, metadata=meta,
                                     obstacles=obstacles, status=result.status)
        return plot_slices(result.values, grid["shape"], grid["lo"], grid["step"], labels=labels, title=title,
                           metadata=meta, obstacles=obstacles, status=result.status)


def _counts_line(result: MapResult) -> str:
    """The pictures' line of the nodes' three answers (a new line first), or "" without a status."""
    counts = result.counts
    if counts is None:
        return ""
    return "\nnodes: " + ", ".join(f"{count} {name}" for name, count in counts.items())


def _floor_words(floor: float | None) -> str:
    """The floor in the map's `how` (and the command line's summary line): said either way."""
    return ", no floor" if floor is None else f", floor at z = {floor:g} m"


def _write_view(flag: str, tmp: Path, result: MapResult) -> None:
    """One 3-D view (--html, --ply or --glb) of a map with at least one reachable node, to `tmp`."""
    from ..views import save_glb, save_html, save_ply

    kind, grid, robot = result.plan.kind, result.plan.grid, result.plan.robot
    values = np.asarray(result.values, dtype=np.float64)
    if flag == "--html":
        from ..collision.sources import map_picture

        # a float map gets a threshold slider; every map a cut plane through its z-layers; a
        # collision-aware one says what it is free of and shows the scene's obstacles
        collision, obstacles = map_picture(result.plan.checker, result.settings.get("collision"))
        save_html(tmp, values, grid, label=kind.label, title=f"{robot.name or 'arm'}: {kind.name} map"
                  + (f", collision-free: {collision}" if collision else "")
                  + _counts_line(result).replace("\n", "<br>"),
                  thresholds=np.linspace(0.0, 0.9, 10) * values.max() if kind.value_type is float else None,
                  cut_plane=True, obstacles=obstacles if kind.scope == "R3" else None, status=result.status)
    elif flag == "--ply":
        save_ply(tmp, values, grid, label=kind.label, status=result.status)
    else:
        save_glb(tmp, values, grid, levels=kind.levels(values), status=result.status)
