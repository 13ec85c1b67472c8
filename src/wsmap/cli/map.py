"""`wsmap map`: its options, parsed into a `wsmap.jobs.MapJob`."""

from __future__ import annotations

from .._optional import require
from ..jobs import MapJob, MapOutputs
from .arguments import (HelpFormatter, arm_arguments, arm_source, collision_arguments, collision_source, non_negative_int,
                        notice, number, positive_int, quiet_argument, seed_int, tolerance)

def add_parser(sub):
    from ..workspace.kinds import default_kind, kind_names, kinds, kinds_taking

    m = sub.add_parser(
        "map",
        help="compute the workspace map of an arm on a grid",
        description="Compute a workspace map of an arm (one value per grid node: a bit or a number, as --kind "
                    "says) and write it: a .npz map file, pictures and views, a Reuleaux .h5 for ROS.",
        epilog="Node order: x fastest, then y, then z (flat index i + nx*j + nx*ny*k). All outputs are put in "
               "place together, once each was written: an error leaves every file as it was. A map with no "
               "reachable node is written (--out, --png, --h5), but its 3-D views (--html, --ply, --glb) would draw "
               "nothing: they are skipped with a warning on stderr (even with --quiet), exit code 0.",
        formatter_class=HelpFormatter,
    )
    arm_arguments(m)
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
    g.add_argument("--status-budget", type=non_negative_int, metavar="BOXES",
                   help="each node's answer (reached, certified unreachable, not found): boxes per pose of the "
                        "certificate's branch and bound (0: the sound filters and the closed form's certificate "
                        "only; default: 5000 for maps at one orientation, 0 for maps over --orientations, whose "
                        "N x K poses would take minutes)")
    collision_arguments(m)
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
    quiet_argument(g)
    m.set_defaults(run=run)


def run(args) -> int:
    """`wsmap map`: the options parsed into a `wsmap.jobs.MapJob`, checked, run and saved."""
    if args.method == "model" and args.model:
        require("torch", why="--method model")
        from ..learn import predictor  # noqa: F401 -- registers the "model" map method
    job = MapJob(arm=arm_source(args), kind=args.kind, scope=args.scope, lo=args.lo, hi=args.hi, step=args.step,
                 rpy=args.rpy, point=args.point, orientations=args.orientations, convention=args.convention,
                 method=args.method, starts=args.starts, retry=args.retry, seed=args.seed, paper_lm=args.paper_lm,
                 tol=args.tol, ilimit=args.ilimit, rlimit=args.rlimit, model=args.model,
                 allow_extrapolation=args.allow_extrapolation, collision=collision_source(args),
                 outputs=MapOutputs(out=args.out, png=args.png, html=args.html, ply=args.ply, glb=args.glb,
                                    h5=args.h5), progress=not args.quiet, status_budget=args.status_budget)
    result = job.run(job.check(), notify=notice)  # a first run says why it is silent, only if it compiles
    paths = job.save(result, warn=lambda line: notice(f"warning: {line}"))  # shown even with --quiet
    if not args.quiet:
        print(f"{result.summary}; {result.plan.method} {result.plan.kind.name} map ({result.settings['how']}) in "
              f"{result.seconds:.3f} s -> {', '.join(map(str, paths)) or 'nothing written'}")
        print(status_lines(result))
    return 0


def status_lines(result) -> str:
    """The three answers of a computed `wsmap.jobs.MapResult` as `wsmap map` prints them: the
    nodes' counts (`nodes: N reached, M certified unreachable, K not found`), for a map over a set
    of orientations the same over every node and orientation (`poses: ...`), or why there are none."""
    if result.counts is None:
        return "nodes: no status (a network's prediction: no search and no certificate)"
    lines = ["nodes: " + ", ".join(f"{count} {name}" for name, count in result.counts.items())
             + f" (certificates in {result.status_seconds:.3f} s)"]
    if result.pose_counts is not None:
        lines.append("poses (node x orientation): " + ", ".join(f"{count} {name}"
                                                               for name, count in result.pose_counts.items()))
    return "\n".join(lines)


