import json
import math
import re

import numpy as np
import pytest
import torch
from torch import nn

from wsmap.learn.training import (
    History,
    Split,
    TrainConfig,
    make_loss,
    split_indices,
    train,
    train_sessions,
    validation_stop,
)

torch.set_num_threads(1)  # tiny models: threads only add overhead (and other agents share the CPU)


class StackedMLP(nn.Module):
    """Minimal stacked tanh MLP: S parameter sets, weights (S, in, out), biases (S, 1, out).

    ``forward(x)``: x (n, f) or (S, n, f) → (S, n, m). Session s is initialised from seeds[s]
    alone, so a stack equals the sessions built one by one.
    """

    def __init__(self, sizes, seeds):
        super().__init__()
        self.weights, self.biases = nn.ParameterList(), nn.ParameterList()
        per = []
        for sd in seeds:
            g = torch.Generator().manual_seed(sd)
            layers = []
            for fan_in, fan_out in zip(sizes[:-1], sizes[1:]):
                bound = 1.0 / math.sqrt(fan_in)
                layers.append(((torch.rand(fan_in, fan_out, generator=g) * 2 - 1) * bound,
                               (torch.rand(1, fan_out, generator=g) * 2 - 1) * bound))
            per.append(layers)
        for i in range(len(sizes) - 1):
            self.weights.append(nn.Parameter(torch.stack([p[i][0] for p in per])))
            self.biases.append(nn.Parameter(torch.stack([p[i][1] for p in per])))

    @property
    def n_sessions(self):
        return self.weights[0].shape[0]

    def forward(self, x):
        h = x if x.ndim == 3 else x.expand(self.n_sessions, *x.shape)
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.baddbmm(b, h, w)
            if i < last:
                h = torch.tanh(h)
        return h

    def session(self, s):
        """A copy of session s as an S = 1 stack."""
        sizes = [self.weights[0].shape[1]] + [w.shape[2] for w in self.weights]
        one = StackedMLP(sizes, [0])
        with torch.no_grad():
            for dst, src in zip(list(one.weights) + list(one.biases), list(self.weights) + list(self.biases)):
                dst.copy_(src[s:s + 1])
        return one


def mlp(sizes, seed):
    torch.manual_seed(seed)
    layers = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2:
            layers.append(nn.Tanh())
    return nn.Sequential(*layers)


def regression_data(n=200, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, (n, 2)).astype(np.float32)
    Y = (np.sin(2 * X[:, :1]) + 0.5 * X[:, 1:]) + noise * rng.standard_normal((n, 1))
    return X, Y.astype(np.float32)


# ---------------------------------------------------------------------------------------------
# losses and splits
# ---------------------------------------------------------------------------------------------


def test_losses_match_torch():
    torch.manual_seed(0)
    out, t = torch.randn(5, 3), torch.rand(5, 3).round()
    assert torch.allclose(make_loss("mse")(out, t), nn.functional.mse_loss(out, t))
    assert torch.allclose(make_loss("mae")(out, t), nn.functional.l1_loss(out, t))
    assert torch.allclose(make_loss("crossentropy")(out, t), nn.functional.binary_cross_entropy_with_logits(out, t))
    # Stacked outputs: one mean per session, target broadcast.
    stacked = torch.randn(4, 5, 3)
    per = make_loss("crossentropy")(stacked, t)
    assert per.shape == (4,)
    assert torch.allclose(per[2], nn.functional.binary_cross_entropy_with_logits(stacked[2], t))


def test_unknown_loss():
    with pytest.raises(ValueError, match=re.escape("unknown loss 'hinge'; known: crossentropy, mae, mse")):
        make_loss("hinge")


def test_split_properties():
    sp = split_indices(1000, (0.7, 0.15, 0.15), seed=3)
    assert isinstance(sp, Split)
    assert (len(sp.train), len(sp.val), len(sp.test)) == (700, 150, 150)
    allidx = np.concatenate(sp)
    assert np.array_equal(np.sort(allidx), np.arange(1000))  # disjoint and covering
    assert all(np.all(np.diff(part) > 0) for part in sp)  # sorted
    again = split_indices(1000, seed=3)
    assert all(np.array_equal(a, b) for a, b in zip(sp, again))
    other = split_indices(1000, seed=4)
    assert not np.array_equal(sp.train, other.train)
    assert sp.train.dtype == np.int64


def test_split_rounding_and_errors():
    sp = split_indices(7, (0.7, 0.15, 0.15), seed=0)
    assert (len(sp.train), len(sp.val), len(sp.test)) == (5, 1, 1)
    assert len(split_indices(10, (1.0, 0.0, 0.0)).val) == 0
    with pytest.raises(ValueError):
        split_indices(10, (0.5, 0.5, 0.5))
    with pytest.raises(ValueError):
        split_indices(10, (0.0, 0.5, 0.5))


def test_config_round_trip():
    cfg = TrainConfig(optimizer="trainscg", optimizer_kwargs={"sigma": 1e-4}, loss="mae", max_epochs=50,
                      max_fail=100, seed=7, time_limit_s=3.5, fractions=(0.8, 0.1, 0.1))
    d = json.loads(json.dumps(cfg.to_dict()))
    assert TrainConfig.from_dict(d) == cfg
    rp = TrainConfig(optimizer_kwargs={"etas": (0.4, 1.3)})
    back = TrainConfig.from_dict(json.loads(json.dumps(rp.to_dict())))
    assert back.optimizer_kwargs == {"etas": [0.4, 1.3]}
    with pytest.raises(ValueError, match="unknown TrainConfig keys"):
        TrainConfig.from_dict({"epochs": 3})
    with pytest.raises(ValueError, match="unknown optimizer"):
        TrainConfig(optimizer="sgd")


# ---------------------------------------------------------------------------------------------
# train
# ---------------------------------------------------------------------------------------------


def test_tiny_regression_trains_to_low_loss():
    X, Y = regression_data()
    model = mlp([2, 10, 1], seed=0)
    res = train(model, X, Y, TrainConfig(max_epochs=300, max_fail=1000, seed=0))
    h = res.history
    assert res.stop_reason == "max_epochs" and len(h) == 301 and h.epoch[-1] == 300
    assert h.loss[-1] < 1e-3 < h.loss[0]
    assert h.val_loss[res.best_epoch] < 2e-3
    assert all(t1 >= t0 for t0, t1 in zip(h.time, h.time[1:]))
    frame = h.to_frame()
    assert list(frame.columns) == ["epoch", "loss", "grad_norm", "val_loss", "time"] and len(frame) == 301


@pytest.mark.parametrize("name", ["scg", "cgb", "oss", "gdx"])
def test_other_optimisers_train(name):
    X, Y = regression_data()
    model = mlp([2, 10, 1], seed=0)
    res = train(model, X, Y, TrainConfig(optimizer=name, max_epochs=150, max_fail=1000))
    assert res.history.loss[-1] < 0.1 * res.history.loss[0], (name, res.history.loss[-1], res.stop_reason)


def test_early_stopping_restores_the_best_epoch():
    # Validation targets are half the training targets: fitting the training data first helps,
    # then hurts the validation loss.
    X, Y = regression_data(300)
    sp = split_indices(300, seed=0)
    Yc = Y.copy()
    Yc[sp.val] *= 0.5
    model = mlp([2, 10, 1], seed=1)
    cfg = TrainConfig(max_epochs=1000, max_fail=6)
    res = train(model, X, Yc, cfg, split=sp)
    h = res.history
    assert res.stop_reason == "max_fail"
    assert 0 < res.best_epoch < res.stop_epoch < 1000
    assert res.stop_epoch >= res.best_epoch + cfg.max_fail
    assert h.val_loss[res.best_epoch] == min(h.val_loss) == res.best_val_loss
    # The last max_fail epochs were all failures (no improvement on the best).
    assert all(v > res.best_val_loss for v in h.val_loss[res.best_epoch + 1:])
    # The model holds the best epoch's parameters.
    with torch.no_grad():
        xv, yv = torch.as_tensor(X[sp.val]), torch.as_tensor(Yc[sp.val])
        assert float(nn.functional.mse_loss(model(xv), yv)) == pytest.approx(res.best_val_loss, rel=1e-6)


def test_validation_stop_replay_agrees_with_training_at_that_max_fail():
    # A run with a large max_fail replayed at max_fail 6 must stop where a max_fail-6 run stops:
    # the epochs up to the stop do not depend on max_fail.
    X, Y = regression_data(300)
    sp = split_indices(300, seed=0)
    Yc = Y.copy()
    Yc[sp.val] *= 0.5
    long = train(mlp([2, 10, 1], seed=1), X, Yc, TrainConfig(max_epochs=400, max_fail=1000), split=sp)
    short = train(mlp([2, 10, 1], seed=1), X, Yc, TrainConfig(max_epochs=400, max_fail=6), split=sp)
    assert long.stop_reason == "max_epochs" and short.stop_reason == "max_fail"
    r = validation_stop(long.history.val_loss, 6)
    assert r == {"stop_epoch": short.stop_epoch, "stopped": True, "best_epoch": short.best_epoch,
                 "best_val_loss": short.best_val_loss}
    # At the run's own max_fail the replay does not fire and keeps the run's best epoch.
    r = validation_stop(long.history.val_loss, 1000)
    assert r["stopped"] is False and r["stop_epoch"] == 400
    assert (r["best_epoch"], r["best_val_loss"]) == (long.best_epoch, long.best_val_loss)


def test_validation_stop_known_sequence():
    # equal values are neither improvement nor failure (MATLAB); three failures in a row stop
    v = [5, 4, 4, 5, 6, 3, 4, 4, 4, 1]
    assert validation_stop(v, 3) == {"stop_epoch": 8, "stopped": True, "best_epoch": 5, "best_val_loss": 3.0}
    assert validation_stop(v, 4) == {"stop_epoch": 9, "stopped": False, "best_epoch": 9, "best_val_loss": 1.0}
    # a stopped session's NaN tail ends the replay
    assert validation_stop([2.0, 1.0, float("nan"), 0.5], 6) == {"stop_epoch": 1, "stopped": False, "best_epoch": 1,
                                                               "best_val_loss": 1.0}


@pytest.mark.parametrize("args, message", [
    (([1.0, 2.0], 0), "max_fail must be an integer >= 1, got 0"),
    (([1.0, 2.0], 2.5), "max_fail must be an integer >= 1, got 2.5"),
    (([1.0, 2.0], "6"), "max_fail must be an integer >= 1, got '6'"),
    (([1.0, 2.0], None), "max_fail must be an integer >= 1, got None"),
    (([], 6), "val_loss must be a non-empty 1-D sequence, got shape (0,)"),
    (([[1.0, 2.0]], 6), "val_loss must be a non-empty 1-D sequence, got shape (1, 2)"),
    (([float("nan"), 1.0], 6), "val_loss[0] is not finite: the history has no validation loss"),
])
def test_validation_stop_bad_input(args, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        validation_stop(*args)


def test_validation_failing_from_the_start_restores_the_initial_weights():
    X, Y = regression_data(100)
    sp = split_indices(100, seed=0)
    Yc = Y.copy()
    Yc[sp.val] = -5.0 * Yc[sp.val]
    model = mlp([2, 5, 1], seed=0)
    init = [p.detach().clone() for p in model.parameters()]
    res = train(model, X, Yc, TrainConfig(max_fail=3), split=sp)
    assert res.stop_reason == "max_fail" and res.best_epoch == 0 and res.stop_epoch == 3
    assert all(torch.equal(a, b) for a, b in zip(init, model.parameters()))


def test_stop_reasons_min_grad_time_limit_and_no_validation():
    X, Y = regression_data(50)
    res = train(mlp([2, 4, 1], 0), X, Y, TrainConfig(min_grad=1e6))
    assert res.stop_reason == "min_grad" and res.stop_epoch == 0
    res = train(mlp([2, 4, 1], 0), X, Y, TrainConfig(time_limit_s=0.0))
    assert res.stop_reason == "time_limit" and res.stop_epoch == 0
    # Without a validation split the best epoch is the lowest training loss (MATLAB).
    res = train(mlp([2, 4, 1], 0), X, Y, TrainConfig(max_epochs=20, fractions=(1.0, 0.0, 0.0)))
    assert res.stop_reason == "max_epochs" and all(math.isnan(v) for v in res.history.val_loss)
    assert res.best_epoch == int(np.argmin(res.history.loss))


def test_track_test():
    X, Y = regression_data(60)
    res = train(mlp([2, 4, 1], 0), X, Y, TrainConfig(max_epochs=5, track_test=True))
    assert len(res.history.test_loss) == 6 and "test_loss" in res.history.to_frame()


def test_same_seed_same_history_and_weights():
    X, Y = regression_data(120, noise=0.05)

    def run(seed):
        cfg = TrainConfig(max_epochs=40, seed=seed)
        (res,) = train_sessions(lambda seeds: mlp([2, 6, 1], seeds[0]), X, Y, cfg, sessions=1)
        return res

    a, b, c = run(5), run(5), run(6)
    for key in ("loss", "grad_norm", "val_loss"):
        assert getattr(a.history, key) == getattr(b.history, key)
    assert all(torch.equal(p, q) for p, q in zip(a.model.parameters(), b.model.parameters()))
    assert all(np.array_equal(i, j) for i, j in zip(a.split, b.split))
    assert a.history.loss != c.history.loss
    assert not np.array_equal(a.split.train, c.split.train)


# ---------------------------------------------------------------------------------------------
# stacked sessions
# ---------------------------------------------------------------------------------------------


def test_stacked_rprop_equals_separate_runs():
    # Noisy data, small validation sets: the sessions stop early, at different epochs (~70-80).
    X, Y = regression_data(200, noise=0.3, seed=1)
    seeds = [10, 11, 12]
    cfg = TrainConfig(max_epochs=300, max_fail=40, seed=10)
    stacked = StackedMLP([2, 8, 1], seeds)
    alone = [stacked.session(s) for s in range(3)]
    res = train(stacked, X, Y, cfg)
    assert res.n_sessions == 3 and len(res.split) == 3
    views = res.sessions()
    for s in range(3):
        single = train(alone[s], X, Y, cfg.replace(seed=cfg.seed + s))
        ref = single.sessions()[0]  # an S = 1 stack is itself a stacked run
        v = views[s]
        assert (v.stop_reason, v.stop_epoch, v.best_epoch) == (ref.stop_reason, ref.stop_epoch, ref.best_epoch)
        for key in ("loss", "grad_norm", "val_loss"):
            np.testing.assert_allclose(getattr(v.history, key), getattr(ref.history, key), rtol=1e-5, atol=1e-7)
        assert all(np.array_equal(i, j) for i, j in zip(v.split, ref.split))
        for p, q in zip(stacked.parameters(), alone[s].parameters()):
            torch.testing.assert_close(p[s:s + 1], q, rtol=1e-5, atol=1e-6)
    assert len({v.stop_epoch for v in views}) > 1  # the test exercises per-session stopping
    # The stacked history records NaN for sessions that have stopped.
    first = min(v.stop_epoch for v in views)
    if first < len(res.history) - 1:
        assert any(math.isnan(x) for x in res.history.loss[-1])
    assert set(res.history.to_frame().columns) >= {"epoch", "session", "loss"}


def test_train_sessions_stacked_and_sequential_agree():
    X, Y = regression_data(100, noise=0.1)
    cfg = TrainConfig(max_epochs=30, seed=3)

    def factory(seeds):
        return StackedMLP([2, 5, 1], seeds)

    stacked = train_sessions(factory, X, Y, cfg, sessions=3, stacked=True)
    sequential = train_sessions(factory, X, Y, cfg, sessions=3)  # the default
    assert [r.session for r in stacked] == [0, 1, 2]
    assert stacked[0].model is stacked[2].model and sequential[0].model is not sequential[2].model
    for a, b in zip(stacked, sequential):
        assert a.config.seed == b.config.seed
        np.testing.assert_allclose(a.history.loss, b.history.loss, rtol=1e-5)
        assert a.best_epoch == b.best_epoch


def test_non_elementwise_optimisers_refuse_stacking():
    X, Y = regression_data(40)
    cfg = TrainConfig(optimizer="scg", max_epochs=3)
    with pytest.raises(ValueError, match="not elementwise"):
        train_sessions(lambda s: StackedMLP([2, 3, 1], s), X, Y, cfg, sessions=2, stacked=True)
    results = train_sessions(lambda s: mlp([2, 3, 1], s[0]), X, Y, cfg, sessions=2)  # sequential
    assert len(results) == 2 and results[0].history.loss[0] != results[1].history.loss[0]


def test_history_session_view():
    h = History(epoch=[0, 1, 2], loss=[[1.0, 2.0], [0.5, 1.5], [0.4, math.nan]], grad_norm=[[1, 1]] * 3,
                val_loss=[[1, 1]] * 3, time=[0.0, 0.1, 0.2])
    v = h.session(1, length=2)
    assert v.epoch == [0, 1] and v.loss == [2.0, 1.5] and v.test_loss == []


def test_mse_gradient():
    out = torch.randn(3, 4, 2, dtype=torch.float64, requires_grad=True)
    t = torch.rand(4, 2, dtype=torch.float64)
    assert torch.autograd.gradcheck(lambda o: make_loss("mse")(o, t), (out,))
    per = make_loss("mse")(out, t)
    per.sum().backward()
    torch.testing.assert_close(out.grad, 2 * (out.detach() - t) / 8)
    single = torch.randn(4, 2, dtype=torch.float64, requires_grad=True)
    torch.testing.assert_close(make_loss("mse")(single, t), nn.functional.mse_loss(single, t))


def test_tensor_and_numpy_inputs_agree():
    X, Y = regression_data(60)
    a = train(mlp([2, 4, 1], 0), torch.as_tensor(X), torch.as_tensor(Y), TrainConfig(max_epochs=5))
    b = train(mlp([2, 4, 1], 0), X, Y > 0, TrainConfig(max_epochs=5))  # bool labels become float
    c = train(mlp([2, 4, 1], 0), X, (Y > 0).astype(np.float32), TrainConfig(max_epochs=5))
    assert a.history.loss[0] != b.history.loss[0] and b.history.loss == c.history.loss
    with pytest.raises(ValueError, match="same n"):
        train(mlp([2, 4, 1], 0), X, Y[:-1])


@pytest.mark.parametrize("shared_split", [True, False])
def test_stacked_per_session_targets(shared_split):
    # Section 6.2 style: one stack, a different target set (output block) per session.
    X, Y = regression_data(120, noise=0.1)
    Y3 = np.stack([Y, -Y, 2 * Y])
    cfg = TrainConfig(max_epochs=25, seed=4)
    stacked = StackedMLP([2, 6, 1], [1, 2, 3])
    alone = [stacked.session(s) for s in range(3)]
    split = split_indices(120, seed=9) if shared_split else None
    views = train(stacked, X, Y3, cfg, split=split).sessions()
    for s in range(3):
        ref = train(alone[s], X, Y3[s], cfg.replace(seed=4 + s), split=split).sessions()[0]
        np.testing.assert_allclose(views[s].history.loss, ref.history.loss, rtol=1e-5)
        np.testing.assert_allclose(views[s].history.val_loss, ref.history.val_loss, rtol=1e-5)
    with pytest.raises(ValueError, match="need a stacked model"):
        train(mlp([2, 3, 1], 0), X, Y3, cfg)
    with pytest.raises(ValueError, match="have S = 3"):
        train(StackedMLP([2, 3, 1], [0, 1]), X, Y3, cfg)


# ---------------------------------------------------------------------------------------------
# minibatches and Adam
# ---------------------------------------------------------------------------------------------


def test_adam_minibatch_trains_and_records_pass_losses():
    X, Y = regression_data(200)
    cfg = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 0.02}, batch_size=16, max_epochs=60, max_fail=1000)
    res = train(mlp([2, 10, 1], seed=0), X, Y, cfg)
    h = res.history
    assert res.stop_reason == "max_epochs" and len(h) == 61
    assert h.loss[-1] < 0.05 * h.loss[0]
    assert h.val_loss[res.best_epoch] < 0.05 * h.val_loss[0]
    assert all(math.isnan(g) for g in h.grad_norm)  # no full-batch gradient in minibatch mode
    # Epoch 0 is the full training loss of the initial network.
    model0 = mlp([2, 10, 1], seed=0)
    with torch.no_grad():
        tr = res.split.train
        assert h.loss[0] == pytest.approx(float(nn.functional.mse_loss(model0(torch.as_tensor(X[tr])),
                                                                        torch.as_tensor(Y[tr]))), rel=1e-6)


def test_adam_minibatch_is_reproducible_from_the_seed():
    X, Y = regression_data(150, noise=0.05)

    def run(seed):
        cfg = TrainConfig(optimizer="adam", batch_size=10, max_epochs=8, seed=seed)
        model = mlp([2, 6, 1], 0)  # same initial weights: only the seed (split, shuffle) differs
        return train(model, X, Y, cfg), model

    (a, ma), (b, mb) = run(3), run(3)
    assert a.history.loss == b.history.loss and a.history.val_loss == b.history.val_loss
    assert all(torch.equal(p, q) for p, q in zip(ma.parameters(), mb.parameters()))
    # Same split, different shuffle: the order of the minibatches matters.
    sp = split_indices(150, seed=3)
    cfg = TrainConfig(optimizer="adam", batch_size=10, max_epochs=8)
    c = train(mlp([2, 6, 1], 0), X, Y, cfg.replace(seed=3), split=sp)
    d = train(mlp([2, 6, 1], 0), X, Y, cfg.replace(seed=4), split=sp)
    assert c.history.loss == a.history.loss and d.history.loss[0] == c.history.loss[0]
    assert d.history.loss[1:] != c.history.loss[1:]


def test_one_minibatch_per_epoch_equals_full_batch_adam():
    X, Y = regression_data(80)
    cfg = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 0.01}, max_epochs=15)
    full, mini = mlp([2, 5, 1], 0), mlp([2, 5, 1], 0)
    a = train(full, X, Y, cfg)
    b = train(mini, X, Y, cfg.replace(batch_size=10_000))  # larger than the split: one batch
    for p, q in zip(full.parameters(), mini.parameters()):
        torch.testing.assert_close(p, q, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(a.history.val_loss, b.history.val_loss, rtol=1e-5)
    assert b.history.loss[0] == pytest.approx(a.history.loss[0], rel=1e-6)


def test_minibatch_bool_targets_equal_float_targets():
    X, Y = regression_data(100)
    cfg = TrainConfig(optimizer="adam", loss="crossentropy", batch_size=32, max_epochs=5)
    a = train(mlp([2, 4, 1], 0), X, Y > 0, cfg)
    b = train(mlp([2, 4, 1], 0), X, (Y > 0).astype(np.float32), cfg)
    assert a.history.loss == b.history.loss and a.history.val_loss == b.history.val_loss


def test_cosine_decay_follows_the_schedule():
    # Full batch, one step per epoch: lr_t = lr·(1 + cos(pi·t/E))/2; replay it by hand.
    X, Y = regression_data(60)
    E, lr = 4, 0.05
    model = mlp([2, 4, 1], 0)
    train(model, X, Y, TrainConfig(optimizer="adam", optimizer_kwargs={"lr": lr}, lr_decay="cosine",
                                   max_epochs=E, fractions=(1.0, 0.0, 0.0)))
    ref = mlp([2, 4, 1], 0)
    opt = torch.optim.Adam(ref.parameters(), lr=lr)
    x, y = torch.as_tensor(X), torch.as_tensor(Y)
    for t in range(E):
        opt.param_groups[0]["lr"] = lr * 0.5 * (1 + math.cos(math.pi * t / E))
        opt.zero_grad()
        nn.functional.mse_loss(ref(x), y).backward()
        opt.step()
    # the last step uses the best epoch (the lowest training loss: the last here)
    for p, q in zip(model.parameters(), ref.parameters()):
        torch.testing.assert_close(p, q, rtol=1e-5, atol=1e-6)
    plain = mlp([2, 4, 1], 0)
    train(plain, X, Y, TrainConfig(optimizer="adam", optimizer_kwargs={"lr": lr}, max_epochs=E,
                                   fractions=(1.0, 0.0, 0.0)))
    assert not all(torch.allclose(p, q) for p, q in zip(model.parameters(), plain.parameters()))


def test_stacked_minibatch_masks_stopped_sessions():
    X, Y = regression_data(200, noise=0.3, seed=1)
    stacked = StackedMLP([2, 8, 1], [10, 11, 12])
    res = train(stacked, X, Y, TrainConfig(optimizer="adam", batch_size=20, max_epochs=60, max_fail=5, seed=10))
    assert res.n_sessions == 3 and len(res.sessions()) == 3
    for v in res.sessions():
        assert v.best_epoch <= v.stop_epoch and len(v.history) == v.stop_epoch + 1
    # every session holds its best epoch's parameters
    for s, sp in enumerate(res.split):
        with torch.no_grad():
            out = stacked(torch.as_tensor(X[sp.val]))[s]
        assert float(nn.functional.mse_loss(out, torch.as_tensor(Y[sp.val]))) == pytest.approx(
            res.best_val_loss[s], rel=1e-5)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(optimizer="adam", batch_size=0), "batch_size must be a positive integer or None"),
        (dict(optimizer="adam", batch_size=-4), "batch_size must be a positive integer or None"),
        (dict(optimizer="adam", batch_size=2.5), "batch_size must be a positive integer or None"),
        (dict(optimizer="adam", batch_size=True), "batch_size must be a positive integer or None"),
        (dict(batch_size=32), "optimizer 'rprop' is a full-batch trainer; batch_size needs one of ['adam']"),
        (dict(optimizer="trainscg", batch_size=32), "is a full-batch trainer"),
        (dict(optimizer="adam", lr_decay="step"), "lr_decay must be None or one of"),
        (dict(lr_decay="cosine"), "lr_decay needs one of ['adam']"),
        (dict(optimizer="adam", lr_decay="cosine-time"), "set time_limit_s"),
        (dict(optimizer="sgd"), "unknown optimizer 'sgd'; known: adam, cgb, gdx, oss, rprop, scg"),
    ],
)
def test_minibatch_config_errors(kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        TrainConfig(**kwargs)


def test_minibatch_config_round_trip():
    cfg = TrainConfig(optimizer="Adam", optimizer_kwargs={"lr": 1e-3, "betas": (0.9, 0.99)}, batch_size=256,
                      lr_decay="cosine-time", time_limit_s=60.0, loss="crossentropy")
    back = TrainConfig.from_dict(json.loads(json.dumps(cfg.to_dict())))
    assert back.batch_size == 256 and back.lr_decay == "cosine-time" and back.optimizer_kwargs["betas"] == [0.9, 0.99]
    assert TrainConfig.from_dict({"optimizer": "rprop"}).batch_size is None  # old configs: full batch


def test_mlp_sessions_configure_each_model_on_its_own_training_split():
    from wsmap.learn import MLPConfig, train_mlp_sessions

    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, size=(60, 4))
    Y = (X[:, :2] > 0).astype(np.float32)
    mlp = MLPConfig(n_inputs=4, n_outputs=2, hidden=[5])
    config = TrainConfig(max_epochs=3, seed=10)
    results = train_mlp_sessions(mlp, X, Y, config, 2)
    stacked = train_mlp_sessions(mlp, X, Y, config, 2, stacked=True)
    for s, (one, both) in enumerate(zip(results, stacked)):
        train_rows = X[split_indices(len(X), config.fractions, 10 + s).train]
        np.testing.assert_array_equal(one.model.training_range.low, train_rows.min(axis=0))
        np.testing.assert_array_equal(one.model.training_range.high, train_rows.max(axis=0))
        assert one.model.n_subspaces == 1 and both.model.n_subspaces == 2 and both.session == s
        # a stacked run starts each session where the sequential run does (its own split's
        # ranges and stats), so Rprop, elementwise, trains them alike
        torch.testing.assert_close(one.model.input_mean[0], both.model.input_mean[s])
        np.testing.assert_allclose(one.history.loss, both.history.loss, rtol=1e-5)


def test_crossentropy_pos_weight_known_values_and_refusals():
    import math as _m

    from wsmap.learn.training import TrainConfig, make_loss

    out = torch.zeros(2, 2)
    t = torch.tensor([[1.0, 0.0], [1.0, 1.0]])
    # at logit 0 every term is log 2; a positive's term is weighted: (3 w + 1) / 4 log 2
    assert float(make_loss("crossentropy", 20)(out, t)) == pytest.approx((3 * 20 + 1) / 4 * _m.log(2))
    assert float(make_loss("crossentropy", None)(out, t)) == pytest.approx(_m.log(2))
    with pytest.raises(ValueError, match="pos_weight must be a positive number or None, got -1"):
        make_loss("crossentropy", -1)
    with pytest.raises(ValueError, match="pos_weight weighs the positive targets of crossentropy, not of loss 'mse'"):
        TrainConfig(loss="mse", pos_weight=2.0)
    # left out of to_dict when unset: the settings hashes of runs made before it stay the same
    assert "pos_weight" not in TrainConfig().to_dict()
    tc = TrainConfig(optimizer="adam", loss="crossentropy", batch_size=4, pos_weight=5)
    assert TrainConfig.from_dict(tc.to_dict()) == tc and tc.to_dict()["pos_weight"] == 5.0
