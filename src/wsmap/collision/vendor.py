"""The named arms' collision geometry from the vendors' own descriptions: the exact meshes and the
capsules fitted around them.

Each arm with a vendor description has one record in `VENDOR` that says where its meshes are:

* `PackagedURDF` — a vendor URDF in an installed Python package: the Panda (Franka Emika's
  `franka_description` as `pybullet_data` ships it, `franka_panda/panda.urdf`, Apache-2.0) and the
  LBR iiwa 14 R820 (`pybullet_data`'s `kuka_iiwa/model.urdf`, from Krug and Stoyanov's `lbr_iiwa`
  description, BSD-3-Clause). Their link frames are wsmap's body frames up to a constant transform
  per body (`frame_offsets` measures it on every load and checks it is constant), with the same
  joint angles;
* `CommittedHulls` — the convex hulls of a vendor description's collision meshes committed with
  wsmap as package data, with the licence and a `SOURCE.md` (repository, commit, paths, git blob
  hashes): the UR5e and the UR10e (Universal Robots' `Universal_Robots_ROS2_Description`,
  BSD-3-Clause, `urdf/ur.urdf.xacro` expanded with `ur_type:=ur5e`/`ur10e`;
  `data/ur_description/`, written by `tools/vendor_hulls.py`, which checked the frames when it
  derived them: the vendor's `default_kinematics.yaml` is wsmap's DH table to 8e-10 m), and the
  Kinova Gen3 (Kinova's `ros2_kortex`, BSD-3-Clause, `kortex_description/robots/gen3.xacro`
  expanded with `dof:=7`, its `.dae` collision meshes; `data/kortex_description/`). Kinova's URDF
  is not wsmap's DH table (lengths to 0.01 mm, a 0.175 mm offset, pi/2 as 1.5708): its link frames
  leave wsmap's bodies by up to 0.73 mm (the bracelet) as the joints turn, so each Gen3 hull is
  committed grown by its link's measured bound (0-0.8 mm), and wsmap's hull holds Kinova's wherever
  both sit (`tools/vendor_hulls.py`, tested in `tests/collision/test_vendor_judge.py`). They need
  nothing installed.

* `mesh_model(name)` — the vendor's collision meshes (the arm's links only, without a hand), in
  the bodies' frames of wsmap's chain; the exact checks take each mesh's convex hull
  (`wsmap.collision.shapes.mesh`), grown by `MESH_MARGIN` (1 mm, Bullet's margin around a hull).
  Without the package that ships a `PackagedURDF` (pybullet_data, a test dependency) a one-line
  `CollisionError` names it.
* `fitted_model(name)` — capsules (cylinders where a part is flat: the flange discs) that
  enclose every vertex of each link's mesh hull plus `PADDING`, fitted by `tools/fit_collision_spheres.py` and committed in
  `wsmap/collision/data/fitted_<arm>.json` with their source, the package version or the hull
  file's hash, and the slack per link (fitted volume over hull volume), and with the
  allowed-collision matrix built on the vendor meshes (the shapes of two links a joint apart
  overlap where the housings do not, so the pairs never checked are the meshes'). Needs nothing
  but numpy.
* `two_level_model(name)` — the meshes, with the fitted capsules as their coarse model
  (`CollisionModel.coarse`): a checker asks the capsules first and the meshes only where the
  capsules say colliding, so it answers as the meshes do (`wsmap.collision.checks`). Not the
  default of any arm today (the record's `default`): where it was measured it cost more than it
  saved (docs/collision.md).

`mesh_model` and `two_level_model` carry the allowed-collision matrix committed with the fitted
capsules: it was built on these meshes, grown by the margin (`build_acm`, 10,000 samples, seed 0),
so a checker need not sample it again.

Both models name their links `link0` ... `link<n>` by body (as the capsule models along the links
do), ride on the chain of `wsmap.load(name)` and stand on the floor `z = 0`.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import os
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from ..robots import load
from .acm import acm_from_record
from .errors import CollisionError
from .geometry import CollisionModel, Link, Shape, body_frames, from_urdf_collision, segment_shape

if TYPE_CHECKING:  # names of the annotations only
    from wsmap.kinematics.chain import Arm

__all__ = ["VENDOR", "PADDING", "MESH_MARGIN", "VendorDescription", "PackagedURDF", "CommittedHulls", "VendorLink",
           "vendor_record", "vendor_urdf", "vendor_installed", "frame_offsets", "mesh_model", "fitted_model",
           "two_level_model", "fitted_record", "FITTED", "segment_shape", "same_kinematics"]

#: Metres by which the checks grow every vendor mesh hull (`CollisionModel.margin`): Bullet keeps
#: a collision margin of about a millimetre around each convex hull, so PyBullet (the judge of
#: `tests/collision/test_vendor_judge.py`) finds two hulls in contact that coal keeps up to 2 mm
#: apart (measured: coal's distance minus PyBullet's, 1.96-1.99 mm, on near-contact configurations
#: of both arms). Two hulls closer than 2 mm, or a hull within 1 mm of an obstacle, collide.
MESH_MARGIN = 0.001

#: Metres added to every fitted capsule's radius beyond the farthest hull vertex: Bullet keeps a
#: collision margin of about a millimetre around a convex hull (`tests/collision/test_pybullet.py`),
#: so PyBullet can call a pair touching that coal's hulls keep up to ~1 mm apart.
PADDING = 0.002


def _trimesh_missing(name: str) -> str | None:
    """A one-line reason when trimesh (which reads the meshes and encloses their hulls in spheres,
    `wsmap.collision.shapes.mesh`) cannot be imported, else None."""
    try:
        import trimesh  # noqa: F401
    except ImportError:
        return (f"the vendor meshes of {name!r} need trimesh, which is not installed: pip install 'wsmap[views]' "
                "(or geometry='fitted': the capsules fitted around them need nothing)")
    return None


@dataclass(frozen=True, eq=False)
class VendorLink:
    """One vendor link on wsmap's chain: its vendor `name`, the `body` it rides on, its own `frame`
    `(4, 4)` in that body's frame, its collision `shapes` (meshes, placed in the body's frame) and the
    vendor's mesh files it comes from (`meshes`, relative to the description)."""

    name: str
    body: int
    frame: np.ndarray
    shapes: tuple
    meshes: tuple[str, ...]


@dataclass(frozen=True)
class VendorDescription(ABC):
    """Where a named arm's vendor collision meshes are (one record per arm in `VENDOR`): `links`
    (the vendor links of bodies 0..n, in order), `licence` and `origin` (who made the description),
    `default` (the geometry `wsmap.collision.checker_for` gives the arm where the meshes are:
    `"meshes"` or `"two-level"`, whichever is faster: both give the same answers). A subclass says
    where the meshes are read from."""

    links: tuple[str, ...]
    licence: str
    origin: str
    default: str

    @abstractmethod
    def installed(self) -> bool:
        """Whether the meshes can be read and checked here (their package, if any, and trimesh)."""

    @abstractmethod
    def label(self) -> str:
        """Where the meshes are read from, for a model's `source`."""

    @abstractmethod
    def vendor_links(self, name: str, arm: Arm) -> list[VendorLink]:
        """The vendor links of bodies 0..n on `arm` (the named arm `name`'s kinematics), or a
        one-line `CollisionError` (not installed, other kinematics)."""

    @abstractmethod
    def source_record(self, name: str) -> dict:
        """What `tools/fit_collision_spheres.py` records of the source (`fitted_record`'s `source`)."""


@dataclass(frozen=True)
class PackagedURDF(VendorDescription):
    """A vendor URDF shipped by an installed Python package: `package` (the importable module whose
    folder holds it), `distribution` (what pip installs), `urdf` (relative to the package's folder).
    Its link frames are checked against wsmap's bodies on every load (`frame_offsets`)."""

    package: str = ""
    distribution: str = ""
    urdf: str = ""

    def installed(self) -> bool:
        return importlib.util.find_spec(self.package) is not None and _trimesh_missing("") is None

    def label(self) -> str:
        return f"{self.package}/{self.urdf}"

    def path(self, name: str) -> str:
        """The URDF's path; a one-line `CollisionError` when the package is not installed."""
        spec = importlib.util.find_spec(self.package)
        if spec is None or not spec.submodule_search_locations:
            raise CollisionError(f"the vendor meshes of {name!r} come from {self.package}/{self.urdf}, which is not "
                                 f"installed: pip install {self.distribution}")
        return os.path.join(list(spec.submodule_search_locations)[0], self.urdf)

    def vendor_links(self, name, arm):
        path = self.path(name)
        if _trimesh_missing(name):
            raise CollisionError(_trimesh_missing(name))
        vendor = from_urdf_collision(path, ee_link=self.links[-1], base_link=self.links[0])
        X = frame_offsets(vendor.chain, arm)
        by_name = {lk.name: lk for lk in vendor.links}
        return [VendorLink(lname, k, frame=X[k] @ by_name[lname].frame,
                           shapes=tuple(s.placed(X[k]) for s in by_name[lname].shapes),
                           meshes=tuple(sorted({os.path.relpath(s.source, os.path.dirname(path))
                                                for s in by_name[lname].shapes})))
                for k, lname in enumerate(self.links)]

    def source_record(self, name):
        from importlib.metadata import version

        with open(self.path(name), "rb") as fh:
            sha = hashlib.sha256(fh.read()).hexdigest()
        v = version(self.distribution)
        return {"package": self.package, "version": v, "urdf": self.urdf, "urdf_sha256": sha, "licence": self.licence,
                "origin": self.origin, "label": f"{self.package} {v} {self.urdf}"}


@dataclass(frozen=True)
class CommittedHulls(VendorDescription):
    """The convex hulls of a vendor description's collision meshes, committed as package data
    (`data/<hulls>`, written by `tools/vendor_hulls.py` with the licence and a `SOURCE.md`): per
    link the hull's vertices in the vendor link's frame and that frame in wsmap's body frame, checked
    when derived (`frame_offsets` on 200 random configurations) and by PyBullet on the vendor's own
    URDF in `tests/collision/test_vendor_judge.py`. Read with numpy alone; checked with coal and
    trimesh (the hulls' enclosing spheres), as every mesh."""

    hulls: str = ""

    def installed(self) -> bool:
        return _trimesh_missing("") is None

    def label(self) -> str:
        return f"wsmap/collision/data/{self.hulls}"

    def vendor_links(self, name, arm):
        if not same_kinematics(arm, load(name)):
            raise CollisionError(f"the vendor meshes of {name!r} are in the bodies' frames of the named arm; this arm's "
                                 "kinematics differ (give geometry='capsules' for capsules along its links)")
        if _trimesh_missing(name):
            raise CollisionError(_trimesh_missing(name))
        rec = _hull_record(self.hulls)
        out = []
        for lk in rec["links"]:
            frame = np.array(lk["frame"], dtype=np.float64)
            shape = Shape("mesh", (), frame, np.array(lk["vertices"], dtype=np.float64),
                          source=f"{self.label()}#{lk['name']}")
            out.append(VendorLink(lk["name"], int(lk["body"]), frame=frame, shapes=(shape,), meshes=tuple(lk["meshes"])))
        if [v.name for v in out] != list(self.links):
            raise CollisionError(f"{self.label()} holds the links {[v.name for v in out]}, expected {list(self.links)}")
        return out

    def source_record(self, name):
        src = _hull_record(self.hulls)["source"]
        with open(os.path.join(_data_dir(), self.hulls), "rb") as fh:
            sha = hashlib.sha256(fh.read()).hexdigest()
        return {"package": "wsmap", "hulls": f"wsmap/collision/data/{self.hulls}", "hulls_sha256": sha,
                "repository": src["repository"], "commit": src["commit"], "licence": self.licence,
                "origin": self.origin, "label": f"{self.label()} (commit {src['commit'][:12]})"}


_UR_LINKS = ("base_link_inertia", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
             "wrist_2_link", "wrist_3_link")


def _ur(arm: str) -> CommittedHulls:
    return CommittedHulls(
        # the meshes, not the two-level check: the fitted capsules call most of what a closed-form
        # map asks about colliding (coarse level free for 12 % of the UR5e's tool-down queries), so
        # the coarse level costs more than it saves (docs/collision.md: 1.41 s against 1.16 s)
        links=_UR_LINKS, default="meshes", hulls=f"ur_description/{arm}.json",
        licence="BSD-3-Clause (wsmap/collision/data/ur_description/LICENSE)",
        origin=f"Universal Robots' ROS 2 description (Universal_Robots_ROS2_Description), urdf/ur.urdf.xacro with "
               f"ur_type:={arm}: collision meshes meshes/{arm}/collision/*.stl as convex hulls "
               "(data/ur_description/SOURCE.md)")


#: The named arms with a vendor description, by name (one record each: where its meshes are).
VENDOR: dict[str, VendorDescription] = {
    "panda": PackagedURDF(
        package="pybullet_data", distribution="pybullet", urdf="franka_panda/panda.urdf",
        links=tuple(f"panda_link{k}" for k in range(8)), default="meshes",
        licence="Apache-2.0 (pybullet_data/franka_panda/LICENSE.txt)",
        origin="Franka Emika's franka_description, collision meshes meshes/collision/link0-7.obj"),
    "iiwa14": PackagedURDF(
        package="pybullet_data", distribution="pybullet", urdf="kuka_iiwa/model.urdf",
        links=tuple(f"lbr_iiwa_link_{k}" for k in range(8)), default="meshes",
        licence="BSD-3-Clause (the header of pybullet_data/kuka_iiwa/model.urdf)",
        origin="Krug and Stoyanov's lbr_iiwa description of the LBR iiwa 14 R820 (AASS, Orebro University), "
               "collision meshes meshes/link_0-7.stl"),
    "ur5e": _ur("ur5e"),
    "ur10e": _ur("ur10e"),
    "gen3": CommittedHulls(
        links=("base_link", "shoulder_link", "half_arm_1_link", "half_arm_2_link", "forearm_link",
               "spherical_wrist_1_link", "spherical_wrist_2_link", "bracelet_link"),
        default="meshes", hulls="kortex_description/gen3.json",
        licence="BSD-3-Clause (wsmap/collision/data/kortex_description/LICENSE)",
        origin="Kinova's ROS 2 description (ros2_kortex), kortex_description/robots/gen3.xacro with dof:=7 (no vision "
               "module): collision meshes arms/gen3/7dof/meshes/*.dae as convex hulls, each grown by its link's "
               "frame mismatch against wsmap's DH table (up to 0.8 mm; data/kortex_description/SOURCE.md)"),
}


def vendor_record(name: str) -> VendorDescription:
    """The `VENDOR` record of the named arm; a one-line `CollisionError` listing the arms if none."""
    rec = VENDOR.get(name)
    if rec is None:
        raise CollisionError(f"no vendor collision meshes for robot {name!r}; arms with them: {', '.join(VENDOR)}")
    return rec


def vendor_urdf(name: str) -> str:
    """The path of the named arm's vendor URDF in an installed package (`PackagedURDF`); a one-line
    `CollisionError` when the arm has none or the package that ships it is not installed."""
    rec = vendor_record(name)
    if not isinstance(rec, PackagedURDF):
        raise CollisionError(f"the vendor meshes of {name!r} are committed convex hulls ({rec.label()}), not a URDF "
                             "file in a package")
    return rec.path(name)


def vendor_installed(name: str) -> bool:
    """Whether the named arm has a vendor description whose meshes can be read here."""
    rec = VENDOR.get(name)
    return rec is not None and rec.installed()


def same_kinematics(a: Arm, b: Arm) -> bool:
    """Whether two single arms have the same joints and fixed transforms (their limits may differ)."""
    from ..kinematics.chain import as_chain

    a, b = as_chain(a), as_chain(b)
    if a.n != b.n or a.batch_shape != () or b.batch_shape != ():
        return False
    base_a = np.eye(4) if a.base is None else a.base
    base_b = np.eye(4) if b.base is None else b.base
    return (np.array_equal(a.kinds, b.kinds) and np.allclose(a.axes, b.axes, atol=1e-12)
            and np.allclose(a.offset, b.offset, atol=1e-12) and np.allclose(a.fixed, b.fixed, atol=1e-12)
            and np.allclose(base_a, base_b, atol=1e-12))


def frame_offsets(vendor: Arm, arm: Arm, *, samples: int = 16, tol: float = 1e-6) -> np.ndarray:
    """The constant transform of each vendor body frame in wsmap's: `X` `(n + 1, 4, 4)` with
    `B_arm_k(q) · X_k = B_vendor_k(q)` for every `q` (same joint angles).

    Measured at `q = 0` and checked at `samples` random configurations (seed 0) inside the limits:
    a difference over `tol` (m, and rad in the rotation's entries) is a `CollisionError` (the
    descriptions then move differently: another zero, sign or length)."""
    if vendor.n != arm.n:
        raise CollisionError(f"the vendor description has {vendor.n} joints, the arm {arm.n}")
    X = np.linalg.inv(body_frames(arm, np.zeros((1, arm.n)))[0]) @ body_frames(vendor, np.zeros((1, arm.n)))[0]
    lim = np.clip(arm.limits, -np.pi, np.pi)
    q = np.random.default_rng(0).uniform(lim[:, 0], lim[:, 1], (samples, arm.n))
    err = np.abs(body_frames(arm, q) @ X - body_frames(vendor, q)).max(axis=(0, 2, 3))
    if np.any(err > tol):
        k = int(np.argmax(err))
        raise CollisionError(f"the vendor description's body {k} does not move with wsmap's (off by {err[k]:.3g}): "
                             "not the same kinematics")
    return X


def mesh_model(name: str, robot: Arm | None = None) -> CollisionModel:
    """The named arm's vendor collision meshes on `robot` (default `wsmap.load(name)`; its limits
    may differ, its kinematics must be the named arm's): one link per body, `link0` ... `link<n>`,
    each with the meshes of the vendor link on that body (the module notes), on the floor."""
    rec = vendor_record(name)
    arm = load(name) if robot is None else robot
    links = tuple(Link(f"link{v.body}", v.body, v.shapes, parent=f"link{v.body - 1}" if v.body else None, frame=v.frame)
                  for v in rec.vendor_links(name, arm))
    model = CollisionModel(arm, links, source=f"{rec.label()}: collision meshes of {', '.join(rec.links)} "
                           f"({rec.origin}; {rec.licence}), grown by {MESH_MARGIN * 1e3:g} mm", floor=True,
                           margin=MESH_MARGIN)
    if name in FITTED:  # the matrix committed with the fitted capsules is these meshes' (module notes)
        model.acm = acm_from_record(model, {"links": list(model.names), **fitted_record(name)["acm"]})
    return model


def two_level_model(name: str, robot: Arm | None = None) -> CollisionModel:
    """The named arm's vendor meshes (`mesh_model`) with the capsules fitted around them
    (`fitted_model`) as their `coarse` model: checked on the capsules first, on the meshes where the
    capsules collide (module notes). Needs the vendor package, as `mesh_model`; a `CollisionError`
    for an arm without fitted capsules."""
    if name not in FITTED:
        raise CollisionError(f"no fitted collision capsules for robot {name!r}; named arms with them: "
                             f"{', '.join(FITTED)}")
    fine = mesh_model(name, robot)
    coarse = fitted_model(name, fine.chain)
    return replace(fine, coarse=coarse, source=f"two-level: {coarse.source}; where they collide, {fine.source}")


def _data_dir() -> str:
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")


@lru_cache(maxsize=None)
def _hull_record(path: str) -> dict:
    """The committed hull file `data/<path>` (`CommittedHulls`, written by `tools/vendor_hulls.py`)."""
    with open(os.path.join(_data_dir(), path), encoding="utf-8") as fh:
        return json.load(fh)


#: The named arms with fitted capsules committed (`data/fitted_<arm>.json`).
FITTED: tuple[str, ...] = tuple(sorted(
    f[len("fitted_"):-len(".json")] for f in os.listdir(_data_dir())
    if f.startswith("fitted_") and f.endswith(".json"))) if os.path.isdir(_data_dir()) else ()


@lru_cache(maxsize=None)
def fitted_record(name: str) -> dict:
    """The committed record of the named arm's fitted capsules (`data/fitted_<name>.json`): its
    `source` (package, version, URDF, licence), `padding` (m) and per link `name` (the vendor's),
    `body`, `meshes`, `shapes` (`kind` capsule or cylinder, axis ends `p0`, `p1` and `radius`, m,
    the body's frame of wsmap's chain), `hull_volume`, `fitted_volume` (m³) and `slack` (their
    ratio); `acm`: the allowed-collision
    matrix of the vendor meshes (`samples`, `seed`, `disabled` pairs with their reasons)."""
    if name not in FITTED:
        raise CollisionError(f"no fitted capsules for robot {name!r}; arms with them: {', '.join(FITTED)}")
    with open(os.path.join(_data_dir(), f"fitted_{name}.json"), encoding="utf-8") as fh:
        return json.load(fh)


def fitted_model(name: str, robot: Arm | None = None) -> CollisionModel:
    """The capsules (and cylinders) fitted around the named arm's vendor meshes (`fitted_record`),
    on `robot` (default `wsmap.load(name)`; its limits may differ, its kinematics must be the named
    arm's: the shapes are fixed numbers in its bodies' frames), standing on the floor; links
    `link0` ... `link<n>` by body, the allowed-collision matrix of the vendor meshes."""
    rec = fitted_record(name)
    arm = load(name) if robot is None else robot
    if not same_kinematics(arm, load(name)):
        raise CollisionError(f"the fitted capsules of {name!r} are in the bodies' frames of the named arm; "
                             "this arm's kinematics differ (give geometry='capsules' for capsules along its links)")
    links = []
    for lk in sorted(rec["links"], key=lambda x: int(x["body"])):
        k = int(lk["body"])
        shapes = tuple(segment_shape(sh["kind"], sh["p0"], sh["p1"], sh["radius"]) for sh in lk["shapes"])
        links.append(Link(f"link{k}", k, shapes, parent=links[-1].name if links else None))
    src = rec["source"]
    model = CollisionModel(arm, tuple(links), floor=True,
                           source=f"capsules fitted around {src['label']} collision meshes (every hull vertex inside, "
                                  f"+{rec['padding'] * 1e3:g} mm; tools/fit_collision_spheres.py)")
    model.acm = acm_from_record(model, {"links": list(model.names), **rec["acm"]})
    return model
