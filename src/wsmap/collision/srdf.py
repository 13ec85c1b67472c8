"""MoveIt's semantic robot description (SRDF): disabled collision pairs, planning groups and end
effectors, read so that a hostile file cannot hurt.

`load_srdf(source, urdf=...)` reads what wsmap uses of an SRDF:

* `<disable_collisions link1= link2= reason=>`: link pairs never checked; they go into the
  allowed-collision matrix (`wsmap.collision.build_acm(srdf=...)`, reason `"srdf"`) beside the
  pairs wsmap finds itself. A pair with a link that is in the URDF but carries no collision
  geometry on the chosen chain (a gripper off the chain) has nothing to disable and is skipped;
* `<group name=><chain base_link= tip_link=/></group>`: the chain of a planning group. `Srdf.ends()`
  picks the chain of the arm when no end link or base link is given (`wsmap map --srdf` without
  `--ee`/`--base`): the one group with a `<chain>` (or the group an `<end_effector>` hangs from,
  when several have one);
* `<end_effector name= parent_link= group= parent_group=>`: the link a tool is attached to. The
  end link of the chosen group is its end effector's `parent_link` (as MoveIt's group's
  end-effector link), else the chain's `tip_link`; without any chain group, the one end
  effector's `parent_link` from the URDF's root.

The rest of an SRDF (virtual joints, passive joints, group states, link spheres) is not read.
The XML goes through the URDF reader's checks (`wsmap.kinematics.urdf.parse_xml`: no entity
declarations, nesting at most 64 deep, a `<robot>` root with a name) after a size bound
(`MAX_SRDF_BYTES`). With `urdf=` every link an element names must be one of the URDF's links.
Every problem is an `SRDFError` (a `CollisionError`, so a `ValueError`) of one line naming the
file, the element (by its number among its kind, from 1) and what is wrong.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from ..kinematics.urdf import URDFError, URDFTree, parse_xml, read_source
from .errors import CollisionError

__all__ = ["SRDFError", "Srdf", "load_srdf", "MAX_SRDF_BYTES"]

#: The largest SRDF read (bytes): a large robot's (a PR2's) is about 100 kB.
MAX_SRDF_BYTES = 16_000_000


class SRDFError(CollisionError):
    """An SRDF that cannot be used; the message names the file, the element and what is wrong."""


@dataclass(frozen=True)
class Srdf:
    """What wsmap reads of an SRDF (module notes).

    Attributes
    ----------
    name : str
        The `<robot name>`.
    disabled : tuple of (str, str, str)
        `(link1, link2, reason)` of each `<disable_collisions>`, in file order.
    groups : dict
        Group name -> `(base_link, tip_link)` of its `<chain>`, or None for a group without one.
    end_effectors : tuple of (str, str, str or None)
        `(name, parent_link, parent_group)` of each `<end_effector>`.
    source : str
        The file, or `"SRDF text"`.
    """

    name: str
    disabled: tuple = ()
    groups: dict | None = None
    end_effectors: tuple = ()
    source: str = "SRDF text"

    def disabled_pairs(self, names) -> list[tuple[str, str]]:
        """The disabled pairs whose two links are both in `names` (a collision model's links)."""
        have = set(names)
        return [(a, b) for a, b, _ in self.disabled if a in have and b in have and a != b]

    def ends(self, group: str | None = None, *, options: tuple[str, str, str | None] = ("--ee", "--base", None)
             ) -> tuple[str | None, str | None]:
        """`(base_link, ee_link)` of the arm the SRDF describes (module notes); `group` picks a
        planning group by name. None where the SRDF says nothing (the URDF's root, its leaf).
        `options`: how messages name the end link, the base link and the group where the SRDF
        does not decide (`wsmap map`'s `--ee`, `--base`, no group option; a study's `ee`, `base`,
        `group`)."""
        label = f"SRDF {self.source!r}" if self.source != "SRDF text" else "SRDF text"
        groups = self.groups or {}
        chains = [g for g, c in groups.items() if c is not None]
        ee_opt, base_opt, group_opt = options
        pick = "" if group_opt is None else f"the group ({group_opt}) or "
        if group is not None:
            if group not in groups:
                raise SRDFError(f"{label}: no group {group!r}; the groups are: {', '.join(groups) or 'none'}")
            chosen = group
        elif len(chains) == 1:
            chosen = chains[0]
        elif chains:
            hung = sorted({pg for _, _, pg in self.end_effectors if pg in chains})
            if len(hung) != 1:
                raise SRDFError(f"{label} has several chain groups ({', '.join(chains)}): give {pick}the end and "
                                f"base links ({ee_opt}, {base_opt})")
            chosen = hung[0]
        else:
            if len(self.end_effectors) == 1:
                return None, self.end_effectors[0][1]
            if self.end_effectors:
                raise SRDFError(f"{label} has no chain group and several end effectors "
                                f"({', '.join(e[0] for e in self.end_effectors)}): give the end link ({ee_opt})")
            return None, None
        base, tip = groups[chosen] if groups[chosen] is not None else (None, None)
        tools = [e[1] for e in self.end_effectors if e[2] == chosen]
        return base, (tools[0] if len(tools) == 1 else tip)


def _attr(el, key: str, where: str, label: str) -> str:
    value = el.get(key)
    if value is None or not value.strip():
        raise SRDFError(f"{label}: {where} has no {key}= attribute")
    return value.strip()


def _check_link(link: str, links, where: str, label: str) -> None:
    if links is not None and link not in links:
        shown = ", ".join(list(links)[:20]) + (", ..." if len(links) > 20 else "")
        raise SRDFError(f"{label}: {where} names link {link[:80]!r}, which the URDF does not have; its links are: "
                        f"{shown}")


def _urdf_links(urdf) -> set[str]:
    try:
        data, label, _ = read_source(urdf)
    except (FileNotFoundError, TypeError) as e:
        raise URDFError(str(e)) from None
    return set(URDFTree(parse_xml(data, label), label).links)


def _groups(root, links, label: str) -> dict:
    """Group name -> `(base_link, tip_link)` of its `<chain>`, or None."""
    groups: dict = {}
    for i, el in enumerate(root.findall("group"), 1):
        name = _attr(el, "name", f"<group> {i}", label)
        if name in groups:
            raise SRDFError(f"{label}: group {name[:80]!r} is defined twice")
        chains = el.findall("chain")
        if len(chains) > 1:
            raise SRDFError(f"{label}: group {name[:80]!r} has {len(chains)} <chain> elements; a group has one")
        groups[name] = None
        if chains:
            ends = tuple(_attr(chains[0], k, f"the <chain> of group {name[:80]!r}", label)
                         for k in ("base_link", "tip_link"))
            for link in ends:
                _check_link(link, links, f"the <chain> of group {name[:80]!r}", label)
            groups[name] = ends
    return groups


def _read(source) -> tuple[bytes, str, str | None]:
    """`read_source` of the URDF reader, with SRDF's size bound and messages."""
    if isinstance(source, (str, os.PathLike)) and not (isinstance(source, str) and "<" in source
                                                        and not os.path.isfile(source)):
        path = os.fspath(source)
        if not os.path.isfile(path):
            raise SRDFError(f"no such SRDF file: {path!r}")
        size = os.path.getsize(path)
        if size > MAX_SRDF_BYTES:
            raise SRDFError(f"SRDF file {path!r}: {size} bytes, more than an SRDF holds (at most {MAX_SRDF_BYTES})")
    elif isinstance(source, (bytes, str)) and len(source) > MAX_SRDF_BYTES:
        raise SRDFError(f"SRDF text: {len(source)} bytes, more than an SRDF holds (at most {MAX_SRDF_BYTES})")
    try:
        data, label, path = read_source(source)
    except (FileNotFoundError, TypeError) as e:
        raise SRDFError(str(e).replace("URDF", "SRDF")) from None
    return data, label, path


def load_srdf(source, urdf=None) -> Srdf:
    """Read an SRDF (module notes).

    Parameters
    ----------
    source : path, str or bytes
        The SRDF file, or its XML text (bytes, or a string with a `<` in it that names no file).
    urdf : path, str or bytes, optional
        The arm's URDF: every link the SRDF names must be one of its links.

    Returns
    -------
    Srdf

    Raises
    ------
    SRDFError
        No such file, a file over `MAX_SRDF_BYTES`, XML that is not an SRDF (module notes), a
        `<disable_collisions>`, `<chain>` or `<end_effector>` without a link attribute it needs, a
        link the URDF does not have, a group or an end effector defined twice.
    """
    data, label, path = _read(source)
    label = label.replace("URDF", "SRDF")
    try:
        root = parse_xml(data, label, kind="SRDF")
        links = None if urdf is None else _urdf_links(urdf)
    except URDFError as e:
        raise SRDFError(str(e)) from None
    disabled = []
    for i, el in enumerate(root.findall("disable_collisions"), 1):
        where = f"<disable_collisions> {i}"
        a, b = _attr(el, "link1", where, label), _attr(el, "link2", where, label)
        for link in (a, b):
            _check_link(link, links, where, label)
        disabled.append((a, b, el.get("reason") or ""))
    groups = _groups(root, links, label)
    effectors, seen = [], set()
    for i, el in enumerate(root.findall("end_effector"), 1):
        name = _attr(el, "name", f"<end_effector> {i}", label)
        if name in seen:
            raise SRDFError(f"{label}: end effector {name[:80]!r} is defined twice")
        seen.add(name)
        parent = _attr(el, "parent_link", f"end effector {name[:80]!r}", label)
        _check_link(parent, links, f"end effector {name[:80]!r}", label)
        effectors.append((name, parent, el.get("parent_group")))
    return Srdf(name=root.get("name"), disabled=tuple(disabled), groups=groups, end_effectors=tuple(effectors),
                source=path if path is not None else "SRDF text")
