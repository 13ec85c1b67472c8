import math
import re

import pytest
import torch

from wsmap.learn.optim import CGB, ELEMENTWISE, GDX, OSS, SCG, charalambous_search, make_optimizer, paper_rprop

torch.set_num_threads(1)  # small problems: threads only add overhead (and other agents share the CPU)

NAMES = ["rprop", "scg", "cgb", "oss", "gdx"]


def quadratic(n=10, cond=100.0, seed=0):
    """f(x) = ½(x − x*)ᵀA(x − x*), A SPD with eigenvalues log-spaced in [1, cond]; min f(x*) = 0.

    (The minimum value is 0 because GDX's acceptance test is MATLAB's ratio ``f_new/f``, which
    assumes a non-negative loss.)
    """
    g = torch.Generator().manual_seed(seed)
    q, _ = torch.linalg.qr(torch.randn(n, n, generator=g, dtype=torch.float64))
    a = q @ torch.diag(torch.logspace(0, math.log10(cond), n, dtype=torch.float64)) @ q.T
    a = 0.5 * (a + a.T)
    x_star = torch.randn(n, generator=g, dtype=torch.float64)
    return (lambda x: 0.5 * (x - x_star) @ a @ (x - x_star)), x_star


def rosenbrock(x):
    return (1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2


def minimise(name, f, x0, x_star, max_steps, tol, **kw):
    """Steps until |x − x*| < tol (or max_steps); returns (steps, error)."""
    x = torch.nn.Parameter(x0.clone())
    opt = make_optimizer(name, [x], **kw)

    def closure():
        opt.zero_grad()
        loss = f(x)
        loss.backward()
        return loss

    err = float("inf")
    for step in range(1, max_steps + 1):
        opt.step(closure)
        err = float((x.detach() - x_star).norm())
        if err < tol:
            return step, err
    return max_steps, err


# Steps allowed and tolerance on |x − x*| (float64). Rprop with the paper's 1e-6 minimum step
# settles within ~1e-5 of the minimum, so its tolerances are looser.
QUADRATIC = {"rprop": (300, 1e-4), "scg": (60, 1e-6), "cgb": (60, 1e-6), "oss": (60, 1e-6), "gdx": (400, 1e-6)}
ROSENBROCK = {"rprop": (3000, 1e-2), "scg": (100, 1e-4), "cgb": (50, 1e-4), "oss": (50, 1e-4), "gdx": (4000, 1e-3)}


@pytest.mark.parametrize("name", NAMES)
def test_ill_conditioned_quadratic(name):
    f, x_star = quadratic(10, cond=100.0)
    max_steps, tol = QUADRATIC[name]
    steps, err = minimise(name, f, torch.zeros(10, dtype=torch.float64), x_star, max_steps, tol)
    assert err < tol, (name, steps, err)


@pytest.mark.parametrize("name", NAMES)
def test_rosenbrock(name):
    max_steps, tol = ROSENBROCK[name]
    x0 = torch.tensor([-1.2, 1.0], dtype=torch.float64)
    steps, err = minimise(name, rosenbrock, x0, torch.ones(2, dtype=torch.float64), max_steps, tol)
    assert err < tol, (name, steps, err)


@pytest.mark.parametrize("name", ["scg", "cgb", "oss"])
def test_conjugate_methods_take_about_n_steps_on_a_quadratic(name):
    # Exact CG needs n steps; SCG's scale λ and the inexact (Wolfe-terminated) line searches of
    # CGB/OSS cost some: about 1.5n-2n here. Steepest descent would need hundreds.
    n = 30
    f, x_star = quadratic(n, cond=100.0, seed=0)
    tol = 1e-6 * float(x_star.norm())
    steps, err = minimise(name, f, torch.zeros(n, dtype=torch.float64), x_star, 10 * n, tol)
    assert err < tol and steps <= 2.5 * n, (name, steps, err)


def test_gdx_learning_rate_grows_on_progress():
    x = torch.nn.Parameter(torch.tensor([1.0, -2.0], dtype=torch.float64))
    opt = GDX([x], lr=1e-3)

    def closure():
        opt.zero_grad()
        loss = 0.5 * (x ** 2).sum()
        loss.backward()
        return loss

    for k in range(1, 6):
        opt.step(closure)
        assert not opt.rejected
        assert opt.param_groups[0]["lr"] == pytest.approx(1e-3 * 1.05 ** k, rel=1e-12)


def test_gdx_rejects_a_loss_increase_and_shrinks_the_rate():
    x = torch.nn.Parameter(torch.tensor([1.0], dtype=torch.float64))
    opt = GDX([x], lr=10.0)  # trial x − 10x = −9x: loss ×81 > max_perf_inc

    def closure():
        opt.zero_grad()
        loss = 0.5 * (x ** 2).sum()
        loss.backward()
        return loss

    opt.step(closure)
    assert opt.rejected
    assert x.item() == 1.0  # trial discarded
    assert opt.param_groups[0]["lr"] == pytest.approx(7.0)
    # An equal loss (lr 2: x → −x) is accepted but does not grow the rate.
    opt = GDX([x], lr=2.0)
    opt.step(closure)
    assert not opt.rejected and x.item() == -1.0 and opt.param_groups[0]["lr"] == 2.0


def test_paper_rprop_settings():
    p = torch.nn.Parameter(torch.zeros(3))
    opt = paper_rprop([p])
    g = opt.param_groups[0]
    assert isinstance(opt, torch.optim.Rprop)
    assert g["lr"] == 0.07 and tuple(g["etas"]) == (0.5, 1.2) and tuple(g["step_sizes"]) == (1e-6, 50.0)


@pytest.mark.parametrize("alias, cls", [("trainrp", torch.optim.Rprop), ("TRAINSCG", SCG), ("traincgb", CGB),
                                        ("trainoss", OSS), ("traingdx", GDX), ("scg", SCG)])
def test_aliases(alias, cls):
    assert isinstance(make_optimizer(alias, [torch.nn.Parameter(torch.zeros(2))]), cls)


def test_overrides_reach_the_optimiser():
    opt = make_optimizer("gdx", [torch.nn.Parameter(torch.zeros(2))], lr=0.5, mc=0.0)
    assert opt.param_groups[0]["lr"] == 0.5 and opt.param_groups[0]["mc"] == 0.0


def test_unknown_name_fails_with_the_exact_error():
    msg = ("unknown optimizer 'adam'; known: cgb, gdx, oss, rprop, scg "
           "(MATLAB aliases: traincgb, traingdx, trainoss, trainrp, trainscg)")
    with pytest.raises(ValueError, match=f"^{re.escape(msg)}$"):
        make_optimizer("adam", [torch.nn.Parameter(torch.zeros(2))])


def test_elementwise_set():
    assert ELEMENTWISE == {"rprop"}


def test_line_search_finds_the_minimum_of_a_parabola():
    # phi(t) = (t − 2)² along d = 1 from x0 = 0: exact after one cubic interpolation.
    def phi(t):
        return (t - 2.0) ** 2, torch.tensor([2.0 * (t - 2.0)], dtype=torch.float64)

    g0 = torch.tensor([-4.0], dtype=torch.float64)
    d = torch.tensor([1.0], dtype=torch.float64)
    for step0 in (0.01, 1.0, 7.0):  # too short (extend), short, past the minimum (interpolate)
        t, f, _, evals = charalambous_search(phi, 4.0, g0, d, step0)
        assert abs(f) <= 0.01 * 4.0 + 1e-12 and evals < 10, (step0, t, f, evals)


def test_line_search_with_no_descent_returns_zero_step():
    def phi(t):
        return 1.0 + t, torch.tensor([1.0])

    t, f, _, _ = charalambous_search(phi, 1.0, torch.tensor([1.0]), torch.tensor([1.0]), 1.0)
    assert t == 0.0 and f == 1.0


@pytest.mark.parametrize("name", ["scg", "cgb", "oss", "gdx"])
def test_flat_optimisers_handle_several_float32_tensors(name):
    # Parameters of different shapes are one flat vector inside; float32 works.
    torch.manual_seed(0)
    w = torch.nn.Parameter(torch.randn(3, 2))
    b = torch.nn.Parameter(torch.randn(2))
    target_w, target_b = torch.ones(3, 2), -torch.ones(2)
    opt = make_optimizer(name, [w, b])

    def closure():
        opt.zero_grad()
        loss = ((w - target_w) ** 2).sum() + ((b - target_b) ** 2).sum()
        loss.backward()
        return loss

    for _ in range(200):
        opt.step(closure)
    assert torch.allclose(w, target_w, atol=1e-3) and torch.allclose(b, target_b, atol=1e-3)


def test_step_requires_a_closure():
    with pytest.raises(ValueError):
        SCG([torch.nn.Parameter(torch.zeros(2))]).step(None)
