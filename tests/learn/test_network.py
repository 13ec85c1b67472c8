"""Tests of wsmap.learn's networks and files: initialisation, the stacked subspace MLP, model files."""

import dataclasses
import math
import os

import numpy as np
import pytest
import torch
from torch import nn

from wsmap.learn.files import FORMAT, FORMAT_VERSION, load, payload_checksum, save
from wsmap.learn.init import matlab_rands_, nguyen_widrow_, torch_default_
from wsmap.learn.network import MLPConfig, SubspaceMLP, check_features
from wsmap.metrics import precision_recall_f, threshold_sweep

torch.set_num_threads(1)  # tiny models; the CPU is shared

F_IN, M_OUT = 12, 5


def small_config(**kw) -> MLPConfig:
    base = dict(n_inputs=F_IN, n_outputs=M_OUT, hidden=[7, 6])
    base.update(kw)
    return MLPConfig(**base)


def features(n=9, f=F_IN, seed=0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1, 1, size=(n, f))


def reference_net(model: SubspaceMLP, k: int) -> nn.Sequential:
    """Subspace k of ``model`` as a plain nn.Sequential (Linear/Tanh), weights copied."""
    layers = []
    for j, (W, b) in enumerate(zip(model.weights, model.biases)):
        lin = nn.Linear(W.shape[1], W.shape[2])
        with torch.no_grad():
            lin.weight.copy_(W[k].T)
            lin.bias.copy_(b[k])
        layers.append(lin)
        if j < len(model.weights) - 1:
            layers.append(nn.Tanh())
    return nn.Sequential(*layers)


# ------------------------------------------------------------------ Nguyen–Widrow


def test_nguyen_widrow_scale_default_range():
    H, N = 7, 5
    lin = nn.Linear(N, H)
    w, b = nguyen_widrow_(lin, generator=torch.Generator().manual_seed(0))
    beta = 0.7 * H ** (1 / N)
    # tansig's active range [-2, 2] doubles the [-1, 1] construction: row norm 2 * beta
    torch.testing.assert_close(w.norm(dim=1), torch.full((H,), 2 * beta))
    spread = 2 * beta * torch.linspace(-1, 1, H).abs()
    torch.testing.assert_close(b.abs(), spread)
    assert torch.equal(torch.sign(b[b != 0]), (torch.sign(w[:, 0]) * torch.sign(torch.linspace(-1, 1, H)))[b != 0])


def test_nguyen_widrow_input_range_and_constant_inputs():
    H = 6
    pr = torch.tensor([[0.0, 0.5], [3.0, 3.0], [-2.0, 6.0], [1.0, 1.0]], dtype=torch.float64)
    w = torch.empty(4, H)  # the stacked layout (in, out)
    b = torch.empty(H)
    nguyen_widrow_(w, b, pr, generator=torch.Generator().manual_seed(1))
    w, b = w.double(), b.double()
    assert torch.all(w[1] == 0) and torch.all(w[3] == 0)  # constant inputs: zero weight
    r = 2  # only the varying inputs count
    beta2 = 2 * 0.7 * H ** (1 / r)
    half = (pr[:, 1] - pr[:, 0]) / 2
    torch.testing.assert_close((w * half[:, None]).norm(dim=0), torch.full((H,), beta2, dtype=torch.float64),
                               rtol=1e-5, atol=1e-5)
    centre = (pr[:, 0] + pr[:, 1]) / 2
    net_at_centre = centre @ w + b  # the net input at the centre of the input box
    torch.testing.assert_close(net_at_centre.abs(), beta2 * torch.linspace(-1, 1, H, dtype=torch.float64).abs(),
                               rtol=1e-5, atol=1e-5)


def test_nguyen_widrow_stacked_slices_independent_and_reproducible():
    w = torch.empty(3, 4, 5)
    b = torch.empty(3, 5)
    nguyen_widrow_(w, b, generator=torch.Generator().manual_seed(2))
    assert not torch.equal(w[0], w[1])
    w2, b2 = torch.empty(3, 4, 5), torch.empty(3, 5)
    nguyen_widrow_(w2, b2, generator=torch.Generator().manual_seed(2))
    assert torch.equal(w, w2) and torch.equal(b, b2)
    with pytest.raises(ValueError, match="input_range must be"):
        nguyen_widrow_(w, b, torch.zeros(3, 2))


def test_rands_and_torch_default_bounds():
    w, b = torch.empty(50, 40), torch.empty(40)
    matlab_rands_(w, b, generator=torch.Generator().manual_seed(0))
    assert w.abs().max() <= 1 and b.abs().max() <= 1 and w.abs().max() > 0.9
    torch_default_(w, b, generator=torch.Generator().manual_seed(0))
    bound = 1 / math.sqrt(50)
    assert w.abs().max() <= bound and b.abs().max() <= bound and w.abs().max() > 0.9 * bound


def test_model_init_layers():
    cfg = small_config(hidden=[8, 6], n_subspaces=2)
    m = SubspaceMLP(cfg, seeds=[0, 1])
    # hidden layers: Nguyen–Widrow, default input range [-1, 1] (first layer), tanh outputs after
    for j, n_in in ((0, F_IN), (1, 8)):
        H = m.weights[j].shape[2]
        torch.testing.assert_close(m.weights[j][1].norm(dim=0), torch.full((H,), 1.4 * H ** (1 / n_in)))
    # linear output layer: MATLAB rands, U(-1, 1)
    assert m.weights[2].abs().max() <= 1 and m.biases[2].abs().max() <= 1
    t = SubspaceMLP(small_config(init="torch"))
    assert t.weights[0].abs().max() <= 1 / math.sqrt(F_IN)


def test_configure_uses_data_ranges():
    x = features(40)
    x[:, 3] = 0.25  # a constant column
    x[:, 0] *= 10
    m = SubspaceMLP(small_config(hidden=[9])).configure(x, seeds=[0])
    W = m.weights[0][0].double()
    assert torch.all(W[3] == 0)
    half = torch.as_tensor((x.max(0) - x.min(0)) / 2)
    half[3] = 0
    torch.testing.assert_close((W * half[:, None]).norm(dim=0), torch.full((9,), 1.4 * 9 ** (1 / (F_IN - 1)),
                                                                           dtype=torch.float64), rtol=1e-5, atol=1e-5)


# ------------------------------------------------------------------ config


def test_config_round_trip_and_validation():
    cfg = small_config(input_columns=[0, 3, 5], input_scaling="standardize", n_subspaces=4, output_kind="logit")
    assert MLPConfig.from_dict(cfg.to_dict()) == cfg
    assert cfg.n_network_inputs == 3 and cfg.layer_sizes == [3, 7, 6, M_OUT]
    assert MLPConfig(n_inputs=84, n_outputs=1323).hidden == [125, 100, 100, 125]
    with pytest.raises(ValueError, match="unknown MLPConfig keys"):
        MLPConfig.from_dict({**cfg.to_dict(), "depth": 3})
    with pytest.raises(ValueError, match="input_columns"):
        small_config(input_columns=[0, F_IN])
    with pytest.raises(ValueError, match="output_kind"):
        small_config(output_kind="sigmoid")
    with pytest.raises(ValueError, match="n_subspaces"):
        small_config(n_subspaces=0)


# ------------------------------------------------------------------ stacking and keys


@pytest.fixture
def singles():
    return [SubspaceMLP(small_config(), seeds=[s]) for s in (11, 12, 13)]


def test_stacked_equals_separate_models(singles):
    stacked = SubspaceMLP.from_models(singles)
    assert stacked.n_subspaces == 3
    x = torch.as_tensor(features(), dtype=torch.float32)
    out = stacked(x)
    assert out.shape == (3, 9, M_OUT)
    for k, single in enumerate(singles):
        ref = reference_net(single, 0)(x)
        torch.testing.assert_close(out[k], ref)
        torch.testing.assert_close(stacked(x, key=k), ref)
        torch.testing.assert_close(single(x)[0], ref)
        extracted = stacked.subspace(k)
        for a, b in zip(extracted.parameters(), single.parameters()):
            assert torch.equal(a, b)
    # seeded stack == stack of the seeded singles (what train_sessions relies on)
    direct = SubspaceMLP(small_config(n_subspaces=3), seeds=[11, 12, 13])
    for a, b in zip(direct.parameters(), stacked.parameters()):
        assert torch.equal(a, b)
    # one batch per subspace
    xs = torch.as_tensor(np.stack([features(4, seed=s) for s in range(3)]), dtype=torch.float32)
    out3 = stacked(xs)
    for k in range(3):
        torch.testing.assert_close(out3[k], stacked(xs[k], key=k))


def test_from_models_rejects_different_configs(singles):
    other = SubspaceMLP(small_config(hidden=[7, 5]))
    with pytest.raises(ValueError, match=r"model 1 differs from model 0 in \['hidden'\]"):
        SubspaceMLP.from_models([singles[0], other])


def test_per_sample_keys(singles):
    stacked = SubspaceMLP.from_models(singles)
    x = torch.as_tensor(features(7), dtype=torch.float32, ).requires_grad_(False)
    keys = [2, 0, 1, 2, 0, 0, 1]
    out = stacked(x, key=torch.tensor(keys))
    assert out.shape == (7, M_OUT)
    for i, k in enumerate(keys):
        torch.testing.assert_close(out[i], stacked(x, key=k)[i])
    torch.testing.assert_close(stacked(x, key=np.array(keys)), out)
    torch.testing.assert_close(stacked(x, key=keys), out)
    out.sum().backward()  # gradients flow through the grouped passes
    assert stacked.weights[0].grad is not None and torch.all(stacked.weights[0].grad.flatten(1).abs().sum(1) > 0)


def test_unknown_subspace_key(singles):
    stacked = SubspaceMLP.from_models(singles)
    x = features(3)
    msg = "unknown subspace key 3: the model has 3 subspace(s), keys 0..2"
    with pytest.raises(ValueError) as e:
        stacked(x, key=3)
    assert str(e.value) == msg
    with pytest.raises(ValueError, match=r"unknown subspace key -1"):
        stacked(x, key=-1)
    with pytest.raises(ValueError) as e:
        stacked(x, key=torch.tensor([0, 3, 1]))
    assert str(e.value) == msg
    with pytest.raises(ValueError, match="unknown subspace key 5"):
        stacked.subspace(5)
    with pytest.raises(ValueError, match="must be integers"):
        stacked(x, key=torch.tensor([0.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match=r"per-sample keys must be \(3,\)"):
        stacked(x, key=[0, 1])


def test_assemble_shape_and_order(singles):
    stacked = SubspaceMLP.from_models(singles)
    x = features(6)
    full = stacked.assemble(x)
    assert full.shape == (6, 3 * M_OUT)
    for k in range(3):
        torch.testing.assert_close(full[:, k * M_OUT:(k + 1) * M_OUT], stacked(x, key=k))
    assert torch.equal(stacked.predict(x, assemble=True), full > 0.5)


def test_predict_linear_and_logit(singles):
    m = singles[0]
    x = features(20)
    raw = m(x)
    assert torch.equal(m.predict(x), raw > 0.5)
    assert torch.equal(m.predict(x, 0.1, key=0), raw[0] > 0.1)
    logit_model = SubspaceMLP(small_config(output_kind="logit"), seeds=[11])
    assert torch.equal(logit_model(x), raw)  # same seed, same weights
    t = 0.7
    pred = logit_model.predict(x, t)
    assert torch.equal(pred, torch.sigmoid(raw) > t)
    assert torch.equal(pred, raw > math.log(t / (1 - t)))  # no value sits at the boundary here
    # predict and the metrics' sweep threshold the same scores the same way
    truth = np.random.default_rng(0).random((1, 20, M_OUT)) < 0.5
    prf = precision_recall_f(m.predict(x), truth)
    sw = threshold_sweep(m.score(x), truth, [0.5])
    assert (sw.tp[0], sw.fp[0], sw.fn[0]) == (prf.tp, prf.fp, prf.fn)
    # batching does not change results
    assert torch.equal(m.predict(x, batch_size=3), m.predict(x))
    stacked = SubspaceMLP.from_models(singles)
    keys = torch.tensor([0, 1, 2, 1] * 5)
    assert torch.equal(stacked.predict(x, key=keys, batch_size=3), stacked.predict(x, key=keys))


def test_input_columns_and_scaling():
    cols = [0, 4, 7]
    m = SubspaceMLP(small_config(input_columns=cols), seeds=[3])
    x = features(5)
    y = m(x)
    x2 = x.copy()
    x2[:, [1, 2, 3]] += 5.0  # columns the model does not use
    assert torch.equal(m(x2), y)
    sub = SubspaceMLP(small_config(n_inputs=3), seeds=[3])
    assert torch.equal(sub(x[:, cols]), y)

    s = SubspaceMLP(small_config(input_scaling="standardize", n_subspaces=2), seeds=[4, 5])
    mean, std = np.linspace(-1, 1, F_IN), np.linspace(0.5, 2, F_IN)
    s.set_input_stats(mean, std)
    plain = SubspaceMLP(small_config(n_subspaces=2), seeds=[4, 5])
    z = torch.as_tensor((x - mean) / std, dtype=torch.float32)
    torch.testing.assert_close(s(x), plain(z))
    with pytest.raises(ValueError, match="positive"):
        s.set_input_stats(mean, np.zeros(F_IN))
    with pytest.raises(ValueError, match="does not use input stats"):
        plain.set_input_stats(mean, std)

    # configure: stats from data; a constant column standardises to exactly 0
    xd = features(30)
    xd[:, 2] = 0.1
    c = SubspaceMLP(small_config(input_scaling="standardize")).configure(xd)
    assert c.input_std[0, 2] == 1 and c.input_mean[0, 2] == torch.tensor(0.1, dtype=torch.float32)
    z = c.network_inputs(xd, key=0)
    assert torch.all(z[:, 2] == 0)
    torch.testing.assert_close(z.mean(0), torch.zeros(F_IN), atol=1e-5, rtol=0)


def test_wrong_feature_count():
    m = SubspaceMLP(MLPConfig(n_inputs=84, n_outputs=3, hidden=[4]))
    x = np.zeros((2, 83))
    with pytest.raises(ValueError) as e:
        check_features(m, x)
    assert str(e.value) == "model expects 84 features, got 83"
    with pytest.raises(ValueError) as e:
        m.predict(x)
    assert str(e.value) == "model expects 84 features, got 83"
    check_features(m, np.zeros((2, 84)))
    with pytest.raises(ValueError, match=r"features must be \(n, f\)"):
        m(np.zeros(84))


def test_trains_as_stacked_model():
    from wsmap.learn.training import TrainConfig, train

    x = features(60)
    y = (x[:, :M_OUT] > 0).astype(np.float32)
    m = SubspaceMLP(small_config(n_subspaces=2), seeds=[0, 1]).configure(x, seeds=[0, 1])
    before = m(x).detach().clone()
    res = train(m, x, y, TrainConfig(max_epochs=5))
    assert res.n_sessions == 2 and not torch.equal(m(x).detach(), before)


# ------------------------------------------------------------------ files


@dataclasses.dataclass
class _Spec:
    name: str
    step: float

    def to_dict(self):
        return {"name": self.name, "step": self.step, "shape": (21, 21, 21)}


def test_save_load_round_trip(tmp_path, singles):
    stacked = SubspaceMLP.from_models(singles)
    path = tmp_path / "models" / "m.pt"
    save(stacked, path, dataset_spec=_Spec("sec62", 0.1), train_config={"optimizer": "rprop", "lr": np.float64(0.07)},
         extra={"blocks": np.arange(3), "note": "x"})
    assert sorted(os.listdir(path.parent)) == ["m.pt"]  # no temporary file left behind
    loaded, meta = load(path)
    x = features(8)
    assert torch.equal(loaded(x), stacked(x))
    assert loaded.config == stacked.config and not loaded.training
    assert meta["dataset_spec"] == {"name": "sec62", "step": 0.1, "shape": [21, 21, 21]}
    assert meta["train_config"] == {"optimizer": "rprop", "lr": 0.07}
    assert meta["extra"] == {"blocks": [0, 1, 2], "note": "x"}
    assert meta["format"] == FORMAT and meta["version"] == FORMAT_VERSION == 2
    assert meta["checksum"].startswith("sha256:") and len(meta["checksum"]) == 7 + 64

    scaled = SubspaceMLP(small_config(input_scaling="standardize", input_columns=[1, 2, 3]), seeds=[0])
    scaled.set_input_stats(np.arange(3.0), np.ones(3) * 2)
    save(scaled, tmp_path / "s.pt")
    back, meta = load(tmp_path / "s.pt")
    assert torch.equal(back(x), scaled(x)) and meta["dataset_spec"] is None
    with pytest.raises(TypeError, match=r"cannot save extra\['f'\]"):
        save(scaled, tmp_path / "bad.pt", extra={"f": object()})


def sealed(payload: dict) -> dict:
    """``payload`` with its checksum recomputed: a file edited on purpose, to reach the checks
    behind the checksum."""
    return {**payload, "checksum": payload_checksum(payload)}


def test_load_rejects_bad_files(tmp_path, singles):
    good = tmp_path / "good.pt"
    save(singles[0], good)
    data = good.read_bytes()

    missing = tmp_path / "missing.pt"
    with pytest.raises(ValueError) as e:
        load(missing)
    assert str(e.value) == f"cannot load model {missing}: no such file"

    truncated = tmp_path / "truncated.pt"
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError) as e:
        load(truncated)
    assert str(e.value) == f"cannot load model {truncated}: not a readable torch file (truncated or corrupt)"

    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(np.random.default_rng(0).bytes(4096))
    with pytest.raises(ValueError) as e:
        load(garbage)
    assert str(e.value).startswith(f"cannot load model {garbage}: not a wsmap model file (not a torch zip archive")

    payload = torch.load(good, weights_only=True)
    wrong_tag = tmp_path / "tag.pt"
    torch.save(sealed({**payload, "format": "something.else"}), wrong_tag)
    with pytest.raises(ValueError) as e:
        load(wrong_tag)
    assert str(e.value) == f"cannot load model {wrong_tag}: format tag 'something.else' is not '{FORMAT}'"

    newer = tmp_path / "newer.pt"
    torch.save(sealed({**payload, "version": 99}), newer)
    with pytest.raises(ValueError, match="format version 99 is not supported"):
        load(newer)

    mismatch = tmp_path / "mismatch.pt"
    torch.save(sealed({**payload, "config": {**payload["config"], "hidden": [7, 4]}}), mismatch)
    with pytest.raises(ValueError) as e:
        load(mismatch)
    assert str(e.value) == (f"cannot load model {mismatch}: state does not match config: "
                            "biases.1 has shape (1, 6), config needs (1, 4); "
                            "weights.1 has shape (1, 7, 6), config needs (1, 7, 4); "
                            "weights.2 has shape (1, 6, 5), config needs (1, 4, 5)")

    bad_config = tmp_path / "config.pt"
    torch.save(sealed({**payload, "config": {**payload["config"], "activation": "relu"}}), bad_config)
    with pytest.raises(ValueError, match=r"cannot load model .*config\.pt: invalid config: MLPConfig.activation"):
        load(bad_config)

    not_dict = tmp_path / "tensor.pt"
    torch.save(torch.zeros(3), not_dict)
    with pytest.raises(ValueError, match="no format tag"):
        load(not_dict)


def test_map_spec_is_saved_and_not_carried_by_restacking(tmp_path):
    from wsmap.datasets import DatasetSpec
    from wsmap.paper.specs import PAPER_SPECS

    spec = PAPER_SPECS["table1_r3_step1"]  # 3³ = 27 nodes, 48 features
    stack = SubspaceMLP(MLPConfig(n_inputs=spec.n_features, n_outputs=9, hidden=[4], n_subspaces=3), seeds=[0, 1, 2])
    stack.set_map_spec(spec, assemble=True, threshold=0.4)
    assert stack.map_spec["nodes"] == [0, 27]
    with pytest.warns(UserWarning, match="without a training range: predict_maps will refuse"):
        loaded, meta = load(save(stack, tmp_path / "m.pt"))
    assert loaded.map_spec == stack.map_spec == meta["map_spec"]
    assert DatasetSpec.from_dict(loaded.map_spec["dataset"]) == spec
    # A slice or a restack maps something else: the description is not carried over.
    assert stack.subspace(1).map_spec is None
    assert SubspaceMLP.from_models([stack, stack]).map_spec is None
    # Files without one (older files, bare models) load with None.
    stack.map_spec = None
    assert load(save(stack, tmp_path / "bare.pt"))[0].map_spec is None
    with pytest.raises(ValueError, match=r"covers 27 nodes \[0, 27\) but the model gives 9 \(9 outputs\)"):
        stack.set_map_spec(spec, subspace=0)  # 9 outputs cannot cover the 27 labelled nodes


def test_hidden_outputs_feed_the_output_layer_and_match_forward():
    from wsmap.learn.network import SubspaceMLP as Net

    model = Net(small_config(n_subspaces=2), seeds=[3, 4])
    x = features(n=11)
    for key in (0, 1):
        hidden = model.hidden_outputs(x, key)
        assert [tuple(h.shape) for h in hidden] == [(11, 7), (11, 6)]
        assert all(float(h.abs().max()) <= 1.0 for h in hidden)
        out = hidden[-1] @ model.weights[-1][key] + model.biases[-1][key]
        torch.testing.assert_close(out, model(x, key=key).detach())
    with pytest.raises(ValueError, match="unknown subspace key 2"):
        model.hidden_outputs(x, 2)


def test_unit_saturation_tells_constant_units_from_switching_ones():
    from wsmap.learn import unit_saturation

    model = SubspaceMLP(small_config(hidden=[3, 2]), seeds=[0])
    x = np.zeros((101, F_IN))
    x[:, 0] = np.linspace(-1, 1, 101)  # one varying input, both signs, 0 once
    with torch.no_grad():
        W, b = model.weights[0], model.biases[0]
        W.zero_()
        b.zero_()
        W[0, 0, 0] = 1000.0  # unit 0: saturated on 100 of 101 samples (not at 0), at both signs: switching
        b[0, 1] = 50.0  # unit 1: saturated at +1 on every sample: constant
        W[0, 0, 2] = 0.1  # unit 2: |h| <= tanh(0.1): never saturated
    rows = unit_saturation(model, x)
    assert [r["layer"] for r in rows] == [1, 2] and rows[0]["units"] == 3
    assert rows[0]["saturated"] == pytest.approx((100 + 101 + 0) / 303)
    assert rows[0]["constant"] == pytest.approx(1 / 3)
    assert rows[0]["active_units"] == 2
    with pytest.raises(ValueError, match="level must lie in"):
        unit_saturation(model, x, level=1.5)
