"""Fit conservative capsules around the named arms' vendor collision meshes and write them to
`src/wsmap/collision/data/fitted_<arm>.json`.

For each arm of `wsmap.collision.vendor.VENDOR` the vendor URDF's collision meshes are read
(`wsmap.collision.vendor.mesh_model`: moved into the bodies' frames of wsmap's chain, after checking
that both descriptions move alike), and each link's convex hull (the hull is what coal and PyBullet
test) is enclosed by 1 to `MAX_CAPSULES` capsules, and the allowed-collision matrix is built on the
meshes (`wsmap.collision.build_acm`, 10,000 samples, seed 0) and stored with the capsules:

* the hull is cut across an axis (its principal axis, or one of the body's x, y, z) into slabs;
  each slab's piece of the hull is the hull of the hull's vertices inside the slab and the hull's
  edges' crossings of the slab's planes, so capsules around those points cover the whole hull;
* one capsule per piece: its axis is the piece's principal axis, the line through the centre of
  the piece's bounding box across that axis, the radius the farthest point from the line, and the
  ends as short as the points allow (a point at distance `d` from the line and `t` along it
  needs the segment to reach `t ± sqrt(r² - d²)`);
* among the axes and 1..MAX_CAPSULES slabs the fit with the least summed capsule volume wins;
  then `PADDING` is added to every radius.

Every hull vertex is then checked to lie inside the fitted capsules (before padding, to 1e-9 m);
the script refuses to write otherwise. The record holds per link the hull volume, the volume of the
capsules' union (padding included; counted on 200,000 Halton points of its bounding box, about
±1 %) and `slack` = capsule volume / hull volume.

Run: `.venv/bin/python tools/fit_collision_spheres.py [ARM ...]` (default: every vendor arm);
`--check` fits again and compares with the committed files (exit 1 on a difference).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from importlib.metadata import version

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "src", "wsmap", "collision", "data")
MAX_CAPSULES = 6
ACM_SAMPLES = 10000  # MoveIt's default, as wsmap.collision.DEFAULT_SAMPLES


def hull_of(vertices: np.ndarray):
    """The convex hull (trimesh) of a point set: its vertices `(V, 3)`, unique edges `(E, 2)`, volume."""
    import trimesh

    h = trimesh.convex.convex_hull(vertices)
    return np.asarray(h.vertices), np.asarray(h.edges_unique), float(h.volume)


def slab_points(v: np.ndarray, edges: np.ndarray, axis: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Points whose hull is the part of the convex polytope (vertices `v`, edges `edges`) between the
    planes `axis·x = lo` and `axis·x = hi`: its vertices there and its edges' crossings of the planes."""
    s = v @ axis
    pts = [v[(s >= lo) & (s <= hi)]]
    a, b = s[edges[:, 0]], s[edges[:, 1]]
    for plane in (lo, hi):
        cross = (a - plane) * (b - plane) < 0
        if cross.any():
            t = (plane - a[cross]) / (b[cross] - a[cross])
            va, vb = v[edges[cross, 0]], v[edges[cross, 1]]
            pts.append(va + t[:, None] * (vb - va))
    return np.concatenate(pts)


def capsule_volume(p0, p1, r) -> float:
    return float(np.pi * r * r * np.linalg.norm(np.subtract(p1, p0)) + 4.0 / 3.0 * np.pi * r ** 3)


def fit_capsule(p: np.ndarray):
    """The capsule `(p0, p1, r)` around points `p` `(m, 3)` (module notes), every point inside."""
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    best = None
    for u in (vt[0], np.eye(3)[0], np.eye(3)[1], np.eye(3)[2]):
        e1 = np.cross(u, [1.0, 0, 0]) if abs(u[0]) < 0.9 else np.cross(u, [0, 1.0, 0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(u, e1)
        xy = np.stack([p @ e1, p @ e2], axis=1)
        mid = (xy.min(axis=0) + xy.max(axis=0)) / 2
        o = mid[0] * e1 + mid[1] * e2
        t = p @ u
        d = np.linalg.norm(xy - mid, axis=1)
        r = float(d.max())
        reach = np.sqrt(np.maximum(r * r - d * d, 0.0))
        t0, t1 = float(np.max(t - reach)), float(np.min(t + reach))  # the segment must span [t0, t1]
        lo, hi = min(t0, t1), max(t0, t1)
        if t0 > t1:  # every point fits a sphere of radius r anywhere in [t1, t0]: a point segment
            lo = hi = (t0 + t1) / 2
            r = float(np.linalg.norm(p - (o + lo * u), axis=1).max())
        cap = (o + lo * u, o + hi * u, r)
        if best is None or capsule_volume(*cap) < capsule_volume(*best):
            best = cap
    return best


def point_capsule_distance(x: np.ndarray, caps) -> np.ndarray:
    """Distance of points `x` `(m, 3)` outside the union of capsules `(p0, p1, r)` (<= 0 inside)."""
    out = np.full(len(x), np.inf)
    for p0, p1, r in caps:
        p0, p1 = np.asarray(p0), np.asarray(p1)
        d = p1 - p0
        L2 = float(d @ d)
        s = np.clip((x - p0) @ d / L2, 0.0, 1.0) if L2 > 0 else np.zeros(len(x))
        out = np.minimum(out, np.linalg.norm(x - p0 - s[:, None] * d, axis=1) - r)
    return out


def union_volume(caps, lo, hi, n: int = 40000) -> float:
    """The volume (m³) of the union of capsules, by counting a fixed quasi-random set of `n` points
    of the box `lo`-`hi` that holds them (the same points for every candidate, so fits compare)."""
    from scipy.stats import qmc

    u = qmc.Halton(d=3, scramble=False).random(n)
    x = lo + u * (hi - lo)
    return float(np.mean(point_capsule_distance(x, caps) <= 0) * np.prod(hi - lo))


def fit_link(vertices: np.ndarray):
    """The capsules of one link (1..MAX_CAPSULES, least union volume) around the hull of `vertices`
    `(V, 3)` (m, the body frame), before padding; and the hull's volume."""
    v, edges, volume = hull_of(vertices)
    c = v.mean(axis=0)
    _, _, vt = np.linalg.svd(v - c, full_matrices=False)
    cands = []
    for axis in (vt[0], np.eye(3)[0], np.eye(3)[1], np.eye(3)[2]):
        s = v @ axis
        for m in range(1, MAX_CAPSULES + 1):
            cuts = np.linspace(s.min(), s.max(), m + 1)
            cands.append([fit_capsule(slab_points(v, edges, axis, cuts[i], cuts[i + 1])) for i in range(m)])
    r = max(c[2] for caps in cands for c in caps)
    lo, hi = v.min(axis=0) - r, v.max(axis=0) + r
    # one more capsule costs the checker work: it must save 3 % of the volume
    score = [union_volume(caps, lo, hi) * 1.03 ** (len(caps) - 1) for caps in cands]
    best = cands[int(np.argmin(score))]
    out = point_capsule_distance(v, best).max()
    if out > 1e-9:
        raise SystemExit(f"fit failed: a hull vertex is {out:.3g} m outside the capsules")
    return best, volume


def fit_arm(name: str) -> dict:
    """The record of `data/fitted_<name>.json` (`wsmap.collision.vendor.fitted_record`)."""
    from wsmap.collision import build_acm
    from wsmap.collision.vendor import PADDING, VENDOR, mesh_model, vendor_urdf

    rec = VENDOR[name]
    model = mesh_model(name)
    urdf = vendor_urdf(name)
    links = []
    for lk, vname in zip(model.links, rec.links):
        pts = np.concatenate([s.vertices @ s.origin[:3, :3].T + s.origin[:3, 3] for s in lk.shapes])
        caps, hull_volume = fit_link(pts)
        caps = [(p0, p1, r + PADDING) for p0, p1, r in caps]
        reach = max(c[2] for c in caps)
        cap_volume = union_volume(caps, pts.min(axis=0) - reach, pts.max(axis=0) + reach, 200000)
        files = sorted({os.path.relpath(s.source, os.path.dirname(urdf)) for s in lk.shapes})
        links.append({"name": vname, "body": lk.body, "meshes": files,
                      "capsules": [[np.round(p0, 6).tolist(), np.round(p1, 6).tolist(), round(float(r), 6)]
                                   for p0, p1, r in caps],
                      "hull_volume": round(hull_volume, 9), "capsule_volume": round(cap_volume, 9),
                      "slack": round(cap_volume / hull_volume, 3)})
    for lk, fitted in zip(model.links, links):
        # rounding to the micrometre: check again, with the rounded numbers, against the padded radii
        pts = np.concatenate([s.vertices @ s.origin[:3, :3].T + s.origin[:3, 3] for s in lk.shapes])
        out = point_capsule_distance(pts, fitted["capsules"]).max()
        if out > -PADDING + 2e-6:
            raise SystemExit(f"{name} {fitted['name']}: a vertex lies {out + PADDING:.3g} m from the capsules' skin")
    with open(urdf, "rb") as fh:
        sha = hashlib.sha256(fh.read()).hexdigest()
    # the pairs never checked are those of the vendor meshes (MoveIt's rules on the real shapes):
    # the fatter capsules of two links a joint apart overlap where the housings do not
    acm = build_acm(model, samples=ACM_SAMPLES, seed=0).describe()
    return {"arm": name, "padding": PADDING,
            "acm": {"samples": acm["samples"], "seed": acm["seed"], "disabled": acm["disabled"]},
            "source": {"package": rec.package, "version": version(rec.distribution), "urdf": rec.urdf,
                       "urdf_sha256": sha, "licence": rec.licence, "origin": rec.origin},
            "fitted_by": "tools/fit_collision_spheres.py", "links": links}


def main(argv=None) -> int:
    from wsmap.collision.vendor import VENDOR

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("arms", nargs="*", help=f"arms to fit (default: {' '.join(VENDOR)})")
    ap.add_argument("--check", action="store_true", help="compare with the committed files instead of writing")
    args = ap.parse_args(argv)
    bad = [a for a in args.arms if a not in VENDOR]
    if bad:
        ap.error(f"no vendor description for {', '.join(bad)}; arms with one: {', '.join(VENDOR)}")
    status = 0
    os.makedirs(OUT, exist_ok=True)
    for name in args.arms or list(VENDOR):
        rec = fit_arm(name)
        path = os.path.join(OUT, f"fitted_{name}.json")
        text = json.dumps(rec, indent=1) + "\n"
        if args.check:
            same = os.path.isfile(path) and open(path, encoding="utf-8").read() == text
            print(f"{name}: {'same' if same else 'DIFFERS from'} {os.path.relpath(path, ROOT)}")
            status |= not same
            continue
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        print(f"{name}: {os.path.relpath(path, ROOT)}")
        for lk in rec["links"]:
            print(f"  {lk['name']:>18}: {len(lk['capsules'])} capsule(s), slack {lk['slack']:.2f}, radii "
                  f"{[c[2] for c in lk['capsules']]}")
    return status


if __name__ == "__main__":
    sys.exit(main())
