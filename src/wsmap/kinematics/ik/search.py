"""Reachability search: multi-start Levenberg–Marquardt for any serial arm, joint limits inside the search.

`ikine_search` decides, per target pose, whether the arm reaches it, and returns a solution
where it does. It is the numerical path of `wsmap.workspace` (maps and
`wsmap.workspace.reachable`). Per target:

* **Starts, in order, with early exit.** Start 0 is `q0` (default zeros); starts `1 ..` are
  drawn uniformly inside the limits (`[-pi, pi)` for an unlimited revolute joint). Start `k`
  runs only on the targets that starts `0 .. k-1` did not solve, so a run with `k` starts is
  the first `k` starts of a longer one. The random numbers of a target come from a counter-based
  hash (splitmix64) of `seed`, the target pose's bits, the start and the joint
  (`wsmap.kinematics.ik.kernel.pose_keys`): deterministic, independent between targets, and
  the same wherever the pose sits in a batch. Every target is solved on its own (one compiled loop
  per target, `wsmap.kinematics.lm_compiled`), so results do not depend on `chunk`, on the
  thread count or on which targets share a call.
* **The iteration** is the paper's LM (Appendix; `wsmap.kinematics.ik.lm.ikine_LM`)::

      dq = (JᵀJ + λ² I)⁻¹ Jᵀe,   q' = P(q + dq)
      accept if |e(q')| < |e(q)|: q = q', λ /= 2, r = 0;  else λ *= 2, r += 1 (fail when r > rlimit)

  with `J` the base-frame geometric Jacobian, and three changes. (1) The rotation part of `e`
  is the rotation vector `θ·a` of `R_target·Rᵀ` rather than Corke's `tr2delta`
  `sin θ·a`, which also vanishes at a half turn: from random starts LM fell into that false zero
  about half the time. (2) `P` projects onto the limits: a revolute joint whose range is
  narrower than a turn and which leaves it is first moved by a multiple of 2·pi to the equivalent
  angle closest to the range (inside it when there is one), then clipped; a prismatic joint is
  clipped. And a joint on a limit that the gradient `Jᵀe` pushes outward is held for that step
  (its row and column replaced by the identity, as in Bertsekas' projected Newton), so the
  iteration slides along the limits instead of stalling against them. Joints without limits, or
  with a range of a turn or more, move freely and are brought into their range by a multiple of
  2·pi at the end. (3) Per-start limits `ilimit = 100`, `rlimit = 20` (see
  `DEFAULT_ILIMIT`).
* **Two passes per start on limited arms.** Where the constrained run fails and the limits did
  change it, LM runs again from the same start ignoring the limits, and its solution, moved into
  the range by multiples of 2·pi, counts if it lies inside the limits (a solution behind a limit
  that the constrained run could not walk around). Where the limits never changed the
  constrained run, the free run would be the same run, so it is skipped.
* **Success** = the error norm reached `tol`, `q` lies inside the limits, and an independent
  forward kinematics (`SerialChain.fkine`) of the returned `q` puts the tool within
  `confirm_tol` of the target (metres in position, radians in rotation angle). A start whose
  check fails does not count, and the next start runs.
* **Sound pre-filter** (`wsmap.kinematics.ik.reach_filter`). A target whose wrist point is
  farther from the base than the sum of the arm's link lengths (plus `confirm_tol` margins), or
  outside the set that the joints before it can sweep it through, cannot be confirmed by any
  `q`; it is marked unreachable (`IKReason.OUT_OF_REACH`) without running LM. It changes no
  success, only the time.
* **Exact stagnation shortcut**: once λ is so large that no later step can move `q` by one bit,
  every later trial is rejected, so the start fails at once.

`wsmap.kinematics.ik.lm_reference` is the same search in numpy, the reference the tests
compare the compiled kernel with. The paper's own one-start path,
`wsmap.kinematics.ik.lm.ikine_LM` (DH arms, limits checked after convergence), is unchanged;
the paper's pipeline keeps using it (in the maps: `ik={"solver": "paper"}`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..chain import PRISMATIC, SerialChain, flatten_arms
from ..transforms import check_rigid
from .fk_seeds import nearest_starts, sample_count
from .kernel import arm_arrays, pose_keys, run_compiled, unsolved
from .memo import Memo, as_chain_memo, chain_key
from .certificate import joint_certificate
from .reach_filter import limit_filter, position_filter, reach_filter
from .settings import (DEFAULT_ILIMIT, DEFAULT_RLIMIT, DEFAULT_STARTS, FK_CONFIRM_TOL, MAP_SETTINGS, SearchSettings,
                       check_kernel_settings, integer_setting)
from .solution import MIN_TOL, IKSolution, failure_reasons
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # names of the annotations only (wsmap._typing)
    from wsmap._typing import ArrayLike, Callable
    from wsmap.kinematics.chain import Arm

__all__ = ["MAP_SETTINGS", "SearchSettings", "map_search", "check_search", "broadcast_targets", "with_joint_limits",
           "search_solution", "DEFAULT_ILIMIT", "DEFAULT_RLIMIT", "DEFAULT_STARTS", "FK_CONFIRM_TOL",
           "ikine_search"]

_ARM_ARRAYS = Memo()
# targets per call of the border search (bounds its (C, K, n) array of starts)
_BORDER_CHUNK = 1 << 16
#: Boxes per node of the branch and bound (`wsmap.kinematics.ik.certificate.joint_certificate`) that
#: the border search spends before its starts at a node, to skip nodes it proves unreachable (0: off;
#: one arm, revolute joints, limits on). Sound, so the answers are the same either way; only the time
#: differs (`benchmarks/maps/bench_certificates.py`).
BORDER_CERTIFY_BUDGET = 0
#: Starts per node of the global seeding: the configurations of its nearest sampled poses
#: (`wsmap.kinematics.ik.fk_seeds`), measured in `benchmarks/maps/bench_recall.py`.
FK_STARTS_PER_NODE = 8


def _check_seed(seed):
    if seed is None:
        return int(np.random.default_rng().integers(0, 2**63))
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0 or seed >= 2**64:
        raise ValueError(f"seed must be a non-negative integer below 2**64 (or None for a random one), got {seed!r}")
    return int(seed)


def _check_settings(chain: SerialChain, tol, lam, confirm_tol, seed, q0):
    """The checks `ikine_search` and `map_search` share: `tol`, `lam` and
    `confirm_tol` positive and finite with `confirm_tol >= tol`; returns `(seed, q0)` checked
    (`q0` default zeros, shape `(..., n)`)."""
    for label, v in (("tol", tol), ("lam", lam), ("confirm_tol", confirm_tol)):
        if isinstance(v, bool) or not (np.isscalar(v) and np.isreal(v) and v > 0 and np.isfinite(v)):
            raise ValueError(f"{label} must be positive and finite, got {v!r}")
    if tol < MIN_TOL:
        raise ValueError(f"tol must be at least {MIN_TOL:g} (float64 forward kinematics is exact to about 1e-16 per "
                         f"metre, so no pose meets a smaller one), got {tol!r}")
    if confirm_tol < tol:
        raise ValueError(f"confirm_tol ({confirm_tol}) must be at least tol ({tol})")
    seed = _check_seed(seed)
    q0 = np.zeros(chain.n) if q0 is None else chain._check_q(q0)
    return seed, q0


def check_search(chain: SerialChain, starts, ilimit, rlimit, tol, lam, confirm_tol, seed, q0):
    """The arguments `ikine_search` and its numpy reference check alike: `starts >= 1`,
    `ilimit`, `rlimit >= 0` and `_check_settings`'s; returns `(starts, ilimit, rlimit,
    seed, q0)` checked."""
    starts = integer_setting("starts", starts, 1)
    ilimit = integer_setting("ilimit", ilimit, 0)
    rlimit = integer_setting("rlimit", rlimit, 0)
    return (starts, ilimit, rlimit) + _check_settings(chain, tol, lam, confirm_tol, seed, q0)


def broadcast_targets(chain: SerialChain, T: np.ndarray, q0: np.ndarray):
    """Targets `T` (..., 4, 4), the arms of `chain` (batch shape `(...)`) and starts `q0`
    (..., n) broadcast together and flattened: `(shape, count, Tf (count, 4, 4), Q0 (count, n),
    arm_of (count,))`, `arm_of` the index of each target's arm in the flattened batch."""
    n, batch = chain.n, chain.batch_shape
    shape = np.broadcast_shapes(T.shape[:-2], batch, q0.shape[:-1])
    count = int(np.prod(shape, dtype=np.int64))
    Tf = np.broadcast_to(T, shape + (4, 4)).reshape(-1, 4, 4)
    Q0 = np.broadcast_to(q0, shape + (n,)).reshape(-1, n)
    arm_of = np.broadcast_to(np.arange(int(np.prod(batch, dtype=np.int64))).reshape(batch), shape).reshape(-1)
    return shape, count, Tf, Q0, arm_of


def search_solution(shape: tuple, q, ok, it, res, start, possible) -> IKSolution:
    """The flat answers of a search (`count` targets) as an `IKSolution` of batch shape
    `shape`; `possible` (count,) False where the pre-filter ruled the target out of reach."""
    return IKSolution(q.reshape(shape + q.shape[-1:]), ok.reshape(shape), it.reshape(shape), res.reshape(shape),
                      failure_reasons(ok, out_of_reach=~possible).reshape(shape), start.reshape(shape))


def with_joint_limits(chain: SerialChain, joint_limits: bool) -> SerialChain:
    """The chain, or without its revolute limits (prismatic joints keep their strokes)."""
    if joint_limits or chain.qlim is None:
        return chain
    if chain.coupling is not None:
        return chain.without_revolute_limits()
    pris = np.array([k == PRISMATIC for k in chain.kinds])
    if not pris.any():
        return chain.replace(qlim=None)
    qlim = np.array(chain.qlim, dtype=np.float64)
    qlim[..., ~pris, 0], qlim[..., ~pris, 1] = -np.inf, np.inf
    return chain.replace(qlim=qlim)


def _possible_targets(chain, T, shape, count, arm_of, confirm_tol, position_only):
    """The flat targets (count,) of `ikine_search` that the sound pre-filters leave (`arm_of`
    each target's arm); a coupled chain's are its relaxation's (`SerialChain.uncoupled`)."""
    chain = chain.uncoupled()
    if not position_only:
        return reach_filter(chain, np.broadcast_to(T, shape + (4, 4)), confirm_tol).reshape(-1)
    pb = position_filter(chain, np.broadcast_to(T, shape + (4, 4))[..., :3, 3].reshape(-1, 3), confirm_tol)
    if pb.ndim == 1:
        return np.broadcast_to(pb, (count,))
    B = int(np.prod(chain.batch_shape, dtype=np.int64))
    return pb.reshape(B, count)[arm_of, np.arange(count)]  # a batch of arms: the filter per target's arm


def ikine_search(
    robot: Arm,
    T: ArrayLike,
    *,
    starts: int = DEFAULT_STARTS,
    seed: int = 0,
    q0: ArrayLike | None = None,
    tol: float = 1e-10,
    ilimit: int = DEFAULT_ILIMIT,
    rlimit: int = DEFAULT_RLIMIT,
    lam: float = 0.1,
    joint_limits: bool = True,
    confirm_tol: float = FK_CONFIRM_TOL,
    chunk: int = 16384,
    progress: bool | None = None,
    position_only: bool = False,
    kernel: Mapping | None = None,
) -> IKSolution:
    """Multi-start Levenberg–Marquardt reachability search with joint limits (see the module notes).

    Parameters
    ----------
    robot : SerialChain or DHRobot
        One arm or a batch; its batch shape broadcasts with the targets'.
    T : array_like, shape (..., 4, 4)
        Target tool poses in the base (world) frame; each must be a rigid transform.
    starts : int
        Start configurations per target, tried in order until one succeeds (1: only `q0`).
    seed : int >= 0, or None
        Seed of the random starts 1.. (None: a fresh random seed, not reproducible).
    q0 : array_like, shape (n,) or (..., n), optional
        Start 0 (default zeros; projected into the limits).
    tol, ilimit, rlimit, lam :
        Per start: tolerance on the error norm (m and rad), iteration limit, consecutive-rejection
        limit, initial λ. Defaults 1e-10, 100, 20, 0.1 (the paper's LM: 1e-10, 500, 100, 0.1).
    joint_limits : bool
        Honour the arm's limits (default). False drops the revolute joints' limits.
    confirm_tol : float
        Forward-kinematics confirmation tolerance (m, rad); at least `tol`.
    chunk : int
        Targets solved together (bounds memory; the result does not depend on it).
    progress : callable, optional
        Called with the number of targets finished after each chunk.
    position_only : bool
        Reach the position of each `T` at any orientation.
    kernel : mapping, optional
        The kernels' own settings by name (`SearchSettings.kernel`, `KERNEL_FIELDS`).

    Returns
    -------
    IKSolution
        Of the broadcast batch shape of targets and
        arms: `q` a confirmed solution where `success` (inside the limits); elsewhere the end point
        of the start with the smallest final error (inside the limits; NaN where LM was not run);
        `iterations` over all starts tried; `residual` the error norm at `q` (`inf` where LM
        was not run); `reason` `OUT_OF_REACH` where the pre-filter ruled the target out, else
        `NO_CONVERGENCE` where no start succeeded; `start` the index of the start that succeeded,
        -1 where none did.

    Notes
    -----
    Runs on `wsmap.kinematics.lm_compiled.set_threads` threads.
    """
    chain = with_joint_limits(as_chain_memo(robot), joint_limits)
    T = check_rigid("target poses", T)
    starts, ilimit, rlimit, seed, q0 = check_search(chain, starts, ilimit, rlimit, tol, lam, confirm_tol, seed, q0)
    chunk = integer_setting("chunk", chunk, 1)
    extra = dict(check_kernel_settings(kernel or {}))
    shape, count, Tf, Q0, arm_of = broadcast_targets(chain, T, q0)
    q_out, ok_out, it_out, res_out, start_out = unsolved(count, chain.n)
    possible = _possible_targets(chain, T, shape, count, arm_of, confirm_tol, position_only)

    aa = _ARM_ARRAYS.get(chain_key(chain), lambda: arm_arrays(chain))
    for s0 in range(0, count, chunk):
        todo = s0 + np.flatnonzero(possible[s0 : s0 + chunk])
        keys = pose_keys(seed, Tf[todo])
        q, ok, it, res, st = run_compiled(2 if position_only else 0, aa, arm_of[todo], Tf[todo], keys,
                                          Q0[todo][:, None, :],
                                          np.ones(todo.size, dtype=np.int64), 1, starts, ilimit, rlimit, tol,
                                          lam, confirm_tol, **extra)
        q_out[todo], ok_out[todo], it_out[todo], res_out[todo], start_out[todo] = q, ok, it, res, st
        if progress is not None:
            progress(min(s0 + chunk, count) - s0)
    return search_solution(shape, q_out, ok_out, it_out, res_out, start_out, possible)


# --------------------------------------------------------------------------- maps: starts from neighbours
def map_search(robot: Arm, T: ArrayLike, neighbours: ArrayLike, settings: SearchSettings | None = None, *,
               q_init: ArrayLike | None = None, progress: Callable[[int], object] | None = None,
               accept: Callable[[np.ndarray], np.ndarray] | None = None, **overrides) -> IKSolution:
    """Reachability of a map's nodes, each start of `ikine_search`'s iteration, with starts taken
    from neighbouring nodes' solutions (continuation): the solution at a node is an excellent start
    at the next one, and an unreachable node costs a few failed starts instead of dozens.

    Parameters
    ----------
    robot : SerialChain or DHRobot, one arm or a batch of `B` arms (flattened)
    T : (N, 4, 4) the nodes' target poses (base frame), shared by the arms
    neighbours : (N, K) int, node indices of each node's neighbours, `-1` padding (e.g. from
        `wsmap.workspace.grids.node_neighbours`)
    settings : `SearchSettings` of solver `"search"` (default `SearchSettings()`, the
        measured `MAP_SETTINGS`); what each field does here is in its docstring (`starts`,
        `seeds`, `retry`, `hole_retry`, `border_starts`, `accept_retry`, `gtol`,
        `limit_bound`, ...; per start `ilimit`, `rlimit`, `tol`, `lam`, `joint_limits`,
        `confirm_tol` as `ikine_search`)
    q_init : optional `(N, n)` (or `(B, N, n)`) starts tried first at each node, NaN rows where
        none (e.g. each node's solution at a neighbouring orientation, or a sampled configuration
        whose tool lies near the node)
    progress : called with the number of targets settled as the search goes (those the reach filter
        rules out at once, those solved after each pass and wave, the rest at the end); the numbers
        add up to the number of targets
    accept : optional configuration predicate, `accept(q)` with `q` `(M, n)` → bool `(M,)`
        (e.g. collision-free, `wsmap.collision.CollisionChecker`); a converged solution it
        rejects does not count, and its node keeps looking: neighbours' accepted solutions in the
        waves, the retries, then `accept_retry` more random starts, and the border search
    **overrides : fields of `settings` to change for this call (`SearchSettings.replace`)

    Returns
    -------
    IKSolution
        Of shape `(B, N)` (`(N,)` for one
        arm), its fields as `ikine_search`'s; `start` is the random start's index `k`
        (0 = `q0`) that succeeded, `-2` where a neighbour's solution did, `-3` where a sampled
        configuration (global seeding) did, `-1` where none did.

    Notes
    -----
    Per arm, in passes: (1) every node: `q0` then `starts` random starts (the first ones of
    `ikine_search`'s sequence) until one succeeds; (2) waves: every unsolved node with a solved
    neighbour whose solution it has not tried takes up to `seeds` of them, in neighbour order, as
    starts, until a wave solves nothing new; (2b) global seeding (`fk_seeds` > 0,
    `wsmap.kinematics.ik.fk_seeds`): every node left takes the configurations of the
    `FK_STARTS_PER_NODE` sampled poses nearest its own as starts, then (2) again, so that islands no
    solved node borders (and maps where `q0` solves nothing) are searched; (3) the nodes left take
    `retry` more random starts,
    and (2) again; (4) the border search: every node still unsolved next to a solved node, and not
    border-searched before, tries its solved neighbours' solutions not tried yet and then the `border_starts`
    starts of `ikine_search` (with `seed` and `q0`, the same starts that search draws for
    the node's pose), then (2) again, until no new node borders a solved one. So a node next to a
    solved node is reached whenever `ikine_search` with `border_starts` starts reaches it,
    whatever the waves did before. Every success is confirmed by forward kinematics inside the
    limits, so `True` is never wrong; recall is measured in `benchmarks/maps/bench_fast_maps.py` and
    `benchmarks/maps/bench_recall_arms.py`. Deterministic; does not depend on the thread count.
    """
    s = SearchSettings() if settings is None else settings
    if not isinstance(s, SearchSettings):
        raise ValueError(f"settings must be a SearchSettings, got {type(s).__name__}")
    if overrides:
        s = s.replace(**overrides)
    if s.solver != "search":
        raise ValueError(f"map_search runs the solver 'search', got settings of solver {s.solver!r}")
    if accept is not None and not callable(accept):
        raise TypeError(f"accept must be a configuration predicate (callable), got {type(accept).__name__}")
    search = _MapSearch(robot, T, neighbours, s, q_init, progress, accept)
    return search.solve()


def _check_map_targets(T, neighbours):
    """`T` (N, 4, 4) rigid and `neighbours` (N, K) node indices or -1, checked: `(T, nb)`."""
    T = check_rigid("target poses", T)
    if T.ndim != 3:
        raise ValueError(f"target poses must have shape (N, 4, 4), got {T.shape}")
    N = T.shape[0]
    nb = np.asarray(neighbours)
    if nb.ndim != 2 or nb.shape[0] != N or not np.issubdtype(nb.dtype, np.integer):
        raise ValueError(f"neighbours must be an integer array of shape ({N}, K), got {nb.dtype} {nb.shape}")
    if nb.size and (nb.min() < -1 or nb.max() >= N):
        raise ValueError(f"neighbours must be node indices in [0, {N}) or -1 (none)")
    return T, nb


class _MapSearch:
    """The state of one `map_search` (every arm x node target, flattened: target `b·N + i`) and
    its passes; the methods share the answers found so far."""

    def __init__(self, robot, T, neighbours, s: SearchSettings, q_init, progress, accept):
        chain = with_joint_limits(as_chain_memo(robot), s.joint_limits)
        T, nb = _check_map_targets(T, neighbours)
        seed, q0 = _check_settings(chain, s.tol, s.lam, s.confirm_tol, s.seed, s.q0_array)
        N, n = T.shape[0], chain.n
        if q0.shape != (n,):
            raise ValueError(f"q0 must have shape ({n},) for a map, got {q0.shape}")
        batch = chain.batch_shape
        B = int(np.prod(batch, dtype=np.int64))
        self.s, self.T, self.nb, self.q0, self.accept, self.progress = s, T, nb, q0, accept, progress
        self.N, self.n, self.B, self.M, self.K, self.batch = N, n, B, B * N, nb.shape[1], batch
        self.flat = chain if not batch else flatten_arms(chain)
        self.chain = chain
        self.arm_of = np.repeat(np.arange(B), N)
        self.node_of = np.tile(np.arange(N), B)
        self.possible = self._possible(chain)
        self.q_init = self._q_init(q_init)
        self.keys_node = pose_keys(seed, T)
        self.seed = seed
        self.aa = _ARM_ARRAYS.get(chain_key(self.flat), lambda: arm_arrays(self.flat))
        self.per_start = (s.ilimit, s.rlimit, s.tol, s.lam, s.confirm_tol, float(s.gtol))
        self.kernel = dict(s.kernel)
        M = self.M
        self.q = np.full((M, n), np.nan)
        self.ok = np.zeros(M, dtype=bool)
        self.its = np.zeros(M, dtype=np.int64)
        self.res = np.full(M, np.inf)
        self.start = np.full(M, -1, dtype=np.int64)
        self.rejected = np.zeros(M, dtype=bool)  # a converged solution was refused by `accept`
        self.tried = np.zeros((M, self.K), dtype=bool)
        self.valid_nb = nb >= 0
        self.slot_nb = np.where(self.valid_nb, nb, 0)
        self.reported = 0

    def _possible(self, chain):
        """Targets the sound pre-filters leave (M,) bool (a coupled chain's: its relaxation's,
        `SerialChain.uncoupled`, whose reach holds the coupled chain's)."""
        s, T, batch = self.s, self.T, self.batch
        chain, flat = chain.uncoupled(), self.flat.uncoupled()
        if s.position_only:
            # (N,) for one arm, (B, N) for a batch: target b·N + i
            return position_filter(flat if batch else chain, T[:, :3, 3], s.confirm_tol).reshape(-1)
        Tb = T[None] if not batch else T[:, None]
        possible = reach_filter(flat if batch else chain, Tb, s.confirm_tol)
        possible = (possible.T if batch else possible).reshape(-1)
        if s.limit_bound and not batch:
            # the limits-aware invariants of the last axis (its first build per arm takes 0.1-0.4 s;
            # an arm in a batch, e.g. the labels of a family, would pay that per arm, so only one arm)
            idx = np.flatnonzero(possible)
            possible[idx] = limit_filter(chain, T[idx], s.confirm_tol)
        return possible

    def _q_init(self, q_init):
        if q_init is None:
            return None
        N, n, B = self.N, self.n, self.B
        q_init = np.asarray(q_init, dtype=np.float64)
        if q_init.shape not in ((N, n), (B, N, n)):
            raise ValueError(f"q_init must have shape ({N}, {n}) or ({B}, {N}, {n}), got {q_init.shape}")
        return np.broadcast_to(q_init, (B, N, n)).reshape(self.M, n)

    def report(self, count):
        if self.progress is not None and count:
            self.reported += count
            self.progress(count)

    def solve(self) -> IKSolution:
        s = self.s
        self.report(int(self.M - self.possible.sum()))
        self.first_pass()
        self.waves()
        if s.fk_seeds:
            self.fk_seed_pass()
        if s.retry:
            self.retries()
        if self.accept is not None and s.accept_retry:
            self.accept_retries()
        if s.border_starts and self.K:
            self.border_search(s.border_starts)
        self.report(self.M - self.reported)
        shape = (self.N,) if not self.batch else self.batch + (self.N,)
        ok = self.ok
        return IKSolution(self.q.reshape(shape + (self.n,)), ok.reshape(shape), self.its.reshape(shape),
                          self.res.reshape(shape), failure_reasons(ok, out_of_reach=~self.possible).reshape(shape),
                          self.start.reshape(shape))

    def run(self, idx, qexp, nexp, k_first, k_last, seeded, per_start=None, free=None):
        """Run the kernel on targets `idx` from the explicit starts `qexp` (C, E, n) (`nexp`
        of them per target), then random starts `k_first .. k_last - 1`; keep what it solved.
        `seeded`: False for `q0` and random starts, else the `start` code of the explicit ones
        (True: -2, a neighbour's solution; -3: a sampled configuration)."""
        if not idx.size:
            return 0
        free = (not seeded or self.s.seed_free_pass) if free is None else free
        mode = 2 if self.s.position_only else 0
        nodes = self.node_of[idx]
        qq, okk, it, rr, st = run_compiled(mode, self.aa, self.arm_of[idx], self.T[nodes], self.keys_node[nodes], qexp,
                                           nexp, k_first, k_last, *(per_start or self.per_start), free_pass=free,
                                           **self.kernel)
        if self.accept is not None and okk.any():
            hit = np.flatnonzero(okk)
            yes = np.asarray(self.accept(qq[hit]), dtype=bool)
            self.rejected[idx[hit[~yes]]] = True
            okk = okk.copy()
            okk[hit[~yes]] = False
        ok, res = self.ok, self.res
        self.its[idx] += it
        better = okk | (~ok[idx] & (rr < res[idx]))
        self.q[idx[better]] = qq[better]
        res[idx[better]] = rr[better]
        ok[idx] |= okk
        self.report(int(okk.sum()))
        if seeded:
            self.start[idx[okk]] = -2 if seeded is True else seeded
        else:
            # positions in the run's order (explicit q0 first) → random-start index k
            self.start[idx[okk]] = np.where(st[okk] < nexp[okk], 0, st[okk] - nexp[okk] + k_first)
        return int(okk.sum())

    def _neighbour_starts(self, idx, use, nbt, width):
        """The solutions of the neighbours where `use` (C, K) as explicit starts `(C, width, n)`."""
        qexp = np.zeros((idx.size, width, self.n))
        slot = np.cumsum(use, axis=1) - 1
        r, c = np.nonzero(use)
        qexp[r, slot[r, c]] = self.q[nbt[r, c]]
        return qexp

    def _neighbour_targets(self, idx):
        """Node indices (C, K) of the neighbours of targets `idx` and their target indices."""
        nbn = self.nb[self.node_of[idx]]
        return nbn, self.arm_of[idx][:, None] * self.N + np.where(nbn >= 0, nbn, 0)

    def waves(self):
        # a wave: every unsolved node next to a node solved since the last wave tries up to
        # `seeds` of those fresh solutions; it ends when a wave solves nothing
        seeds, ok = self.s.seeds, self.ok
        if not seeds or not self.K:
            return
        fresh = ok.copy()
        while fresh.any():
            cand = np.flatnonzero(~ok & self.possible)
            if not cand.size:
                return
            nbn, nbt = self._neighbour_targets(cand)
            usable = (nbn >= 0) & fresh[nbt] & ~self.tried[cand]
            pick = usable & (np.cumsum(usable, axis=1) <= seeds)
            count = pick.sum(axis=1)
            has = count > 0
            if not has.any():
                return
            cand, pick, nbt, count = cand[has], pick[has], nbt[has], count[has]
            self.tried[cand] |= pick
            qexp = self._neighbour_starts(cand, pick, nbt, seeds)
            before = ok.copy()
            self.run(cand, qexp, count, 0, 0, True)
            fresh = ok & ~before

    def solved_neighbours(self):
        # solved neighbours per target, one neighbour slot at a time: (B, N) arrays, never (B·N, K)
        ok_bn = self.ok.reshape(self.B, self.N)
        count = np.zeros((self.B, self.N), dtype=np.int32)
        for k in range(self.K):
            count += ok_bn[:, self.slot_nb[:, k]] & self.valid_nb[:, k]
        return count.reshape(-1)

    def _from_q0(self, idx):
        """Start 0 (`q0`) as the one explicit start of targets `idx`: `(qexp, nexp)`."""
        return np.broadcast_to(self.q0, (idx.size, 1, self.n)), np.ones(idx.size, dtype=np.int64)

    def first_pass(self):
        first = np.flatnonzero(self.possible)
        starts, q_init, q0 = self.s.starts, self.q_init, self.q0
        if q_init is None:
            self.run(first, *self._from_q0(first), 1, 1 + starts, False)
            return
        # the given start first where there is one, then q0 (start 0 counts for both)
        qexp = np.empty((first.size, 2, self.n))
        given = np.all(np.isfinite(q_init[first]), axis=1)
        qexp[:, 0] = np.where(given[:, None], q_init[first], q0)
        qexp[:, 1] = q0
        self.run(first, qexp, np.where(given, 2, 1).astype(np.int64), 1, 1 + starts, False)

    def fk_seed_pass(self):
        # global seeding (wsmap.kinematics.ik.fk_seeds): every node the first pass and the waves
        # left takes the configurations of the sampled poses nearest its own as starts, so that a
        # region no solved node borders (an island, or every node when q0 solves none) gets
        # started; the waves then spread from what they solve
        s = self.s
        idx = np.flatnonzero(~self.ok & self.possible)
        if not idx.size:
            return
        per_node = FK_STARTS_PER_NODE
        qexp = nearest_starts(self.flat, self.T, self.arm_of[idx], self.node_of[idx],
                              sample_count(s.fk_seeds, self.N), per_node, self.seed, s.position_only)
        self.run(idx, qexp, np.full(idx.size, per_node, dtype=np.int64), 0, 0, -3)
        self.waves()

    def retries(self):
        # only next to solved nodes: a reachable node that the waves missed borders solved ones (a
        # pocket behind a joint limit, another branch), while nodes deep in an unreachable region
        # would spend every retry in vain. A hole (at least half of its neighbours solved) is most
        # likely reachable: it gets hole_retry starts instead
        s, M = self.s, self.M
        left = ~self.ok & self.possible
        hole = np.zeros(M, dtype=bool)
        if self.K:
            solved_nb = self.solved_neighbours()
            left &= solved_nb > 0
            hole = left & (2 * solved_nb.reshape(self.B, self.N) >= self.valid_nb.sum(axis=1)).reshape(-1)
        k0 = 1 + s.starts
        for group, count in ((left & ~hole, s.retry), (hole, max(s.retry, s.hole_retry))):
            idx = np.flatnonzero(group)
            self.run(idx, np.zeros((idx.size, 1, self.n)), np.zeros(idx.size, dtype=np.int64), k0, k0 + count, False)
        self.waves()

    def accept_retries(self):
        # a node whose every solution so far was refused is reachable by the chain: other random
        # starts find other solutions (branches, the self-motion of a redundant arm)
        s = self.s
        k0 = 1 + s.starts + max(s.retry, s.hole_retry)
        for r0 in range(0, s.accept_retry, 4):
            idx = np.flatnonzero(self.rejected & ~self.ok)
            if not idx.size:
                break
            w = min(4, s.accept_retry - r0)
            self.run(idx, np.zeros((idx.size, 1, self.n)), np.zeros(idx.size, dtype=np.int64), k0 + r0, k0 + r0 + w,
                     False)
            self.waves()

    def border_search(self, count):
        # what ikine_search does for one pose, at every unsolved node next to a solved one, once
        # each: its starts (q0, then its random starts 1 .. count-1 from the same keys) with its
        # per-start settings, after the solved neighbours' solutions that the waves have not tried
        # yet; then the waves carry what it finds, and the nodes that newly border a solved node
        # get it too
        s = self.s
        per_start = (DEFAULT_ILIMIT, DEFAULT_RLIMIT, s.tol, s.lam, s.confirm_tol, 0.0)
        searched = np.zeros(self.M, dtype=bool)
        while True:
            cand = np.flatnonzero(~self.ok & self.possible & ~searched & (self.solved_neighbours() > 0))
            if not cand.size:
                return
            searched[cand] = True
            cand = self._skip_certified(cand)
            # chunks bound the (C, K, n) starts
            for c0 in range(0, cand.size, _BORDER_CHUNK):
                self._border_chunk(cand[c0 : c0 + _BORDER_CHUNK], count, per_start)
            self.waves()

    def _skip_certified(self, cand):
        """`cand` without the targets the branch and bound proves unreachable (within the
        confirmation tolerance, so no confirmed solution is lost), which are marked impossible."""
        budget, s = BORDER_CERTIFY_BUDGET, self.s
        if not budget or self.batch or s.position_only or self.chain.qlim is None:
            return cand
        cert = joint_certificate(self.chain.uncoupled(), self.T[self.node_of[cand]], s.confirm_tol, budget=budget)
        self.possible[cand[cert]] = False
        return cand[~cert]

    def _border_chunk(self, idx, count, per_start):
        ok = self.ok
        nbn, nbt = self._neighbour_targets(idx)
        use = (nbn >= 0) & ok[nbt] & ~self.tried[idx]
        self.tried[idx] |= use
        count_nb = use.sum(axis=1)
        has = count_nb > 0
        if has.any():
            qexp = self._neighbour_starts(idx[has], use[has], nbt[has], self.K)
            self.run(idx[has], qexp, count_nb[has].astype(np.int64), 0, 0, True)
        idx = idx[~ok[idx]]
        self.run(idx, *self._from_q0(idx), 1, count, False, per_start=per_start, free=True)
