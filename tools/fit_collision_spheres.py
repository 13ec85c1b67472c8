"""Fit conservative capsules (and cylinders) around the named arms' vendor collision meshes and write
them to `src/wsmap/collision/data/fitted_<arm>.json`.

For each arm of `wsmap.collision.vendor.VENDOR` the vendor's collision meshes are read
(`wsmap.collision.vendor.mesh_model`: a vendor URDF in an installed package, moved into the bodies'
frames of wsmap's chain after checking that both descriptions move alike, or the committed convex
hulls of `tools/vendor_hulls.py`), each link's convex hull (the hull is what coal and PyBullet
test) is enclosed by 1 to `MAX_PIECES` shapes, and the allowed-collision matrix is built on the
meshes (`wsmap.collision.build_acm`, 10,000 samples, seed 0) and stored with the shapes:

* the hull is cut across an axis (its principal axes, or the body's x, y, z) into equal slabs;
  each slab's piece of the hull is the hull of the hull's vertices inside the slab and the hull's
  edges' crossings of the slab's planes, so shapes around those points cover the whole hull;
* each piece gets the smaller of a capsule and a cylinder. The capsule: along the piece's principal
  axis or a body axis, the line through the centre of the points' bounding box across it, the
  radius the farthest point from the line, the ends as short as the points allow (a point at
  distance `d` from the line and `t` along it needs the segment to reach `t ± sqrt(r² - d²)`).
  The cylinder (for flat parts: a flange disc, whose round enclosure would reach its radius past
  its faces): along one of the same axes, the same line, from the lowest to the highest point;
* among the axes and 1..MAX_PIECES slabs the fit with the least union volume wins (3 % more per
  extra piece, 5 % more per cylinder: cylinder pairs go to coal, capsule pairs stay in numpy);
  then `PADDING` is added to every radius and to both ends of every cylinder.

Every hull vertex is then checked to lie inside the fitted shapes, `PADDING` deep (with the rounded
numbers written); the script refuses to write otherwise. The record holds per link the hull volume,
the volume of the shapes' union (padding included; counted on 200,000 Halton points of its bounding
box, about ±1 %) and `slack` = fitted volume / hull volume.

Run: `.venv/bin/python tools/fit_collision_spheres.py [ARM ...]` (default: every vendor arm);
`--check` fits again and compares with the committed files (exit 1 on a difference).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import replace

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "src", "wsmap", "collision", "data")
MAX_PIECES = 6
ACM_SAMPLES = 10000  # MoveIt's default, as wsmap.collision.DEFAULT_SAMPLES
PIECE_COST, CYLINDER_COST = 1.03, 1.05


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


def volume(shape) -> float:
    """The volume (m³) of a shape `(kind, p0, p1, r)`."""
    kind, p0, p1, r = shape
    length = float(np.linalg.norm(np.subtract(p1, p0)))
    return float(np.pi * r * r * length + (4.0 / 3.0 * np.pi * r ** 3 if kind == "capsule" else 0.0))


def _axes(p: np.ndarray):
    """The candidate axes of a point set: its principal axes and the body's x, y, z."""
    _, _, vt = np.linalg.svd(p - p.mean(axis=0), full_matrices=False)
    return [*vt, *np.eye(3)]


def fit_piece(p: np.ndarray, kinds=("capsule", "cylinder")):
    """The least-volume shape of `kinds` (capsule, cylinder) `(kind, p0, p1, r)` around points `p`
    `(m, 3)` (module notes), every point inside."""
    best = None
    for u in _axes(p):
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
        lo, hi, rc = min(t0, t1), max(t0, t1), r
        if t0 > t1:  # every point fits a sphere of radius r anywhere in [t1, t0]: a point segment
            lo = hi = (t0 + t1) / 2
            rc = float(np.linalg.norm(p - (o + lo * u), axis=1).max())
        for shape in (("capsule", o + lo * u, o + hi * u, rc), ("cylinder", o + t.min() * u, o + t.max() * u, r)):
            if shape[0] in kinds and (best is None or volume(shape) < volume(best)):
                best = shape
    return best


def outside(x: np.ndarray, shapes) -> np.ndarray:
    """How far points `x` `(m, 3)` lie outside the union of `shapes` (<= 0 inside; for a cylinder the
    larger of the radial and the axial excess, so `-PADDING` means at least that deep)."""
    out = np.full(len(x), np.inf)
    for kind, p0, p1, r in shapes:
        p0, p1 = np.asarray(p0, dtype=np.float64), np.asarray(p1, dtype=np.float64)
        d = p1 - p0
        L2 = float(d @ d)
        s = (x - p0) @ d / L2 if L2 > 0 else np.zeros(len(x))
        if kind == "capsule":
            sc = np.clip(s, 0.0, 1.0)
            out = np.minimum(out, np.linalg.norm(x - p0 - sc[:, None] * d, axis=1) - r)
        else:
            L = np.sqrt(L2)
            radial = np.linalg.norm(x - p0 - s[:, None] * d, axis=1) - r
            out = np.minimum(out, np.maximum(radial, np.maximum(-s, s - 1.0) * L))
    return out


def union_volume(shapes, lo, hi, n: int = 40000) -> float:
    """The volume (m³) of the union of shapes, by counting a fixed quasi-random set of `n` points of
    the box `lo`-`hi` that holds them (the same points for every candidate, so fits compare)."""
    from scipy.stats import qmc

    x = lo + qmc.Halton(d=3, scramble=False).random(n) * (hi - lo)
    return float(np.mean(outside(x, shapes) <= 0) * np.prod(hi - lo))


#: Slab cuts, as fractions of the hull's extent along the axis: equal slabs, and thin slabs at the
#: ends (a housing's round end, where the next link but one swings in).
CUTS = [np.linspace(0, 1, m + 1) for m in range(1, MAX_PIECES + 1)] + [
    np.array(c) for c in ([0, 0.1, 1], [0, 0.9, 1], [0, 0.1, 0.9, 1], [0, 0.05, 0.15, 0.85, 0.95, 1],
                          [0, 0.1, 0.5, 0.9, 1], [0, 0.05, 0.15, 0.5, 0.85, 0.95, 1])]
TOP = 4  # candidates of each family (capsules only, with cylinders) tried per link by `choose`


def _best(cands, lo, hi, cylinder_cost: float):
    score = [union_volume(shapes, lo, hi) * PIECE_COST ** (len(shapes) - 1)
             * cylinder_cost ** sum(sh[0] == "cylinder" for sh in shapes) for shapes in cands]
    return [cands[i] for i in np.argsort(score, kind="stable")[:TOP]]


def fit_link(vertices: np.ndarray):
    """Candidate fits of one link around the hull of `vertices` `(V, 3)` (m, the body frame), before
    padding: the `TOP` least scored union volumes of capsules only, then of capsules and cylinders
    (one piece per slab of `CUTS`); and the hull's volume."""
    v, edges, hull_volume = hull_of(vertices)
    cands = []
    for axis in _axes(v):
        s = v @ axis
        for frac in CUTS:
            cuts = s.min() + frac * (s.max() - s.min())
            pieces = [slab_points(v, edges, axis, cuts[i], cuts[i + 1]) for i in range(len(cuts) - 1)]
            cands.append([fit_piece(p) for p in pieces])
            cands.append([fit_piece(p, kinds=("capsule",)) for p in pieces])
    r = max(sh[3] + np.linalg.norm(np.subtract(sh[2], sh[1])) for shapes in cands for sh in shapes)
    lo, hi = v.min(axis=0) - r, v.max(axis=0) + r
    only_caps = [c for c in cands if all(sh[0] == "capsule" for sh in c)]
    fits = _best(only_caps, lo, hi, 1.0) + _best(cands, lo, hi, CYLINDER_COST)
    for best in fits:
        worst = outside(v, best).max()
        if worst > 1e-9:
            raise SystemExit(f"fit failed: a hull vertex is {worst:.3g} m outside the shapes")
    return fits, hull_volume


def choose(model, fits, samples: int = 2000):
    """Per link, the candidate fit (`fits[link]`, padded) with the fewest false collisions against the
    vendor meshes (`model`, its matrix) on `samples` random configurations (seed 1): links in turn,
    two passes, starting from the capsules-only fits. A fit that misses a collision of the meshes
    stops the script (every fit contains the hulls, so none can)."""
    from wsmap.collision import CollisionChecker, CollisionModel, Link, Scene
    from wsmap.collision.vendor import segment_shape

    q = model.chain.random_q(samples, np.random.default_rng(1))
    truth = CollisionChecker(model, Scene())(q)

    def false_collisions(pick):
        links = tuple(Link(lk.name, lk.body, tuple(segment_shape(*sh) for sh in fits[i][pick[i]]), parent=lk.parent)
                      for i, lk in enumerate(model.links))
        free = CollisionChecker(CollisionModel(model.chain, links), Scene(), acm=model.acm)(q)
        if np.any(free & ~truth):
            raise SystemExit("a fitted model calls a configuration free that the meshes call colliding")
        return int(np.sum(~free & truth))

    pick = [0] * len(fits)
    best = false_collisions(pick)
    for _ in range(2):
        for i in range(len(fits)):
            for c in range(len(fits[i])):
                if c != pick[i]:
                    trial = pick[:i] + [c] + pick[i + 1:]
                    n = false_collisions(trial)
                    if n < best:
                        pick, best = trial, n
    return pick, best / samples


def padded(shape, pad: float):
    """The shape grown by `pad` (m): a capsule's radius; a cylinder's radius and both ends."""
    kind, p0, p1, r = shape
    if kind == "cylinder":
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        p0, p1 = p0 - pad * u, p1 + pad * u
    return kind, p0, p1, r + pad


def fit_arm(name: str) -> dict:
    """The record of `data/fitted_<name>.json` (`wsmap.collision.vendor.fitted_record`)."""
    from wsmap.collision import build_acm
    from wsmap.collision.vendor import PADDING, VENDOR, mesh_model

    rec = VENDOR[name]
    grown = mesh_model(name)
    meshes = [v.meshes for v in rec.vendor_links(name, grown.chain)]
    # the pairs never checked are those of the vendor meshes as the checks see them, grown by
    # MESH_MARGIN (MoveIt's rules on the real shapes; the fatter fitted shapes of two links a joint
    # apart overlap where the housings do not). Grown, not bare: the UR10e's upper arm passes its
    # base 0.44 mm apart (never touching bare, within the margin whenever it hangs down)
    acm = build_acm(grown, samples=ACM_SAMPLES, seed=0)
    # the bare hulls (no MESH_MARGIN): the fit and its false collisions are measured against them
    model = replace(grown, margin=0.0)
    model.acm = acm
    fits, points, hulls = [], [], []
    for lk in model.links:
        pts = np.concatenate([s.vertices @ s.origin[:3, :3].T + s.origin[:3, 3] for s in lk.shapes])
        cands, hull_volume = fit_link(pts)
        # rounded to the micrometre: the numbers written are the numbers checked
        fits.append([[(k, np.round(p0, 6), np.round(p1, 6), round(float(r), 6))
                      for k, p0, p1, r in (padded(sh, PADDING) for sh in c)] for c in cands])
        points.append(pts)
        hulls.append(hull_volume)
    pick, rate = choose(model, fits)
    links = []
    for lk, vname, files, pts, hull_volume, cands, c in zip(model.links, rec.links, meshes, points, hulls, fits, pick):
        shapes = cands[c]
        worst = outside(pts, shapes).max()
        if worst > -PADDING + 2e-6:
            raise SystemExit(f"{name} {vname}: a vertex lies {worst + PADDING:.3g} m from the shapes' skin")
        reach = max(sh[3] + np.linalg.norm(sh[2] - sh[1]) for sh in shapes)
        fitted_volume = union_volume(shapes, pts.min(axis=0) - reach, pts.max(axis=0) + reach, 200000)
        links.append({"name": vname, "body": lk.body, "meshes": list(files),
                      "shapes": [{"kind": k, "p0": p0.tolist(), "p1": p1.tolist(), "radius": r}
                                 for k, p0, p1, r in shapes],
                      "hull_volume": round(hull_volume, 9), "fitted_volume": round(fitted_volume, 9),
                      "slack": round(fitted_volume / hull_volume, 3)})
    acm = model.acm.describe()
    return {"arm": name, "padding": PADDING, "false_collisions_at_fit": round(rate, 4),
            "acm": {"samples": acm["samples"], "seed": acm["seed"], "disabled": acm["disabled"]},
            "source": rec.source_record(name),
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
            kinds = [s["kind"][:3] for s in lk["shapes"]]
            print(f"  {lk['name']:>18}: {' '.join(kinds)}, slack {lk['slack']:.2f}")
    return status


if __name__ == "__main__":
    sys.exit(main())
