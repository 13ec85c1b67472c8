"""Derive the vendor collision geometry of the UR5e and the UR10e from Universal Robots' own
description and write it as package data: `src/wsmap/collision/data/ur_description/`.

Universal Robots' ROS 2 description (`UniversalRobots/Universal_Robots_ROS2_Description`, BSD-3-Clause
for everything but the UR20/UR30 meshes) is read from a git mirror of the repository at one commit
(`--repo`, default `/work/.mirror/UniversalRobots+Universal_Robots_ROS2_Description/repo`, its
`HEAD`): the files the arm needs are exported by `git archive` into a temporary
`ur_description/` package, `urdf/ur.urdf.xacro` is expanded by `xacro` with `ur_type:=<arm>`
(`$(find ur_description)` answered by that folder, as ROS's package index would) and the URDF's
collision meshes read by `wsmap.collision.from_urdf_collision`.

For each arm:

* the vendor's chain is expressed in its `base` link (the controller's base frame, `base_link`
  turned by pi about z: the frame of the DH parameters wsmap's `ur5e` and `ur10e` use), and
  `wsmap.collision.vendor.frame_offsets` checks that every vendor link frame is wsmap's body frame
  times a constant transform (200 random configurations; the largest difference is recorded: the
  description's `default_kinematics.yaml` rounds pi/2 to 1.570796327);
* each link's collision meshes are replaced by the vertices of their convex hull (what coal and PyBullet test), in
  the vendor link's own frame (the `<collision><origin>` applied), with the link frame in wsmap's
  body frame: `data/ur_description/<arm>.json`, with the commit, every file's path and git blob hash;
* the repository's `LICENSE` is copied beside it and `SOURCE.md` says where every number comes from.

The Kinova Gen3 (7 DoF) from Kinova's `ros2_kortex` (`Kinovarobotics/ros2_kortex`, BSD-3-Clause;
`--kortex-repo`, default `/work/.mirror/Kinovarobotics+ros2_kortex/repo`, its `HEAD`), into
`src/wsmap/collision/data/kortex_description/`: `kortex_description/robots/gen3.xacro` expanded by
xacro with `dof:=7` (vision off, no gripper: the defaults), its `<collision>` meshes
(`arms/gen3/7dof/meshes/*.dae`, read by trimesh with pycollada) taken per link as for the UR arms.
Kinova's URDF is *not* wsmap's Gen3 DH table (the User Guide's): its joint origins carry lengths
to 0.01 mm, a 0.175 mm offset the table lacks and angles rounded to 1.5708, so a vendor link frame
is wsmap's body frame times a constant transform (matched at q = 0) only up to a small motion that
depends on q. That motion is measured: per link, the largest distance between a hull vertex placed
by the vendor's chain and the same vertex placed by wsmap's body frame (`FRAME_SAMPLES` random
configurations inside the limits, seed 0, then a local search from the worst `REFINE` of them),
rounded up to the next `GROWTH_STEP`; each hull is then grown by that bound (its face planes moved
out; every vertex of the bare hull is checked to lie that deep inside the grown one) on top of the
checks' usual `MESH_MARGIN`. So wherever the vendor's arm and wsmap's Gen3 sit at the same joint
angles, wsmap's grown hull contains the vendor's hull (tested on fresh configurations,
`tests/collision/test_vendor_judge.py`).

Run: `.venv/bin/python tools/vendor_hulls.py [ARM ...]` (default: ur5e ur10e gen3); `--check`
derives again and compares with the committed files (exit 1 on a difference). Then
`tools/fit_collision_spheres.py ARM` fits the capsules around the hulls.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import types
import xml.etree.ElementTree as ET

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "src", "wsmap", "collision", "data", "ur_description")
REPO = "/work/.mirror/UniversalRobots+Universal_Robots_ROS2_Description/repo"
URL = "https://github.com/UniversalRobots/Universal_Robots_ROS2_Description"
#: The arms and the vendor links of their bodies 0..6 (base_link_inertia rides on body 0).
ARMS = {arm: ("base_link_inertia", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
              "wrist_2_link", "wrist_3_link") for arm in ("ur5e", "ur10e")}
FRAME_SAMPLES = 200
DECIMALS = 8  # hull vertices rounded to 10 nm (the STL files hold float32: ~0.06 um at 1 m)

KORTEX_OUT = os.path.join(ROOT, "src", "wsmap", "collision", "data", "kortex_description")
KORTEX_REPO = "/work/.mirror/Kinovarobotics+ros2_kortex/repo"
KORTEX_URL = "https://github.com/Kinovarobotics/ros2_kortex"
#: The Gen3's vendor links of bodies 0..7 (no vision module: the xacro's default).
GEN3_LINKS = ("base_link", "shoulder_link", "half_arm_1_link", "half_arm_2_link", "forearm_link",
              "spherical_wrist_1_link", "spherical_wrist_2_link", "bracelet_link")
GEN3_XACRO_ARGS = {"dof": "7"}
GEN3_SAMPLES = 20000  # random configurations for the frame-mismatch bound (seed 0)
REFINE = 8  # the worst configurations per link from which a local search climbs further
GROWTH_STEP = 1e-4  # the bound is rounded up to the next 0.1 mm (m)


def git(repo: str, *args: str) -> bytes:
    return subprocess.run(["git", "-C", repo, *args], check=True, capture_output=True).stdout


def export(repo: str, arm: str, dest: str) -> None:
    """The files `arm` needs from the repository's HEAD, as the package folder `dest`."""
    paths = ["LICENSE", "package.xml", "urdf", f"config/{arm}", f"meshes/{arm}/collision"]
    tar = git(repo, "archive", "HEAD", *paths)
    os.makedirs(dest, exist_ok=True)
    subprocess.run(["tar", "-x", "-C", dest], input=tar, check=True)


def run_xacro(package: str, package_dir: str, xacro_file: str, mappings: dict):
    """The xacro document of `xacro_file` with `mappings`, `$(find package)` answered by
    `package_dir` (xacro asks ROS 2's `ament_index_python`, absent here: a stand-in module for the
    call only)."""
    import xacro

    index = types.ModuleType("ament_index_python.packages")
    index.get_package_share_directory = lambda name: package_dir if name == package else None
    top = types.ModuleType("ament_index_python")
    top.packages = index
    saved = {k: sys.modules.get(k) for k in ("ament_index_python", "ament_index_python.packages")}
    sys.modules.update({"ament_index_python": top, "ament_index_python.packages": index})
    try:
        return xacro.process_file(xacro_file, mappings=mappings)
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v


def expand(package_dir: str, arm: str) -> str:
    """The URDF text of `urdf/ur.urdf.xacro` with `ur_type:=arm`, `$(find ur_description)` = `package_dir`."""
    doc = run_xacro("ur_description", package_dir, os.path.join(package_dir, "urdf", "ur.urdf.xacro"),
                    {"ur_type": arm, "name": arm, "force_abs_paths": "true"})
    return doc.toprettyxml(indent="  ")


def base_in_base_link(urdf_text: str) -> np.ndarray:
    """The pose `(4, 4)` of the URDF link `base` in `base_link` (its fixed joint's origin)."""
    from wsmap.collision.fields import urdf_origin

    root = ET.fromstring(urdf_text)
    joint = next(j for j in root.findall("joint") if j.find("child").get("link") == "base")
    assert joint.find("parent").get("link") == "base_link" and joint.get("type") == "fixed"
    return urdf_origin(joint.find("origin"), "UR URDF", "base joint")


def hull(points: np.ndarray) -> np.ndarray:
    """The vertices `(V, 3)` of the convex hull of `points` `(P, 3)` (qhull, by scipy)."""
    from scipy.spatial import ConvexHull

    return points[np.sort(ConvexHull(points).vertices)]


def derive(repo: str, arm: str) -> dict:
    """The record of `data/ur_description/<arm>.json` (`wsmap.collision.vendor`)."""
    from wsmap.collision import body_frames, from_urdf_collision
    from wsmap.collision.vendor import frame_offsets
    from wsmap.robots import load

    commit = git(repo, "rev-parse", "HEAD").decode().strip()
    with tempfile.TemporaryDirectory() as tmp:
        pkg = os.path.join(tmp, "ur_description")
        export(repo, arm, pkg)
        text = expand(pkg, arm)
        urdf = os.path.join(tmp, f"{arm}.urdf")
        with open(urdf, "w", encoding="utf-8") as fh:
            fh.write(text)
        vendor = from_urdf_collision(urdf, ee_link=ARMS[arm][-1], base_link="base_link")
        T = base_in_base_link(text)
        chain = vendor.chain.replace(base=np.linalg.inv(T) @ (np.eye(4) if vendor.chain.base is None
                                                             else vendor.chain.base))
        wsarm = load(arm)
        X = frame_offsets(chain, wsarm, samples=16)
        lim = np.clip(wsarm.limits, -np.pi, np.pi)
        q = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], (FRAME_SAMPLES, wsarm.n))
        err = float(np.abs(body_frames(wsarm, q) @ X - body_frames(chain, q)).max())
        by_name = {lk.name: lk for lk in vendor.links}
        links = []
        for k, lname in enumerate(ARMS[arm]):
            lk = by_name[lname]
            if lk.body != k:
                raise SystemExit(f"{arm}: vendor link {lname} rides on body {lk.body}, expected {k}")
            to_link = np.linalg.inv(lk.frame)  # the shapes are in the body's frame; keep them in the link's
            pts = np.concatenate([s.vertices @ (to_link @ s.origin)[:3, :3].T + (to_link @ s.origin)[:3, 3]
                                  for s in lk.shapes])
            v = hull(pts)
            files = sorted(os.path.relpath(s.source, pkg) for s in lk.shapes)
            links.append({"name": lname, "body": k, "meshes": files,
                          "blobs": {p: git(repo, "rev-parse", f"HEAD:{p}").decode().strip() for p in files},
                          "frame": np.round(X[k] @ lk.frame, 12).tolist(),
                          "vertices": np.round(v, DECIMALS).tolist(),
                          "mesh_vertices": int(len(pts))})
        files = ["LICENSE", "urdf/ur.urdf.xacro", "urdf/ur_macro.xacro", "urdf/inc/ur_common.xacro",
                 f"config/{arm}/default_kinematics.yaml", f"config/{arm}/joint_limits.yaml",
                 f"config/{arm}/physical_parameters.yaml", f"config/{arm}/visual_parameters.yaml"]
        blobs = {p: git(repo, "rev-parse", f"HEAD:{p}").decode().strip() for p in files}
    return {"arm": arm, "source": {
        "repository": URL, "commit": commit, "xacro": "urdf/ur.urdf.xacro",
        "xacro_args": {"ur_type": arm, "name": arm, "force_abs_paths": "true"}, "blobs": blobs,
        "licence": "BSD-3-Clause (LICENSE; the repository's README: every file but the UR20 and UR30 meshes)",
        "origin": f"Universal Robots' ROS 2 description of the {arm.upper()}: collision meshes "
                  f"meshes/{arm}/collision/*.stl, frames by urdf/ur.urdf.xacro and config/{arm}/default_kinematics.yaml"},
        "derived_by": "tools/vendor_hulls.py",
        "base": {"link": "base", "in": "base_link", "pose": np.round(T, 12).tolist(),
                 "why": "wsmap's UR chains start at the controller's base frame, the URDF's link 'base'"},
        "frame_check": {"samples": FRAME_SAMPLES, "seed": 0, "max_error": err,
                        "why": "default_kinematics.yaml's roll 1.570796327 is pi/2 rounded"},
        "links": links}


def export_kortex(repo: str, dest: str) -> list[str]:
    """The files the Gen3's xacro needs from `ros2_kortex`'s HEAD, under `dest` (`dest/kortex_description`
    the package); the paths exported (files, relative to the repository)."""
    paths = ["LICENSE", "kortex_description/package.xml", "kortex_description/robots/gen3.xacro",
             "kortex_description/robots/kortex_robot.xacro", "kortex_description/config/initial_positions.yaml",
             "kortex_description/arms/gen3/7dof/urdf"]
    tar = git(repo, "archive", "HEAD", *paths)
    os.makedirs(dest, exist_ok=True)
    subprocess.run(["tar", "-x", "-C", dest], input=tar, check=True)
    files = [p for p in git(repo, "ls-tree", "-r", "--name-only", "HEAD", *paths).decode().split()]
    return files


def expand_kortex(package_dir: str) -> str:
    """The URDF text of `robots/gen3.xacro` with `GEN3_XACRO_ARGS`, `$(find kortex_description)` =
    `package_dir`, `package://kortex_description/` mesh names made absolute (ROS resolves them so)."""
    doc = run_xacro("kortex_description", package_dir, os.path.join(package_dir, "robots", "gen3.xacro"),
                    dict(GEN3_XACRO_ARGS))
    return doc.toprettyxml(indent="  ").replace("package://kortex_description/", package_dir.rstrip("/") + "/")


def grown_hull(points: np.ndarray, by: float) -> np.ndarray:
    """The vertices of the convex hull of `points` `(P, 3)` with every face plane moved out by `by`
    (m; a polytope that holds the hull grown by a ball of radius `by`): qhull's halfspace
    intersection. Checked: every hull vertex lies at least `by` inside every face of the result."""
    from scipy.spatial import ConvexHull, HalfspaceIntersection

    h = ConvexHull(points)
    if by <= 0:
        return points[np.sort(h.vertices)]
    eq = np.unique(np.round(h.equations, 12), axis=0)  # coplanar triangles share a plane
    eq[:, 3] -= by
    centre = points[h.vertices].mean(axis=0)
    v = HalfspaceIntersection(eq, centre).intersections
    out = v[np.sort(ConvexHull(v).vertices)]
    return out


def depth_inside(vertices: np.ndarray, points: np.ndarray) -> float:
    """How deep (m) the shallowest of `points` lies inside the convex hull of `vertices` (< 0: outside)."""
    from scipy.spatial import ConvexHull

    eq = ConvexHull(vertices).equations
    return float(-(points @ eq[:, :3].T + eq[:, 3]).max())


def frame_mismatch(wsarm, vendor_chain, X: np.ndarray, points: list[np.ndarray]) -> tuple[list[float], np.ndarray]:
    """Per body, the largest distance (m) between a vertex of `points[k]` (the vendor link's hull, in
    the vendor body's frame) placed by the vendor chain and placed by wsmap's body frame times `X[k]`,
    at the same joint angles: `GEN3_SAMPLES` random configurations inside the limits (joints without
    limits: [-pi, pi]; seed 0), then a local search (Nelder-Mead on -distance) from the worst `REFINE`
    of them. Returns the bounds and the worst configuration of each body `(n + 1, n)`."""
    from scipy.optimize import minimize

    from wsmap.collision import body_frames

    lim = np.clip(wsarm.limits, -np.pi, np.pi)

    def worst(q, k):  # (C,) the largest vertex displacement of body k
        q = np.clip(np.atleast_2d(q), lim[:, 0], lim[:, 1])
        E = np.linalg.inv(body_frames(wsarm, q)[:, k] @ X[k]) @ body_frames(vendor_chain, q)[:, k]
        p = points[k]
        moved = np.einsum("cij,pj->cpi", E[:, :3, :3], p) + E[:, None, :3, 3]
        return np.linalg.norm(moved - p, axis=2).max(axis=1)

    q = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], (GEN3_SAMPLES, wsarm.n))
    bounds, where = [], np.zeros((len(points), wsarm.n))
    for k in range(len(points)):
        d = np.concatenate([worst(c, k) for c in np.array_split(q, 20)])
        best, arg = float(d.max()), q[int(np.argmax(d))]
        for start in q[np.argsort(d)[-REFINE:]]:
            res = minimize(lambda x: -worst(x, k)[0], start, method="Nelder-Mead",  # noqa: B023
                           options={"xatol": 1e-6, "fatol": 1e-10, "maxiter": 4000})
            if -res.fun > best:
                best, arg = float(-res.fun), np.clip(res.x, lim[:, 0], lim[:, 1])
        bounds.append(best)
        where[k] = arg
    return bounds, where


def derive_gen3(repo: str) -> dict:
    """The record of `data/kortex_description/gen3.json` (`wsmap.collision.vendor`): per link the
    hull grown by its frame-mismatch bound (module notes)."""
    from wsmap.collision import body_frames, from_urdf_collision
    from wsmap.robots import load

    commit = git(repo, "rev-parse", "HEAD").decode().strip()
    with tempfile.TemporaryDirectory() as tmp:
        export_kortex(repo, tmp)
        pkg = os.path.join(tmp, "kortex_description")
        text = expand_kortex(pkg)
        urdf = os.path.join(tmp, "gen3.urdf")
        with open(urdf, "w", encoding="utf-8") as fh:
            fh.write(text)
        root = ET.fromstring(text)
        mesh_names = sorted({m.get("filename") for m in root.iter("mesh")
                             if m.get("filename", "").startswith(pkg)})
        # only the collision meshes are read: the visual ones are the same files here
        for fn in mesh_names:
            rel = os.path.relpath(fn, tmp)
            os.makedirs(os.path.dirname(fn), exist_ok=True)
            with open(fn, "wb") as fh:
                fh.write(git(repo, "show", f"HEAD:{rel}"))
        vendor = from_urdf_collision(urdf, ee_link=GEN3_LINKS[-1], base_link=GEN3_LINKS[0])
        wsarm = load("gen3")
        chain = vendor.chain
        # the constant transform per body, matched at q = 0 (the q-dependent rest is measured below)
        X = np.linalg.inv(body_frames(wsarm, np.zeros((1, wsarm.n)))[0]) @ body_frames(chain, np.zeros((1, wsarm.n)))[0]
        by_name = {lk.name: lk for lk in vendor.links}
        bare = []
        for k, lname in enumerate(GEN3_LINKS):
            lk = by_name[lname]
            if lk.body != k:
                raise SystemExit(f"gen3: vendor link {lname} rides on body {lk.body}, expected {k}")
            to_link = np.linalg.inv(lk.frame)
            bare.append(np.concatenate([s.vertices @ (to_link @ s.origin)[:3, :3].T + (to_link @ s.origin)[:3, 3]
                                        for s in lk.shapes]))
        hulls = [hull(p) for p in bare]
        in_body = [h @ by_name[n].frame[:3, :3].T + by_name[n].frame[:3, 3] for h, n in zip(hulls, GEN3_LINKS)]
        bounds, where = frame_mismatch(wsarm, chain, X, in_body)
        links = []
        for k, lname in enumerate(GEN3_LINKS):
            lk = by_name[lname]
            # rounded up, with 1 um to spare for the vertices' rounding (DECIMALS) and the search's last digits
            growth = float(np.ceil((bounds[k] + 1e-6) / GROWTH_STEP) * GROWTH_STEP) if bounds[k] > 1e-9 else 0.0
            growth = round(growth, 6)
            v = np.round(grown_hull(hulls[k], growth), DECIMALS)
            depth = depth_inside(v, bare[k])
            if depth < growth - 1e-7:
                raise SystemExit(f"gen3 {lname}: a mesh vertex lies {depth:.3g} m inside the grown hull, "
                                 f"less than its growth {growth:.3g} m")
            files = sorted(os.path.relpath(s.source, tmp) for s in lk.shapes)
            links.append({"name": lname, "body": k, "meshes": files,
                          "blobs": {p: git(repo, "rev-parse", f"HEAD:{p}").decode().strip() for p in files},
                          "frame": np.round(X[k] @ lk.frame, 12).tolist(),
                          "frame_mismatch": round(bounds[k], 9), "worst_q": np.round(where[k], 6).tolist(),
                          "growth": growth, "depth_of_mesh_vertices": round(depth, 9),
                          "vertices": v.tolist(), "mesh_vertices": int(len(bare[k])),
                          "bare_hull_vertices": int(len(hulls[k]))})
        files = ["LICENSE", "kortex_description/robots/gen3.xacro", "kortex_description/robots/kortex_robot.xacro",
                 "kortex_description/arms/gen3/7dof/urdf/gen3_macro.xacro",
                 "kortex_description/arms/gen3/7dof/urdf/kortex.ros2_control.xacro",
                 "kortex_description/config/initial_positions.yaml"]
        blobs = {p: git(repo, "rev-parse", f"HEAD:{p}").decode().strip() for p in files}
    return {"arm": "gen3", "source": {
        "repository": KORTEX_URL, "commit": commit, "xacro": "kortex_description/robots/gen3.xacro",
        "xacro_args": dict(GEN3_XACRO_ARGS), "blobs": blobs,
        "licence": "BSD-3-Clause (LICENSE, the repository's)",
        "origin": "Kinova's ROS 2 description of the Gen3 (7 DoF, no vision module, no gripper): collision meshes "
                  "kortex_description/arms/gen3/7dof/meshes/*.dae, frames by kortex_description/arms/gen3/7dof/"
                  "urdf/gen3_macro.xacro"},
        "derived_by": "tools/vendor_hulls.py",
        "frame_check": {"samples": GEN3_SAMPLES, "seed": 0, "refined_from": REFINE, "growth_step": GROWTH_STEP,
                        "max_error": max(bounds),
                        "why": "Kinova's URDF rounds the User Guide's lengths to 0.01 mm, adds a 0.175 mm offset at "
                               "joints 6 and 7 and rounds pi/2 to 1.5708: its link frames leave wsmap's bodies by up "
                               "to max_error; each hull is grown by its link's bound, rounded up to growth_step"},
        "links": links}


def gen3_source_note(rec: dict) -> str:
    src = rec["source"]
    fc = rec["frame_check"]
    lines = ["# Source of the Kinova Gen3 collision hulls", "", f"Repository: {KORTEX_URL}", "",
             "## gen3 (`gen3.json`)", "", f"* commit `{src['commit']}`",
             f"* expanded by xacro: `{src['xacro']}` with "
             + ", ".join(f"`{k}:={v}`" for k, v in src["xacro_args"].items())
             + " (the other arguments at their defaults: no vision module, no gripper)",
             "* frames: the URDF's `base_link` is wsmap's base; every link frame is wsmap's body frame times a "
             "constant transform (matched at q = 0) **up to a motion that depends on q**: Kinova's URDF rounds "
             "the User Guide's lengths to 0.01 mm, adds a 0.175 mm offset at joints 6 and 7 and rounds pi/2 "
             f"to 1.5708. Largest vertex displacement over {fc['samples']} random configurations (seed "
             f"{fc['seed']}) and a local search from the worst {fc['refined_from']} per link: "
             f"{fc['max_error'] * 1e3:.3f} mm. Each link's hull is grown by its own bound rounded up to "
             f"{fc['growth_step'] * 1e3:g} mm (below), so wsmap's hull holds the vendor's wherever both sit",
             "* files (path: git blob hash):"]
    lines += [f"  * `{p}`: `{h}`" for p, h in src["blobs"].items()]
    for lk in rec["links"]:
        lines += [f"  * `{p}`: `{h}` (link `{lk['name']}`, body {lk['body']}; convex hull of {lk['mesh_vertices']} "
                  f"vertices: {lk['bare_hull_vertices']}; frame mismatch {lk['frame_mismatch'] * 1e3:.3f} mm, grown "
                  f"by {lk['growth'] * 1e3:.1f} mm: {len(lk['vertices'])} vertices)" for p, h in lk["blobs"].items()]
    lines += ["", "Each link's collision mesh is stored as its convex hull grown by the link's frame-mismatch bound",
              "(face planes moved out; vertices in metres in the vendor link's frame; `frame`: that link frame in",
              "wsmap's body frame), which the exact checks (coal) grow by a further 1 mm (`MESH_MARGIN`).",
              "Licence: BSD-3-Clause, `LICENSE` (the repository's). Derived by `tools/vendor_hulls.py`.", ""]
    return "\n".join(lines)


def source_note(records: dict) -> str:
    lines = ["# Source of the UR5e and UR10e collision hulls", "",
             f"Repository: {URL}", ""]
    for arm, rec in records.items():
        src = rec["source"]
        lines += [f"## {arm} (`{arm}.json`)", "", f"* commit `{src['commit']}`",
                  f"* expanded by xacro: `{src['xacro']}` with "
                  + ", ".join(f"`{k}:={v}`" for k, v in src["xacro_args"].items()),
                  f"* frames: the URDF link `base` (the controller's base frame) is wsmap's base; every link frame "
                  f"is wsmap's body frame times a constant transform (largest difference over "
                  f"{rec['frame_check']['samples']} random configurations: {rec['frame_check']['max_error']:.2g} m)",
                  "* files (path: git blob hash):"]
        lines += [f"  * `{p}`: `{h}`" for p, h in src["blobs"].items()]
        for lk in rec["links"]:
            lines += [f"  * `{p}`: `{h}` (link `{lk['name']}`, body {lk['body']}; convex hull of "
                      f"{lk['mesh_vertices']} vertices: {len(lk['vertices'])})" for p, h in lk["blobs"].items()]
        lines.append("")
    lines += ["Each link's collision meshes are stored as their convex hull (vertices in metres in the vendor",
              "link's frame, the `<collision><origin>` applied; `frame`: that link frame in wsmap's body frame),",
              "which is what the exact checks (coal) and PyBullet test. Licence: BSD-3-Clause, `LICENSE`",
              "(the repository's; its README excludes only the UR20 and UR30 meshes). Derived by",
              "`tools/vendor_hulls.py`.", ""]
    return "\n".join(lines)


def _write(texts: dict, out: str, check: bool) -> int:
    status = 0
    os.makedirs(out, exist_ok=True)
    for fn, text in texts.items():
        path = os.path.join(out, fn)
        if check:
            same = os.path.isfile(path) and open(path, encoding="utf-8").read() == text
            print(f"{'same' if same else 'DIFFERS from'} {os.path.relpath(path, ROOT)}")
            status |= not same
            continue
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        print(f"{os.path.relpath(path, ROOT)}: {hashlib.sha256(text.encode()).hexdigest()[:12]}")
    return status


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    every = [*ARMS, "gen3"]
    ap.add_argument("arms", nargs="*", help=f"arms (default: {' '.join(every)})")
    ap.add_argument("--repo", default=REPO, help="a git clone of Universal_Robots_ROS2_Description (its HEAD)")
    ap.add_argument("--kortex-repo", default=KORTEX_REPO, help="a git clone of Kinova's ros2_kortex (its HEAD)")
    ap.add_argument("--check", action="store_true", help="compare with the committed files instead of writing")
    args = ap.parse_args(argv)
    bad = [a for a in args.arms if a not in every]
    if bad:
        ap.error(f"unknown arm {', '.join(bad)}; arms: {', '.join(every)}")
    arms = args.arms or every
    ur = [a for a in arms if a in ARMS]
    for arm, repo, flag in (("ur", args.repo, "--repo"), ("gen3", args.kortex_repo, "--kortex-repo")):
        if (ur if arm == "ur" else "gen3" in arms) and not os.path.isdir(repo):
            ap.error(f"no git repository at {repo!r} ({flag})")
    status = 0
    if ur:
        records = {arm: derive(args.repo, arm) for arm in ur}
        # compact: the hulls are numbers (indented, each on its own line, the files would be 3x larger)
        texts = {f"{arm}.json": json.dumps(rec, separators=(",", ":")) + "\n" for arm, rec in records.items()}
        texts["LICENSE"] = git(args.repo, "show", "HEAD:LICENSE").decode()
        if set(ur) == set(ARMS):
            texts["SOURCE.md"] = source_note(records)
        status |= _write(texts, OUT, args.check)
        for arm, rec in records.items():
            print(f"{arm}: frames agree to {rec['frame_check']['max_error']:.2g} m; hull vertices per link "
                  + " ".join(str(len(lk["vertices"])) for lk in rec["links"]))
    if "gen3" in arms:
        rec = derive_gen3(args.kortex_repo)
        texts = {"gen3.json": json.dumps(rec, separators=(",", ":")) + "\n",
                 "LICENSE": git(args.kortex_repo, "show", "HEAD:LICENSE").decode(), "SOURCE.md": gen3_source_note(rec)}
        status |= _write(texts, KORTEX_OUT, args.check)
        print("gen3: frame mismatch per link (mm) " + " ".join(f"{lk['frame_mismatch'] * 1e3:.3f}" for lk in rec["links"])
              + "; grown by " + " ".join(f"{lk['growth'] * 1e3:.1f}" for lk in rec["links"])
              + "; hull vertices " + " ".join(str(len(lk["vertices"])) for lk in rec["links"]))
    return status


if __name__ == "__main__":
    sys.exit(main())
