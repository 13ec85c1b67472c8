"""Time ``from_urdf`` on a URDF of one revolute joint followed by a long chain of fixed links.

The loop check of `wsmap.kinematics.urdf.URDFTree` used to walk every link to the root through
Python lists (``link in seen`` on a growing list): cubic in the chain's length, 2000 links 15 s and
4000 links 108 s, and a 5000-link file (0.8 MB) never finished. It now visits each link once. This
script times, side by side in one run, the whole ``from_urdf`` (XML checks, the loop check, yourdfpy's
transforms) and the old loop check alone (re-implemented here as it was, on the same tree, only up to
``--old-max`` links so that the run stays short).

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/kernel/bench_urdf_long_chain.py --links 1000 2000 5000 --old-max 2000
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from wsmap.kinematics.urdf import URDFError, URDFTree, from_urdf

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402


def long_chain(n: int) -> str:
    """The URDF text: link l0 -revolute-> l1 -fixed-> l2 ... -fixed-> l{n}."""
    parts = ['<?xml version="1.0"?>\n<robot name="long">'] + [f'<link name="l{i}"/>' for i in range(n + 1)]
    parts.append('<joint name="j0" type="revolute"><parent link="l0"/><child link="l1"/><axis xyz="0 0 1"/>'
                 '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
    parts += [f'<joint name="j{i}" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/>'
              '<origin xyz="0 0 0.0001"/></joint>' for i in range(1, n)]
    return "".join(parts) + "</robot>"


def old_loop_check(tree: URDFTree) -> None:
    """The check as it was before issue 29: every link walked to the root, ``seen`` a list."""
    for start in tree.links:
        seen, link = [start], start
        while link in tree.parent_joint:
            link = tree.parent(link)
            if link in seen:
                raise URDFError("loop")
            seen.append(link)


def main(argv=None) -> None:
    ap = harness.parser(__doc__)
    ap.add_argument("--links", type=int, nargs="+", default=[1000, 2000, 5000])
    ap.add_argument("--old-max", type=int, default=2000, help="time the old check only up to this many links")
    args = ap.parse_args(argv)
    rows = []
    print("| links | MB | from_urdf now (s) | old loop check alone (s) |")
    print("|---:|---:|---:|---:|")
    for n in args.links:
        text = long_chain(n)
        now, arm = harness.timed(lambda: from_urdf(text))  # noqa: B023 - called at once
        assert arm.n == 1 and arm.links[-1] == f"l{n}"
        old = None
        if n <= args.old_max:
            tree = URDFTree(ET.fromstring(text.encode()), "URDF text")
            old, _ = harness.timed(lambda: old_loop_check(tree))  # noqa: B023 - called at once
        print(f"| {n} | {len(text) / 1e6:.2f} | {now:.2f} | {'-' if old is None else f'{old:.2f}'} |")
        rows.append({"links": n, "megabytes": len(text) / 1e6, "from_urdf_seconds": now, "old_check_seconds": old})
    harness.write_json(args, {"rows": rows})


if __name__ == "__main__":
    main()
