"""`wsmap place`: its options, parsed into a `wsmap.jobs.PlacementJob`."""

from __future__ import annotations

import numpy as np

from ..jobs import PlacementJob
from ..workspace.placement import RANKING
from ..workspace.targets import TARGET_CSV_HELP
from .arguments import (HelpFormatter, arm_arguments, arm_source, collision_arguments, collision_source, number,
                        positive_float, positive_int, quiet_argument)

def add_parser(sub):
    m = sub.add_parser(
        "place",
        help="where to put an arm's base so that it reaches a set of target poses",
        description="Rank candidate base poses on the floor (x, y, heading) by the fraction of the target "
                    "poses they reach; every reached target has a joint solution that forward kinematics confirms. "
                    f"Ranking: {RANKING}.",
        epilog=TARGET_CSV_HELP,
        formatter_class=HelpFormatter,
    )
    arm_arguments(m)
    collision_arguments(m)
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
    quiet_argument(g, "no table")
    m.set_defaults(run=run)


def _plain(value: float, digits: int) -> float:
    """`value` rounded as printed, with -0.0 made 0.0 (so `-0.0004` prints `+0.000`, not `-0.000`)."""
    return round(float(value), digits) + 0.0


def run(args) -> int:
    """`wsmap place`: the options parsed into a `wsmap.jobs.PlacementJob`, checked, run and saved."""
    job = PlacementJob(targets=args.targets, arm=arm_source(args), collision=collision_source(args), x=args.x, y=args.y,
                       z0=args.z0, step=args.step, yaws=args.yaws, method=args.method, out=args.out,
                       progress=not args.quiet)
    result = job.run(job.check())
    paths = job.save(result)
    if not args.quiet:
        pl, robot, M = result.placement, result.plan.robot, len(result.plan.targets)
        free = "" if result.plan.checker is None else ", collision-free"
        print(f"{robot.name or 'arm'}: {len(pl.score)} candidate bases x {M} targets ({pl.method}{free}) in "
              f"{result.seconds:.2f} s")
        print("rank  x (m)    y (m)    yaw (deg)  reached        mean manip.  margin")
        for r in range(min(args.top, len(pl.score))):
            x, y, yaw = (_plain(v, d) for v, d in ((pl.x[r], 3), (pl.y[r], 3), (np.degrees(pl.yaw[r]), 1)))
            reached = f"{int(pl.reached[r].sum())}/{M} ({pl.score[r]:.0%})"
            print(f"{r + 1:>4}  {x:+.3f}   {y:+.3f}   {yaw:8.1f}   {reached:<13}  {pl.manipulability[r]:<11.4g}  {pl.joint_margin[r]:.3f}")
        print(f"ranking: {RANKING}")
        if paths:
            print(f"ranking -> {paths[0]}")
    return 0


