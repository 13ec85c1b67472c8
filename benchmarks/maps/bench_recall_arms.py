"""Recall of the default numerical map on real arms that no default was tuned on, judged independently.

The arms are built from the URDFs shipped with PyBullet's data package (``pybullet_data``) and
Robotics Toolbox's ``rtbdata`` (xacro sources expanded in-process with the ``xacro`` package, its
``$(find pkg)`` pointed at ``rtbdata``'s folders; no network): see `ARMS`. Per arm and
orientation (tool frame ``R = I`` and tool down ``R = Rx(pi)``, pose convention ``standard``: the
node is the tool position), on a cube grid around the arm's first joint (half-width the sum of its
link lengths, ``--nodes`` per axis):

* **the map**: `wsmap.kinematics.ik.search.map_search` with `MAP_SETTINGS`, exactly
  what ``grid_map(..., method="numerical")`` runs; timed, and timed again without the border
  search (``border_starts=0``, the map before issue 29) for the side-by-side cost;
* **its positives** are confirmed by an independent forward kinematics, Pinocchio's (``pin``,
  built from the same URDF text, the joints outside the chain locked), and inside the URDF's
  limits: a positive that fails is a false positive;
* **the reference**: at every node the map left unsolved, a per-node search of ``--ref-starts``
  (default 128) starts (`ikine_search`, a different seed from the map's), each success again
  confirmed by Pinocchio. Reachable = confirmed map positives ∪ confirmed reference successes;
  recall = map positives / reachable.

Prints a Markdown table (per arm and orientation: reachable, recall, misses, false positives,
seconds with and without the border search) and the worst arm; ``--json PATH`` writes it all.

    # quick (5 arms, 11³ nodes, a couple of minutes single-threaded)
    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 nice -n 10 .venv/bin/python benchmarks/maps/bench_recall_arms.py --quick
    # full (every arm of ARMS, 15³ nodes: about 8 minutes; --nodes 21 for the paper's density, about 20)
    NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1 nice -n 10 .venv/bin/python benchmarks/maps/bench_recall_arms.py
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

from wsmap import workspace as ws
from wsmap.kinematics.ik.search import MAP_SETTINGS, ikine_search, map_search
from wsmap.kinematics.urdf import from_urdf

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the harness
import harness  # noqa: E402

#: (name, source, base_link, ee_link): ``pb:`` paths are in ``pybullet_data``, the others in
#: ``rtbdata/xacro``; ``None`` links: the URDF's root, its only leaf.
ARMS = [
    ("xArm6", "pb:xarm/xarm6_robot.urdf", None, None),
    ("KUKA iiwa 7", "pb:kuka_iiwa/model.urdf", None, None),
    ("Panda (PyBullet)", "pb:franka_panda/panda.urdf", None, "panda_grasptarget"),
    # (rtbdata's irb140.urdf is another arm, 1.49 m forearm and a 2 cm wrist offset; its xacro is the IRB 140)
    ("ABB IRB 140", "abb_irb140/urdf/irb140.xacro", "base_link", "tool0"),
    ("KUKA KR 16-2", "kuka_description/kuka_kr16/urdf/kr16_2.urdf", "base_link", "tool0"),
    ("KUKA KR 120", "kuka_description/kuka_kr120/urdf/kr120r2500pro.urdf", "base_link", "tool0"),
    ("KUKA KR 210", "kuka_description/kuka_kr210/urdf/kr210l150.urdf", "base_link", "tool0"),
    ("Kinova Gen3 6-DOF", "kortex_description/arms/gen3/6dof/urdf/GEN3-6DOF_NO-VISION_URDF_ARM_V01.urdf", None,
     None),
    ("Kinova Gen3 lite", "kortex_description/arms/gen3_lite/6dof/urdf/GEN3-LITE.urdf", None, None),
    ("YuMi right arm", "yumi_description/urdf/yumi.urdf", "yumi_body", "yumi_link_7_r"),
    ("Fetch arm", "fetch_description/robots/fetch.urdf", "torso_lift_link", "gripper_link"),
    ("UR10 (CB3)", "ur_description/urdf/ur10_robot.urdf.xacro", "base_link", "tool0"),
    ("UR3 (CB3)", "ur_description/urdf/ur3_robot.urdf.xacro", "base_link", "tool0"),
    ("Jaco2 6-DOF", "kinova_description/urdf/j2n6s300_standalone.xacro", "root", "j2n6s300_end_effector"),
    ("Jaco2 7-DOF", "kinova_description/urdf/j2s7s300_standalone.xacro", "root", "j2s7s300_end_effector"),
    ("Mico", "kinova_description/urdf/m1n6s300_standalone.xacro", "root", "m1n6s300_end_effector"),
]
#: ROS package names whose folder in rtbdata is named otherwise
PACKAGES = {"abb_irb140_support": "abb_irb140"}
QUICK = ["YuMi right arm", "Panda (PyBullet)", "KUKA iiwa 7", "ABB IRB 140", "Jaco2 7-DOF"]
ORIENTATIONS = {"R=I": (0.0, 0.0, 0.0), "tool down": (math.pi, 0.0, 0.0)}


def _dirs():
    import pybullet_data
    import rtbdata

    return pybullet_data.getDataPath(), os.path.join(os.path.dirname(rtbdata.__file__), "xacro")


def urdf_text(source: str) -> str:
    """The plain URDF text of ``source`` (see `ARMS`); a xacro file is expanded in-process."""
    pb, rx = _dirs()
    path = os.path.join(pb, source[3:]) if source.startswith("pb:") else os.path.join(rx, source)
    if not path.endswith(".xacro"):
        with open(path) as f:
            return f.read()
    import xacro
    import xacro.substitution_args as sa

    # $(find pkg): the package folders of rtbdata (no ROS installation, no network)
    sa._eval_find = lambda pkg: os.path.join(rx, PACKAGES.get(pkg, pkg))
    return xacro.process_file(path).toxml()


class PinFK:
    """Pinocchio's forward kinematics of the chain ``base_link → ee_link`` of a URDF text: every
    joint outside the chain locked at 0; ``q`` in the chain's joint order (the URDF's values)."""

    def __init__(self, text: str, chain, base_link, ee_link):
        import pinocchio as pin

        self.pin = pin
        full = pin.buildModelFromXML(text)
        links = list(chain.links)
        ee = ee_link or links[-1]
        keep = []
        body = pin.FrameType.BODY  # a link may share its name with a joint (Gen3 lite's END_EFFECTOR)
        for link in links[:-1]:
            keep.append(full.frames[full.getFrameId(link, body)].parentJoint)
        lock = [j for j in range(1, full.njoints) if j not in keep]
        # (nothing to lock: the full model; buildReducedModel trips over Gen3 lite's shared frame names)
        self.model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        self.data = self.model.createData()
        names = [full.names[j] for j in keep]
        self.joints = [self.model.getJointId(nm) for nm in names]
        self.ee = self.model.getFrameId(ee, body)
        root = base_link or full.frames[1].name
        self.base = self.model.getFrameId(root, body) if base_link else self.model.getFrameId(root)

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """Tool poses (..., 4, 4) in the base link's frame for ``q`` (..., n)."""
        pin = self.pin
        q = np.asarray(q, dtype=np.float64)
        out = np.empty(q.shape[:-1] + (4, 4))
        flat_q, flat_out = q.reshape(-1, q.shape[-1]), out.reshape(-1, 4, 4)
        for i, qi in enumerate(flat_q):
            x = pin.neutral(self.model)
            for k, j in enumerate(self.joints):
                jm = self.model.joints[j]
                if jm.nq == 2:  # continuous joint: (cos, sin)
                    x[jm.idx_q], x[jm.idx_q + 1] = math.cos(qi[k]), math.sin(qi[k])
                else:
                    x[jm.idx_q] = qi[k]
            pin.framesForwardKinematics(self.model, self.data, x)
            flat_out[i] = (self.data.oMf[self.base].inverse() * self.data.oMf[self.ee]).homogeneous
        return out


def confirm(pin_fk: PinFK, chain, q, T, tol=1e-6) -> np.ndarray:
    """Pinocchio puts the tool within ``tol`` (m, and rad of rotation angle) of ``T`` and ``q`` lies
    inside the URDF's limits (1e-9 slack): bool (M,)."""
    if not len(q):
        return np.zeros(0, dtype=bool)
    F = pin_fk(q)
    dp = np.linalg.norm(F[:, :3, 3] - T[:, :3, 3], axis=-1)
    Rr = np.einsum("mji,mjk->mik", F[:, :3, :3], T[:, :3, :3])
    ang = np.arccos(np.clip((np.trace(Rr, axis1=1, axis2=2) - 1) / 2, -1, 1))
    return (dp <= tol) & (ang <= tol) & chain.within_limits(q, atol=1e-9)


def grid(chain, nodes_per_axis: int):
    """A cube of ``nodes_per_axis``³ nodes around the first joint, half-width the sum of the link
    lengths (distances between consecutive joint origins and the tool at q = 0)."""
    frames, tool = chain.joint_frames(np.zeros(chain.n))
    pts = np.concatenate([frames[..., :3, 3], tool[None, :3, 3]])
    R = float(np.linalg.norm(np.diff(pts, axis=0), axis=-1).sum())
    c = pts[0]
    axes = [np.linspace(c[i] - R, c[i] + R, nodes_per_axis) for i in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=-1), 2 * R / (nodes_per_axis - 1)


def run_arm(name, source, base_link, ee_link, nodes_per_axis, ref_starts):
    text = urdf_text(source)
    chain = from_urdf(text, ee_link=ee_link, base_link=base_link, name=name)
    pin_fk = PinFK(text, chain, base_link, ee_link)
    q = np.random.default_rng(0).uniform(-1, 1, (50, chain.n))
    fk_err = float(np.abs(pin_fk(q) - chain.fkine(q)).max())
    nodes, step = grid(chain, nodes_per_axis)
    nb = ws.node_neighbours(nodes)
    rows = []
    for oname, rpy in ORIENTATIONS.items():
        T = ws.target_poses(nodes, rpy, "standard")
        t_before, before = harness.timed(
            lambda: map_search(chain, T, nb, **{**MAP_SETTINGS, "border_starts": 0}))  # noqa: B023
        t_after, res = harness.timed(lambda: map_search(chain, T, nb, **MAP_SETTINGS))  # noqa: B023
        pos = np.flatnonzero(res.success)
        good = confirm(pin_fk, chain, res.q[pos], T[pos])
        fp = int((~good).sum())
        reach = np.zeros(len(T), dtype=bool)
        reach[pos[good]] = True
        todo = np.flatnonzero(~res.success)
        t_ref, ref = harness.timed(lambda: ikine_search(chain, T[todo], starts=ref_starts, seed=12345))  # noqa: B023
        hit = np.flatnonzero(ref.success)
        ok_ref = confirm(pin_fk, chain, ref.q[hit], T[todo][hit])
        reach[todo[hit[ok_ref]]] = True
        n_reach = int(reach.sum())
        found = res.success & reach
        found_before = before.success & reach
        missed = np.flatnonzero(reach & ~res.success)
        rows.append(dict(arm=name, joints=chain.n, orientation=oname, nodes=len(T), step=step, fk_vs_pinocchio=fk_err,
                         reachable=n_reach, recall=float(found.sum() / max(n_reach, 1)), missed=int(missed.size),
                         false_positives=fp, recall_before=float(found_before.sum() / max(n_reach, 1)),
                         missed_before=int((reach & ~before.success).sum()),
                         seconds=t_after, seconds_before=t_before, seconds_reference=t_ref,
                         missed_nodes=[[round(float(x), 4) for x in nodes[i]] for i in missed[:10]]))
        r = rows[-1]
        print(f"{name}, {oname}: {n_reach} reachable, recall {r['recall']:.4f} ({r['missed']} missed; before "
              f"{r['recall_before']:.4f}, {r['missed_before']}), {fp} false positives, {t_after:.1f} s "
              f"(before {t_before:.1f} s), reference {t_ref:.1f} s", file=sys.stderr, flush=True)
    return rows


def warm_up():
    """Compile the kernels (cached on disk after the first run) before anything is timed."""
    from wsmap.robots import puma560

    arm = puma560(joint_limits=True)
    nodes = ws.cartesian_grid(-0.3, 0.3, 0.3)
    T = ws.target_poses(nodes, (0.0, 0.0, 0.0), "standard")
    map_search(arm, T, ws.node_neighbours(nodes), **MAP_SETTINGS)
    ikine_search(arm, T, starts=2)


def panda_map_times(repeats: int = 3) -> dict:
    """Seconds of the default numerical tool-down map of the named Panda (``wsmap.load("panda")``,
    the paper's grid, ``grid_map(..., rpy=(pi, 0, 0), method="numerical")``) without and with the
    border search, alternating, best of ``repeats``; and the reachable counts."""
    from wsmap import load

    arm, grid = load("panda"), ws.grid_spec("R3")
    out = {"before": [], "after": []}
    counts = {}
    for _ in range(repeats):
        for label, ik in (("before", {"border_starts": 0}), ("after", {})):
            t, m = harness.timed(lambda: ws.grid_map(arm, grid, rpy=(math.pi, 0.0, 0.0), method="numerical",
                                                     ik=ik))  # noqa: B023
            out[label].append(t)
            counts[label] = int(m.sum())
    return {"seconds_before": min(out["before"]), "seconds_after": min(out["after"]),
            "reachable_before": counts["before"], "reachable_after": counts["after"], "nodes": int(m.size)}


def main(argv=None):
    p = harness.parser(__doc__, repeat=3, quick=f"only {', '.join(QUICK)}; 11 nodes per axis",
                       repeat_help="timed Panda maps without and with the border search, alternating; best kept "
                                   "(default 3)")
    p.add_argument("--arms", nargs="+", help="arm names of ARMS (default: all, or the quick ones)")
    p.add_argument("--nodes", type=int, help="nodes per axis (default 15, 11 with --quick)")
    p.add_argument("--ref-starts", type=int, default=128)
    args = p.parse_args(argv)
    names = args.arms or (QUICK if args.quick else [a[0] for a in ARMS])
    unknown = sorted(set(names) - {a[0] for a in ARMS})
    if unknown:
        p.error(f"unknown arms {unknown}; known: {[a[0] for a in ARMS]}")
    if args.ref_starts < 128:
        p.error("--ref-starts must be at least 128")
    nodes = args.nodes or (11 if args.quick else 15)
    rows = []
    warm_up()
    with harness.Stopwatch() as sw:
        for arm in ARMS:
            if arm[0] in names:
                rows.extend(run_arm(*arm, nodes, args.ref_starts))
    total = sw.seconds
    print(f"\nRecall of the default numerical map (MAP_SETTINGS, border_starts={MAP_SETTINGS['border_starts']}) "
          f"against a {args.ref_starts}-start per-node reference, every positive confirmed by Pinocchio's FK; "
          f"{nodes}³ nodes per arm; total {total:.0f} s\n")
    print("| arm | R | reachable | recall | missed | false pos. | recall before | missed before | s | s before |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['arm']} | {r['orientation']} | {r['reachable']} | {r['recall']:.4f} | {r['missed']} | "
              f"{r['false_positives']} | {r['recall_before']:.4f} | {r['missed_before']} | {r['seconds']:.1f} | "
              f"{r['seconds_before']:.1f} |")
    worst = min(rows, key=lambda r: r["recall"])
    worst_before = min(rows, key=lambda r: r["recall_before"])
    fk = max(r["fk_vs_pinocchio"] for r in rows)
    print(f"\nWorst: {worst['arm']}, {worst['orientation']}: recall {worst['recall']:.4f} ({worst['missed']} of "
          f"{worst['reachable']}); without the border search: {worst_before['arm']}, {worst_before['orientation']}: "
          f"{worst_before['recall_before']:.4f} ({worst_before['missed_before']} of {worst_before['reachable']}); "
          f"false positives in all: {sum(r['false_positives'] for r in rows)}; "
          f"largest FK difference from Pinocchio {fk:.1e}; map time {sum(r['seconds'] for r in rows):.1f} s "
          f"(before {sum(r['seconds_before'] for r in rows):.1f} s)")
    pm = panda_map_times(args.repeat)
    print(f"\nDefault Panda tool-down map (wsmap.load('panda'), {pm['nodes']} nodes, numerical), best of {args.repeat}: "
          f"{pm['seconds_before']:.2f} s without the border search, {pm['seconds_after']:.2f} s with it "
          f"({pm['seconds_after'] / pm['seconds_before']:.1f}x); reachable {pm['reachable_before']} -> "
          f"{pm['reachable_after']}")
    meta = {"nodes_per_axis": nodes, "ref_starts": args.ref_starts, "map_settings": MAP_SETTINGS}
    harness.write_json(args, {"meta": meta, "rows": rows, "panda_tool_down_map": pm})


if __name__ == "__main__":
    main()
