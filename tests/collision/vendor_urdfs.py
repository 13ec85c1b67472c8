"""Universal Robots' own URDF of the UR5e and the UR10e, expanded from their xacro the way ROS loads
it, for the judges that share no code with wsmap's checker (`test_vendor_judge.py`,
`benchmarks/collision/bench_vendor_judge.py`).

`data/ur_description/` beside this file holds the files of Universal Robots' ROS 2 description the
expansion needs (its `SOURCE.md`: repository, commit; BSD-3-Clause, `LICENSE`). `xacro` resolves
`$(find ur_description)` through ROS's package index (`ament_index_python`); without ROS installed,
the index is answered here by that folder. Needs `xacro` (a test dependency).
"""

from __future__ import annotations

import sys
import types
import xml.etree.ElementTree as ET
from pathlib import Path

UR_DESCRIPTION = Path(__file__).resolve().parent / "data" / "ur_description"
UR = ("ur5e", "ur10e")


def ur_urdf(arm: str, folder: Path) -> Path:
    """Universal Robots' `urdf/ur.urdf.xacro` expanded by xacro with `ur_type:=arm` (`$(find
    ur_description)` answered by `UR_DESCRIPTION`, mesh paths absolute: `force_abs_paths:=true`),
    the `<visual>` elements removed (their meshes are not copied), written to `folder/<arm>.urdf`."""
    import xacro

    index = types.ModuleType("ament_index_python.packages")
    index.get_package_share_directory = lambda name: str(UR_DESCRIPTION) if name == "ur_description" else None
    top = types.ModuleType("ament_index_python")
    top.packages = index
    saved = {k: sys.modules.get(k) for k in ("ament_index_python", "ament_index_python.packages")}
    sys.modules.update({"ament_index_python": top, "ament_index_python.packages": index})
    try:
        doc = xacro.process_file(str(UR_DESCRIPTION / "urdf" / "ur.urdf.xacro"),
                                 mappings={"ur_type": arm, "name": arm, "force_abs_paths": "true"})
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
    path = Path(folder) / f"{arm}.urdf"
    path.write_bytes(ET.tostring(root))
    return path
