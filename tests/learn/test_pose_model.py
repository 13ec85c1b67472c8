"""The pose-conditioned network of RAM's query (wsmap.learn.pose_model)."""

import numpy as np
import pytest
import torch

from wsmap import datasets as ds
from wsmap.learn import ModelFileError, TrainConfig
from wsmap.learn import pose_model as pm
from wsmap.learn.training_range import ExtrapolationError

SMALL = pm.PoseModelConfig(encoder=(32,), latent=16, decoder=(32, 32), frequencies=2)


@pytest.fixture(scope="module")
def shards(tmp_path_factory):
    torch.set_num_threads(1)
    out = tmp_path_factory.mktemp("pose_shards")
    return out, pm.build_pose_shards(out, (5, 6, 7), 1, 4, random=30, geodesics=3, per_geodesic=4)


@pytest.fixture(scope="module")
def trained(shards):
    tc = TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 3e-3}, loss="crossentropy", batch_size=4,
                     max_epochs=80, max_fail=1000, fractions=(1.0, 0.0, 0.0), seed=0)
    return pm.fit_pose_model(shards[1], SMALL, tc, seed=0)


def _poses(raw):
    T = np.zeros(raw.shape[:-1] + (4, 4))
    x, y = raw[..., 3:6], raw[..., 6:9]
    T[..., :3, 0], T[..., :3, 1], T[..., :3, 2], T[..., :3, 3], T[..., 3, 3] = x, y, np.cross(x, y), raw[..., :3], 1
    return T


def test_inputs_shapes_and_padding():
    m5 = ds.sample_morphologies(2, 5, seed=3)
    A = pm.ram_inputs(m5)
    assert A.shape == (2, pm.MORPH_INPUTS)
    slots = A.reshape(2, 8, 5)
    assert np.all(slots[:, 5:7] == 0)  # joints 6 and 7 missing
    assert np.all(slots[:, [0, 1, 2, 3, 4, 7], 4] == 1)  # present flags, the end effector in slot 7
    np.testing.assert_allclose(slots[:, 7, 2:4], m5[:, 5, 1:3])  # its (a, d)
    np.testing.assert_allclose(np.arctan2(slots[:, :5, 0], slots[:, :5, 1]), m5[:, :5, 0], atol=1e-12)
    T, _ = ds.random_poses(m5[0], 7, seed=0)
    raw = pm.pose_inputs(T)
    assert raw.shape == (7, pm.POSE_INPUTS)
    np.testing.assert_allclose(_poses(raw), T, atol=1e-12)  # the 6-D representation keeps the whole pose


def test_shards_hold_exact_labels_and_resume(shards):
    out, sh = shards
    assert [s.morphs.shape[1] - 1 for s in sh] == [5, 6, 7]
    for s in sh:
        assert s.poses.shape == (4, 42, pm.POSE_INPUTS) and s.labels.shape == (4, 42)
    s6 = sh[1]
    again = ds.ik_labels(s6.morphs[0], _poses(s6.poses[0, 30:]))  # the boundary part, labelled again
    np.testing.assert_array_equal(again, s6.labels[0, 30:])
    assert s6.labels[0, 30:33].all()  # each geodesic starts at a reachable FK pose
    reloaded = pm.build_pose_shards(out, (6,), 1, 4, random=30, geodesics=3, per_geodesic=4)[0]
    np.testing.assert_array_equal(reloaded.labels, s6.labels)
    assert reloaded.cpu_seconds == s6.cpu_seconds  # loaded, not rebuilt


def test_corrupt_shard_is_rebuilt(tmp_path):
    kw = dict(random=5, geodesics=1, per_geodesic=2)
    first = pm.build_pose_shards(tmp_path, (6,), 1, 1, **kw)[0]
    path = tmp_path / "pose_d6_s0_1.npz"
    path.write_bytes(path.read_bytes()[:200])
    second = pm.build_pose_shards(tmp_path, (6,), 1, 1, **kw)[0]
    np.testing.assert_array_equal(first.labels, second.labels)  # the same streams give the same labels


def test_encoder_split_equals_full_forward():
    torch.manual_seed(0)
    model = pm.PoseMapModel(SMALL).eval()
    m = ds.sample_morphologies(3, 6, seed=1)
    raw = np.stack([pm.pose_inputs(ds.random_poses(mi, 5, seed=i)[0]) for i, mi in enumerate(m)])
    A = torch.as_tensor(pm.ram_inputs(m), dtype=torch.float32)
    R = torch.as_tensor(raw, dtype=torch.float32)
    with torch.no_grad():
        split = model.logits_at(A, R, chunk=2)
        # the same network with its first decoder layer as one layer on [latent, pose features]
        z = model.encode(A)
        W = torch.cat([model.dec_latent.weight, model.dec_pose.weight], dim=1)
        x = torch.cat([z[:, None, :].expand(-1, 5, -1), model.pose_features(R)], dim=-1)
        full = model.decoder(x @ W.T + model.dec_latent.bias)[..., 0]
        rows = model(torch.cat([A, R.reshape(3, -1)], dim=1))
        shared = model.logits_at(A, R[0])
    torch.testing.assert_close(split, full, rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(rows, split)
    torch.testing.assert_close(shared[0], split[0])


def test_training_lowers_loss_and_beats_constants(shards, trained):
    model, result = trained
    loss = result.history.loss
    assert loss[-1] < 0.8 * loss[0]
    P = [(pm.predict_poses(model, s.morphs, _poses(s.poses)), s.labels) for s in shards[1]]
    pred, truth = np.concatenate([p for p, _ in P]), np.concatenate([t for _, t in P])
    f = ds.ram_f1(pred, truth)[0]
    assert f > ds.ram_f1(np.ones_like(truth), truth)[0] + 0.05
    assert f > ds.ram_f1(np.zeros_like(truth), truth)[0] + 0.05
    one = pm.predict_pose_logits(model, shards[1][0].morphs[0], _poses(shards[1][0].poses[0]))
    assert one.shape == (42,) and one.dtype == np.float32


def test_file_round_trip_and_corruption(trained, tmp_path):
    model, _ = trained
    path = pm.save_pose_model(model, tmp_path / "pose.pt", extra={"note": "test"})
    back, meta = pm.load_pose_model(path)
    m = ds.sample_morphologies(2, 7, seed=5)
    T, _ = ds.random_poses(m[0], 9, seed=1)
    np.testing.assert_array_equal(pm.predict_pose_logits(back, m, T), pm.predict_pose_logits(model, m, T))
    assert back.threshold == model.threshold and back.dofs == (5, 6, 7) and meta["extra"] == {"note": "test"}
    payload = torch.load(path, weights_only=True)
    payload["threshold"] = 0.123  # edited without a new checksum
    torch.save(payload, tmp_path / "tampered.pt")
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        pm.load_pose_model(tmp_path / "tampered.pt")
    data = bytearray(path.read_bytes())
    (tmp_path / "cut.pt").write_bytes(bytes(data[: len(data) // 2]))
    with pytest.raises(ModelFileError, match="cannot load model .*cut.pt"):
        pm.load_pose_model(tmp_path / "cut.pt")
    with pytest.raises(ModelFileError, match="no such file"):
        pm.load_pose_model(tmp_path / "missing.pt")


def test_refusals():
    model = pm.PoseMapModel(SMALL, dofs=(6, 7)).eval()
    m5 = ds.sample_morphologies(1, 5, seed=0)[0]
    T = np.broadcast_to(np.eye(4), (3, 4, 4))
    with pytest.raises(ExtrapolationError, match=r"^the arm has 5 joints; the pose model was trained on arms of 6, 7"):
        pm.predict_poses(model, m5, T)
    with pytest.raises(ValueError, match="RAM's table"):
        pm.predict_poses(model, np.zeros((10, 3)), T)
    bad = ds.sample_morphologies(1, 6, seed=0)[0]
    bad[0, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        pm.predict_poses(model, bad, T)
    m6 = ds.sample_morphologies(2, 6, seed=0)
    with pytest.raises(ValueError, match="one set per arm: 3 sets for 2 arms"):
        pm.predict_poses(model, m6, np.broadcast_to(np.eye(4), (3, 5, 4, 4)))
    with pytest.raises(ValueError, match="poses must have shape"):
        pm.predict_poses(model, m6[0], np.eye(4))
    with pytest.raises(ValueError, match="threshold must lie in"):
        pm.predict_poses(model, m6[0], T, threshold=1.5)
    with pytest.raises(ValueError, match="dofs must be among"):
        pm.build_pose_shards("/nonexistent", (4,), 1, 1)
    with pytest.raises(ValueError, match="per_geodesic must be an integer of at least 2"):
        pm.build_pose_shards("/nonexistent", (6,), 1, 1, per_geodesic=1)
    with pytest.raises(ValueError, match="encoder must be a non-empty list"):
        pm.PoseModelConfig(encoder=())
    with pytest.raises(TypeError, match="needs a PoseMapModel"):
        pm.save_pose_model(torch.nn.Linear(1, 1), "/tmp/x.pt")


def test_training_set_with_poses_returns_what_it_labelled():
    """`with_poses`: the poses themselves (their inputs are `poses`), the same labels, and the FK
    poses labelled without IK: a quarter of a 5-joint arm's random poses, none of a 6-joint arm's."""
    for dof, known_share in ((5, 0.25), (6, 0.0)):
        m = ds.sample_morphologies(2, dof, seed=5)
        raw, labels = pm.pose_training_set(m, 12, 2, 3, seed=4)
        raw2, labels2, T, known = pm.pose_training_set(m, 12, 2, 3, seed=4, with_poses=True)
        np.testing.assert_array_equal(raw2, raw)
        np.testing.assert_array_equal(labels2, labels)
        assert T.shape == (2, 18, 4, 4) and known.shape == (2, 18)
        np.testing.assert_array_equal(pm.pose_inputs(T), raw)
        assert labels[known].all() and not known[:, 12:].any()  # the boundary poses are all labelled by IK
        assert known[:, :12].sum(axis=1).max() <= 12 * known_share
        if dof == 5:
            assert known.any()
