"""wsmap.design: box tasks, the interpolating surrogate, the optimisers on a case with a known answer."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch

from wsmap import design
from wsmap import workspace as ws
from wsmap.datasets.spec import DatasetSpec
from wsmap.learn import MLPConfig, SubspaceMLP

torch.set_num_threads(1)

#: A small grid for the tiny models: [-1, 1]³ m at 0.5 m (5³ = 125 nodes).
SMALL = DatasetSpec("tiny_sw", family="spherical_wrist", scope="R3", lo=-1.0, hi=1.0, step=0.5,
                    fixed=(0.0, 0.0, 0.0), method="exact", samples=200, seed=0)


def test_box_tasks_are_the_corners_and_edge_midpoints():
    c = np.array([0.5, -0.1, 0.2])
    t = design.box_tasks(c, 0.4)
    assert t.shape == (20, 3)
    off = t - c
    # 8 corners: every coordinate ±0.2; 12 midpoints: one coordinate 0, two ±0.2
    np.testing.assert_allclose(np.abs(off[:8]), 0.2)
    assert {tuple(np.sign(o).astype(int)) for o in off[:8]} == set(itertools.product((-1, 1), repeat=3))
    mids = off[8:]
    assert np.all((np.abs(mids) < 1e-15).sum(1) == 1)
    np.testing.assert_allclose(np.abs(mids)[np.abs(mids) > 1e-15], 0.2)
    assert len({tuple(np.round(o, 9)) for o in off}) == 20
    # each midpoint is the mean of the two corners of its edge
    for m in mids:
        ends = [k for k in off[:8] if np.allclose(k[np.abs(m) > 0], m[np.abs(m) > 0])]
        assert len(ends) == 2
        np.testing.assert_allclose((ends[0] + ends[1]) / 2, m, atol=1e-15)
    with pytest.raises(ValueError, match="size"):
        design.box_tasks(c, -0.4)
    with pytest.raises(ValueError, match="centre"):
        design.box_tasks([0, 0], 0.4)


def _tiny_model(output_kind="logit", seed=0) -> SubspaceMLP:
    """An untrained tiny model on the 5³ grid: interpolation checks need any fixed network."""
    torch.manual_seed(seed)
    cfg = MLPConfig(n_inputs=SMALL.n_features, n_outputs=SMALL.grid_nodes, hidden=[8], init="torch",
                    output_kind=output_kind)
    model = SubspaceMLP(cfg)
    model.set_map_spec(SMALL)
    return model


@pytest.mark.parametrize("kind", ["logit", "linear"])
def test_interpolation_equals_nodes_at_nodes_and_is_linear_between(kind):
    model = _tiny_model(kind)
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    params = torch.tensor([[0.3, 0.2, 0.1, 0.25], [0.1, 0.4, 0.05, 0.3]], dtype=torch.float64)
    some = nodes[[0, 7, 62, 124]]
    s = design.MapSurrogate(model, "spherical_wrist", some)
    with torch.no_grad():
        full = model.forward(s.features(params), key=0).double()
        thr = np.log(0.5 / 0.5) if kind == "logit" else 0.5
        got = s(params)
    np.testing.assert_allclose(got.numpy(), (full[:, [0, 7, 62, 124]] - thr).numpy(), atol=1e-5)
    # the pruned output layer gives the model's own outputs at the needed nodes
    a, b = nodes[62], nodes[63]  # neighbours along x
    mid = design.MapSurrogate(model, "spherical_wrist", np.array([a + w * (b - a) for w in (0.0, 0.25, 0.7, 1.0)]))
    with torch.no_grad():
        v = mid(params).numpy()
    for j, w in enumerate((0.0, 0.25, 0.7, 1.0)):
        np.testing.assert_allclose(v[:, j], (1 - w) * v[:, 0] + w * v[:, 3], atol=1e-5)
    # trilinear at a cell centre: the mean of the 8 corners
    centre = nodes[0] + 0.25
    c = design.MapSurrogate(model, "spherical_wrist", centre[None])
    corner_idx = [i + 5 * j + 25 * k for i, j, k in itertools.product((0, 1), repeat=3)]
    with torch.no_grad():
        np.testing.assert_allclose(c(params).numpy()[:, 0], (full[:, corner_idx] - thr).mean(1).numpy(), atol=1e-5)
    # and it is differentiable in the parameters
    p = params.clone().requires_grad_(True)
    mid(p).sum().backward()
    assert p.grad is not None and torch.isfinite(p.grad).all()


def test_tasks_outside_the_grid_and_unknown_family_are_clear_errors():
    model = _tiny_model()
    tasks = design.box_tasks((0.5, 0.0, 0.9), 0.4)  # z up to 1.1 m: above the grid's 1.0
    with pytest.raises(ValueError, match=r"task 1 at \[0\.3, -0\.2, 1\.1\] m is outside the model's grid "
                                         r"\[-1, 1\] x \[-1, 1\] x \[-1, 1\] m"):
        design.MapSurrogate(model, "spherical_wrist", tasks)
    # before any work: design_by_gradient refuses too, with a verify that would fail loudly
    def never(_):
        raise AssertionError("verification ran")
    with pytest.raises(ValueError, match="outside the model's grid"):
        design.design_by_gradient("spherical_wrist", tasks, model, verify=never)
    with pytest.raises(ValueError, match="unknown design family 'ur5'; known families: panda7, spherical_wrist"):
        design.design_by_gradient("ur5", design.box_tasks((0.4, 0, 0.2)), model)
    with pytest.raises(ValueError, match="unknown design family"):
        design.design_by_cmaes("ur5", design.box_tasks((0.4, 0, 0.2)))
    with pytest.raises(ValueError, match="maps family 'spherical_wrist'"):
        design.MapSurrogate(model, "panda7", design.box_tasks((0.4, 0, 0.2)))
    with pytest.raises(ValueError, match="orientation"):
        design.MapSurrogate(model, "spherical_wrist", design.box_tasks((0.4, 0, 0.2)), rpy=(np.pi, 0, 0))


def test_a_node_slice_model_refuses_tasks_off_its_slice():
    torch.manual_seed(0)
    cfg = MLPConfig(n_inputs=SMALL.n_features, n_outputs=25, hidden=[4], init="torch")
    model = SubspaceMLP(cfg)
    model.set_map_spec(SMALL, nodes=(50, 75))  # the z = 0 layer only
    with pytest.raises(ValueError, match=r"does not cover: it maps nodes \[50, 75\).*\[-1, 1\] x \[-1, 1\] x \[0, 0\]"):
        design.MapSurrogate(model, "spherical_wrist", np.array([[0.1, 0.2, 0.3]]))
    design.MapSurrogate(model, "spherical_wrist", np.array([[0.1, 0.2, 0.0]]))  # in the layer: fine


# ------------------------------------------------------------------------------------- known answer
#: reach(s) = W · s (m) for the panda7 scales; coverage of p is |p| <= reach.
W = np.array([0.2, 0.3, 0.25, 0.05, 0.05, 0.05])
TASKS = design.box_tasks((0.5, 0.0, 0.2), 0.4)
R_NEED = float(np.linalg.norm(TASKS, axis=1).max())
FAM = design.design_family("panda7")


def _known_answer():
    """min l·s s.t. W·s >= R, s in [lo, hi]: one linear constraint, so the LP's answer is greedy
    (the fractional knapsack): from s = lo, raise the parameter of best W_k / l_k first."""
    l, lo, hi = FAM.length_coeffs, FAM.low, FAM.high
    s = lo.copy()
    need = R_NEED - W @ s
    for k in np.argsort(-W / l):
        if need <= 0:
            break
        add = min(hi[k] - lo[k], need / W[k])
        s[k] += add
        need -= add * W[k]
    return s, float(l @ s)


def _analytic_surrogate(params: torch.Tensor) -> torch.Tensor:
    reach = params @ torch.as_tensor(W)
    return reach[:, None] - torch.as_tensor(np.linalg.norm(TASKS, axis=1))[None]


def _analytic_verify(params: np.ndarray) -> np.ndarray:
    return (params @ W)[:, None] >= np.linalg.norm(TASKS, axis=1)[None]


def test_the_known_answer_uses_two_parameters():
    s, L = _known_answer()
    # d3 (best ratio) at its upper bound, d5 (next) partly raised, the rest at 0.7
    assert s[1] == 1.3 and 0.7 < s[2] < 1.3
    assert np.all(s[[0, 3, 4, 5]] == 0.7)
    assert W @ s == pytest.approx(R_NEED)


def test_gradient_design_finds_the_known_answer():
    s_star, L_star = _known_answer()
    r = design.design_by_gradient("panda7", TASKS, _analytic_surrogate, verify=_analytic_verify, margin=0.0,
                             margin_step=1e-4, starts=4, steps=400, seed=0)
    assert r.verified and r.covered.all() and r.method == "gradient"
    assert r.total_length == pytest.approx(L_star, rel=2e-3)
    np.testing.assert_allclose(r.params, s_star, atol=0.02)
    assert r.classical_calls == 4 * r.rounds and r.surrogate_evals == 4 * 400 * r.rounds
    assert r.path.shape == (400 * r.rounds, 2) and r.path[-1, 0] == pytest.approx(r.total_length, rel=1e-2)


def test_cmaes_and_random_search_on_the_known_answer():
    s_star, L_star = _known_answer()
    r = design.design_by_cmaes("panda7", TASKS, verify=_analytic_verify, target_length=L_star * 1.01, max_calls=4000,
                          seed=1)
    assert r.verified and r.time_to_target is not None and r.time_to_verified <= r.time_to_target
    assert L_star <= r.total_length <= L_star * 1.01
    q = design.design_by_random_search("panda7", TASKS, verify=_analytic_verify, target_length=L_star * 1.01,
                                  max_calls=64, seed=0)
    # 64 uniform draws do not come within 1 % of a corner of a 6-D box: the budget stops it
    assert q.classical_calls == 64 and q.time_to_target is None
    assert q.total_length >= L_star


def test_a_tiny_trained_model_gives_a_verified_design():
    """(a) a SubspaceMLP trained here on the exact maps of spherical-wrist arms on the 5³ grid."""
    from wsmap import robots
    from wsmap.datasets.features import features_for

    rng = np.random.default_rng(0)
    arms = robots.sample_spherical_wrist(600, seed=rng)
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    Y = ws.constant_orientation_map(arms, nodes, (0, 0, 0), method="exact").astype(np.float32)
    X = features_for(arms, SMALL)
    torch.manual_seed(0)
    cfg = MLPConfig(n_inputs=SMALL.n_features, n_outputs=125, hidden=[32, 32], init="torch",
                    input_columns=[2, 3, 7, 8], input_scaling="standardize", output_kind="logit")
    model = SubspaceMLP(cfg).configure(X)
    opt = torch.optim.Adam(model.parameters(), lr=1e-2)
    Xt, Yt = torch.as_tensor(X), torch.as_tensor(Y)
    for _ in range(300):
        opt.zero_grad()
        loss = torch.nn.functional.binary_cross_entropy_with_logits(model(Xt, key=0), Yt)
        loss.backward()
        opt.step()
    model.set_map_spec(SMALL)
    tasks = np.array([[0.5, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 0.5, 0.5]])
    r = design.design_by_gradient("spherical_wrist", tasks, model, starts=4, steps=200, seed=0)
    assert r.verified and r.covered.all()
    exact = design.design_family("spherical_wrist").classical(r.params[None], tasks)
    assert exact.all()
    # a design can be no shorter than the farthest task: reach <= a2 + a3 + d3 + d4
    assert r.total_length >= np.linalg.norm(tasks, axis=1).max() - 1e-9
    rows, res = design.compare_designs("spherical_wrist", tasks, model, gradient={"starts": 4, "steps": 200},
                                  max_calls=500, max_seconds=10)
    assert [row["method"] for row in rows] == ["gradient", "cmaes", "random"]
    assert res["gradient"].verified and res["cmaes"].target_length == pytest.approx(res["gradient"].total_length * 1.02)
    assert "| gradient | spherical_wrist |" in design.format_design_table(rows)


def test_panda7_surrogate_puts_the_scales_in_the_model_features():
    """A panda7 model (chain family: the features start with the 6 scales), tool-down."""
    from wsmap.datasets.features import features_for

    spec = DatasetSpec("tiny_p7", family="panda7", scope="R3", lo=-1.2, hi=1.2, step=0.6, fixed=(np.pi, 0.0, 0.0),
                       convention="standard", method="numerical", samples=10, seed=0)
    torch.manual_seed(0)
    model = SubspaceMLP(MLPConfig(n_inputs=spec.n_features, n_outputs=spec.grid_nodes, hidden=[4], init="torch",
                                  output_kind="logit"))
    model.set_map_spec(spec)
    tasks = design.box_tasks((0.5, 0.0, 0.2), 0.4)
    s = design.MapSurrogate(model, "panda7", tasks)  # the family's default orientation: tool-down, standard
    scales = np.array([[0.8, 0.9, 1.0, 1.1, 1.2, 1.3], [1.0] * 6])
    np.testing.assert_array_equal(s.features(torch.as_tensor(scales)).numpy(), features_for(scales, spec))
    with torch.no_grad():
        full = model.forward(torch.as_tensor(features_for(scales, spec)), key=0).double()
        on_nodes = design.MapSurrogate(model, "panda7", np.array([[0.0, 0.0, 0.0], [0.6, -0.6, 1.2]]))
        np.testing.assert_allclose(on_nodes(torch.as_tensor(scales)).numpy(), full[:, [62, 3 + 5 * 1 + 25 * 4]].numpy(),
                                   atol=1e-5)
    assert s.bounds[0].tolist() == [0.7] * 6 and s.bounds[1].tolist() == [1.3] * 6  # no training range recorded
    with pytest.raises(ValueError, match="orientation"):
        design.MapSurrogate(model, "panda7", tasks, rpy=(0.0, 0.0, 0.0))


def test_spherical_wrist_map_at_the_tasks_does_not_depend_on_the_orientation():
    """Why the paper's identity-orientation models serve tool-down tasks: unlimited joints and the
    tool point at the wrist centre (d6 = 0)."""
    from wsmap import robots

    arms = robots.sample_spherical_wrist(300, seed=3)
    tasks = design.box_tasks((0.4, 0.0, 0.2), 0.4)
    at_identity = ws.constant_orientation_map(arms, tasks, (0, 0, 0), method="exact", convention="standard")
    tool_down = ws.constant_orientation_map(arms, tasks, (np.pi, 0, 0), method="exact", convention="standard")
    assert 0.1 < at_identity.mean() < 0.9
    np.testing.assert_array_equal(at_identity, tool_down)


def test_an_assembled_block_model_is_read_block_by_block():
    """Section 6.2's layout: S subspaces, each a consecutive block of nodes (here 5 x 25 = 125)."""
    torch.manual_seed(1)
    model = SubspaceMLP(MLPConfig(n_inputs=SMALL.n_features, n_outputs=25, hidden=[6], init="torch", n_subspaces=5))
    model.set_map_spec(SMALL, assemble=True)
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    pick = [0, 24, 25, 63, 99, 124]
    s = design.MapSurrogate(model, "spherical_wrist", nodes[pick])
    params = torch.tensor([[0.3, 0.2, 0.1, 0.25]], dtype=torch.float64)
    with torch.no_grad():
        want = model.assemble(s.features(params)).double()[:, pick] - 0.5
        np.testing.assert_allclose(s(params).numpy(), want.numpy(), atol=1e-5)


def test_a_failed_verification_raises_the_margin_and_goes_on():
    """The classical side is stricter than the surrogate by 1 cm of reach: the margin has to rise
    (steps of 4 mm) past 1 cm before a design verifies, and then the design is ~1 cm longer in reach."""
    def stricter(params):
        return (params @ W)[:, None] >= np.linalg.norm(TASKS, axis=1)[None] + 0.01

    r = design.design_by_gradient("panda7", TASKS, _analytic_surrogate, verify=stricter, margin=0.0, margin_step=0.004,
                             starts=2, steps=300, seed=0)
    assert r.verified and r.rounds >= 4 and np.all(r.margins >= 0.012 - 1e-12)
    assert R_NEED + 0.01 <= r.params @ W <= R_NEED + 0.02
