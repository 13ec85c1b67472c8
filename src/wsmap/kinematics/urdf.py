"""Serial chains from URDF: the path of joints from a base link to an end link.

`from_urdf` reads a URDF (a file or its XML text) into a `SerialChain`:

* the joints on the path from `base_link` (default: the root) to `ee_link` (default: the one
  leaf, if the tree does not branch) become the chain; side branches (a gripper's fingers, a
  `base` or `tool0` frame beside the path) are ignored;
* fixed joints are folded into the neighbouring fixed transforms; revolute joints carry their
  `<limit>`; continuous joints are unlimited (`±inf`); prismatic joints carry their stroke; a
  `<limit>` without `lower` or `upper` reads it as 0, the specification's default (as
  urdfdom and Pinocchio do), with a `URDFWarning` (without both the joint cannot move);
* elements in an XML namespace (`<robot xmlns="...">`) are read by their local names, as
  urdfdom reads them;
* a mimic joint on the path (`<mimic joint= multiplier= offset=>`: its value is
  `multiplier · q + offset`, `q` its driver's) follows its driver, the chain's variable. A
  driver off the path (a gripper's second finger, the chain ending at it) that drives one joint of
  the path at a multiplier of ±1 takes the mimic joint's place: the joint moves by
  `sign · (q + sign · offset)` along or about its axis, and `q` keeps to the driver's limits
  narrowed to those that keep the mimic joint inside its own (an uncoupled chain, as before
  coupled joints were read). Any other mimic (a driver on the path, a parallelogram's passive
  joint; a driver of two joints; any finite non-zero multiplier) makes a chain with coupled
  joints (`SerialChain.couple`, `wsmap.kinematics.chain.Coupling`): the variables are the
  drivers, in the order of the first joint each drives, limited to the values that keep every
  joint they drive inside its own limits (and a driver off the path to its own). Refused
  (`URDFError`, naming the joints): a driver that is not a joint, is the joint itself or is a
  mimic joint itself, a multiplier of 0, a driver of another kind (prismatic driving revolute),
  limits that leave no common value;
* a floating or planar joint on the path is refused (`URDFError`, naming it), as
  are: text that is not XML, a link that does not exist, no path from base to end, a loop (a link
  with two parents, or a cycle), a NaN or infinite number in an origin, an axis or a limit,
  limits with `lower > upper`, a `<limit>` on the chain without the `effort` or `velocity`
  the specification requires, a `<robot>` without a name, and unexpanded xacro;
* meshes are never loaded, so a URDF whose meshes are missing reads the same;
* a revolute joint whose limits reach beyond `UNBOUNDED_LIMIT` (1e6 rad, 160,000 turns) on
  either side, spanning at least a turn, is read as continuous (`±inf`): it reaches every angle,
  and float64 angles that large lose the precision the searches wrap by (±1e308 found 3 of a map's
  4 nodes where `continuous` found all 4); such a limit spanning less than a turn is refused;
* the XML is refused before it is parsed into a tree when it declares entities (`<!ENTITY>`:
  an entity bomb expands a kilobyte into gigabytes; URDF has no use for them) or nests deeper
  than `MAX_XML_DEPTH` levels (URDF needs five; the tree walks recurse).

The transforms come from yourdfpy's joint objects (origins with `rpy`:
`R = Rz(yaw) · Ry(pitch) · Rx(roll)`, the URDF convention). yourdfpy is lax about broken files
(it recovers from malformed XML, accepts NaN origins and cycles, and fails on an undefined link
with `list.remove(x): x not in list`), so the XML is checked here first with `xml.etree`.
"""

from __future__ import annotations

import io
import logging
import math
import os
import xml.etree.ElementTree as ET

import numpy as np

from .chain import PRISMATIC, REVOLUTE, SerialChain
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import PathLike

__all__ = ["URDFError", "URDFWarning", "URDFTree", "from_urdf", "parse_xml", "read_source", "rpy_matrix",
           "moving_off_chain",
           "UNBOUNDED_LIMIT", "MAX_XML_DEPTH"]

#: Limits (rad) of a revolute joint beyond which it is read as continuous (module notes).
UNBOUNDED_LIMIT = 1e6
#: The deepest element nesting a URDF may have (`<robot><link><collision><geometry><mesh>` is 5).
MAX_XML_DEPTH = 64

#: Joint types of the URDF specification.
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
_MOVABLE = {"revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}


class URDFError(ValueError):
    """A URDF that cannot be read as a serial chain; the message names what is wrong."""


class URDFWarning(UserWarning):
    """A URDF read as the specification says, but probably not as its author meant (a joint whose
    `<limit>` lacks `lower`/`upper`, read as 0)."""


# ---------------------------------------------------------------------------------------- reading
def read_source(source: PathLike | bytes) -> tuple[bytes, str, str | None]:
    """The bytes of a URDF given as a file or as its text.

    Parameters
    ----------
    source : path, str or bytes
        A URDF file, or the URDF's XML text (bytes, or a string with a `<` in it that is not the
        name of a file).

    Returns
    -------
    data : bytes
        The XML.
    label : str
        The URDF named for messages: `"URDF file 'PATH'"` or `"URDF text"`.
    path : str or None
        The file's path, or None for text.

    Raises
    ------
    FileNotFoundError
        No such file.
    TypeError
        `source` is neither a path nor text.
    """
    if isinstance(source, bytes):
        return source, "URDF text", None
    if isinstance(source, str) and "<" in source and not os.path.isfile(source):  # XML text, not a file named "a<b"
        return source.encode("utf-8"), "URDF text", None
    if not isinstance(source, (str, os.PathLike)):
        raise TypeError(f"URDF source must be a path or the URDF's XML text, got {type(source).__name__}")
    path = os.fspath(source)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"no such URDF file: {path!r}")
    with open(path, "rb") as f:
        return f.read(), f"URDF file {path!r}", path


def _q(value) -> str:
    """A value read from the file, quoted for a message, cut to 60 characters: a 20 MB attribute
    made a 20 MB error line."""
    text = repr(value)
    return text if len(text) <= 80 else f"{text[:60]}... ({len(str(value))} characters)"


def _local(tag) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _prescan(data: bytes, label: str, kind: str = "URDF") -> None:
    """Refuse entity declarations and deep nesting while expat streams the XML, before a tree is
    built (expat's own guard stops only the largest entity expansions, and the tree's walks
    recurse); `kind` names the format in messages (`"URDF"`, `"SRDF"`)."""
    from xml.parsers import expat

    parser = expat.ParserCreate()
    depth = [0]
    a_kind = f"{'an' if kind[:1] in 'AEFHILMNORSX' else 'a'} {kind}"  # an SRDF, a URDF

    def start(name, attrs):
        depth[0] += 1
        if depth[0] > MAX_XML_DEPTH:
            raise URDFError(f"{label} nests its elements deeper than {MAX_XML_DEPTH} levels (at line "
                            f"{parser.CurrentLineNumber}); {a_kind} needs five")

    def end(name):
        depth[0] -= 1

    def entity(name, *args):
        raise URDFError(f"{label} declares the XML entity {_q(name)} (line {parser.CurrentLineNumber}); {a_kind} "
                        "declares none (an entity bomb expands a few lines into gigabytes)")

    parser.StartElementHandler, parser.EndElementHandler, parser.EntityDeclHandler = start, end, entity
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise URDFError(f"{label} is not XML: {exc}") from None


def parse_xml(data: bytes, label: str, kind: str = "URDF") -> ET.Element:
    """The `<robot>` element of a URDF's XML, checked, with every tag by its local name.

    Parameters
    ----------
    data : bytes
        The XML (`read_source`).
    label : str
        What to call the URDF in messages.
    kind : str
        The format named in messages: `"URDF"`, or `"SRDF"` (MoveIt's semantic description, whose
        root is a `<robot>` too).

    Returns
    -------
    xml.etree.ElementTree.Element
        The root `<robot>` element; tags in an XML namespace are renamed to their local names, as
        urdfdom reads them.

    Raises
    ------
    URDFError
        Not XML, entity declarations, nesting deeper than `MAX_XML_DEPTH`, a root that is not
        `<robot>`, a `<robot>` without a name, or unexpanded xacro.
    """
    _prescan(data, label, kind)
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise URDFError(f"{label} is not XML: {exc}") from None
    if _local(root.tag) != "robot":
        raise URDFError(f"{label}: the root element is <{_local(root.tag)}>, not <robot>")
    for el in root.iter():
        if isinstance(el.tag, str) and el.tag.startswith("{") and "xacro" in el.tag.split("}")[0]:
            raise URDFError(f"{label} contains xacro (<xacro:{_local(el.tag)}>): expand it to plain URDF first "
                            "(e.g. with the xacro tool)")
    if not root.get("name"):
        raise URDFError(f"{label}: the <robot> element has no name (the {kind} specification requires one)")
    for el in root.iter():  # a namespace (xmlns="..." on <robot>) is not part of URDF: read local names
        if isinstance(el.tag, str) and el.tag.startswith("{"):
            el.tag = _local(el.tag)
    return root


def _numbers(label: str, what: str, text: str | None, default: str) -> np.ndarray:
    text = default if text is None else text
    try:
        v = np.array([float(x) for x in text.split()], dtype=np.float64)
    except ValueError:
        raise URDFError(f"{label}: {what} is not three numbers: {_q(text)}") from None
    if v.shape != (3,):
        raise URDFError(f"{label}: {what} is not three numbers: {_q(text)}")
    if not np.all(np.isfinite(v)):
        raise URDFError(f"{label}: {what} contains NaN or infinity: {_q(text)}")
    return v


def _limit_value(label: str, jname: str, limit: ET.Element, key: str) -> float:
    text = limit.get(key)
    if text is None:
        return 0.0  # the specification's default; from_urdf warns
    try:
        v = float(text)
    except ValueError:
        raise URDFError(f"{label}: joint {jname!r} has a non-numeric limit {key}={_q(text)}") from None
    if math.isnan(v):
        raise URDFError(f"{label}: joint {jname!r} has a NaN limit {key}={_q(text)}")
    return v


def _new_name(el: ET.Element, tag: str, seen, label: str) -> str:
    """The `name` of a `<link>` or `<joint>` element `el`; a `URDFError` when it has none
    or when `seen` (the names of that tag so far) holds it already."""
    name = el.get("name")
    if not name:
        raise URDFError(f"{label}: a <{tag}> has no name")
    if name in seen:
        raise URDFError(f"{label}: {tag} {_q(name)} is defined twice")
    return name


class URDFTree:
    """The links and joints of a URDF, checked: unique names, defined links, finite joint origins
    and axes, one tree without loops.

    Parameters
    ----------
    root : xml.etree.ElementTree.Element
        The `<robot>` element (`parse_xml`).
    label : str
        What to call the URDF in messages.

    Attributes
    ----------
    links : list of str
        The link names, in file order.
    joints : dict
        Joint name -> its `<joint>` element, in file order.
    parent_joint : dict
        Child link -> the joint above it.
    children : dict
        Link -> the names of the joints below it, in file order.

    Raises
    ------
    URDFError
        A missing or repeated name, an unknown joint type or link, a NaN or infinite origin or
        axis, a loop.
    """

    def __init__(self, root: ET.Element, label: str):
        self.label = label
        self.links: list[str] = []
        known: set[str] = set()
        for el in root.findall("link"):
            self.links.append(_new_name(el, "link", known, label))
            known.add(self.links[-1])
        self.joints: dict[str, ET.Element] = {}
        self.parent_joint: dict[str, str] = {}  # child link -> joint
        self.children: dict[str, list[str]] = {name: [] for name in self.links}  # link -> joints
        for el in root.findall("joint"):
            name = _new_name(el, "joint", self.joints, label)
            jtype = el.get("type")
            if jtype not in JOINT_TYPES:
                raise URDFError(f"{label}: joint {_q(name)} has type {_q(jtype)}; URDF types are {', '.join(JOINT_TYPES)}")
            ends = {}
            for end in ("parent", "child"):
                e = el.find(end)
                link = None if e is None else e.get("link")
                if not link:
                    raise URDFError(f"{label}: joint {_q(name)} has no <{end} link=...>")
                if link not in known:
                    raise URDFError(f"{label}: joint {_q(name)} names an unknown {end} link {_q(link)}")
                ends[end] = link
            o = el.find("origin")
            _numbers(label, f"joint {name!r} <origin xyz>", None if o is None else o.get("xyz"), "0 0 0")
            _numbers(label, f"joint {name!r} <origin rpy>", None if o is None else o.get("rpy"), "0 0 0")
            a = el.find("axis")
            _numbers(label, f"joint {name!r} <axis xyz>", None if a is None else a.get("xyz"), "1 0 0")
            child = ends["child"]
            if child in self.parent_joint:
                raise URDFError(f"{label}: link {child!r} has two parent joints, {self.parent_joint[child]!r} and "
                                f"{_q(name)}: a loop (a URDF must be a tree)")
            if ends["parent"] == child:
                raise URDFError(f"{label}: joint {_q(name)} connects link {child!r} to itself: a loop")
            self.joints[name] = el
            self.parent_joint[child] = name
            self.children[ends["parent"]].append(name)
        # a cycle: following parents from some link never reaches a root. Each link has at most one
        # parent, so one walk per link that stops at a link already known to reach a root visits
        # every link once: linear (a chain of 5000 fixed links is 5000 steps, not 5000² list scans).
        parent = {child: self.parent(child) for child in self.parent_joint}
        rooted: set[str] = set()
        for start in self.links:
            path, on_path, link = [], set(), start
            while link not in rooted and link in parent:
                if link in on_path:
                    cycle = path[path.index(link):] + [link]
                    raise URDFError(f"{label}: the joints form a loop: {' -> '.join(reversed(cycle))}")
                path.append(link)
                on_path.add(link)
                link = parent[link]
            rooted.update(path)
            rooted.add(link)

    def parent(self, link: str) -> str:
        """The parent link of `link` (a link that has a parent joint)."""
        return self.joints[self.parent_joint[link]].find("parent").get("link")

    def child(self, joint: str) -> str:
        """The child link of the joint `joint`."""
        return self.joints[joint].find("child").get("link")

    def check_link(self, link: str, role: str):
        """A `URDFError` listing the links if `link` (the `role`, e.g. `"base_link"`) is not one."""
        if link not in self.children:
            raise URDFError(f"{self.label}: unknown {role} {_q(link)}; the links are: {', '.join(self.links)}")

    def root(self) -> str:
        """The one root link; a `URDFError` when there is none or several (then give a base link)."""
        roots = [link for link in self.links if link not in self.parent_joint]
        if not roots:
            raise URDFError(f"{self.label} has no links")
        if len(roots) > 1:
            raise URDFError(f"{self.label} is not one tree: it has several root links ({', '.join(roots)}); "
                            "give base_link (wsmap map/place: --base LINK)")
        return roots[0]

    def leaves_below(self, base: str) -> list[str]:
        """The links without children below `base` (depth first, file order)."""
        leaves, stack = [], [base]
        while stack:
            link = stack.pop()
            kids = [self.child(j) for j in self.children[link]]
            if not kids:
                leaves.append(link)
            stack.extend(reversed(kids))
        return leaves

    def path(self, base: str, ee: str) -> list[str]:
        """Joint names from `base` down to `ee`."""
        joints, link = [], ee
        while link != base:
            if link not in self.parent_joint:
                raise URDFError(f"{self.label}: no path from base link {base!r} to end link {ee!r} "
                                f"({ee!r} is not below {base!r})")
            joints.append(self.parent_joint[link])
            link = self.parent(link)
        return joints[::-1]


# ---------------------------------------------------------------------------------------- the chain
def _load_yourdfpy(data: bytes, path: str | None, label: str):
    from .._optional import require

    yourdfpy = require("yourdfpy", why="a URDF arm")

    # yourdfpy logs (and recovers from) what it finds odd; the XML has been checked already
    level = logging.getLogger("yourdfpy").level
    logging.getLogger("yourdfpy").setLevel(logging.CRITICAL)
    try:
        return yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False, build_collision_scene_graph=False,
                                  load_meshes=False, load_collision_meshes=False,
                                  mesh_dir=os.path.dirname(path) if path else "")
    except Exception as exc:  # e.g. a non-numeric attribute off the chain, which yourdfpy parses too
        raise URDFError(f"{label}: yourdfpy cannot read it: {type(exc).__name__}: {exc}") from exc
    finally:
        logging.getLogger("yourdfpy").setLevel(level)


def _limits(label: str, jname: str, jtype: str, el: ET.Element) -> tuple[float, float]:
    """`(lower, upper)` of a movable joint on the chain (`±inf` for a continuous one)."""
    if jtype == "continuous":
        return -np.inf, np.inf
    limit = el.find("limit")
    if limit is None:
        raise URDFError(f"{label}: {jtype} joint {jname!r} has no <limit lower=... upper=...>")
    lo = _limit_value(label, jname, limit, "lower")
    hi = _limit_value(label, jname, limit, "upper")
    for key in ("effort", "velocity"):
        if limit.get(key) is None:  # urdfdom (ROS, Pinocchio) refuses the file too
            raise URDFError(f"{label}: joint {jname!r} has a <limit> without {key!r} (the URDF "
                            "specification requires effort and velocity on every <limit>)")
    missing = [k for k in ("lower", "upper") if limit.get(k) is None]
    if missing:
        import warnings

        still = (" so it cannot move" if lo == hi else "")
        # stacklevel: this function, _chain_joints, from_urdf, then from_urdf's caller
        warnings.warn(f"{label}: joint {jname!r} has a <limit> without {' and '.join(missing)}: read as 0 "
                      f"(the URDF specification's default), limits [{lo:g}, {hi:g}]{still}",
                      URDFWarning, stacklevel=4)
    if lo > hi:
        raise URDFError(f"{label}: joint {jname!r} has lower limit {lo} above its upper limit {hi}")
    if jtype == "prismatic" and not (np.isfinite(lo) and np.isfinite(hi)):
        raise URDFError(f"{label}: prismatic joint {jname!r} needs finite limits, got [{lo}, {hi}]")
    if jtype == "revolute" and max(-lo, hi) > UNBOUNDED_LIMIT:
        # every angle is in reach, and angles this large have lost the precision the searches wrap by
        if hi - lo >= 2 * np.pi:
            return -np.inf, np.inf
        raise URDFError(f"{label}: joint {jname!r} has limits [{lo:g}, {hi:g}] rad, beyond ±{UNBOUNDED_LIMIT:g} rad "
                        "yet less than a turn apart; give them within one turn of 0 (or declare it continuous)")
    return lo, hi


def _ends(tree: URDFTree, label: str, ee_link: str | None, base_link: str | None) -> tuple[str, str]:
    """`(base_link, ee_link)`, checked, with their defaults: the root and the one leaf below it."""
    if base_link is None:
        base_link = tree.root()
    else:
        tree.check_link(base_link, "base_link")
    if ee_link is None:
        leaves = tree.leaves_below(base_link)
        if len(leaves) != 1:
            raise URDFError(f"{label}: the tree branches below {base_link!r}, so give ee_link; "
                            f"the candidate end links are: {', '.join(leaves)}")
        ee_link = leaves[0]
    else:
        tree.check_link(ee_link, "ee_link")
    return base_link, ee_link


def _mimic_number(label: str, jname: str, mimic: ET.Element, key: str, default: float) -> float:
    text = mimic.get(key)
    try:
        v = default if text is None else float(text)
    except ValueError:
        raise URDFError(f"{label}: joint {jname!r} has a non-numeric <mimic {key}={_q(text)}>") from None
    if not math.isfinite(v):
        raise URDFError(f"{label}: joint {jname!r} has a NaN or infinite <mimic {key}={_q(text)}>")
    return v


def _mimic(tree: URDFTree, label: str, jname: str, mimic: ET.Element, path_joints: list[str]):
    """`(driver, multiplier, offset)` of the mimic joint `jname` on the chain, whose value is
    `multiplier · q + offset` with `q` its driver's (module notes), checked: the driver a joint of
    the URDF of the same kind (revolute and continuous, or prismatic) and not itself a mimic joint, the
    multiplier finite and non-zero, the offset finite."""
    driver = mimic.get("joint")
    where = f"joint {jname!r} on the chain mimics {_q(driver)}"
    if not driver or driver not in tree.joints:
        raise URDFError(f"{label}: {where}, which is not a joint of the URDF")
    if driver == jname:
        raise URDFError(f"{label}: {where}, itself")
    d_el = tree.joints[driver]
    if d_el.find("mimic") is not None:
        raise URDFError(f"{label}: {where}, itself a mimic joint (a URDF's mimic follows an independent joint)")
    m = _mimic_number(label, jname, mimic, "multiplier", 1.0)
    offset = _mimic_number(label, jname, mimic, "offset", 0.0)
    if m == 0.0:
        raise URDFError(f"{label}: {where} with multiplier 0: a joint that never moves (make it a fixed joint)")
    jtype, d_type = tree.joints[jname].get("type"), d_el.get("type")
    if d_type not in _MOVABLE or _MOVABLE[d_type] != _MOVABLE.get(jtype):
        raise URDFError(f"{label}: {where}, a {d_type} joint driving a {jtype} one: the chain's variable would change "
                        "units")
    return driver, m, offset


def _chain_joints(tree: URDFTree, label: str, path_joints: list[str], base_link: str, ee_link: str):
    """The movable joints on the path, read from the XML: `(kinds, axes, limits, links, names,
    drivers)`, `limits` each joint's own, `drivers` `(driver, multiplier, offset)` per joint (the
    joint itself, 1, 0 for an independent one)."""
    kinds, axes, limits, links, names, drivers = [], [], [], [], [], []
    for jname in path_joints:
        el = tree.joints[jname]
        jtype = el.get("type")
        if jtype in ("floating", "planar"):
            raise URDFError(f"{label}: joint {jname!r} on the chain from {base_link!r} to {ee_link!r} is {jtype}; "
                            "only revolute, continuous, prismatic and fixed joints are supported")
        if jtype == "fixed":
            continue
        axis = _numbers(label, f"joint {jname!r} <axis xyz>",
                        None if el.find("axis") is None else el.find("axis").get("xyz"), "1 0 0")
        if np.linalg.norm(axis) < 1e-12:
            raise URDFError(f"{label}: joint {jname!r} has a zero <axis>")
        mimic = el.find("mimic")
        drivers.append((jname, 1.0, 0.0) if mimic is None else _mimic(tree, label, jname, mimic, path_joints))
        limits.append(_limits(label, jname, jtype, el))
        kinds.append(_MOVABLE[jtype])
        axes.append(axis)
        names.append(jname)
        links.append(tree.child(jname))
    if not kinds:
        raise URDFError(f"{label}: no movable joint between {base_link!r} and {ee_link!r}")
    links.append(ee_link)
    return kinds, axes, limits, links, names, drivers


def _coupled(tree: URDFTree, label: str, chain: SerialChain, names: list[str], drivers: list) -> SerialChain:
    """`chain` (the path's joints, each free in its own limits) with its mimic joints following their
    drivers (module notes): the variables are the drivers, in the order of the first joint each
    drives; a driver off the chain brings its own limits. Where every variable drives one joint at
    a multiplier of ±1 (a mimic joint whose driver is off the chain and drives nothing else on it),
    the chain stays uncoupled: the mimic joint's axis is turned by the multiplier's sign and its
    offset added, as wsmap has always read it."""
    order = list(dict.fromkeys(d for d, _, _ in drivers))
    var = np.array([order.index(d) for d, _, _ in drivers], dtype=np.int64)
    mult = np.array([m for _, m, _ in drivers])
    const = np.array([c for _, _, c in drivers])
    var_limits = np.array([(-np.inf, np.inf) if d in names else
                           _limits(label, d, tree.joints[d].get("type"), tree.joints[d]) for d in order])
    try:
        coupled = chain.couple(var, mult, const, var_limits=var_limits, names=names, var_names=order)
    except ValueError as exc:
        raise URDFError(f"{label}: {exc}") from None
    if len(order) < len(names) or np.any(np.abs(mult) != 1.0):
        return coupled
    return chain.replace(axes=chain.axes * mult[:, None], offset=mult * const, qlim=coupled.qlim)


def _fixed_transforms(model, label: str, path_joints: list[str], axes: list) -> np.ndarray:
    """The chain's fixed transforms `(n + 1, 4, 4)` from yourdfpy's joints `model.joint_map`:
    the joint origins, fixed joints folded in."""
    fixed, T = [], np.eye(4)
    for jname in path_joints:
        joint = model.joint_map[jname]
        origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=np.float64)
        T = T @ origin
        if joint.type != "fixed":
            fixed.append(T)
            T = np.eye(4)
            axis = np.asarray(joint.axis, dtype=np.float64)
            i = len(fixed) - 1
            if not np.allclose(axis, axes[i]):  # pragma: no cover - yourdfpy and the XML disagree
                raise URDFError(f"{label}: joint {jname!r}: yourdfpy reads axis {axis}, the XML says {axes[i]}")
    fixed.append(T)
    return np.stack(fixed)


def from_urdf(source: PathLike, ee_link: str | None = None, base_link: str | None = None,
              name: str | None = None) -> SerialChain:
    """The serial chain of a URDF from `base_link` to `ee_link`.

    Parameters
    ----------
    source : path or str
        A URDF file, or the URDF's XML text (a string with a `<` in it).
    ee_link : str, optional
        The end link (e.g. the tool flange, `tool0`). Default: the only leaf below `base_link`;
        if the tree branches there (a gripper's fingers), a `URDFError` lists the leaves.
    base_link : str, optional
        The first link of the chain (default: the URDF's root link).
    name : str, optional
        The chain's name (default: the `<robot name>`).

    Returns
    -------
    SerialChain
        `fixed` from the joint origins (fixed joints folded in), `axes` from `<axis>` (any
        direction), `qlim` from `<limit>` (`±inf` for continuous joints), `links` the link
        names after each fixed transform (the child link of each movable joint, then `ee_link`),
        `source` the file path or `"URDF text"`. With mimic joints that couple joints (module
        notes), `coupling` says how the joints follow the variables and `qlim` holds the
        variables' limits.
    """
    data, label, path = read_source(source)
    root = parse_xml(data, label)
    if b"xmlns" in data:  # yourdfpy finds no <link> in a namespace: give it the local names
        data = ET.tostring(root)
    tree = URDFTree(root, label)
    base_link, ee_link = _ends(tree, label, ee_link, base_link)
    path_joints = tree.path(base_link, ee_link)
    kinds, axes, limits, links, names, drivers = _chain_joints(tree, label, path_joints, base_link, ee_link)
    model = _load_yourdfpy(data, path, label)
    fixed = _fixed_transforms(model, label, path_joints, axes)
    chain = SerialChain(fixed, np.array(axes), kinds, qlim=np.array(limits, dtype=np.float64),
                        name=name if name is not None else root.get("name"),
                        source=path if path is not None else "URDF text", links=links)
    return chain if all(d == j for (d, _, _), j in zip(drivers, names)) else _coupled(tree, label, chain, names,
                                                                                        drivers)


def moving_off_chain(source: PathLike, ee_link: str | None = None, base_link: str | None = None) -> list[str]:
    """The links with `<collision>` elements that hang below the driver of a mimic joint of the
    chain `from_urdf` reads (same arguments): they move with a variable of the chain, but a
    collision model places the links off the chain at their joints' zero, so `--collision` refuses
    them (`wsmap.collision.sources`)."""
    data, label, _ = read_source(source)
    root = parse_xml(data, label)
    tree = URDFTree(root, label)
    base_link, ee_link = _ends(tree, label, ee_link, base_link)
    path = tree.path(base_link, ee_link)
    drivers = [tree.joints[j].find("mimic").get("joint") for j in path if tree.joints[j].find("mimic") is not None]
    drivers = [d for d in drivers if d not in path]  # a driver on the chain moves the chain's own links
    solid = {el.get("name") for el in root.findall("link") if el.find("collision") is not None}
    out, stack = [], [tree.child(d) for d in drivers if d in tree.joints]
    while stack:
        link = stack.pop()
        if link in solid:
            out.append(link)
        stack.extend(tree.child(j) for j in tree.children[link])
    return out


def rpy_matrix(rpy) -> np.ndarray:
    """The rotation of a URDF `<origin rpy="r p y">`: fixed-axis roll-pitch-yaw,
    `R = Rz(y) · Ry(p) · Rx(r)` (the URDF convention).

    Parameters
    ----------
    rpy : array_like
        `(roll, pitch, yaw)` in radians, shape `(3,)`.

    Returns
    -------
    numpy.ndarray
        The rotation matrix, `(3, 3)`.
    """
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])
