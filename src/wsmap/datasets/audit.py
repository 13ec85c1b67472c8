"""Audits of the IK labels: how many start configurations, and how exact the numerical path is.

* `starts_study` -- on a spec's grid, which start configuration first solves each node
  (how the numerical labels change with the number of starts);
* `starts_recall` -- on poses known to be reachable (forward kinematics of random joint
  angles), the fraction multi-start LM finds; together they chose
  `wsmap.datasets.DEFAULT_STARTS`;
* `audit_labels` / `audit_table` -- exact (closed-form) labels against the paper's
  one-start numerical path on spherical-wrist arms.

Every audit draws its arms from its own streams of `seed` (`wsmap.datasets.sampling`),
independent of every dataset's training and test streams. The specs to audit are arguments: the
paper's choices (Table 3's arbitrary arms for the start studies, every distinct spherical-wrist
spec for the label audit) are in `wsmap.paper.specs`.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable

import numpy as np

from ..kinematics import DHRobot
from .features import spec_nodes
from .labels import labels_for, pair_poses, possibly_reachable, solve_confirmed
from .sampling import audit_rng, draw_arms, draw_fixed
from .spec import MAX_SAMPLES, MAX_STARTS, N_JOINTS, DatasetSpec, check_int, check_spec
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import Sequence

__all__ = ["starts_study", "starts_recall", "audit_labels", "audit_table", "distinct_specs"]


def _counts(counts) -> list[int]:
    if isinstance(counts, (str, bytes)) or not isinstance(counts, Iterable):
        raise ValueError(f"counts must be a list of start counts, got {counts!r}")
    out = sorted({check_int("counts entry", c, 1, MAX_STARTS) for c in counts})
    if not out:
        raise ValueError("counts must name at least one number of starts")
    return out


def starts_study(
    spec: DatasetSpec,
    n_arms: int = 200,
    counts: Sequence[int] = (1, 2, 3, 5, 9, 17),
    seed: int = 0,
    chunk: int = 8,
    progress: bool = True,
) -> list[dict]:
    """How numerical labels change with the number of IK start configurations.

    Draws `n_arms` arms of `spec` (the paper's study: Table 3's arbitrary 6-DOF arms at
    [0.312, 5.6719, 5.936], block 5, `wsmap.paper.specs.PAPER_SPECS["table3_nosubspace"]`) from
    an audit stream of `seed`, runs LM (the spec's settings) from q0 = 0 and then
    `max(counts) - 1` random starts (uniform in [-pi, pi)^6 per arm), each only where the earlier
    ones failed and `possibly_reachable` does not rule the node out, and records which start
    first solved each node. Returns one row per entry of `counts` (total starts, q0 = 0
    included): `starts`, `reachable` (nodes), `fraction` (reachable / all arm-node pairs),
    `new` (nodes that flipped to reachable since the previous row), `new_fraction` (of all
    pairs), `share_of_final` (reachable / reachable at the most starts), `seconds`
    (cumulative LM time, approximate: counted per start).
    """
    spec = check_spec(spec).replace(method="numerical")
    n_arms = check_int("n_arms", n_arms, 1, MAX_SAMPLES)
    seed = check_int("seed", seed, 0)
    chunk = check_int("chunk", chunk, 1)
    counts = _counts(counts)
    S = counts[-1]
    rng = lambda q: audit_rng(seed, "starts_study", q)  # noqa: E731
    arms = draw_arms(spec, n_arms, rng("arms"))
    fixed = draw_fixed(spec, n_arms, rng("fixed"))
    q0 = np.zeros((n_arms, S, N_JOINTS))
    q0[:, 1:] = rng("starts").uniform(-np.pi, np.pi, size=(n_arms, S - 1, N_JOINTS))
    nodes = spec_nodes(spec)
    first = np.empty((n_arms, len(nodes)), dtype=np.int16)  # int8 would wrap at 128 starts
    seconds = np.zeros(S)

    from tqdm.auto import tqdm

    for s in tqdm(range(0, n_arms, chunk), desc="starts study", disable=not progress, leave=False):
        sl = slice(s, min(s + chunk, n_arms))
        # one start at a time so that the time per start can be recorded
        f = np.full((sl.stop - sl.start, len(nodes)), -1, dtype=np.int16)
        sub = arms[sl]
        b_all, n_all = (x.ravel() for x in np.indices(f.shape))
        pair_arms = DHRobot(sub.d[b_all], sub.a[b_all], sub.alpha[b_all])
        possible = possibly_reachable(pair_arms, pair_poses(spec, nodes, fixed[sl], b_all, n_all), max(1e-8, spec.tol))
        possible = possible.reshape(f.shape)
        for k in range(S):
            todo = (f < 0) & possible
            if not todo.any():
                break
            t = time.perf_counter()
            b_idx, n_idx = np.nonzero(todo)
            T = pair_poses(spec, nodes, fixed[sl], b_idx, n_idx)
            ok = solve_confirmed(sub, b_idx, T, q0[sl][:, k], spec)
            f[b_idx[ok], n_idx[ok]] = k
            seconds[k] += time.perf_counter() - t
        first[sl] = f
    total = first.size
    final = int(((first >= 0) & (first < S)).sum())
    rows, prev = [], 0
    for c in counts:
        reach = int(((first >= 0) & (first < c)).sum())
        rows.append(
            dict(
                starts=c,
                reachable=reach,
                fraction=reach / total,
                new=reach - prev,
                new_fraction=(reach - prev) / total,
                share_of_final=reach / final if final else float("nan"),
                seconds=float(seconds[:c].sum()),
            )
        )
        prev = reach
    return rows


def starts_recall(spec: DatasetSpec, n_poses: int = 2000, counts: Sequence[int] = (1, 2, 3, 5, 9, 17), seed: int = 0
                 ) -> list[dict]:
    """Recall of multi-start LM on poses known to be reachable (forward kinematics of random q).

    `n_poses` arms of `spec`'s family (the paper's study: Table 3's arbitrary 6-DOF arms), one
    target each, `fkine(q)` with `q ~ U(-pi, pi)^6`; LM (the spec's settings) from q0 = 0, then
    random starts as in `starts_study`. One row per entry of `counts`: `starts`,
    `found`, `recall` (found / n_poses). Complements `starts_study`, whose grid nodes
    have no ground truth for arbitrary arms.
    """
    check_spec(spec)
    n_poses = check_int("n_poses", n_poses, 1, MAX_SAMPLES)
    seed = check_int("seed", seed, 0)
    counts = _counts(counts)
    S = counts[-1]
    rng = lambda q: audit_rng(seed, "starts_recall", q)  # noqa: E731
    arms = draw_arms(spec, n_poses, rng("arms"))
    T = arms.fkine(rng("fixed").uniform(-np.pi, np.pi, size=(n_poses, N_JOINTS)))
    q0 = np.zeros((n_poses, S, N_JOINTS))
    q0[:, 1:] = rng("starts").uniform(-np.pi, np.pi, size=(n_poses, S - 1, N_JOINTS))
    first = np.full(n_poses, -1)
    for k in range(S):
        todo = np.nonzero(first < 0)[0]
        if not todo.size:
            break
        ok = solve_confirmed(arms, todo, T[todo], q0[:, k], spec)
        first[todo[ok]] = k
    rows = []
    for c in counts:
        found = int(((first >= 0) & (first < c)).sum())
        rows.append(dict(starts=c, found=found, recall=found / n_poses))
    return rows


def audit_labels(spec: DatasetSpec, n_arms: int = 50, seed: int = 0, *, ik: dict | None = None) -> dict:
    """Exact labels against the paper's numerical path on `n_arms` arms of a spherical-wrist spec.

    The numerical path is the paper's: LM with tol 1e-10, q0 = 0, one start (ilimit 500,
    rlimit 100; `ik` overrides, e.g. `dict(starts=9)`). Arms (and random orientations) come
    from an audit stream of `seed`, independent of the spec's training and test streams. Returns
    a dict: `spec`, `scope`, `arms`, `nodes` (labelled nodes per arm), `pairs` (arms x
    nodes), `exact_positives`, `numerical_positives`, `false_negatives` (exact 1, numerical
    0), `false_positives` (numerical 1, exact 0), `fn_rate` (of exact positives), `fp_rate`
    (of exact negatives), `agreement` (fraction of equal labels), `seconds_exact`,
    `seconds_numerical` (with the `possibly_reachable` pre-filter, which changes no label
    but skips far nodes).
    """
    check_spec(spec)
    if not spec.arm_family.exact:
        raise ValueError(f"spec {spec.name!r} has arms of family {spec.family!r}, which has no closed form: no "
                         "exact labels to audit against")
    n_arms = check_int("n_arms", n_arms, 1, MAX_SAMPLES)
    seed = check_int("seed", seed, 0)
    settings = dict(tol=1e-10, ilimit=500, rlimit=100, starts=1)
    if ik is not None:
        if not isinstance(ik, dict) or set(ik) - set(settings):
            raise ValueError(f"ik must be a dict with keys among {', '.join(settings)}, got {ik!r}")
        settings.update(ik)
    num_spec = spec.replace(method="numerical", **settings)
    rng = lambda q: audit_rng(seed, "audit_labels", q)  # noqa: E731
    arms = draw_arms(spec, n_arms, rng("arms"))
    fixed = draw_fixed(spec, n_arms, rng("fixed"))
    t = time.perf_counter()
    exact = labels_for(arms, spec, fixed, method="exact")
    t_exact = time.perf_counter() - t
    t = time.perf_counter()
    q0 = np.zeros((n_arms, num_spec.starts, N_JOINTS))
    if num_spec.starts > 1:
        q0[:, 1:] = rng("starts").uniform(-np.pi, np.pi, size=(n_arms, num_spec.starts - 1, N_JOINTS))
    num = labels_for(arms, num_spec, fixed, method="numerical", q0=q0)
    t_num = time.perf_counter() - t
    fn = int((exact & ~num).sum())
    fp = int((num & ~exact).sum())
    pos, pairs = int(exact.sum()), exact.size
    return dict(
        spec=spec.name,
        scope=spec.scope,
        arms=n_arms,
        nodes=exact.shape[1],
        pairs=pairs,
        exact_positives=pos,
        numerical_positives=int(num.sum()),
        false_negatives=fn,
        false_positives=fp,
        fn_rate=fn / pos if pos else float("nan"),
        fp_rate=fp / (pairs - pos) if pairs > pos else float("nan"),
        agreement=float((exact == num).mean()),
        seconds_exact=t_exact,
        seconds_numerical=t_num,
    )


def distinct_specs(specs: Sequence[DatasetSpec]) -> list[DatasetSpec]:
    """`specs` less those that differ from an earlier one only in name, sample count, seed,
    stream or LM settings: the ones whose grid, nodes, orientation and convention are new."""
    seen, unique = set(), []
    for s in specs:
        check_spec(s)
        key = (s.family, s.scope, s.lo, s.hi, s.step, s.select, s.fixed, s.convention)
        if key not in seen:
            seen.add(key)
            unique.append(s)
    return unique


def audit_table(specs: Sequence[DatasetSpec], n_arms: int = 50, seed: int = 0, progress: bool = False) -> list[dict]:
    """`audit_labels` for each of `specs` (DatasetSpecs; the paper's choice is
    `wsmap.paper.specs.audit_specs()`); a list of row dicts (`pandas.DataFrame(rows)` to
    tabulate)."""
    if isinstance(specs, (str, DatasetSpec)) or not isinstance(specs, Iterable):
        raise ValueError(f"specs must be a list of DatasetSpecs, got {specs!r}")
    specs = list(specs)
    for s in specs:
        if not isinstance(s, DatasetSpec):
            raise TypeError(
                f"audit_table takes DatasetSpecs, got {s!r}; look names up in a catalogue first "
                "(wsmap.paper.specs.paper_spec)"
            )
    rows = []
    for s in specs:
        if progress:
            print(f"audit {s.name} ...", file=sys.stderr, flush=True)
        rows.append(audit_labels(s, n_arms=n_arms, seed=seed))
    return rows
