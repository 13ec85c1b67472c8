"""Full-batch trainers of the paper's Table 2, as `torch.optim` optimisers.

The paper trained its networks with MATLAB's Neural Network Toolbox. Table 2 compares five of its
training functions; this module provides each as a torch optimiser:

==========  ===========  =========================================================================
name        MATLAB       algorithm
==========  ===========  =========================================================================
`rprop`   `trainrp`  resilient backpropagation (Riedmiller & Braun 1993): `paper_rprop`
`scg`     `trainscg` scaled conjugate gradient (Møller 1993): `SCG`
`cgb`     `traincgb` conjugate gradient with Powell–Beale restarts (Powell 1977): `CGB`
`oss`     `trainoss` one-step secant (Battiti 1992): `OSS`
`gdx`     `traingdx` gradient descent, momentum, adaptive learning rate: `GDX`
==========  ===========  =========================================================================

All are *full-batch* and deterministic. Like `torch.optim.LBFGS`, `step(closure)` takes a
closure that zeroes the gradients, evaluates the loss on the whole training set, calls
`backward()` and returns the loss; the optimisers here may call it several times per step (line
searches, trial points). One `step` is one MATLAB *epoch*.

`SCG`, `CGB`, `OSS` and `GDX` treat all parameters as one flat vector
(`torch.nn.utils.parameters_to_vector`); vectors are kept in the parameters' dtype (float32
for the networks), scalars (dot products, step sizes) in Python floats. Every step starts by
calling the closure at the current parameters: `wsmap.learn.training.train` answers that call from
a cache, so it costs nothing there.

`paper_rprop` is the only *elementwise* optimiser (each parameter's update depends only on its
own gradient history). That is what lets `wsmap.learn.training` train several independent sessions
stacked in one model: see `ELEMENTWISE`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

import torch
from torch.nn.utils import parameters_to_vector
from torch.optim import Optimizer

__all__ = [
    "OPTIMIZERS",
    "ALIASES",
    "ELEMENTWISE",
    "canonical_name",
    "make_optimizer",
    "paper_rprop",
    "SCG",
    "CGB",
    "OSS",
    "GDX",
    "charalambous_search",
]

#: MATLAB's trainrp defaults as the paper used them (delta0, (delt_dec, delt_inc), (min, deltamax)).
RPROP_DEFAULTS = {"lr": 0.07, "etas": (0.5, 1.2), "step_sizes": (1e-6, 50.0)}


def paper_rprop(params: Iterable, *, lr: float = 0.07, etas: tuple[float, float] = (0.5, 1.2),
                step_sizes: tuple[float, float] = (1e-6, 50.0), **kwargs) -> torch.optim.Rprop:
    """Resilient backpropagation configured as the paper (MATLAB `trainrp`).

    Riedmiller & Braun, "A direct adaptive method for faster backpropagation learning: the RPROP
    algorithm", ICNN 1993. Defaults: initial step `lr = 0.07` (trainrp `delta0`), step factors
    `etas = (0.5, 1.2)` (`delt_dec`, `delt_inc`), step bounds `step_sizes = (1e-6, 50)`
    (`deltamax` 50; MATLAB has no lower bound, torch needs one). Extra keyword arguments go to
    `torch.optim.Rprop`.

    Difference from MATLAB: torch's Rprop is the Rprop⁻ variant that, after a gradient sign change,
    shrinks the step and *skips* that parameter's update (its stored gradient is zeroed), while
    trainrp applies the shrunken step at once in the direction of the new gradient sign. Both
    are elementwise; trajectories differ in detail, not in character.

    `step(closure)` calls the closure once per step (one epoch).
    """
    return torch.optim.Rprop(params, lr=lr, etas=tuple(etas), step_sizes=tuple(step_sizes), **kwargs)


# --------------------------------------------------------------------------------------------
# Flat-vector base class
# --------------------------------------------------------------------------------------------


class _FlatOptimizer(Optimizer):
    """Common machinery: one parameter group seen as a flat vector, closure evaluation."""

    def __init__(self, params, defaults: dict):
        super().__init__(params, defaults)
        if len(self.param_groups) != 1:
            raise ValueError(f"{type(self).__name__} doesn't support per-parameter options (one parameter group)")
        self._params: list[torch.Tensor] = self.param_groups[0]["params"]
        self._numel = sum(p.numel() for p in self._params)
        #: True when the last step could not move (a line search returned a zero step).
        self.stalled = False

    # -- flat vector helpers --------------------------------------------------------------
    @property
    def _state(self) -> dict:
        # Like LBFGS: all state lives under the first parameter, so state_dict() round-trips it.
        return self.state[self._params[0]]

    def _get_x(self) -> torch.Tensor:
        return parameters_to_vector(self._params).detach().clone()

    @torch.no_grad()
    def _set_x(self, x: torch.Tensor) -> None:
        # Copy in place (vector_to_parameters would re-point .data at views of x).
        offset = 0
        for p in self._params:
            n = p.numel()
            p.copy_(x[offset:offset + n].view_as(p))
            offset += n

    def _flat_grad(self) -> torch.Tensor:
        parts = []
        for p in self._params:
            g = p.grad
            parts.append(torch.zeros_like(p).reshape(-1) if g is None else g.detach().reshape(-1))
        return torch.cat(parts).clone()

    def _start_step(self, closure: Callable) -> tuple[torch.Tensor, float, torch.Tensor]:
        """The start of every step: `closure` checked (these optimisers re-evaluate the loss), then
        the flat weights `x`, the loss `f` and its gradient `g` at `x`."""
        if closure is None:
            raise ValueError(f"{type(self).__name__} needs a closure that re-evaluates the loss")
        x = self._get_x()
        f, g = self._evaluate(closure)
        return x, f, g

    def _evaluate(self, closure: Callable, x: torch.Tensor | None = None) -> tuple[float, torch.Tensor]:
        """Loss and flat gradient at `x` (at the current parameters when `x` is None).

        Leaves the parameters at `x`.
        """
        if x is not None:
            self._set_x(x)
        with torch.enable_grad():
            loss = closure()
        return float(loss), self._flat_grad()

    def objective_changed(self) -> None:
        """Forget the search history (directions, secant pairs, momentum).

        Call when the function the closure computes changes between steps (e.g. new data, or a
        stacked session masked out by `wsmap.learn.training.train`).
        """
        self.state.clear()
        self.stalled = False


def _dot(a: torch.Tensor, b: torch.Tensor) -> float:
    return float(torch.dot(a, b))


# --------------------------------------------------------------------------------------------
# Line search
# --------------------------------------------------------------------------------------------


def charalambous_search(phi: Callable[[float], tuple[float, torch.Tensor]], f0: float, g0: torch.Tensor,
                        d: torch.Tensor, step0: float, *, c1: float = 1e-3, c2: float = 0.1,
                        gamma: float = 0.1, scale: float = 3.0, rel_tol: float = 0.05,
                        max_step: float = 100.0, min_step: float = 1e-6, max_iter: int = 100,
                        ) -> tuple[float, float, torch.Tensor, int]:
    """One-dimensional minimisation along `d`, Charalambous-style interval location.

    After C. Charalambous, "Conjugate gradient algorithm for efficient training of artificial
    neural networks", IEE Proc. G 139(3), 1992, as MATLAB's `srchcha` uses it: keep an interval
    `[a, b]` (`a` starts at 0), and at each iteration

    * if the slope at `b` is negative and `f(b) <= f(a)`, extend: `b ← a + scale·(b − a)`;
    * if the slope at `b` is negative but `f(b) > f(a)`, contract: `b ← a + (b − a)/scale`;
    * otherwise (a minimum is bracketed) take the minimiser of the cubic through
      `(a, f(a), f'(a))` and `(b, f(b), f'(b))`, kept inside
      `[a + gamma·(b − a), b − gamma·(b − a)]`;

    until the better end point satisfies sufficient decrease `f ≤ f0 + c1·t·f'(0)` *and*
    `|f'(t)| ≤ c2·|f'(0)|` (strong Wolfe with c1 = 1e-3, c2 = 0.1: srchcha's `alpha` and
    `beta`), the interval is narrower than `rel_tol·b`, `f(a) == f(b)` without a bracketed
    minimum, or `max_iter` evaluations were spent. A non-finite `f(b)` contracts. Steps are capped so that
    `t·|d| ≤ max_step` and the search gives up below `t·|d| < min_step`. Differences from
    srchcha: its tolerance is absolute (`delta/scale_tol`); here it is relative, so a search
    that has not yet found any decrease (`a = 0`) keeps contracting instead of giving up.

    Parameters
    ----------
    phi
        `phi(t) -> (f, g)`: loss and flat gradient at `x0 + t·d`.
    f0, g0
        loss and gradient at `t = 0`; `d` must be a descent direction (`g0·d < 0`).
    step0
        first trial step `t`.

    Returns
    -------
    tuple[float, float, torch.Tensor, int]
        `(t, f, g, evaluations)` at the best point found; `t = 0` (with `f0`, `g0`) when
        no point improved on the start. The caller must set the parameters to `x0 + t·d`.
    """
    d0 = _dot(g0, d)
    norm_d = float(torch.linalg.vector_norm(d))
    if not d0 < 0 or norm_d == 0:
        return 0.0, f0, g0, 0
    t_max = max_step / norm_d
    t_min = min_step / norm_d

    def probe(t):
        f, g = phi(t)
        dd = _dot(g, d) if math.isfinite(f) else math.inf
        if not math.isfinite(dd):
            f = math.inf
        return f, dd, g

    a, fa, da, ga = 0.0, f0, d0, g0
    b = min(max(step0, t_min), t_max)
    fb, db, gb = probe(b)
    evals = 1
    while True:
        if fa < fb:
            t, ft, dt, gt = a, fa, da, ga
        else:
            t, ft, dt, gt = b, fb, db, gb
        wolfe = t > 0 and ft <= f0 + c1 * t * d0 and abs(dt) <= c2 * abs(d0)
        flat = fa == fb and not da < 0 < db  # equal values that do not bracket a minimum
        if wolfe or flat or evals >= max_iter or (b - a) <= rel_tol * b or b < t_min:
            break
        new = _next_trial(a, fa, da, b, fb, db, t_max, scale, gamma)
        if new is None:
            break  # the minimum lies beyond the largest allowed step: take it
        fn, dn, gn = probe(new)
        evals += 1
        if new > b:
            a, fa, da, ga = b, fb, db, gb
            b, fb, db, gb = new, fn, dn, gn
        elif dn > 0 or fn > fa:
            b, fb, db, gb = new, fn, dn, gn
        else:
            a, fa, da, ga = new, fn, dn, gn
    if not ft < f0:
        return 0.0, f0, g0, evals
    return t, ft, gt, evals


def _next_trial(a: float, fa: float, da: float, b: float, fb: float, db: float, t_max: float, scale: float,
                gamma: float) -> float | None:
    """The next trial step of `charalambous_search` from the interval `[a, b]` (values `f`,
    slopes `d` at both ends): contract when `f(b)` is not finite or higher with a falling slope,
    extend (up to `t_max`) while the slope at `b` still falls, else the cubic's minimiser kept
    `gamma·(b − a)` inside the interval. `None`: the slope still falls at `b = t_max`."""
    if not math.isfinite(fb) or (db < 0 and fb > fa):
        return a + (b - a) / scale
    if db < 0:
        if b >= t_max:
            return None
        return min(a + scale * (b - a), t_max)
    new = _cubic_min(a, fa, da, b, fb, db)
    lo, hi = a + gamma * (b - a), b - gamma * (b - a)
    return min(max(new, lo), hi) if math.isfinite(new) else 0.5 * (a + b)


def _cubic_min(a: float, fa: float, da: float, b: float, fb: float, db: float) -> float:
    """Minimiser of the cubic interpolating values and slopes at `a < b` (Nocedal & Wright 3.59)."""
    d1 = da + db - 3.0 * (fa - fb) / (a - b)
    disc = d1 * d1 - da * db
    if disc < 0:
        return math.nan
    d2 = math.sqrt(disc)
    denom = db - da + 2.0 * d2
    if denom == 0:
        return math.nan
    return b - (b - a) * (db + d2 - d1) / denom


# --------------------------------------------------------------------------------------------
# Scaled conjugate gradient
# --------------------------------------------------------------------------------------------


class SCG(_FlatOptimizer):
    """Scaled conjugate gradient (Møller 1993; MATLAB `trainscg`).

    M. F. Møller, "A scaled conjugate gradient algorithm for fast supervised learning", Neural
    Networks 6(4), 1993. No line search: the curvature along the search direction `p` comes from
    a finite difference of gradients, `s = (g(x + σ_k p) − g(x)) / σ_k` with `σ_k = σ/|p|`, and a
    Levenberg–Marquardt scale `λ` keeps `δ = p·s + λ|p|²` positive. The step
    `α = μ/δ` (`μ = −p·g`) is accepted when the comparison parameter
    `Δ = 2δ(f(x) − f(x + αp))/μ² ≥ 0`; `λ` shrinks ×¼ when `Δ ≥ 0.75` and grows by
    `δ(1 − Δ)/|p|²` when `Δ < 0.25`. Directions follow Polak–Ribière form
    `β = (|g⁺|² − g⁺·g)/μ` and restart to `−g` every `N` accepted steps (`N` = number of
    parameters; Møller's counter from 1, MATLAB's epoch counter restarts once more after its first
    step).

    Defaults (trainscg): `sigma = 5e-5`, `lambd = 5e-7`. Closure evaluations per step: the current
    point, the σ point (after an accepted step only) and the trial point. With float32 parameters
    the finite difference carries only ~3 digits; λ absorbs the noise, and a larger `sigma` (1e-4
    to 1e-3) is a reasonable override.
    """

    def __init__(self, params: Iterable[torch.Tensor], sigma: float = 5e-5, lambd: float = 5e-7):
        if not sigma > 0 or not lambd > 0:
            raise ValueError("sigma and lambd must be positive")
        super().__init__(params, {"sigma": sigma, "lambd": lambd})

    @torch.no_grad()
    def step(self, closure: Callable) -> torch.Tensor:
        x, f, g = self._start_step(closure)
        group = self.param_groups[0]
        st = self._state
        loss = f
        self.stalled = False
        if "p" not in st:
            st.update(p=-g, success=True, lambd=group["lambd"], lambdb=0.0, delta=0.0, k=1)
        p = st["p"]
        mu = -_dot(p, g)
        if not mu > 0:
            # Not a descent direction (rounding, or the objective changed): restart.
            p = st["p"] = -g
            mu = -_dot(p, g)
            st["success"] = True
            if not mu > 0:
                return torch.tensor(loss)  # zero gradient: nothing to do
        nrm2 = _dot(p, p)
        lambd, lambdb, delta = st["lambd"], st["lambdb"], st["delta"]
        if st["success"]:
            # Second-order information along p by a gradient difference.
            sigma_k = group["sigma"] / math.sqrt(nrm2)
            _, g_s = self._evaluate(closure, x + sigma_k * p)
            delta = _dot(p, g_s - g) / sigma_k
        delta = delta + (lambd - lambdb) * nrm2
        if delta <= 0:
            # Make the (scaled) Hessian positive definite along p.
            lambdb = 2.0 * (lambd - delta / nrm2)
            delta = -delta + lambd * nrm2
            lambd = lambdb
        alpha = mu / delta
        x_new = x + alpha * p
        f_new, g_new = self._evaluate(closure, x_new)
        comparison = 2.0 * delta * (f - f_new) / (mu * mu) if math.isfinite(f_new) else -1.0
        if comparison >= 0:
            # Accepted: the parameters stay at x_new.
            k = st["k"]
            if k % self._numel == 0:
                p = -g_new
            else:
                beta = (_dot(g_new, g_new) - _dot(g_new, g)) / mu
                p = -g_new + beta * p
            st["k"] = k + 1
            lambdb = 0.0
            st["success"] = True
            if comparison >= 0.75:
                lambd = 0.25 * lambd
        else:
            self._set_x(x)
            lambdb = lambd
            st["success"] = False
        nrm2 = _dot(p, p)
        if comparison < 0.25 and nrm2 > 0:
            lambd = lambd + delta * (1.0 - comparison) / nrm2
        st.update(p=p, lambd=lambd, lambdb=lambdb, delta=delta)
        return torch.tensor(loss)


# --------------------------------------------------------------------------------------------
# Conjugate gradient with Powell-Beale restarts
# --------------------------------------------------------------------------------------------

_SEARCH_DEFAULTS = {"c1": 1e-3, "c2": 0.1, "gamma": 0.1, "scale_tol": 20.0, "max_step": 100.0,
                    "min_step": 1e-6, "max_iter": 100}


class _LineSearchOptimizer(_FlatOptimizer):
    def _search(self, closure, x, f, g, d, step0):
        group = self.param_groups[0]

        def phi(t):
            return self._evaluate(closure, x + t * d)

        t, f_new, g_new, _ = charalambous_search(
            phi, f, g, d, step0, c1=group["c1"], c2=group["c2"], gamma=group["gamma"],
            rel_tol=1.0 / group["scale_tol"], max_step=group["max_step"], min_step=group["min_step"],
            max_iter=group["max_iter"])
        # The last evaluation may not be the best point: put the parameters where the search ended.
        self._set_x(x + t * d)
        self.stalled = t == 0.0
        return t, f_new, g_new


class CGB(_LineSearchOptimizer):
    """Conjugate gradient with Powell–Beale restarts (MATLAB `traincgb`).

    M. J. D. Powell, "Restart procedures for the conjugate gradient method", Math. Programming 12,
    1977. Directions `d = −g + Z1·d_prev + Z2·d_t` with the Hestenes–Stiefel
    `Z1 = g·Δg / d_prev·Δg` and Beale's term on the direction `d_t` (and gradient change
    `Δg_t`) of the last restart, `Z2 = g·Δg_t / d_t·Δg_t` (0 right after a restart). A restart
    happens when successive gradients are far from orthogonal, `|g_prev·g| ≥ 0.2|g|²`, or after
    `N` (number of parameters) steps; the direction falls back to `−g` when it is not
    sufficiently downhill (`g·d̂ ≥ −0.001|g|`). Directions are normalised, and each step
    minimises along `d̂` with `charalambous_search` (MATLAB's default `srchcha`), first
    trial step `max(delta, |2Δf/g·d̂|)` where `delta` is the previous step (at least
    `delta = 0.01`) and `Δf` the last change in loss (the loss itself at the first step).

    Defaults (traincgb): `delta = 0.01`, `scale_tol = 20`, `c1 = 1e-3` (srchcha's
    `alpha`), `c2 = 0.1` (`beta`), `gamma = 0.1`, `max_step = 100`, `min_step = 1e-6`,
    `max_iter = 100` evaluations per search. `stalled` is set when a search finds no
    decrease (MATLAB then stops with "Minimum step size reached").
    """

    def __init__(self, params: Iterable[torch.Tensor], delta: float = 0.01, **search):
        unknown = set(search) - set(_SEARCH_DEFAULTS)
        if unknown:
            raise TypeError(f"unknown line-search options {sorted(unknown)}; known: {sorted(_SEARCH_DEFAULTS)}")
        super().__init__(params, {"delta": delta, **_SEARCH_DEFAULTS, **search})

    @torch.no_grad()
    def step(self, closure: Callable) -> torch.Tensor:
        x, f, g = self._start_step(closure)
        group = self.param_groups[0]
        st = self._state
        gnorm = float(torch.linalg.vector_norm(g))
        if gnorm == 0:
            self.stalled = True
            return torch.tensor(f)
        zeros = torch.zeros_like(g)
        if "k" not in st:
            k = 0
            change = f
            st.update(d_prev=-g, g_prev=g, dg_t=zeros, d_t=zeros, dgt_dot=1.0, t=1, step=group["delta"])
            d = -g / gnorm
        else:
            k = st["k"]
            change = f - st["f_prev"]
            g_prev, d_prev = st["g_prev"], st["d_prev"]
            if abs(_dot(g_prev, g)) >= 0.2 * gnorm * gnorm or k - st["t"] >= self._numel:
                st.update(t=k - 1, dg_t=g - g_prev, d_t=d_prev)
                st["dgt_dot"] = _dot(st["d_t"], st["dg_t"])
            if k == st["t"] + 1 or st["dgt_dot"] == 0:
                z2 = 0.0
            else:
                z2 = _dot(g, st["dg_t"]) / st["dgt_dot"]
            dg = g - g_prev
            denom = _dot(d_prev, dg)
            z1 = _dot(g, dg) / denom if denom != 0 else 0.0
            d = -g + z1 * d_prev + z2 * st["d_t"]
            st.update(d_prev=d, g_prev=g)
            dnorm = float(torch.linalg.vector_norm(d))
            if dnorm > 0:
                d = d / dnorm
            if not _dot(g, d) < -0.001 * gnorm:
                d = -g / gnorm
                st.update(d_prev=-g, t=k, dg_t=zeros, d_t=zeros, dgt_dot=1.0)
        st["f_prev"] = f
        slope = _dot(g, d)
        step0 = max(st["step"], abs(2.0 * change / slope))
        t, _, _ = self._search(closure, x, f, g, d, step0)
        st["step"] = max(t, group["delta"])
        st["k"] = k + 1
        return torch.tensor(f)


# --------------------------------------------------------------------------------------------
# One-step secant
# --------------------------------------------------------------------------------------------


class OSS(_LineSearchOptimizer):
    """One-step secant (Battiti 1992; MATLAB `trainoss`).

    R. Battiti, "First- and second-order methods for learning: between steepest descent and
    Newton's method", Neural Computation 4(2), 1992. A memoryless BFGS: with the last step
    `s` and gradient change `y`, the direction is `d = −g + A·s + B·y` with
    `B = s·g / s·y` and `A = −(1 + y·y/s·y)·B + y·g/s·y`; it restarts at `−g` every `N`
    (number of parameters) steps, when `s·y = 0`, or when `d` is not downhill. Each step
    minimises along `d` with `charalambous_search`, first trial step
    `max(1, |2Δf/g·d|)` (the quasi-Newton step 1, as MATLAB's `srchbac` starts).

    Difference from MATLAB: trainoss's default search is the backtracking `srchbac`
    (Dennis & Schnabel); this uses the Charalambous-style search with the same sufficient-decrease
    (`c1 = 1e-3`) and slope (`c2 = 0.1`) constants, which also extends steps that are too short.
    Defaults: `c1 = 1e-3`, `c2 = 0.1`, `gamma = 0.1`, `scale_tol = 20`, `max_step = 100`,
    `min_step = 1e-6`, `max_iter = 100`. `stalled` is set when a search finds no decrease.
    """

    def __init__(self, params: Iterable[torch.Tensor], **search):
        unknown = set(search) - set(_SEARCH_DEFAULTS)
        if unknown:
            raise TypeError(f"unknown line-search options {sorted(unknown)}; known: {sorted(_SEARCH_DEFAULTS)}")
        super().__init__(params, {**_SEARCH_DEFAULTS, **search})

    @torch.no_grad()
    def step(self, closure: Callable) -> torch.Tensor:
        x, f, g = self._start_step(closure)
        st = self._state
        if not bool(torch.any(g != 0)):
            self.stalled = True
            return torch.tensor(f)
        if "k" not in st:
            k = 0
            change = f
            d = -g
        else:
            k = st["k"]
            change = f - st["f_prev"]
            s, y = st["s"], g - st["g_prev"]
            den = _dot(s, y)
            if k % self._numel == 0 or den == 0:
                d = -g
            else:
                b_coef = _dot(s, g) / den
                a_coef = -(1.0 + _dot(y, y) / den) * b_coef + _dot(y, g) / den
                d = -g + a_coef * s + b_coef * y
            if _dot(g, d) > 0:
                d = -g
        slope = _dot(g, d)
        if not slope < 0:
            d = -g
            slope = _dot(g, d)
        step0 = max(1.0, abs(2.0 * change / slope))
        t, _, _ = self._search(closure, x, f, g, d, step0)
        st.update(s=t * d, g_prev=g, f_prev=f, k=k + 1)
        return torch.tensor(f)


# --------------------------------------------------------------------------------------------
# Gradient descent with momentum and adaptive learning rate
# --------------------------------------------------------------------------------------------


class GDX(_FlatOptimizer):
    """Gradient descent with momentum and an adaptive learning rate (MATLAB `traingdx`).

    Each step: `dX ← mc·dX − (1 − mc)·lr·g` (`dX = −lr·g` at the first step), trial point
    `x + dX`. If the loss there exceeds `max_perf_inc` times the current loss, the trial is
    discarded, `lr ← lr·lr_dec` and the momentum restarts, `dX ← −lr·g`; otherwise the trial is
    accepted and, if the loss decreased, `lr ← lr·lr_inc`. (Vogl et al., "Accelerating the
    convergence of the back-propagation method", Biol. Cybern. 59, 1988; Hagan, Demuth & Beale,
    *Neural Network Design*, ch. 12.)

    Defaults (traingdx): `lr = 0.01`, `lr_inc = 1.05`, `lr_dec = 0.7`,
    `max_perf_inc = 1.04`, `mc = 0.9`. The current rate is `param_groups[0]["lr"]`;
    `rejected` says whether the last trial was discarded. Two closure evaluations per step
    (current point, trial point).
    """

    def __init__(self, params: Iterable[torch.Tensor], lr: float = 0.01, lr_inc: float = 1.05, lr_dec: float = 0.7,
                 max_perf_inc: float = 1.04, mc: float = 0.9):
        if not lr > 0 or lr_inc < 1 or not 0 < lr_dec <= 1 or max_perf_inc < 1 or not 0 <= mc <= 1:
            raise ValueError("need lr > 0, lr_inc >= 1, 0 < lr_dec <= 1, max_perf_inc >= 1, 0 <= mc <= 1")
        super().__init__(params, {"lr": lr, "lr_inc": lr_inc, "lr_dec": lr_dec,
                                  "max_perf_inc": max_perf_inc, "mc": mc})
        #: True when the last step's trial point was discarded (a rejected step is normal for
        #: traingdx, not a stall, so `stalled` stays False).
        self.rejected = False

    @torch.no_grad()
    def step(self, closure: Callable) -> torch.Tensor:
        x, f, g = self._start_step(closure)
        group = self.param_groups[0]
        st = self._state
        lr, mc = group["lr"], group["mc"]
        dx = st.get("dx")
        dx = -lr * g if dx is None else mc * dx - (1.0 - mc) * lr * g
        f_new, _ = self._evaluate(closure, x + dx)
        if not f_new <= group["max_perf_inc"] * f:  # also rejects a non-finite trial
            self._set_x(x)
            lr = lr * group["lr_dec"]
            dx = -lr * g
            self.rejected = True
        else:
            if f_new < f:
                lr = lr * group["lr_inc"]
            self.rejected = False
        group["lr"] = lr
        st["dx"] = dx
        return torch.tensor(f)


# --------------------------------------------------------------------------------------------
# Factory
# --------------------------------------------------------------------------------------------

OPTIMIZERS: dict[str, Callable[..., Optimizer]] = {
    "cgb": CGB,
    "gdx": GDX,
    "oss": OSS,
    "rprop": paper_rprop,
    "scg": SCG,
}
#: MATLAB training-function names accepted as aliases.
ALIASES = {"traincgb": "cgb", "traingdx": "gdx", "trainoss": "oss", "trainrp": "rprop", "trainscg": "scg"}
#: Optimisers whose update of each parameter depends only on that parameter's own gradients: a
#: sum of independent losses over disjoint parameter sets trains each set exactly as alone.
ELEMENTWISE = frozenset({"rprop"})


def canonical_name(name: str) -> str:
    """`"trainrp"` → `"rprop"` etc.; raise `ValueError` for an unknown name."""
    key = str(name).strip().lower()
    key = ALIASES.get(key, key)
    if key not in OPTIMIZERS:
        raise ValueError(
            f"unknown optimizer {name!r}; known: {', '.join(sorted(OPTIMIZERS))} "
            f"(MATLAB aliases: {', '.join(sorted(ALIASES))})")
    return key


def make_optimizer(name: str, params: Iterable, **overrides) -> Optimizer:
    """The optimiser called `name` (see the module table) with its defaults, or `overrides`.

    `name` is one of `rprop, scg, cgb, oss, gdx` or the MATLAB names `trainrp, trainscg,
    traincgb, trainoss, traingdx` (case-insensitive). Unknown names raise `ValueError` listing
    the known ones.
    """
    return OPTIMIZERS[canonical_name(name)](params, **overrides)
