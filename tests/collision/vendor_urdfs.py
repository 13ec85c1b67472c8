"""Universal Robots' own URDF of the UR5e and the UR10e, and Kinova's of the Gen3, expanded from their
xacro the way ROS loads it, for the judges that share no code with wsmap's checker (`test_vendor_judge.py`,
`benchmarks/collision/bench_vendor_judge.py`).

`data/ur_description/` beside this file holds the files of Universal Robots' ROS 2 description the
expansion needs (its `SOURCE.md`: repository, commit; BSD-3-Clause, `LICENSE`). `xacro` resolves
`$(find ur_description)` through ROS's package index (`ament_index_python`); without ROS installed,
the index is answered here by that folder. Needs `xacro` (a test dependency).
"""

from __future__ import annotations

import os
import subprocess
import sys
import types
import xml.etree.ElementTree as ET
from pathlib import Path

UR_DESCRIPTION = Path(__file__).resolve().parent / "data" / "ur_description"
UR = ("ur5e", "ur10e")


def _expanded(package: str, package_dir: Path, xacro_file: Path, mappings: dict) -> ET.Element:
    """The URDF of `xacro_file` expanded by xacro with `mappings`, `$(find package)` answered by
    `package_dir` (xacro asks ROS 2's `ament_index_python`, absent here: a stand-in module for the
    call only), without its `<visual>` elements."""
    import xacro

    index = types.ModuleType("ament_index_python.packages")
    index.get_package_share_directory = lambda name: str(package_dir) if name == package else None
    top = types.ModuleType("ament_index_python")
    top.packages = index
    saved = {k: sys.modules.get(k) for k in ("ament_index_python", "ament_index_python.packages")}
    sys.modules.update({"ament_index_python": top, "ament_index_python.packages": index})
    try:
        doc = xacro.process_file(str(xacro_file), mappings=mappings)
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v
    root = ET.fromstring(doc.toxml())
    for link in root.findall("link"):
        for vis in link.findall("visual"):
            link.remove(vis)
    return root


def ur_urdf(arm: str, folder: Path) -> Path:
    """Universal Robots' `urdf/ur.urdf.xacro` expanded by xacro with `ur_type:=arm` (`$(find
    ur_description)` answered by `UR_DESCRIPTION`, mesh paths absolute: `force_abs_paths:=true`),
    the `<visual>` elements removed (their meshes are not copied), written to `folder/<arm>.urdf`."""
    root = _expanded("ur_description", UR_DESCRIPTION, UR_DESCRIPTION / "urdf" / "ur.urdf.xacro",
                     {"ur_type": arm, "name": arm, "force_abs_paths": "true"})
    path = Path(folder) / f"{arm}.urdf"
    path.write_bytes(ET.tostring(root))
    return path


#: A git mirror of Kinova's `ros2_kortex` (BSD-3-Clause): the Gen3's judge reads its description
#: there. Its collision meshes (`arms/gen3/7dof/meshes/*.dae`, 5.1 MB for the eight links) are too
#: large to commit with the tests; without the mirror the Gen3's judge is skipped, saying so. The
#: hulls wsmap checks are committed (`wsmap/collision/data/kortex_description/`).
KORTEX_REPO = Path(os.environ.get("WSMAP_KORTEX_REPO", "/work/.mirror/Kinovarobotics+ros2_kortex/repo"))
KORTEX_MISSING = (f"the Gen3's judge needs Kinova's ros2_kortex description (its .dae collision meshes, 5.1 MB, are "
                  f"not committed): no git mirror at {KORTEX_REPO} (set WSMAP_KORTEX_REPO)")


def kortex_present() -> bool:
    """Whether the mirror of `ros2_kortex` is here (a git repository with the Gen3's xacro at HEAD)."""
    if not KORTEX_REPO.is_dir():
        return False
    out = subprocess.run(["git", "-C", str(KORTEX_REPO), "cat-file", "-e", "HEAD:kortex_description/robots/gen3.xacro"],
                         capture_output=True)
    return out.returncode == 0


def gen3_urdf(folder: Path) -> Path:
    """Kinova's `kortex_description/robots/gen3.xacro` (the mirror's HEAD) expanded by xacro with
    `dof:=7` (no vision module, no gripper: its defaults), `$(find kortex_description)` answered by
    the files exported under `folder`, `package://kortex_description/` mesh names made absolute (as
    ROS resolves them), the `<visual>` elements removed: `folder/gen3.urdf`."""

    paths = ["LICENSE", "kortex_description/package.xml", "kortex_description/robots",
             "kortex_description/config", "kortex_description/arms/gen3/7dof/urdf",
             *(f"kortex_description/arms/gen3/7dof/meshes/{m}.dae" for m in (
                 "base_link", "shoulder_link", "half_arm_1_link", "half_arm_2_link", "forearm_link",
                 "spherical_wrist_1_link", "spherical_wrist_2_link", "bracelet_no_vision_link"))]
    tar = subprocess.run(["git", "-C", str(KORTEX_REPO), "archive", "HEAD", *paths], check=True,
                         capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=tar, check=True)
    pkg = Path(folder).resolve() / "kortex_description"
    root = _expanded("kortex_description", pkg, pkg / "robots" / "gen3.xacro", {"dof": "7"})
    for mesh in root.iter("mesh"):
        mesh.set("filename", mesh.get("filename").replace("package://kortex_description/", f"{pkg}/"))
    ET.indent(root)  # one element a line: PyBullet's URDF reader fails on a line of a few thousand characters
    path = Path(folder) / "gen3.urdf"
    path.write_bytes(ET.tostring(root))
    return path
