"""The one command line: `wsmap map`, `wsmap place`, `wsmap robots`, `wsmap data`, `wsmap paper`
(also `python -m wsmap`).

Examples::

    wsmap map --robot puma560 --out puma560.npz --png puma560_slices.png
    wsmap map --robot panda --kind index --orientations 50 --step 0.05 --out panda_index.npz --html panda.html
    wsmap map --robot ur5e --kind index --step 0.05 --h5 ur5e_reachability.h5   # Reuleaux (ROS)
    wsmap map --robot panda --rpy pi 0 0 --png panda_tooldown.png -q              # a picture alone
    wsmap place --robot ur5e --targets poses.csv --x -1 1 --y -1 1 --out ranking.csv
    wsmap map --d 0 0 0.15 0.43 0 0 --a 0 0.43 0.02 0 0 0 \\
              --alpha pi/2 0 -pi/2 pi/2 -pi/2 0 --method numerical --out mine.npz
    wsmap map --robot puma560 --method model --model models/improved_model.pt --out nn.npz
    wsmap data build sec61 --samples 10000 --test-samples 1000 --out data/sec61.npz
    wsmap data build panda7_tooldown --samples 2000 --test-samples 200 --out data/panda7.npz --workers 2
    wsmap data build panda7_tooldown --samples 100000 --out data/panda7.npz --scheduler tcp://head:8786
    wsmap paper run sec61_subspace            # one notebook (a DVC stage) with params.yaml
    wsmap paper run --all --params params.full.yaml --root full --timeout 0

Every input is checked before any work and before any file is written; the outputs of a run are
written to temporary files and put in place together when the whole run has succeeded. A bad
input ends with exit code 2 and one line naming the problem, never a traceback.
"""

from __future__ import annotations

import argparse
import ast
import math
import operator
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np

from .paper.pipeline import NotebookError

__all__ = ["main", "number"]

_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
        ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Pow: operator.pow}


def number(text: str) -> float:
    """A finite float, or an arithmetic expression in `pi` (`pi/2`, `-3*pi/4`, `2*pi`)."""

    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return math.pi
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.operand))
        raise ValueError
    if len(text) > 200:
        raise argparse.ArgumentTypeError(f"not a number or pi expression (too long): {text[:40]!r}...")
    try:
        # floats only: 9**9**9 overflows (OverflowError) instead of building a huge integer
        value = ev(ast.parse(text.strip(), mode="eval"))
    except (ValueError, SyntaxError, ZeroDivisionError, TypeError, OverflowError, RecursionError, MemoryError):
        raise argparse.ArgumentTypeError(f"not a finite number or pi expression: {text!r}") from None
    if isinstance(value, complex) or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def _int_at_least(minimum: int):
    """An argparse type: an integer of at least `minimum`."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        return value

    return parse


positive_int = _int_at_least(1)
non_negative_int = _int_at_least(0)


def seed_int(text: str) -> int:
    """An argparse type: a seed of numpy's generators, an integer in [0, 2**64)."""
    value = non_negative_int(text)
    if value >= 2**64:
        raise argparse.ArgumentTypeError(f"must be below 2**64 = {2**64} (numpy's seed range), got {value}")
    return value


def tolerance(text: str) -> float:
    """An argparse type: an IK tolerance (m and rad), at least `wsmap.kinematics.MIN_TOL`."""
    from .kinematics.ik.solution import MIN_TOL

    value = positive_float(text)
    if value < MIN_TOL:
        raise argparse.ArgumentTypeError(
            f"must be at least {MIN_TOL:g}: float64 forward kinematics is only exact to about 1e-16 per metre, "
            f"so no pose ever meets a smaller tolerance and the map would be empty, got {text!r}")
    return value


def positive_float(text: str) -> float:
    value = number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (naming the problem and where help is), exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class _Help(argparse.ArgumentDefaultsHelpFormatter):
    """Help lines with `(default: X)` only where X says something: not for `None` (the help line
    says what happens then), not for a flag's `False`, not where the line already names a default."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or action.default is False or "default" in text:
            return text
        return super()._get_help_string(action)


#: The options that feed a kind's inputs (`wsmap.workspace.kinds.INPUTS`): given with a kind that
#: does not read them, they are refused instead of ignored.
_INPUT_FLAGS = {"rpy": "--rpy", "point": "--point", "orientations": "--orientations", "convention": "--convention"}
#: The output options of `wsmap map` besides --out, the optional modules each one needs, and the suffix.
_OUTPUTS = {"--png": ((), ".png"), "--html": (("plotly",), ".html"), "--ply": ((), ".ply"),
            "--glb": (("trimesh", "skimage"), ".glb"), "--h5": (("h5py",), ".h5")}


def _quiet_argument(p, what="no progress bar or summary"):
    p.add_argument("-q", "--quiet", action="store_true", help=what)


# ------------------------------------------------------------------------------------- wsmap map
def _robot_from_args(args):
    """The arm of `wsmap map`: a named arm, a URDF file, or DH columns (standard or modified)."""
    from . import robots
    from .kinematics import DHRobot

    def limits(n):
        q = np.asarray(args.qlim_deg, dtype=float)
        if q.size != 2 * n:
            raise ValueError(f"--qlim-deg needs 2 values per joint ({2 * n}), got {q.size}")
        return np.deg2rad(q.reshape(-1, 2))

    dh = [args.d, args.a, args.alpha]
    mjcf = getattr(args, "mjcf", None)
    given = [name for name, v in (("--robot", args.robot), ("--urdf", args.urdf), ("--mjcf", mjcf),
                                  ("the DH columns", any(x is not None for x in dh) or None)) if v is not None]
    if len(given) > 1:
        raise ValueError(f"give one arm: {' and '.join(given)} were both given")
    if args.ee is not None and args.urdf is None and mjcf is None:
        raise ValueError("--ee names the end link of a --urdf arm (or the site of a --mjcf arm)")
    if args.base is not None and args.urdf is None:
        raise ValueError("--base names the first link of a --urdf arm")
    if mjcf is not None:
        if args.ee is None:
            raise ValueError("--mjcf needs the tool's site or body: --ee NAME")
        robot = robots.from_mjcf(mjcf, args.ee)
        if args.joint_limits is False:
            robot = robot.replace(qlim=None)
        if args.qlim_deg is not None and args.joint_limits is not False:
            robot = robot.replace(qlim=limits(robot.n))
        return robot
    if (args.mdh or args.offset is not None) and not any(x is not None for x in dh):
        raise ValueError("--mdh and --offset describe DH columns (--d/--a/--alpha)")
    if any(x is not None for x in dh):
        if any(x is None for x in dh):
            raise ValueError("the DH columns need all three of --d, --a and --alpha")
        if args.joint_limits and args.qlim_deg is None:
            raise ValueError("--joint-limits on DH columns needs the limits: --qlim-deg lo_1 hi_1 ...")
        qlim = limits(len(args.d)) if args.qlim_deg is not None and args.joint_limits is not False else None
        if args.mdh or args.offset is not None:
            return robots.from_dh(args.d, args.a, args.alpha, offset=args.offset, qlim=qlim, modified=args.mdh,
                                  name="custom (modified DH)" if args.mdh else "custom")
        return DHRobot(args.d, args.a, args.alpha, qlim=qlim, name="custom")
    if args.urdf is not None:
        if not Path(args.urdf).is_file():
            raise ValueError(f"--urdf {args.urdf!r}: no such file")
        robot = robots.from_urdf(args.urdf, ee_link=args.ee, base_link=args.base)
        if args.joint_limits is False:
            robot = robot.replace(qlim=None)
    else:
        robot = robots.load(args.robot or "puma560", joint_limits=args.joint_limits)
    if args.qlim_deg is not None and args.joint_limits is not False:
        q = limits(robot.n)
        robot = (DHRobot(robot.d, robot.a, robot.alpha, qlim=q, tool=robot.tool, name=robot.name)
                 if isinstance(robot, DHRobot) else robot.replace(qlim=q))
    return robot


def _collision_from_args(args, robot, kind):
    """The `wsmap.collision.CollisionChecker` of `wsmap map`, or None: every file read and
    checked (scene, meshes, link names of --allow) before the map is computed."""
    wanted = args.collision or args.scene is not None or args.link_radius is not None
    if not wanted:
        for flag, v in (("--allow", args.allow), ("--acm-samples", args.acm_samples), ("--mount", args.mount)):
            if v is not None:
                raise ValueError(f"{flag} is used with --collision or --scene")
        return None
    if kind is not None and not kind.collision:
        from .workspace.kinds import kinds

        takers = ", ".join(k.name for k in kinds() if k.collision)
        raise ValueError(f"--collision/--scene are used by --kind {takers} (kind is {kind.name!r})")
    if args.method == "model":
        raise ValueError("--method model predicts the chain's map; --collision/--scene need method exact or numerical")
    if getattr(args, "paper_lm", False):
        raise ValueError("--paper-lm has one start and cannot look for another solution; drop it for --collision")
    from . import collision as col

    if args.mount is not None and args.scene is None:
        raise ValueError("--mount names a link of a work-cell URDF given with --scene CELL.urdf")
    scene = col.load_scene(args.scene, args.mount) if args.scene is not None else None
    dh = any(x is not None for x in (args.d, args.a, args.alpha))
    if args.link_radius is not None:
        r = args.link_radius
        if len(r) not in (1, robot.n + 1):
            raise ValueError(f"--link-radius takes one radius or one per body (0..{robot.n}: {robot.n + 1}), "
                             f"got {len(r)}")
        model = col.capsules_along_links(robot, r[0] if len(r) == 1 else r, floor=not dh and args.urdf is None)
    elif args.urdf is not None:
        model = col.from_urdf_collision(args.urdf, ee_link=args.ee, base_link=args.base)
        model.chain = robot  # the same URDF chain, with the limits the command line chose
    elif getattr(args, "mjcf", None) is not None:
        from .collision.mjcf import from_mjcf_collision

        model = from_mjcf_collision(args.mjcf, args.ee)
        model.chain = robot
    elif dh:
        raise ValueError("DH columns carry no collision geometry: give --link-radius R (capsules along the links)")
    else:
        model = col.arm_model(args.robot or "puma560", robot)
    samples = col.DEFAULT_SAMPLES if args.acm_samples is None else args.acm_samples
    model.acm = col.build_acm(model, samples=samples, seed=getattr(args, "seed", 0),
                              disable=[tuple(p) for p in (args.allow or [])])
    return col.CollisionChecker(model, scene)


def _method_for(robot, method: str) -> str:
    """`auto`: the closed form where the arm belongs to a closed-form family, else numerical IK."""
    if method == "model":
        return method
    from .workspace import resolve_method

    return resolve_method(robot, method)


def _arg3(values, name):
    if values is None:
        return None
    if len(values) not in (1, 3):
        raise ValueError(f"{name} takes one value or three, got {len(values)}")
    return values[0] if len(values) == 1 else tuple(values)


def _arm_arguments(m):
    """The arm options shared by `wsmap map` and `wsmap place`."""
    g = m.add_argument_group("arm")
    g.add_argument("--robot", help="a named arm (`wsmap robots` lists them; default puma560 when no other arm is given)")
    g.add_argument("--urdf", metavar="FILE", help="the arm as a URDF file (meshes are never read)")
    g.add_argument("--mjcf", metavar="FILE", help="the arm as an MJCF (MuJoCo) file, to the site or body --ee")
    g.add_argument("--ee", metavar="LINK", help="--urdf: the end link (default: the chain's only leaf); "
                                               "--mjcf: the tool's site or body (required)")
    g.add_argument("--base", metavar="LINK", help="--urdf: the first link of the chain (default: the URDF's root)")
    g.add_argument("--d", type=number, nargs="+", help="DH link offsets d_1..d_n in metres")
    g.add_argument("--a", type=number, nargs="+", help="DH link lengths a_1..a_n in metres")
    g.add_argument("--alpha", type=number, nargs="+", help="DH twists alpha_1..alpha_n in radians (pi expressions allowed)")
    g.add_argument("--mdh", action="store_true", help="the DH columns are modified DH (Craig), as Franka and Kinova publish them")
    g.add_argument("--offset", type=number, nargs="+", help="DH joint offsets theta_i in radians (the manufacturer's zero)")
    g.add_argument("--joint-limits", action=argparse.BooleanOptionalAction, default=None,
                   help="honour the arm's joint limits (default: on for real arms and URDFs, off for puma560 as in the paper)")
    g.add_argument("--qlim-deg", type=number, nargs="+", metavar="DEG",
                   help="joint limits in degrees: lo_1 hi_1 lo_2 hi_2 ... (overrides --joint-limits)")


def _collision_arguments(m):
    g = m.add_argument_group("collision (docs/collision.md)")
    g.add_argument("--collision", action="store_true",
                   help="count a node only with a collision-free solution: self-collision from the arm's own geometry "
                        "(--urdf: its <collision> elements; --robot: its capsule model; DH columns: --link-radius), "
                        "and the floor for a named arm")
    g.add_argument("--scene", metavar="FILE", help="obstacles (YAML or JSON: floor, boxes, cylinders, spheres, "
                                                  "meshes; or a work cell's URDF, FILE.urdf: its fixed links' "
                                                  "<collision> elements); implies --collision")
    g.add_argument("--mount", metavar="LINK", help="--scene CELL.urdf: the cell's link the arm's base is attached to "
                                                   "(obstacles in the base frame); default: the cell's root is the "
                                                   "world frame")
    g.add_argument("--link-radius", type=positive_float, nargs="+", metavar="R",
                   help="capsules of these radii (m; one, or one per body 0..n) along the links; implies --collision")
    g.add_argument("--allow", nargs=2, action="append", metavar=("LINK", "LINK"),
                   help="never check this link pair (repeatable), besides the allowed-collision matrix's")
    g.add_argument("--acm-samples", type=non_negative_int, default=None, metavar="N",
                   help="random configurations of the matrix's 'never in collision' test (10000 when not given)")


def _map_parser(sub):
    from .workspace.kinds import default_kind, kind_names, kinds, kinds_taking

    m = sub.add_parser(
        "map",
        help="compute the workspace map of an arm on a grid",
        description="Compute a workspace map of an arm (one value per grid node: a bit or a number, as --kind "
                    "says) and write it: a .npz map file, pictures and views, a Reuleaux .h5 for ROS.",
        epilog="Node order: x fastest, then y, then z (flat index i + nx*j + nx*ny*k).",
        formatter_class=_Help,
    )
    _arm_arguments(m)
    g = m.add_argument_group("kind and scope")
    g.add_argument("--kind", choices=kind_names(), default=None,
                   help="; ".join(f"{k.name}: {k.description}" for k in kinds())
                        + f" (default: {default_kind('R3').name}, or as --scope)")
    g.add_argument("--orientations", type=positive_int, default=None, metavar="K",
                   help=f"{'/'.join(k.name for k in kinds_taking('orientations'))}: K orientations spread over "
                        "SO(3) (super-Fibonacci; default 50)")
    g.add_argument("--scope", choices=["R3", "SO3"], default=None,
                   help="R3: positions at a fixed orientation; SO3: orientations at a fixed point "
                        f"(the same as --kind {default_kind('R3').name} / {default_kind('SO3').name}; default R3)")
    g.add_argument("--lo", type=number, nargs="+", help="grid start, one value or three (default -1 m for R3, 0 rad for SO3)")
    g.add_argument("--hi", type=number, nargs="+", help="grid end, inclusive (default 1 m for R3, 2*pi for SO3)")
    g.add_argument("--step", type=number, nargs="+", help="grid step (default 0.1 m for R3, pi/10 for SO3)")
    g.add_argument("--rpy", type=number, nargs=3, metavar=("R1", "R2", "R3"),
                   help=f"--kind {'/'.join(k.name for k in kinds_taking('rpy'))}: fixed orientation, "
                        "R = Rx(r1) Ry(r2) Rz(r3), radians (default 0 0 0)")
    g.add_argument("--point", type=number, nargs=3, metavar=("X", "Y", "Z"),
                   help=f"--kind {'/'.join(k.name for k in kinds_taking('point'))}: fixed point in metres "
                        "(default 0.5 0.5 0.5)")
    g = m.add_argument_group("method")
    g.add_argument("--method", choices=["auto", "exact", "numerical", "model"], default="auto",
                   help="auto: exact where a closed form exists, else numerical; exact: closed form (the "
                        "spherical-wrist DH family and the UR family); numerical: Levenberg-Marquardt within the "
                        "joint limits, started at q = 0 and from neighbouring nodes' solutions (any arm); "
                        "model: a trained network (--model)")
    g.add_argument("--starts", type=non_negative_int,
                   help="numerical: random IK starts per node before the neighbours' solutions are tried "
                        "(default: the measured default, wsmap.workspace.MAP_SETTINGS)")
    g.add_argument("--retry", type=non_negative_int,
                   help="numerical: random IK starts for unsolved nodes next to solved ones, once the "
                        "neighbours' solutions are spent (default: wsmap.workspace.MAP_SETTINGS)")
    g.add_argument("--seed", type=seed_int, default=0, help="numerical: seed of the random starts")
    g.add_argument("--paper-lm", action="store_true",
                   help="numerical: the paper's one-start Levenberg-Marquardt from q = 0 instead of the multi-start "
                        "search (misses reachable nodes; for comparison with the paper)")
    g.add_argument("--convention", choices=["standard", "paper"],
                   help=f"--kind {'/'.join(k.name for k in kinds_taking('convention'))}: standard: T = transl(p)·R "
                        "(default; the tool at p with orientation R); paper: T = R·transl(p), tests R·p (the "
                        "authors' code, the paper's maps)")
    g.add_argument("--model", help="trained model file for --method model")
    g.add_argument("--allow-extrapolation", action="store_true",
                   help="--method model: predict for arms outside the range the model was trained on (with a warning)")
    g.add_argument("--tol", type=tolerance, default=1e-10,
                   help="numerical IK tolerance on the pose error norm (m and rad; at least 1e-14)")
    g.add_argument("--ilimit", type=positive_int, help="numerical IK iteration limit per start (default: the solver's)")
    g.add_argument("--rlimit", type=positive_int,
                   help="numerical IK limit on consecutive rejected steps per start (default: the solver's)")
    _collision_arguments(m)
    g = m.add_argument_group("output (at least one)")
    g.add_argument("--out", metavar="FILE.npz", help="the map as .npz (map, nodes, grid, settings; wsmap.load_map)")
    g.add_argument("--png", metavar="FILE.png",
                   help="the map's z-slices as a PNG (a colour bar for index/manipulability)")
    g.add_argument("--html", metavar="FILE.html",
                   help="an interactive 3-D view (standalone HTML, plotly.js inline; needs wsmap[views])")
    g.add_argument("--ply", metavar="FILE.ply", help="the reachable nodes as a coloured point cloud")
    g.add_argument("--glb", metavar="FILE.glb", help="iso-surfaces of the map as a glTF scene (needs wsmap[views])")
    g.add_argument("--h5", metavar="FILE.h5",
                   help=f"a Reuleaux reachability map for ROS (HDF5; --kind "
                        f"{'/'.join(k.name for k in kinds() if k.poses is not None)}; needs wsmap[h5]; "
                        "see docs/reuleaux.md)")
    _quiet_argument(g)
    m.set_defaults(run=_run_map)


def _run_map(args) -> int:
    """`wsmap map`: what the kind needs, checked, then its `compute` (the kinds' registry,
    `wsmap.workspace.kinds`, says what each kind reads, computes and how its values read)."""
    from . import workspace as ws
    from .io import atomic_paths, check_outputs
    from .kinematics import closed_form_for
    from .workspace.kinds import MapRequest, default_kind, get_kind, kinds, kinds_taking
    from .workspace.orientations import MAX_ORIENTATIONS

    # every check before any work
    from ._optional import require

    given = {flag: getattr(args, flag[2:]) for flag in _OUTPUTS if getattr(args, flag[2:])}
    if args.out is None and not given:
        raise ValueError(f"nothing to write: give --out FILE.npz and/or {', '.join(_OUTPUTS)}")
    extra = check_outputs({"--out": args.out, **given}, inputs={"--urdf": args.urdf, "--mjcf": args.mjcf,
                                                                "--model": args.model, "--scene": args.scene})
    out = extra.pop("--out", None)
    if out is not None and out.suffix != ".npz":
        raise ValueError(f"--out {args.out!r}: a map file is .npz (numpy writes that format whatever the name)")
    for flag, path in extra.items():
        if path.suffix.lower() != _OUTPUTS[flag][1]:
            raise ValueError(f"{flag} {str(path)!r}: the file name must end in {_OUTPUTS[flag][1]}")
    kind = get_kind(args.kind) if args.kind else default_kind(args.scope or "R3")
    if args.scope is not None and kind.scope != args.scope:
        raise ValueError(f"--scope {args.scope} does not go with --kind {kind.name} (a {kind.scope} map)")
    scope = kind.scope
    for name, flag in _INPUT_FLAGS.items():  # the registry says what each kind reads
        if getattr(args, name) is not None and name not in kind.inputs:
            users = "/".join(k.name for k in kinds_taking(name)) or "no kind"
            raise ValueError(f"--kind {kind.name} does not read {flag} (it is read by --kind {users})")
    if "--h5" in extra and kind.poses is None:
        takers = "/".join(k.name for k in kinds() if k.poses is not None)
        raise ValueError(f"--h5 writes reachability over orientations (--kind {takers}), which the {kind.name} map "
                         "is not")
    for flag in extra:
        for module in _OUTPUTS[flag][0]:
            require(module, why=flag)
    if args.orientations is not None and args.orientations > MAX_ORIENTATIONS:
        raise ValueError(f"--orientations must be at most {MAX_ORIENTATIONS} (neighbouring orientations are then "
                         f"3.6° apart, and each is one more IK solve per node), got {args.orientations}")
    if args.method == "model":
        if "model" not in kind.methods:
            predicted = " or ".join(k.name for k in kinds() if "model" in k.methods)
            raise ValueError(f"--method model predicts the paper's maps (--kind {predicted}), not {kind.name!r}")
        if not args.model:
            raise ValueError("--method model needs a model file (--model PATH)")
        if not Path(args.model).is_file():
            raise ValueError(f"--model {args.model!r}: no such file")
        require("torch", why="--method model")
        from . import learn  # noqa: F401 -- registers the "model" map method of wsmap.workspace.grid_map
    elif args.model:
        raise ValueError(f"--model is only used with --method model (method is {args.method!r})")
    if args.allow_extrapolation and args.method != "model":
        raise ValueError("--allow-extrapolation is only used with --method model")
    if args.paper_lm and not kind.paper_solver:
        takers = " or ".join(k.name for k in kinds() if k.paper_solver)
        raise ValueError(f"--paper-lm is the paper's solver of its own maps (--kind {takers}), not {kind.name!r}")
    robot = _robot_from_args(args)
    grid = ws.grid_spec(scope, _arg3(args.lo, "--lo"), _arg3(args.hi, "--hi"), _arg3(args.step, "--step"))
    if not kind.batch and robot.batch_shape != ():
        raise ValueError(f"--kind {kind.name} maps one arm")
    method = _method_for(robot, args.method)
    if method == "exact" and "exact" not in kind.methods:
        method = "numerical"  # no closed form of the kind's own (reach: the position search)
    for flag, value in (("--starts", args.starts), ("--retry", args.retry), ("--paper-lm", args.paper_lm or None)):
        if value is not None and method != "numerical":
            raise ValueError(f"{flag} is used by the numerical method (method is {method!r})")
    if args.paper_lm and (args.starts is not None or args.retry is not None):
        raise ValueError("--paper-lm is the paper's one-start LM; it takes no --starts or --retry")
    checker = _collision_from_args(args, robot, kind)
    limited = robot.qlim is not None
    K = args.orientations or 50
    R = ws.orientation_samples(K, seed=args.seed) if "orientations" in kind.inputs else None

    if method == "numerical":  # a first run says why it is silent: a one-line notice, only if it compiles
        from .kinematics.ik.warmup import ensure_compiled
        ensure_compiled(notify=lambda line: print(f"wsmap: {line}", file=sys.stderr, flush=True), joints=robot.n)
    t0 = time.perf_counter()
    ik = {k: v for k, v in dict(tol=args.tol, ilimit=args.ilimit, rlimit=args.rlimit).items() if v is not None}
    if method == "numerical":
        if args.paper_lm:
            ik.update(solver="paper")
        else:
            # the kind's own search defaults, with what the command line set on top
            ik.update({**kind.search_settings, **{k: v for k, v in dict(
                tol=args.tol, ilimit=args.ilimit, rlimit=args.rlimit, starts=args.starts, retry=args.retry).items()
                if v is not None}}, seed=args.seed)
    convention = kind.convention or args.convention or "standard"
    rpy = (0.0, 0.0, 0.0) if args.rpy is None else tuple(args.rpy)
    point = (0.5, 0.5, 0.5) if args.point is None else tuple(args.point)
    request = MapRequest(method=method, convention=convention, rpy=rpy, point=point,
                         orientations=R, ik=ik, seed=args.seed, model=args.model,
                         allow_extrapolation=args.allow_extrapolation, progress=not args.quiet, collision=checker)
    if "--h5" in extra:
        if convention != "standard":
            raise ValueError("--h5 writes poses T = transl(p)·R, the standard convention; drop --convention paper")
        flat, bits, R_h5 = kind.poses(robot, grid, request)  # the map and its poses in one computation
    else:
        flat = kind.compute(robot, grid, request)
    seconds = time.perf_counter() - t0
    how = {"exact": "closed form", "model": f"network {args.model}",
           "numerical": ("the paper's LM, one start at q = 0" if args.paper_lm else
                         f"start at q = 0, {ik.get('starts')} random, neighbours' solutions, {ik.get('retry')} "
                         f"retries, seed {args.seed}")}[method]
    if method == "exact":
        how += f" ({closed_form_for(robot).name.replace('_', '-')} family)"
    how += f", joint limits {'on' if limited else 'off'}"
    if R is not None:
        how += f", {K} orientations (super-Fibonacci, seed {args.seed})"
    if checker is not None:
        st = checker.stats
        how += (f", collision-free ({len(checker.pairs)} link pairs, {len(checker.scene.obstacles)} obstacles"
                f"{', floor' if checker.scene.floor is not None else ''}; {st.configurations} configurations "
                f"checked, {st.fast_fraction:.0%} by the spheres alone)")
    settings = {
        "kind": kind.name, "robot": robot.name, "source": getattr(robot, "source", None), "urdf": args.urdf,
        "mjcf": getattr(args, "mjcf", None),
        "ee": args.ee, "n": robot.n, "qlim": None if robot.qlim is None else np.asarray(robot.qlim).tolist(),
        "method": method, "how": how, "convention": convention,
        "rpy": list(rpy), "point": list(point), "model": args.model, "ik": ik, "seconds": seconds,
    }
    if checker is not None:
        settings["collision"] = {**checker.describe(), "scene_file": args.scene, "mount": args.mount,
                                 "stats": {"configurations": checker.stats.configurations,
                                           "decided_fast": checker.stats.decided_fast,
                                           "exact_tests": checker.stats.exact_tests}}
    if hasattr(robot, "d"):  # a DH arm: its table
        settings.update(d=robot.d.tolist(), a=robot.a.tolist(), alpha=robot.alpha.tolist())
    summary = kind.summary(flat)
    fig = None
    if "--png" in extra:
        from .viz import map_title, plot_slices, plot_value_slices, png_metadata

        labels = ("x", "y", "z") if scope == "R3" else ("r1", "r2", "r3")
        # a short title a reader can take in; every setting goes into the PNG's metadata (and the map file)
        title = map_title(robot.name or "arm", kind, rpy=args.rpy, point=args.point, convention=convention,
                          orientations=K if R is not None else None, summary=f"{summary} ({method})")
        meta = png_metadata({**settings, "grid": grid}, title=title)
        if kind.value_type is float:
            vmin, vmax = kind.value_range
            fig = plot_value_slices(flat, grid["shape"], grid["lo"], grid["step"], label=kind.label, title=title,
                                    labels=labels, vmin=vmin, vmax=vmax, metadata=meta)
        else:
            fig = plot_slices(flat, grid["shape"], grid["lo"], grid["step"], labels=labels, title=title, metadata=meta)
    values = np.asarray(flat, dtype=np.float64)
    views = {flag: path for flag, path in extra.items() if flag in ("--html", "--ply", "--glb")}
    first = {flag: path for flag, path in extra.items() if flag not in views}
    paths = ([out] if out is not None else []) + list(first.values())
    try:
        # the map, its slices and its Reuleaux file (which can always be written) together, or none
        with atomic_paths(paths) as tmps:
            if out is not None:
                ws.save_map(tmps[0], flat, grid, settings, orientations=R)
            for flag, tmp in zip(first, tmps[len(tmps) - len(first):]):
                if flag == "--h5":
                    ws.save_reuleaux(tmp, grid, bits, R_h5)
                else:
                    fig.savefig(tmp, format="png", dpi=120, bbox_inches="tight", metadata=fig.wsmap_metadata)
    finally:
        if fig is not None:
            import matplotlib.pyplot as plt

            plt.close(fig)
    if views:
        # after the map is safe: an hour's map is not lost because a view has nothing to draw
        _write_views(views, values, grid, kind, robot, out)
        paths += list(views.values())
    if not args.quiet:
        print(f"{summary}; {method} {kind.name} map ({how}) in {seconds:.3f} s -> {', '.join(map(str, paths))}")
    return 0


def _write_views(views: dict, values, grid, kind, robot, out) -> None:
    """The 3-D views of `wsmap map` (`{flag: path}` of --html, --ply, --glb), all or none, once the
    map is written to `out`; a map with nothing to draw is a `ValueError` naming the flags."""
    from .io import atomic_paths
    from .views import save_glb, save_html, save_ply

    flags = " and ".join(views)
    kept = (f"the map was written to {out}, without the view{'s' if len(views) > 1 else ''}" if out is not None
            else "no file was written (give --out FILE.npz to keep the map)")
    if not np.any(values > 0):
        raise ValueError(f"{flags}: nothing to draw, no node of the map is reachable (its values are all 0); {kept}")
    flag = None
    try:
        with atomic_paths(list(views.values())) as tmps:
            for flag, tmp in zip(views, tmps):
                if flag == "--html":
                    # a float map gets a threshold slider; every map a cut plane through its z-layers
                    save_html(tmp, values, grid, label=kind.label, title=f"{robot.name or 'arm'}: {kind.name} map",
                              thresholds=np.linspace(0.0, 0.9, 10) * values.max() if kind.value_type is float
                              else None, cut_plane=True)
                elif flag == "--ply":
                    save_ply(tmp, values, grid, label=kind.label)
                else:
                    save_glb(tmp, values, grid, levels=kind.levels(values))
    except ValueError as e:
        raise ValueError(f"{flag} {str(views[flag])!r}: {e}; {kept}") from None


# ------------------------------------------------------------------------------------ wsmap place
def _place_parser(sub):
    m = sub.add_parser(
        "place",
        help="where to put an arm's base so that it reaches a set of target poses",
        description="Rank candidate base poses on the floor (x, y, heading) by the fraction of the target "
                    "poses they reach; every reached target has a joint solution that forward kinematics confirms.",
        epilog="Targets file (CSV, world frame, one pose per row, cells separated by commas, semicolons, tabs or "
               "spaces, a header line allowed): 6 columns x y z r1 r2 r3 "
               "(metres; radians, R = Rx(r1) Ry(r2) Rz(r3), T = transl(x, y, z) R) or 16 columns (the 4x4 "
               "matrix, row by row).",
        formatter_class=_Help,
    )
    _arm_arguments(m)
    _collision_arguments(m)
    g = m.add_argument_group("placement")
    g.add_argument("--targets", required=True, metavar="CSV", help="the target poses (see below)")
    g.add_argument("--x", type=number, nargs=2, default=[-1.0, 1.0], metavar=("LO", "HI"), help="base x range (m)")
    g.add_argument("--y", type=number, nargs=2, default=[-1.0, 1.0], metavar=("LO", "HI"), help="base y range (m)")
    g.add_argument("--z0", type=number, default=0.0, help="height of the floor the base stands on (m)")
    g.add_argument("--step", type=positive_float, default=0.1, help="base position step (m)")
    g.add_argument("--yaws", type=positive_int, default=8, help="base headings, 2 pi j / YAWS")
    g.add_argument("--method", choices=["auto", "exact", "numerical"], default="auto",
                   help="auto: the closed form where the arm has one, else the numerical search")
    g.add_argument("--top", type=positive_int, default=5, help="candidates to print")
    g.add_argument("--out", help="write the ranking (every candidate) to this CSV file")
    _quiet_argument(g, "no table")
    m.set_defaults(run=_run_place)


def _read_targets(path):
    """Target poses (M, 4, 4) from a CSV file of 6 or 16 columns (see `wsmap place --help`).

    Cells are separated by commas, semicolons, tabs or spaces; a UTF-8 byte-order mark (as Excel
    writes) is skipped; `#` lines and blank lines are comments. Only the first row may be a
    header, and only when none of its cells is a number: a row with a typo is an error naming its
    line and cell, never dropped.
    """
    import re

    from .io import read_text
    from .workspace import target_poses
    from .workspace.placement import MAX_TARGETS

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"--targets {path!r}: no such file")
    text = read_text(p, f"--targets {path}:", "give a CSV of numbers", encoding="utf-8-sig")
    rows, header_allowed = [], True
    for k, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        cells = [c for c in re.split(r"[,;\t ]+", line) if c]
        values, bad = [], []
        for c in cells:
            try:
                values.append(float(c))
            except ValueError:
                bad.append(c)
        if bad and header_allowed and len(bad) == len(cells):
            header_allowed = False  # a header line: no number in it
            continue
        header_allowed = False
        if bad:
            raise ValueError(f"--targets {path}: line {k}, cell {cells.index(bad[0]) + 1} is not a number: {bad[0]!r}")
        rows.append(values)
        if len(rows) > MAX_TARGETS:
            raise ValueError(f"--targets {path}: more than {MAX_TARGETS} poses (each target is one map over every "
                             "candidate base, 1 to 10 s on one core); split the file")
    if not rows:
        raise ValueError(f"--targets {path}: no poses in the file")
    widths = {len(r) for r in rows}
    if len(widths) != 1 or widths.pop() not in (6, 16):
        raise ValueError(f"--targets {path}: every row needs 6 values (x y z r1 r2 r3) or 16 (a 4x4 matrix); "
                         f"found rows of {sorted({len(r) for r in rows})} values")
    a = np.array(rows, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"--targets {path}: NaN or infinite values")
    if a.shape[1] == 6:
        return np.stack([target_poses(r[:3], r[3:], "standard") for r in a])
    return a.reshape(-1, 4, 4)


def _run_place(args) -> int:
    from . import workspace as ws
    from .io import atomic_path, check_outputs

    out = check_outputs({"--out": args.out}, inputs={"--targets": args.targets, "--urdf": args.urdf,
                                                     "--mjcf": args.mjcf, "--scene": args.scene}).get("--out")
    for name in ("x", "y"):
        lo, hi = getattr(args, name)
        if lo > hi:
            raise ValueError(f"--{name}: lo ({lo}) is above hi ({hi})")
    T = _read_targets(args.targets)
    robot = _robot_from_args(args)
    checker = _collision_from_args(args, robot, None)
    t0 = time.perf_counter()
    pl = ws.base_placement(robot, T, x=args.x, y=args.y, step=args.step, yaws=args.yaws, z0=args.z0,
                           method=args.method, progress=not args.quiet, collision=checker)
    seconds = time.perf_counter() - t0
    if out is not None:
        with atomic_path(out, suffix=".csv") as tmp:
            with open(tmp, "w") as f:
                f.write("rank,x_m,y_m,yaw_rad,score," + ",".join(f"target_{m}" for m in range(len(T))) + "\n")
                for r in range(len(pl.score)):
                    f.write(f"{r + 1},{pl.x[r]:.6f},{pl.y[r]:.6f},{pl.yaw[r]:.6f},{pl.score[r]:.6f},"
                            + ",".join(str(int(b)) for b in pl.reached[r]) + "\n")
    if not args.quiet:
        free = "" if checker is None else ", collision-free"
        print(f"{robot.name or 'arm'}: {len(pl.score)} candidate bases x {len(T)} targets ({pl.method}{free}) in "
              f"{seconds:.2f} s")
        print("rank  x (m)    y (m)    yaw (deg)  reached")
        for r in range(min(args.top, len(pl.score))):
            print(f"{r + 1:>4}  {pl.x[r]:+.3f}   {pl.y[r]:+.3f}   {np.degrees(pl.yaw[r]):8.1f}   "
                  f"{int(pl.reached[r].sum())}/{len(T)} ({pl.score[r]:.0%})")
        if out is not None:
            print(f"ranking -> {out}")
    return 0


# ------------------------------------------------------------------------------------ wsmap data
def _data_parser(sub):
    d = sub.add_parser("data", help="build and inspect experience datasets",
                       description="Experience datasets: features of random arms and their workspace maps.")
    dsub = d.add_subparsers(dest="data_command", required=True, metavar="{build,list,audit}", parser_class=_Parser)
    b = dsub.add_parser("build", help="build one of the catalogue's datasets (and its test set)",
                        description="Build a dataset of the catalogue (`wsmap data list`: the paper's and the "
                                    "extensions such as panda7_tooldown) and, with --test-samples, its independent "
                                    "test set beside it (NAME.test.npz). The labels are computed in this process, "
                                    "or on Dask: --workers K starts a local cluster of K single-threaded "
                                    "processes, --scheduler ADDRESS uses a running cluster (`dask scheduler` and "
                                    "`dask worker ADDRESS` on its machines). The files are byte-identical either "
                                    "way.",
                        formatter_class=_Help)
    b.add_argument("name", help="a dataset of the catalogue (see `wsmap data list`)")
    b.add_argument("--out", required=True, help="output file (.npz)")
    b.add_argument("--samples", type=positive_int, help="number of arms (the first N of the spec's streams; default the paper's)")
    b.add_argument("--test-samples", type=positive_int,
                   help="also build the independent test set of this many arms (OUT with .test.npz)")
    b.add_argument("--test", action="store_true",
                   help="build only the spec's independent test set (of --samples arms, default 1000) into --out")
    b.add_argument("--workers", type=positive_int,
                   help="compute the labels on a Dask LocalCluster of this many worker processes (one thread "
                        "each; at most 4 per core); default: in this process")
    b.add_argument("--scheduler", metavar="ADDRESS",
                   help="compute the labels on the Dask cluster of this scheduler (e.g. tcp://head:8786)")
    b.add_argument("--connect-timeout", type=positive_float, default=5.0,
                   help="seconds to wait for --scheduler to answer (at most 3600)")
    _quiet_argument(b)
    b.set_defaults(run=_run_data_build)
    ls = dsub.add_parser("list", help="list the catalogue's datasets (the paper's and the extensions)")
    ls.set_defaults(run=_run_data_list)
    a = dsub.add_parser("audit", help="exact labels against the paper's one-start numerical path")
    a.add_argument("names", nargs="*", help="datasets (default: every distinct spherical-wrist spec)")
    a.add_argument("--arms", type=positive_int, default=50)
    a.add_argument("--seed", type=non_negative_int, default=0)
    a.set_defaults(run=_run_data_audit)


def _paper_spec(name):
    from .paper.specs import paper_spec

    return paper_spec(name)


def _run_data_build(args) -> int:
    from . import datasets

    if args.test and args.test_samples is not None:
        raise ValueError("--test builds only a test set into --out; --test-samples builds one beside the "
                         "training set: give one of them")
    if args.workers is not None and args.scheduler is not None:
        raise ValueError("--workers sizes the local Dask cluster; a --scheduler's cluster has its own workers: "
                         "give one of them")
    from .paper.specs import dataset_spec

    spec = dataset_spec(args.name)
    t0 = time.perf_counter()
    written = datasets.build_dataset_files(spec, args.out, samples=args.samples, test_samples=args.test_samples,
                                           test_only=args.test, progress=not args.quiet, workers=args.workers,
                                           scheduler=args.scheduler, connect_timeout=args.connect_timeout)
    if not args.quiet:
        for path in written:
            print(f"{path} ({time.perf_counter() - t0:.1f} s)")
    return 0


def _run_data_list(args) -> int:
    from .paper.specs import DATASET_SPECS

    for name, s in DATASET_SPECS.items():
        print(f"{name:22s} {s.family:16s} {s.scope} nodes={s.n_nodes:5d} features={s.n_features:3d} "
              f"samples={s.samples} fixed={s.fixed} method={s.method}"
              + ("" if s.collision is None else " collision-free"))
    return 0


def _run_data_audit(args) -> int:
    import json

    from .datasets import audit_table
    from .paper.specs import audit_specs

    specs = [_paper_spec(n) for n in args.names] or audit_specs()
    rows = audit_table(specs, n_arms=args.arms, seed=args.seed, progress=True)
    print(json.dumps(rows, indent=1))
    return 0


# ---------------------------------------------------------------------------------- wsmap robots
def _robots_parser(sub):
    r = sub.add_parser("robots", help="list the named arms", description="The arms `--robot NAME` knows, "
                       "with their joints, limits and the document their numbers come from.")
    r.set_defaults(run=_run_robots)


def _run_robots(args) -> int:
    from . import robots

    for name in robots.ROBOTS:
        arm = robots.load(name)
        kinds = "".join(getattr(arm, "kinds", ("R",) * arm.n))
        limits = "no limits" if arm.qlim is None else "joint limits"
        print(f"{name:8s} {arm.n} joints ({kinds}), {limits}; {robots.SOURCES[name]}")
    return 0


# ----------------------------------------------------------------------------------- wsmap paper
def _paper_parser(sub):
    p = sub.add_parser("paper", help="reproduce the paper: run its notebooks (the DVC stages)",
                       description="Run the paper's notebooks with papermill. `dvc repro` runs each stage as "
                                   "`python -m wsmap.paper.notebook NAME`, the same run as `wsmap paper run NAME`; "
                                   "--all runs everything without DVC.")
    psub = p.add_subparsers(dest="paper_command", required=True, metavar="{run,list,full}", parser_class=_Parser)
    r = psub.add_parser("run", help="run notebooks (stages) by name, or all of them",
                        formatter_class=_Help)
    r.add_argument("notebooks", nargs="*", help="notebook names (without .ipynb)")
    r.add_argument("--all", action="store_true",
                   help="build the datasets the root lacks, then run every notebook in order (no DVC)")
    r.add_argument("--params", help="parameters file (default params.yaml)")
    r.add_argument("--root", help="output root (default: the project root)")
    r.add_argument("--timeout", type=non_negative_int, default=3600,
                   help="per-cell execution timeout in seconds (0: none; use 0 for params.full.yaml)")
    r.set_defaults(run=_run_paper)
    ls = psub.add_parser("list", help="list the notebooks in pipeline order")
    ls.set_defaults(run=_run_paper_list)
    f = psub.add_parser(
        "full", help="the paper's scale, part by part, resumable, into results/full/",
        description="Run the paper-scale experiments (params.full.yaml) part by part: each Table 1 row, "
                    "section 6.1, section 6.2, Table 2's Rprop + MSE cell, each Table 3 embedding. Each part "
                    "writes OUT/PART.json; a part whose file holds the same settings hash is skipped, and an "
                    "interrupted part resumes at its next step (session or block). See wsmap.paper.full.",
        epilog="Examples: wsmap paper full --list; wsmap paper full table1; wsmap paper full sec61_subspace "
               "--device cuda; wsmap paper full --estimate.",
        formatter_class=_Help)
    f.add_argument("parts", nargs="*", metavar="PART",
                   help="parts to run: names, shell patterns (table1_*) or groups (sec61, sec62, table1, table2, "
                        "table3); none: all, in order")
    f.add_argument("--list", action="store_true", help="list the parts: done/pending, steps, measured or estimated time")
    f.add_argument("--estimate", action="store_true",
                   help="time a few epochs of each part that is not done, on random data of its exact shapes, into "
                        "OUT/estimates.json (minutes; --list then uses them)")
    f.add_argument("--params", help="parameters file (default params.full.yaml)")
    f.add_argument("--out", help="result folder (default results/full)")
    f.add_argument("--data", help="dataset folder, built on demand (default data/full)")
    f.add_argument("--device", help="auto, cpu or cuda for every part (default: each section's device setting)")
    f.set_defaults(run=_run_paper_full)


def _run_paper(args) -> int:
    from . import paths
    from .paper import pipeline

    paths.require_checkout()
    if args.all and args.notebooks:
        raise ValueError("give notebook names or --all, not both")
    if not args.all and not args.notebooks:
        raise ValueError("name at least one notebook, or --all")
    params = Path(args.params) if args.params else paths.PARAMS
    names = pipeline.order() if args.all else args.notebooks
    for name in names:  # every name and section checked before anything runs
        pipeline.check_notebook(name)
        paths.notebook_params(name, params)
    if args.root:
        from .io import check_output_path

        check_output_path(Path(args.root) / "results" / "x", "--root")
    # one process, two cores: keep torch and BLAS from oversubscribing inside the kernel
    os.environ.setdefault("OMP_NUM_THREADS", "2")
    os.environ.setdefault("MPLBACKEND", "Agg")
    if args.all:
        pipeline.run_all(params, args.root, args.timeout)
    else:
        for name in args.notebooks:
            pipeline.run_notebook(name, params, args.root, args.timeout)
    return 0


def _run_paper_full(args) -> int:
    from . import paths
    from .paper import full

    paths.require_checkout("wsmap paper full")
    if args.list and args.estimate:
        raise ValueError("give --list or --estimate, not both")
    params = Path(args.params) if args.params else None
    if args.device is not None:
        from .learn.device import check_device_name

        check_device_name(args.device, "--device")
    if args.list:
        for line in full.list_lines(params, args.out, args.data, device=args.device, names=args.parts):
            print(line)
        return 0
    log = lambda line: print(line, flush=True)  # noqa: E731
    if args.estimate:
        full.estimate(args.parts, params, args.out, device=args.device, log=log)
        return 0
    full.run(args.parts, params, args.out, args.data, device=args.device, log=log)
    return 0


def _run_paper_list(args) -> int:
    from . import paths
    from .paper import pipeline

    paths.require_checkout("wsmap paper list")
    for name in pipeline.order():
        print(name)
    return 0


# ------------------------------------------------------------------------------------------ main
def _parser():
    from ._version import __version__

    p = _Parser(prog="wsmap", description="Manipulator workspace maps, classical and learned.")
    p.add_argument("--version", action="version", version=f"wsmap {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="{map,place,robots,data,paper}",
                           parser_class=_Parser)
    _map_parser(sub)
    _place_parser(sub)
    _robots_parser(sub)
    _data_parser(sub)
    _paper_parser(sub)
    return p


def _protect_negative_expressions(argv):
    # argparse takes '-pi/2' for an option; a leading space makes it a value (number() strips it)
    out = []
    for tok in argv:
        if tok.startswith("-") and not tok.startswith("--") and len(tok) > 1 and not tok[1].isalpha() or tok.startswith("-pi"):
            tok = " " + tok
        out.append(tok)
    return out


def main(argv=None) -> int:
    """Run the command line; returns the exit code (0 success, 2 bad input or failure, 130 interrupted)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(_protect_negative_expressions(argv))
    previous = signal.signal(signal.SIGTERM, _terminate) if threading.current_thread() is threading.main_thread() else None
    try:
        return args.run(args)
    except KeyboardInterrupt:
        print("wsmap: interrupted; no output was written", file=sys.stderr)
        return 130
    except NotebookError as e:  # a notebook's own error, its traceback kept in the executed copy
        print(f"wsmap: error: {e}", file=sys.stderr)
        return 2
    except (ValueError, TypeError, KeyError, MemoryError, OSError) as e:
        # bad input or an OS refusal: one line, no traceback (outputs are only put in place on success)
        msg = e.args[0] if isinstance(e, KeyError) and e.args else e
        if isinstance(e, OSError) and e.filename and str(e.filename) not in str(e):
            msg = f"{e.filename}: {e.strerror or e}"
        print(f"wsmap: error: {msg}", file=sys.stderr)
        return 2
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _terminate(signum, frame):
    # SIGTERM (dvc, a job scheduler, kill) unwinds like Ctrl-C, so temporary files are removed
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main())
