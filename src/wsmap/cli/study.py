"""`wsmap study`: a reach study from its file (`wsmap.jobs.StudyJob`), and `wsmap study compare`."""

from __future__ import annotations

import json
import time

from ..jobs.study import StudyJob
from ..workspace.study_files import compare_studies, load_study
from .arguments import HelpFormatter, quiet_argument


def add_parser(sub):
    s = sub.add_parser("study", help="a reach study: which targets of a workpiece an arm reaches, from where",
                       description="Run the reach study of FILE (YAML or JSON: the arm or arms, the TCP, the targets, "
                                   "the tool's orientation freedom, the scores, the base or base region, the outputs; "
                                   "docs/study.md), or compare two study files.",
                       epilog="Examples: wsmap study cell.yaml; wsmap study compare before.npz after.npz",
                       formatter_class=HelpFormatter)
    s.add_argument("file", metavar="FILE", help="the study file, or the word compare")
    s.add_argument("others", nargs="*", metavar="STUDY.npz", help="compare: the two study files")
    quiet_argument(s, "no table")
    s.set_defaults(run=run)


def run(args) -> int:
    if args.file == "compare":
        if len(args.others) != 2:
            raise ValueError("wsmap study compare takes two study files: A.npz B.npz")
        diff = compare_studies(load_study(args.others[0]), load_study(args.others[1]))
        print(json.dumps(diff, indent=1))
        return 0
    if args.others:
        raise ValueError(f"wsmap study takes one study file, got {1 + len(args.others)} arguments")
    job = StudyJob.from_file(args.file)
    plan = job.check()
    t0 = time.perf_counter()
    result = job.run(plan, progress=not args.quiet)
    seconds = time.perf_counter() - t0
    paths = job.save(result, plan)
    if not args.quiet:
        print(f"{len(plan.targets.poses)} targets, {len(result.variants)} orientation variants each, "
              f"{len(plan.robots)} arm(s), in {seconds:.2f} s")
        print("arm            coverage  mean score  reached  certified  not found  base (x, y, z) m")
        for row in result.summary():
            x, y, z = row["base_xyz"]
            print(f"{row['arm'][:14]:14s} {row['coverage']:8.1%}  {row['mean_score']:10.4g}  "
                  f"{row['reached']:7d}  {row['certified unreachable']:9d}  {row['not found']:9d}  "
                  f"({x:+.3f}, {y:+.3f}, {z:+.3f})")
        for p in paths:
            print(f"study -> {p}")
    return 0
