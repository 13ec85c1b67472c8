"""The command line's shared argument types and option groups, and the jobs' sources built from them."""

from __future__ import annotations

import argparse
import ast
import math
import operator
import sys

from ..collision.sources import CollisionSource
from ..robots.sources import ArmSource

__all__ = ["number", "int_at_least", "positive_int", "non_negative_int", "seed_int", "tolerance", "positive_float",
           "Parser", "HelpFormatter", "quiet_argument", "arm_arguments", "collision_arguments", "arm_source",
           "collision_source", "notice"]

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


def int_at_least(minimum: int):
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


positive_int = int_at_least(1)
non_negative_int = int_at_least(0)


def seed_int(text: str) -> int:
    """An argparse type: a seed of numpy's generators, an integer in [0, 2**64)."""
    value = non_negative_int(text)
    if value >= 2**64:
        raise argparse.ArgumentTypeError(f"must be below 2**64 = {2**64} (numpy's seed range), got {value}")
    return value


def tolerance(text: str) -> float:
    """An argparse type: an IK tolerance (m and rad), at least `wsmap.kinematics.MIN_TOL`."""
    from ..kinematics.ik.solution import MIN_TOL

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


class Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (naming the problem and where help is), exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help lines with `(default: X)` only where X says something: not for `None` (the help line
    says what happens then), not for a flag's `False`, not where the line already names a default."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or action.default is False or "default" in text:
            return text
        return super()._get_help_string(action)


def quiet_argument(p, what="no progress bar or summary"):
    p.add_argument("-q", "--quiet", action="store_true", help=what)


def arm_arguments(m):
    """The arm options shared by `wsmap map` and `wsmap place`."""
    g = m.add_argument_group("arm")
    g.add_argument("--robot", help="a named arm (`wsmap robots` lists them; default puma560 when no other arm is given)")
    g.add_argument("--urdf", metavar="FILE", help="the arm as a URDF file (meshes are never read)")
    g.add_argument("--mjcf", metavar="FILE", help="the arm as an MJCF (MuJoCo) file, to the site or body --ee")
    g.add_argument("--ee", metavar="LINK", help="--urdf: the end link (default: the chain's only leaf); "
                                               "--mjcf: the tool's site or body (required)")
    g.add_argument("--base", metavar="LINK", help="--urdf: the first link of the chain (default: the URDF's root)")
    g.add_argument("--srdf", metavar="FILE",
                   help="--urdf: MoveIt's SRDF of the arm: its planning group's chain and end effector pick --base and "
                        "--ee when they are not given; with --collision its <disable_collisions> pairs are never checked")
    g.add_argument("--d", type=number, nargs="+", help="DH link offsets d_1..d_n in metres")
    g.add_argument("--a", type=number, nargs="+", help="DH link lengths a_1..a_n in metres")
    g.add_argument("--alpha", type=number, nargs="+", help="DH twists alpha_1..alpha_n in radians (pi expressions allowed)")
    g.add_argument("--mdh", action="store_true", help="the DH columns are modified DH (Craig), as Franka and Kinova publish them")
    g.add_argument("--offset", type=number, nargs="+", help="DH joint offsets theta_i in radians (the manufacturer's zero)")
    g.add_argument("--joint-limits", action=argparse.BooleanOptionalAction, default=None,
                   help="honour the arm's joint limits (default: on for real arms and URDFs, off for puma560 as in the paper)")
    g.add_argument("--qlim-deg", type=number, nargs="+", metavar="DEG",
                   help="joint limits in degrees: lo_1 hi_1 lo_2 hi_2 ... (overrides --joint-limits)")


def collision_arguments(m):
    g = m.add_argument_group("collision (docs/collision.md)")
    g.add_argument("--collision", action="store_true",
                   help="count a node only with a collision-free solution: self-collision from the arm's own geometry "
                        "(--urdf: its <collision> elements; --robot: its capsule model; DH columns: --link-radius), "
                        "and the floor for a named arm (--floor, --no-floor)")
    g.add_argument("--scene", metavar="FILE", help="obstacles (YAML or JSON: floor, boxes, cylinders, spheres, "
                                                  "meshes; or a work cell's URDF, FILE.urdf: its fixed links' "
                                                  "<collision> elements); implies --collision")
    g.add_argument("--mount", metavar="LINK", help="--scene CELL.urdf: the cell's link the arm's base is attached to "
                                                   "(obstacles in the base frame); default: the cell's root is the "
                                                   "world frame")
    g.add_argument("--link-radius", type=positive_float, nargs="+", metavar="R",
                   help="capsules of these radii (m; one, or one per body 0..n) along the links; implies --collision")
    fl = g.add_mutually_exclusive_group()
    fl.add_argument("--floor", type=number, metavar="Z",
                    help="a floor at height Z (m, world frame), replacing the scene file's (default: z = 0 for a named "
                         "arm, none for --urdf/--mjcf/DH arms unless the scene file gives one)")
    fl.add_argument("--no-floor", action="store_true", help="no floor, not even a named arm's or the scene file's")
    g.add_argument("--allow", nargs=2, action="append", metavar=("LINK", "LINK"),
                   help="never check this link pair (repeatable), besides the allowed-collision matrix's")
    g.add_argument("--acm-samples", type=non_negative_int, default=None, metavar="N",
                   help="random configurations of the matrix's 'never in collision' test (10000 when not given)")


def _srdf_ends(args) -> tuple[str | None, str | None]:
    """`(ee, base)`: the options, or where they are not given the chain of the `--srdf` file
    (checked against `--urdf`'s links before any work)."""
    srdf = getattr(args, "srdf", None)
    if srdf is None:
        return args.ee, args.base
    if args.urdf is None:
        raise ValueError("--srdf goes with --urdf (MoveIt's semantic description of that URDF arm)")
    from ..collision.srdf import load_srdf

    description = load_srdf(srdf, urdf=args.urdf)
    if args.ee is not None and args.base is not None:
        return args.ee, args.base
    base, ee = description.ends()
    return (args.ee if args.ee is not None else ee), (args.base if args.base is not None else base)


def arm_source(args) -> ArmSource:
    ee, base = _srdf_ends(args)
    return ArmSource(robot=args.robot, urdf=args.urdf, mjcf=args.mjcf, ee=ee, base=base, d=args.d, a=args.a,
                     alpha=args.alpha, offset=args.offset, modified=args.mdh, joint_limits=args.joint_limits,
                     qlim_deg=args.qlim_deg)


def collision_source(args) -> CollisionSource:
    return CollisionSource(collision=args.collision, scene=args.scene, mount=args.mount, link_radius=args.link_radius,
                           allow=args.allow, acm_samples=args.acm_samples, seed=getattr(args, "seed", 0),
                           srdf=getattr(args, "srdf", None), floor=False if args.no_floor else args.floor)


def notice(line: str) -> None:
    print(f"wsmap: {line}", file=sys.stderr, flush=True)


