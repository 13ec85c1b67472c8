"""Command line: ``wsmap map ...`` (also ``python -m wsmap map ...``).

Example: the PUMA560's constant-orientation map on the paper's 21³ grid, with a picture::

    wsmap map --robot puma560 --step 0.1 --out puma560.npz --png puma560_slices.png

Your own arm, by its DH columns (angles accept ``pi`` expressions)::

    wsmap map --d 0 0 0.15 0.43 0 0 --a 0 0.43 0.02 0 0 0 \\
              --alpha pi/2 0 -pi/2 pi/2 -pi/2 0 --method numerical --out mine.npz

A trained network instead of inverse kinematics (a model file saved with a ``map_spec`` that covers
the whole grid asked for, e.g. the 7 block models of section 6.2 assembled)::

    wsmap map --robot puma560 --method model --model puma_blocks.pt --out puma560_model.npz
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import operator
import sys
import time

import numpy as np

__all__ = ["main", "compute_map", "save_map", "load_map"]

_OPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
        ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Pow: operator.pow}


def number(text: str) -> float:
    """A float, or an arithmetic expression in ``pi`` (``pi/2``, ``-3*pi/4``, ``2*pi``)."""

    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return math.pi
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](ev(node.operand))
        raise ValueError
    try:
        value = ev(ast.parse(text.strip(), mode="eval"))
    except (ValueError, SyntaxError, ZeroDivisionError, TypeError):
        raise argparse.ArgumentTypeError(f"not a number or pi expression: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def _robot_from_args(args):
    from . import robots
    from .kinematics import DHRobot

    dh = [args.d, args.a, args.alpha]
    if any(x is not None for x in dh):
        if args.robot is not None:
            raise ValueError("give either --robot or the DH columns --d/--a/--alpha, not both")
        if any(x is None for x in dh):
            raise ValueError("the DH columns need all three of --d, --a and --alpha")
        qlim = None
        if args.qlim_deg is not None:
            q = np.asarray(args.qlim_deg, dtype=float)
            if q.size != 2 * len(args.d):
                raise ValueError(f"--qlim-deg needs 2 values per joint ({2 * len(args.d)}), got {q.size}")
            qlim = np.deg2rad(q.reshape(-1, 2))
        return DHRobot(args.d, args.a, args.alpha, qlim=qlim, name="custom")
    robot = robots.from_name(args.robot or "puma560", joint_limits=args.joint_limits)
    if args.qlim_deg is not None:
        q = np.asarray(args.qlim_deg, dtype=float)
        if q.size != 2 * robot.n:
            raise ValueError(f"--qlim-deg needs 2 values per joint ({2 * robot.n}), got {q.size}")
        robot = DHRobot(robot.d, robot.a, robot.alpha, qlim=np.deg2rad(q.reshape(-1, 2)), name=robot.name)
    return robot


def compute_map(robot, *, scope="R3", lo=None, hi=None, step=None, rpy=(0.0, 0.0, 0.0), point=(0.5, 0.5, 0.5),
                method="exact", convention="paper", model=None, ik=None, progress=False):
    """One call from an arm to its map. Returns ``(map, grid)``.

    ``map`` is bool ``(N,)`` in node order; ``grid`` a dict with ``lo``, ``hi``, ``step``, ``shape``
    (nx, ny, nz) and ``scope``. Defaults are the paper's: R3 on [-1, 1] m at 0.1 m, SO3 on
    [0, 2·pi] at pi/10. ``method="model"`` needs ``model``, a path to a model file saved with a
    ``map_spec`` (:func:`wsmap.models.predict_maps_from_file`) whose grid, pose convention and fixed
    orientation (R3) or point (SO3) are the ones asked for and which covers every node of the grid
    (e.g. the 7 block models assembled); otherwise ``ValueError`` says what differs.
    """
    from . import workspace as ws

    if scope not in ("R3", "SO3"):
        raise ValueError(f"unknown scope {scope!r}; choose one of R3, SO3")
    if scope == "R3":
        lo, hi, step = (-1.0 if lo is None else lo), (1.0 if hi is None else hi), (0.1 if step is None else step)
    else:
        lo, hi, step = (0.0 if lo is None else lo), (2 * math.pi if hi is None else hi), (math.pi / 10 if step is None else step)
    axes = ws.grid_axes(lo, hi, step)
    shape = tuple(len(a) for a in axes)
    nodes = ws.cartesian_grid(lo, hi, step)
    grid = {"scope": scope, "lo": np.broadcast_to(lo, 3).tolist(), "hi": np.broadcast_to(hi, 3).tolist(),
            "step": np.broadcast_to(step, 3).tolist(), "shape": list(shape)}
    if method == "model":
        if model is None:
            raise ValueError("method 'model' needs a model file (--model PATH)")
        from .models import predict_maps_from_file

        fixed = rpy if scope == "R3" else point
        flat = predict_maps_from_file(model, robot, fixed, grid=grid, convention=convention, whole_grid=True)
        if flat.shape != (len(nodes),):  # a model file disagreeing with its own spec
            raise ValueError(f"model {model} gave a map of shape {flat.shape}, the grid has {len(nodes)} nodes")
        return flat, grid
    ik = dict(ik or {})
    bar = None
    if progress and method == "numerical":
        from tqdm.auto import tqdm

        bar = tqdm(total=len(nodes), unit="node", desc="numerical IK", file=sys.stderr)
        ik.setdefault("chunk", 2048)
        ik["progress"] = bar.update
    try:
        if scope == "R3":
            m = ws.constant_orientation_map(robot, nodes, rpy, method=method, convention=convention, ik=ik)
        else:
            m = ws.orientation_map(robot, nodes, point, method=method, convention=convention, ik=ik)
    finally:
        if bar is not None:
            bar.close()
    return m, grid


def save_map(path, flat_map, grid, settings) -> None:
    """Write a map as ``.npz`` (``map`` bool, ``nodes`` float64, ``grid`` and ``settings`` as JSON), atomically."""
    from .io import atomic_path
    from .workspace import cartesian_grid

    nodes = cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    with atomic_path(path, suffix=".npz") as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, map=np.asarray(flat_map, dtype=bool), nodes=nodes,
                                grid=json.dumps(grid), settings=json.dumps(settings))


def load_map(path):
    """Read a map written by :func:`save_map`: ``(map, nodes, grid, settings)``."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return z["map"], z["nodes"], json.loads(str(z["grid"])), json.loads(str(z["settings"]))
    except FileNotFoundError:
        raise
    except Exception as e:
        raise ValueError(f"{path} is not a readable wsmap map file ({e})") from None


def _parser():
    p = argparse.ArgumentParser(prog="wsmap", description="Manipulator workspace maps, classical and learned.")
    sub = p.add_subparsers(dest="command", required=True)
    m = sub.add_parser(
        "map",
        help="compute the workspace map of an arm on a grid",
        description="Compute a binary workspace map (one bit per grid node) and write it as .npz.",
        epilog="Node order: x fastest, then y, then z (flat index i + nx*j + nx*ny*k).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    g = m.add_argument_group("arm")
    g.add_argument("--robot", help="a named arm: puma560 (default when no DH columns are given)")
    g.add_argument("--d", type=number, nargs="+", help="DH link offsets d_1..d_n in metres")
    g.add_argument("--a", type=number, nargs="+", help="DH link lengths a_1..a_n in metres")
    g.add_argument("--alpha", type=number, nargs="+", help="DH twists alpha_1..alpha_n in radians (pi expressions allowed)")
    g.add_argument("--joint-limits", action="store_true", help="use the named arm's joint limits (the paper ignores them)")
    g.add_argument("--qlim-deg", type=number, nargs="+", metavar="DEG",
                   help="joint limits in degrees: lo_1 hi_1 lo_2 hi_2 ... (overrides --joint-limits)")
    g = m.add_argument_group("scope")
    g.add_argument("--scope", choices=["R3", "SO3"], default="R3",
                   help="R3: positions at a fixed orientation; SO3: orientations at a fixed point")
    g.add_argument("--lo", type=number, nargs="+", help="grid start, one value or three (default -1 m for R3, 0 rad for SO3)")
    g.add_argument("--hi", type=number, nargs="+", help="grid end, inclusive (default 1 m for R3, 2*pi for SO3)")
    g.add_argument("--step", type=number, nargs="+", help="grid step (default 0.1 m for R3, pi/10 for SO3)")
    g.add_argument("--rpy", type=number, nargs=3, default=[0.0, 0.0, 0.0], metavar=("R1", "R2", "R3"),
                   help="R3 scope: fixed orientation, R = Rx(r1) Ry(r2) Rz(r3), radians")
    g.add_argument("--point", type=number, nargs=3, default=[0.5, 0.5, 0.5], metavar=("X", "Y", "Z"),
                   help="SO3 scope: fixed point in metres")
    g = m.add_argument_group("method")
    g.add_argument("--method", choices=["exact", "numerical", "model"], default="exact",
                   help="exact: closed form (spherical-wrist arms); numerical: batched Levenberg-Marquardt (any arm); "
                        "model: a trained network (--model)")
    g.add_argument("--convention", choices=["paper", "standard"], default="paper",
                   help="paper: T = R·transl(p), tests R·p (the authors' code); standard: T = transl(p)·R")
    g.add_argument("--model", help="trained model file for --method model")
    g.add_argument("--tol", type=float, default=1e-10, help="numerical IK tolerance on the pose error norm")
    g.add_argument("--ilimit", type=int, default=500, help="numerical IK iteration limit")
    g.add_argument("--rlimit", type=int, default=100, help="numerical IK limit on consecutive rejected steps")
    g = m.add_argument_group("output")
    g.add_argument("--out", required=True, help="output .npz file (map, nodes, grid, settings)")
    g.add_argument("--png", help="also draw the map's z-slices to this PNG")
    g.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    return p


def _arg3(values):
    if values is None:
        return None
    if len(values) not in (1, 3):
        raise ValueError(f"grid bounds and steps take one value or three, got {len(values)}")
    return values[0] if len(values) == 1 else tuple(values)


def _protect_negative_expressions(argv):
    # argparse takes '-pi/2' for an option; a leading space makes it a value (number() strips it)
    out = []
    for tok in argv:
        if tok.startswith("-") and not tok.startswith("--") and len(tok) > 1 and not tok[1].isalpha() or tok.startswith("-pi"):
            tok = " " + tok
        out.append(tok)
    return out


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = _parser().parse_args(_protect_negative_expressions(argv))
    try:
        robot = _robot_from_args(args)
        t0 = time.perf_counter()
        flat, grid = compute_map(
            robot, scope=args.scope, lo=_arg3(args.lo), hi=_arg3(args.hi), step=_arg3(args.step), rpy=args.rpy,
            point=args.point, method=args.method, convention=args.convention, model=args.model,
            ik=dict(tol=args.tol, ilimit=args.ilimit, rlimit=args.rlimit), progress=not args.quiet,
        )
        seconds = time.perf_counter() - t0
        settings = {
            "robot": robot.name, "d": robot.d.tolist(), "a": robot.a.tolist(), "alpha": robot.alpha.tolist(),
            "qlim": None if robot.qlim is None else robot.qlim.tolist(), "method": args.method,
            "convention": args.convention, "rpy": list(args.rpy), "point": list(args.point), "model": args.model,
            "ik": dict(tol=args.tol, ilimit=args.ilimit, rlimit=args.rlimit), "seconds": seconds,
        }
        save_map(args.out, flat, grid, settings)
        if args.png:
            from .render import plot_slices, save_figure

            labels = ("x", "y", "z") if args.scope == "R3" else ("r1", "r2", "r3")
            fig = plot_slices(flat, grid["shape"], grid["lo"], grid["step"], labels=labels,
                              title=f"{robot.name or 'arm'}: {int(flat.sum())} of {flat.size} nodes reachable ({args.method})")
            save_figure(fig, args.png)
    except (ValueError, MemoryError, FileNotFoundError) as e:
        print(f"wsmap: error: {e}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(f"{int(flat.sum())} of {flat.size} nodes reachable ({flat.mean():.1%}); "
              f"{args.method} map in {seconds:.3f} s -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
