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

Run: `.venv/bin/python tools/vendor_hulls.py [ARM ...]` (default: ur5e ur10e); `--check` derives
again and compares with the committed files (exit 1 on a difference). Then
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


def git(repo: str, *args: str) -> bytes:
    return subprocess.run(["git", "-C", repo, *args], check=True, capture_output=True).stdout


def export(repo: str, arm: str, dest: str) -> None:
    """The files `arm` needs from the repository's HEAD, as the package folder `dest`."""
    paths = ["LICENSE", "package.xml", "urdf", f"config/{arm}", f"meshes/{arm}/collision"]
    tar = git(repo, "archive", "HEAD", *paths)
    os.makedirs(dest, exist_ok=True)
    subprocess.run(["tar", "-x", "-C", dest], input=tar, check=True)


def expand(package_dir: str, arm: str) -> str:
    """The URDF text of `urdf/ur.urdf.xacro` with `ur_type:=arm`, `$(find ur_description)` = `package_dir`."""
    index = types.ModuleType("ament_index_python.packages")
    index.get_package_share_directory = lambda name: package_dir if name == "ur_description" else None
    top = types.ModuleType("ament_index_python")
    top.packages = index
    saved = {k: sys.modules.get(k) for k in ("ament_index_python", "ament_index_python.packages")}
    sys.modules.update({"ament_index_python": top, "ament_index_python.packages": index})
    try:
        import xacro

        doc = xacro.process_file(os.path.join(package_dir, "urdf", "ur.urdf.xacro"),
                                 mappings={"ur_type": arm, "name": arm, "force_abs_paths": "true"})
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("arms", nargs="*", help=f"arms (default: {' '.join(ARMS)})")
    ap.add_argument("--repo", default=REPO, help="a git clone of Universal_Robots_ROS2_Description (its HEAD)")
    ap.add_argument("--check", action="store_true", help="compare with the committed files instead of writing")
    args = ap.parse_args(argv)
    bad = [a for a in args.arms if a not in ARMS]
    if bad:
        ap.error(f"unknown arm {', '.join(bad)}; arms: {', '.join(ARMS)}")
    if not os.path.isdir(args.repo):
        ap.error(f"no git repository at {args.repo!r} (--repo)")
    arms = args.arms or list(ARMS)
    records = {arm: derive(args.repo, arm) for arm in arms}
    # compact: the hulls are numbers (indented, each on its own line, the files would be 3x larger)
    texts = {f"{arm}.json": json.dumps(rec, separators=(",", ":")) + "\n" for arm, rec in records.items()}
    texts["LICENSE"] = git(args.repo, "show", "HEAD:LICENSE").decode()
    if set(arms) == set(ARMS):
        texts["SOURCE.md"] = source_note(records)
    status = 0
    os.makedirs(OUT, exist_ok=True)
    for fn, text in texts.items():
        path = os.path.join(OUT, fn)
        if args.check:
            same = os.path.isfile(path) and open(path, encoding="utf-8").read() == text
            print(f"{'same' if same else 'DIFFERS from'} {os.path.relpath(path, ROOT)}")
            status |= not same
            continue
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        print(f"{os.path.relpath(path, ROOT)}: {hashlib.sha256(text.encode()).hexdigest()[:12]}")
    for arm, rec in records.items():
        print(f"{arm}: frames agree to {rec['frame_check']['max_error']:.2g} m; hull vertices per link "
              + " ".join(str(len(lk["vertices"])) for lk in rec["links"]))
    return status


if __name__ == "__main__":
    sys.exit(main())
