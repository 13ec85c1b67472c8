"""The ``device`` setting: names, the clear error without a GPU, and CPU/GPU agreement (on a GPU only)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from wsmap.learn import MLPConfig, SubspaceMLP
from wsmap.learn.device import DeviceUnavailableError, check_device_name, resolve_device
from wsmap.learn.training import TrainConfig, split_indices, train, train_sessions

HAS_CUDA = torch.cuda.is_available()


def _data(n=120, f=6, m=9, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(0.0, 0.5, size=(n, f))
    Y = (X[:, :3].sum(1, keepdims=True) + 0.1 * rng.standard_normal((n, m)) > 0.75).astype(np.float32)
    return X, Y


def _model(X, seeds=(0,), hidden=(8, 7)):
    cfg = MLPConfig(n_inputs=X.shape[1], n_outputs=9, hidden=list(hidden), n_subspaces=len(seeds))
    return SubspaceMLP(cfg, seeds=list(seeds)).configure(X, seeds=list(seeds))


@pytest.mark.parametrize("name, expected", [("cpu", "cpu"), (" CPU ", "cpu"), (torch.device("cpu"), "cpu")])
def test_cpu_names(name, expected):
    assert resolve_device(name) == torch.device(expected)


def test_auto_is_the_gpu_when_present_else_the_cpu():
    assert resolve_device("auto") == torch.device("cuda" if HAS_CUDA else "cpu")
    assert resolve_device("AUTO").type == ("cuda" if HAS_CUDA else "cpu")


@pytest.mark.parametrize("bad", ["gpu", "mps", "", "cuda:x", "cuda0", None, 0, 1.5, ["cpu"], torch.device("meta")])
def test_bad_names_are_refused_with_the_choices(bad):
    with pytest.raises(ValueError) as e:
        resolve_device(bad, "params.yaml section 'x' device")
    msg = str(e.value)
    assert "params.yaml section 'x' device" in msg and "auto" in msg and "cpu" in msg and "cuda" in msg
    with pytest.raises(ValueError):
        check_device_name(bad)


def test_names_are_checked_without_a_gpu():
    assert check_device_name("CUDA") == "cuda" and check_device_name("cuda:1") == "cuda:1"


@pytest.mark.skipif(HAS_CUDA, reason="this machine has a GPU")
@pytest.mark.parametrize("name", ["cuda", "cuda:0", " Cuda "])
def test_cuda_without_a_gpu_is_a_clear_error_naming_the_setting(name):
    with pytest.raises(DeviceUnavailableError) as e:
        resolve_device(name, "params.yaml section 'sec61_subspace' device")
    msg = str(e.value)
    assert isinstance(e.value, ValueError)
    assert "params.yaml section 'sec61_subspace' device" in msg and "CUDA" in msg and "auto" in msg


def test_train_config_checks_the_name_and_round_trips():
    with pytest.raises(ValueError, match="TrainConfig.device"):
        TrainConfig(device="gpu")
    cfg = TrainConfig(device="CPU")
    assert cfg.device == "cpu"
    assert TrainConfig.from_dict(cfg.to_dict()) == cfg
    assert TrainConfig(device=torch.device("cpu")).device == "cpu"
    assert TrainConfig().device is None and TrainConfig.from_dict({"optimizer": "rprop"}).device is None
    assert TrainConfig(device="cuda").device == "cuda"  # presence is checked when training starts


@pytest.mark.skipif(HAS_CUDA, reason="this machine has a GPU")
def test_training_on_cuda_without_a_gpu_fails_before_any_work():
    X, Y = _data()
    model = _model(X)
    before = [p.detach().clone() for p in model.parameters()]
    with pytest.raises(DeviceUnavailableError, match="TrainConfig.device"):
        train(model, X, Y, TrainConfig(max_epochs=3, device="cuda"))
    assert all(torch.equal(a, b) for a, b in zip(before, model.parameters()))
    with pytest.raises(DeviceUnavailableError):
        train_sessions(lambda seeds: _model(X, seeds), X, Y, TrainConfig(max_epochs=2, device="cuda"), sessions=2)


def test_cpu_and_auto_train_as_before():
    X, Y = _data()
    split = split_indices(len(X), seed=0)
    runs = {}
    for device in (None, "cpu", "auto" if not HAS_CUDA else "cpu"):
        res = train(_model(X), X, Y, TrainConfig(max_epochs=6, max_fail=100, device=device), split=split)
        runs[device] = res.history.loss
        assert next(res.model.parameters()).device.type == "cpu"
    assert len({repr(v) for v in runs.values()}) == 1  # bit for bit


@pytest.mark.skipif(HAS_CUDA, reason="this machine has a GPU")
def test_prediction_and_runtime_refuse_cuda_before_any_work(tmp_path):
    from wsmap.learn.predictor import predict_maps, predict_maps_from_file
    from wsmap.paper.runtime import runtime_comparison
    from wsmap import robots

    # the file does not exist: the device error comes first
    with pytest.raises(DeviceUnavailableError):
        predict_maps_from_file(tmp_path / "missing.pt", robots.puma560(), device="cuda")
    X, _ = _data()
    with pytest.raises(DeviceUnavailableError):
        predict_maps(_model(X), robots.puma560(), device="cuda")
    with pytest.raises(DeviceUnavailableError, match="runtime_comparison device"):
        runtime_comparison([1.0], methods=["network"], repeats=1, warmup=0, device="cuda")


def test_runtime_records_the_device():
    from wsmap.paper.runtime import runtime_comparison

    df = runtime_comparison([1.0], methods=["classical_exact", "network"], repeats=2, warmup=0, device="cpu")
    assert set(df.device) == {"cpu"} and (df.mean_s > 0).all()


# ------------------------------------------------------------------------------------ on a GPU


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_cpu_and_cuda_training_agree(tmp_path):
    """The same small Rprop run on the CPU and on the GPU: same start (built on the CPU), same
    losses and weights to float32 rounding; the stacked sessions too; the GPU model saves and
    loads on the CPU and predicts the same."""
    from wsmap.learn.files import load, save

    X, Y = _data(n=300)
    split = split_indices(len(X), seed=0)
    results = {}
    for device in ("cpu", "cuda"):
        results[device] = train(_model(X), X, Y, TrainConfig(max_epochs=15, max_fail=100, device=device), split=split)
    cpu, gpu = results["cpu"], results["cuda"]
    assert next(gpu.model.parameters()).device.type == "cuda"
    np.testing.assert_allclose(gpu.history.loss, cpu.history.loss, rtol=5e-3, atol=1e-5)
    np.testing.assert_allclose(gpu.history.val_loss, cpu.history.val_loss, rtol=5e-3, atol=1e-5)
    for a, b in zip(cpu.model.parameters(), gpu.model.parameters()):
        np.testing.assert_allclose(b.detach().cpu().numpy(), a.detach().numpy(), rtol=1e-3, atol=1e-4)
    s_cpu = cpu.model.score(X).numpy()
    s_gpu = gpu.model.score(X).cpu().numpy()
    np.testing.assert_allclose(s_gpu, s_cpu, rtol=1e-3, atol=1e-4)

    # stacked sessions run on the device as one model
    stacked = {}
    for device in ("cpu", "cuda"):
        stacked[device] = train_sessions(lambda seeds: _model(X, seeds), X, Y,
                                         TrainConfig(max_epochs=15, max_fail=100, device=device),
                                         sessions=3, stacked=True)
    assert next(stacked["cuda"][0].model.parameters()).device.type == "cuda"
    for a, b in zip(stacked["cpu"], stacked["cuda"]):
        np.testing.assert_allclose(b.history.loss, a.history.loss, rtol=5e-3, atol=1e-5)

    # a GPU-trained model file loads on the CPU
    path = save(gpu.model, tmp_path / "gpu.pt")
    back, _ = load(path, map_location="cpu")
    assert next(back.parameters()).device.type == "cpu"
    np.testing.assert_allclose(back.score(X).numpy(), s_gpu, rtol=1e-5, atol=1e-6)
    on_gpu, _ = load(path, map_location=resolve_device("cuda"))
    assert next(on_gpu.parameters()).device.type == "cuda"


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_runtime_network_on_cuda():
    from wsmap.paper.runtime import runtime_comparison

    df = runtime_comparison([1.0, 0.5], methods=["network"], repeats=3, warmup=1, device="cuda")
    assert set(df.device) == {"cuda"} and (df.mean_s > 0).all()
