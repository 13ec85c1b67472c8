import hashlib
import json
import math
import re
import zipfile

import numpy as np
import pytest
import yaml

from wsmap import datasets
from wsmap import workspace as ws
from wsmap.datasets import labels as labels_module
from wsmap.datasets import store
from wsmap.kinematics import DHRobot, rpy2r
from wsmap.paper.specs import PAPER_SPECS, STARTS_STUDY_SPEC, TABLE3_RPY

P = PAPER_SPECS

# (features, label columns, training samples) of every paper spec
EXPECTED = {
    "sec61": (84, 1323, 100_000),
    "sec62": (84, 9261, 100_000),
    "table1_r3_step1": (30, 27, 60_000),
    "table1_r3_step05": (36, 125, 60_000),
    "table1_r3_block5": (84, 1323, 60_000),
    "table1_r3_crop3087": (84, 3087, 30_000),
    "table1_r3_full": (84, 9261, 15_000),
    "table1_so3_pi3": (42, 343, 60_000),
    "table1_so3_pi8": (72, 4913, 15_000),
    "table1_so3_pi10": (84, 9261, 15_000),
    "table2": (84, 1323, 60_000),
    "table3_subspace": (84, 1323, 15_000),
    "table3_workspace": (84, 1323, 15_000),
    "table3_nosubspace": (84, 1323, 15_000),
}


def small(key, n, **changes):
    return datasets.scaled(P[key], n).replace(**changes)


# --------------------------------------------------------------------------- specs
def test_every_paper_experiment_has_a_spec():
    assert set(P) == set(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_paper_spec_layout(name):
    spec = P[name]
    f, n, samples = EXPECTED[name]
    assert (spec.n_features, spec.n_nodes, spec.samples) == (f, n, samples)
    names = datasets.feature_names(spec)
    assert len(names) == f and len(set(names)) == f
    assert names[:3] == ["d_1", "d_2", "d_3"] and names[17] == "alpha_6"
    assert names[-3:] == (["r_1", "r_2", "r_3"] if spec.scope == "R3" else ["p_1", "p_2", "p_3"])
    assert datasets.spec_nodes(spec).shape == (n, 3)
    t = datasets.test_spec(spec)
    assert (t.samples, t.stream, t.seed, t.n_nodes, t.n_features) == (1000, "test", spec.seed, n, f)
    # the paper's convention, and exact labels wherever the arms are spherical-wrist
    assert spec.convention == "paper"
    assert spec.method == ("numerical" if spec.family == "arbitrary_6dof" else "exact")


def test_paper_selections():
    assert P["sec61"].select == (5292, 6615)
    assert P["table1_r3_crop3087"].select == (5292, 8379)
    z = datasets.spec_nodes(P["sec61"])[:, 2]
    np.testing.assert_allclose(np.unique(z), [0.2, 0.3, 0.4], atol=1e-12)
    assert P["table1_so3_pi8"].fixed == (1.0, 0.0, 0.0) and P["table1_so3_pi10"].fixed == (0.5, 0.5, 0.5)
    assert P["table3_workspace"].fixed == "random" and P["table3_nosubspace"].fixed == TABLE3_RPY
    assert len({s.seed for s in P.values()}) == len(P)  # experiments do not share arms


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_spec_round_trips_through_yaml(name):
    spec = P[name]
    text = yaml.safe_dump({"datasets": {name: spec.to_dict()}})
    back = datasets.DatasetSpec.from_dict(yaml.safe_load(text)["datasets"][name])
    assert back == spec and back.to_dict() == spec.to_dict()
    assert datasets.DatasetSpec.from_dict(datasets.test_spec(spec).to_dict()) == datasets.test_spec(spec)


@pytest.mark.parametrize(
    "changes, message",
    [
        (dict(family="scara"), "unknown family 'scara'; choose one of spherical_wrist, arbitrary_6dof, puma560"),
        (dict(scope="SE3"), "unknown scope 'SE3'; choose one of R3, SO3"),
        (dict(convention="zyx"), "unknown convention 'zyx'; choose one of paper, standard"),
        (dict(method="magic"), "unknown method 'magic'; choose one of exact, numerical"),
        (dict(lo=1.0, hi=-1.0), "empty or invalid grid"),
        (dict(step=0.0), "step must be positive"),
        (dict(select=(10, 10)), "empty node selection [10, 10)"),
        (dict(select=(0, 10_000)), "node selection [0, 10000) runs past the grid's 9261 nodes"),
        (dict(select="some"), "select must be 'all' or [start, stop]"),
        (dict(samples=0), "samples must be at least 1, got 0"),
        (dict(samples=2.5), "samples must be an integer"),
        (dict(family="arbitrary_6dof"), "method 'exact' needs arms of the spherical-wrist family"),
        (dict(fixed="sideways"), "fixed must be 3 numbers or 'random'"),
        (dict(fixed=(0.0, 1.0)), "fixed must be 3 finite numbers or 'random'"),
        (dict(tol=0.0), "tol must be positive"),
        (dict(starts=0), "starts must be at least 1"),
        (dict(beta=-1.0), "beta must be positive"),
        (dict(stream="val"), "unknown stream 'val'"),
        (dict(name=""), "name must be a non-empty string"),
    ],
)
def test_bad_specs(changes, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        P["sec61"].replace(**changes)


def test_hand_written_yaml_takes_plain_numbers():
    text = """
name: table1_so3_pi10
scope: SO3
lo: 0
hi: 6.283185307179586
step: 0.3141592653589793
fixed: [0.5, 0.5, 0.5]
convention: paper
tol: 1e-10
samples: 15000
seed: 108
"""
    # YAML reads 1e-10 as a string: a plain numeral is accepted
    assert datasets.DatasetSpec.from_dict(yaml.safe_load(text)) == P["table1_so3_pi10"]
    # expressions are not evaluated (the spec takes plain numbers)
    with pytest.raises(ValueError, match=re.escape("step must be a number, got the string 'pi/10'")):
        P["sec61"].replace(step="pi/10")


def test_bad_spec_dicts():
    d = P["sec61"].to_dict()
    with pytest.raises(ValueError, match="unknown dataset spec field"):
        datasets.DatasetSpec.from_dict({**d, "sample": 5})
    d.pop("name")
    with pytest.raises(ValueError, match="needs a name"):
        datasets.DatasetSpec.from_dict(d)
    with pytest.raises(ValueError, match="already a test spec"):
        datasets.test_spec(datasets.test_spec(P["sec61"]))


# --------------------------------------------------------------------------- features
def test_features_for_layout():
    spec = P["table1_r3_step05"]
    arms, _ = datasets.draw_samples(spec, 4)
    X = datasets.features_for(arms, spec)
    assert X.shape == (4, 36) and X.dtype == np.float64
    sl = datasets.feature_slices(spec)
    np.testing.assert_array_equal(X[:, sl["d"]], arms.d)
    np.testing.assert_array_equal(X[:, sl["alpha"]], arms.alpha)
    np.testing.assert_allclose(X[0, sl["nx"]], [-1, -0.5, 0, 0.5, 1], atol=1e-15)
    np.testing.assert_array_equal(X[:, sl["fixed"]], 0.0)
    X2 = datasets.features_for(arms, spec, fixed=(0.1, 0.2, 0.3))
    np.testing.assert_array_equal(X2[:, -3:], [[0.1, 0.2, 0.3]] * 4)
    with pytest.raises(ValueError, match="fixed='random'"):
        datasets.features_for(arms, P["table3_workspace"])
    with pytest.raises(ValueError, match="6-joint arms"):
        datasets.features_for(DHRobot(np.zeros((2, 5)), np.zeros((2, 5)), np.zeros((2, 5))), spec)


def test_uniform_rotations_and_angle_round_trip():
    rng = np.random.default_rng(0)
    R = datasets.uniform_rotations(20_000, rng)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0)
    # Haar measure: E[R] = 0, and the rotation angle has density (1 - cos t) / pi (mean pi/2 + 2/pi)
    assert np.abs(R.mean(axis=0)).max() < 0.02
    angle = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert abs(angle.mean() - (np.pi / 2 + 2 / np.pi)) < 0.02
    rpy = datasets.rotation_to_rpy(R)
    assert rpy.min() >= 0 and rpy.max() < 2 * np.pi
    np.testing.assert_allclose(rpy2r(rpy), R, atol=1e-12)
    # the Table 3 orientation is written the same way
    np.testing.assert_allclose(datasets.rotation_to_rpy(rpy2r(np.array(TABLE3_RPY))), TABLE3_RPY, atol=1e-12)


# --------------------------------------------------------------------------- build and load
@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Small builds of a few kinds of spec: R3 block, SO3, random orientation, PUMA560."""
    root = tmp_path_factory.mktemp("data")
    specs = {
        "r3": small("sec61", 60),
        "so3": small("table1_so3_pi3", 40),
        "random": small("table3_workspace", 40),
        "puma": small("table3_workspace", 10, family="puma560", name="puma_random"),
        "so3_random": small("table1_so3_pi3", 20, fixed="random", convention="standard", name="so3r"),
    }
    return {k: (s, datasets.build_dataset(s, root / f"{k}.npz", chunk=7, progress=False)) for k, s in specs.items()}


@pytest.mark.parametrize("kind", ["r3", "so3", "random", "puma", "so3_random"])
def test_built_file_shapes(built, kind):
    spec, path = built[kind]
    ds = datasets.load_dataset(path, expect_spec=spec)
    assert ds.spec == spec and len(ds) == spec.samples
    assert ds.features.shape == (spec.samples, spec.n_features) and ds.features.dtype == np.float64
    assert ds.labels.shape == (spec.samples, spec.n_nodes) and ds.labels.dtype == bool
    assert ds.labels_packed.shape == (spec.samples, math.ceil(spec.n_nodes / 8))
    assert ds.header["wsmap_version"] and ds.header["labels_shape"] == [spec.samples, spec.n_nodes]
    assert ds.feature_names == datasets.feature_names(spec)
    assert 0 < ds.labels.mean() < 1


def _rebuild_nodes(X, spec):
    """The labelled nodes from the axis columns alone: cartesian product, first axis fastest."""
    sl = datasets.feature_slices(spec)
    zz, yy, xx = np.meshgrid(X[sl["nz"]], X[sl["ny"]], X[sl["nx"]], indexing="ij")
    nodes = np.stack([xx.ravel(), yy.ravel(), zz.ravel()], axis=-1)
    return nodes[datasets.node_slice(spec)]


@pytest.mark.parametrize("kind", ["r3", "so3", "random", "puma", "so3_random"])
def test_labels_recomputed_from_features(built, kind):
    spec, path = built[kind]
    ds = datasets.load_dataset(path)
    for i in (0, 3, spec.samples - 1):
        x = ds.features[i]
        arm = DHRobot(x[0:6], x[6:12], x[12:18])  # the stored DH columns, nothing else
        nodes = _rebuild_nodes(x, spec)
        fixed = x[-3:]
        if spec.scope == "R3":
            expected = ws.constant_orientation_map(arm, nodes, fixed, method="exact", convention=spec.convention)
        else:
            expected = ws.orientation_map(arm, nodes, fixed, method="exact", convention=spec.convention)
        np.testing.assert_array_equal(ds.labels[i], expected)


def test_random_orientation_is_per_sample(built):
    spec, path = built["random"]
    X = datasets.load_dataset(path).features
    rpy = datasets.fixed_from_features(X, spec)
    assert len(np.unique(rpy, axis=0)) == spec.samples
    assert rpy.min() >= 0 and rpy.max() < 2 * np.pi


def test_same_spec_gives_identical_bytes(tmp_path):
    spec = small("sec62", 25)
    a = datasets.build_dataset(spec, tmp_path / "a.npz", chunk=4, progress=False)
    b = datasets.build_dataset(spec, tmp_path / "b.npz", chunk=1000, progress=False)
    c = datasets.build_dataset(spec.replace(seed=spec.seed + 1), tmp_path / "c.npz", progress=False)
    assert a.read_bytes() == b.read_bytes()
    assert a.read_bytes() != c.read_bytes()
    fa, fc = datasets.load_dataset(a).features, datasets.load_dataset(c).features
    assert not np.any(np.all(fa[:, :18] == fc[:, :18], axis=1))
    assert [p.name for p in tmp_path.iterdir()] and all(not p.name.startswith(".") for p in tmp_path.iterdir())


def test_scaled_is_a_prefix():
    big, little = small("table3_workspace", 50), small("table3_workspace", 20)
    arms_b, fix_b = datasets.draw_samples(big)
    arms_l, fix_l = datasets.draw_samples(little)
    np.testing.assert_array_equal(datasets.features_for(arms_b, big, fix_b)[:20], datasets.features_for(arms_l, little, fix_l))


@pytest.mark.parametrize("name", ["sec61", "table3_workspace", "table3_nosubspace", "table1_so3_pi8"])
def test_test_sets_are_disjoint_from_training(name):
    spec = P[name]
    arms, fixed = datasets.draw_samples(spec, 2000)
    train = datasets.features_for(arms, spec, fixed)
    arms, fixed = datasets.draw_samples(datasets.test_spec(spec))
    test = datasets.features_for(arms, spec, fixed)
    assert test.shape[0] == 1000
    train_rows = {r.tobytes() for r in train[:, :18]}
    assert not any(r.tobytes() in train_rows for r in test[:, :18])
    if spec.fixed == "random":
        assert not set(map(bytes, train[:, -3:])) & set(map(bytes, test[:, -3:]))


def test_built_test_set_disjoint_from_built_training_set(tmp_path):
    spec = small("sec61", 300)
    train = datasets.load_dataset(datasets.build_dataset(spec, tmp_path / "train.npz", progress=False))
    test = datasets.load_dataset(datasets.build_dataset(datasets.test_spec(spec), tmp_path / "test.npz", progress=False))
    assert len(test) == 1000
    rows = {r.tobytes() for r in train.features[:, :18]}
    assert not any(r.tobytes() in rows for r in test.features[:, :18])


def test_interrupted_build_leaves_no_file(tmp_path, monkeypatch):
    spec = small("sec61", 20)
    real, calls = datasets.labels_for, []

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(store, "labels_for", failing)
    with pytest.raises(KeyboardInterrupt):
        datasets.build_dataset(spec, tmp_path / "x.npz", chunk=5, progress=False)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- refusing bad files
@pytest.fixture
def good_file(tmp_path):
    spec = small("table1_r3_step05", 30)
    return spec, datasets.build_dataset(spec, tmp_path / "good.npz", progress=False)


def test_missing_file(tmp_path):
    path = tmp_path / "nothing.npz"
    with pytest.raises(FileNotFoundError, match=re.escape(f"dataset file {path} does not exist")):
        datasets.load_dataset(path)


def test_truncated_file(good_file):
    _, path = good_file
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(datasets.DatasetError, match=re.escape(f"dataset file {path} is truncated or not a dataset file")):
        datasets.load_dataset(path)


def test_flipped_byte_is_corrupt(good_file):
    _, path = good_file
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 3] ^= 0xFF  # inside the compressed features
    path.write_bytes(bytes(raw))
    with pytest.raises(datasets.DatasetError, match=re.escape(f"dataset file {path} is corrupt")):
        datasets.load_dataset(path)


def test_checksum_mismatch_is_corrupt(good_file, tmp_path):
    # a well-formed zip whose labels were changed after the header was written
    _, path = good_file
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["labels_packed"] = arrays["labels_packed"].copy()
    arrays["labels_packed"][0, 0] ^= 0x80
    bad = tmp_path / "tampered.npz"
    np.savez_compressed(bad, **arrays)
    with pytest.raises(
        datasets.DatasetError,
        match=re.escape(f"dataset file {bad} is corrupt (SHA-256 of its arrays does not match its header)"),
    ):
        datasets.load_dataset(bad)


def test_foreign_npz_is_refused(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, features=np.zeros((2, 3)))
    with pytest.raises(datasets.DatasetError, match=re.escape(f"dataset file {path} is not a wsmap dataset")):
        datasets.load_dataset(path)


def test_mismatched_spec_is_refused(good_file):
    spec, path = good_file
    with pytest.raises(datasets.DatasetError, match=re.escape(
        f"dataset file {path} was built for a different spec (seed: file has {spec.seed}, expected {spec.seed + 1})"
    )):
        datasets.load_dataset(path, expect_spec=spec.replace(seed=spec.seed + 1))
    with pytest.raises(datasets.DatasetError, match="samples: file has 30, expected 31"):
        datasets.load_dataset(path, expect_spec=datasets.scaled(spec, 31))


def test_file_layout_is_documented(good_file):
    spec, path = good_file
    with zipfile.ZipFile(path) as zf:
        infos = zf.infolist()
        assert [i.filename for i in infos] == ["features.npy", "labels_packed.npy", "header.npy"]
        assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in infos)
    with np.load(path) as z:
        header = json.loads(z["header"].tobytes())
        digest = hashlib.sha256(z["features"].tobytes() + z["labels_packed"].tobytes()).hexdigest()
        labels = np.unpackbits(z["labels_packed"], axis=1, count=spec.n_nodes).astype(bool)
    assert header["sha256"] == digest and header["spec"] == spec.to_dict()
    np.testing.assert_array_equal(labels, datasets.load_dataset(path).labels)


# --------------------------------------------------------------------------- numerical labels
def test_numerical_labels_multistart_and_chunking(tmp_path):
    spec = small("table3_nosubspace", 4, step=1.0, select=None, starts=3, fixed=(0.0, 0.0, 0.0))
    a = datasets.build_dataset(spec, tmp_path / "a.npz", chunk=1, progress=False)
    b = datasets.build_dataset(spec, tmp_path / "b.npz", chunk=3, progress=False)
    assert a.read_bytes() == b.read_bytes()
    ds = datasets.load_dataset(a)
    arms = datasets.arms_from_features(ds.features)
    q0 = datasets.start_configurations(spec)
    assert q0.shape == (4, 3, 6) and np.all(q0[:, 0] == 0) and np.all(np.abs(q0[:, 1:]) <= np.pi)
    one = datasets.labels_for(arms, spec, q0=q0[:, :1])
    np.testing.assert_array_equal(ds.labels, datasets.labels_for(arms, spec, q0=q0))
    assert not np.any(one & ~ds.labels)  # more starts only add reachable nodes
    # every node solved by start k alone is labelled reachable
    for k in range(3):
        assert not np.any(datasets.labels_for(arms, spec, q0=q0[:, k : k + 1]) & ~ds.labels)


def test_numerical_labels_find_constructed_poses():
    # targets made by forward kinematics are reachable: multi-start LM must find (nearly) all
    spec = small("table3_nosubspace", 30, starts=9)
    arms, _ = datasets.draw_samples(spec)
    rng = np.random.default_rng(3)
    q = rng.uniform(-np.pi, np.pi, (30, 6))
    T = arms.fkine(q)
    rpy = datasets.rotation_to_rpy(T[:, :3, :3])
    # under the paper convention the tested position is R·p, so ask for p = Rᵀ·t
    p = np.einsum("bji,bj->bi", T[:, :3, :3], T[:, :3, 3])
    found = np.array([datasets.labels_for(arms[i : i + 1], spec, fixed=rpy[i], nodes=p[i : i + 1])[0, 0] for i in range(30)])
    assert found.mean() >= 0.9


@pytest.mark.parametrize("family", ["arbitrary_6dof", "spherical_wrist", "general"])
def test_prefilter_never_rejects_a_reachable_pose(family):
    rng = np.random.default_rng(11)
    n = 5000
    if family == "general":  # negative lengths and large twists too
        arms = DHRobot(rng.uniform(-1, 1, (n, 6)), rng.uniform(-1, 1, (n, 6)), rng.uniform(-4, 4, (n, 6)))
    else:
        arms, _ = datasets.draw_samples(P["table3_nosubspace"].replace(family=family, method="numerical"), n)
    T = arms.fkine(rng.uniform(-np.pi, np.pi, (n, 6)))
    assert datasets.possibly_reachable(arms, T, margin=0.0).all()
    # and it does reject: the same poses pushed 3 m up are out of reach of every arm here
    T[:, 2, 3] += 3.0 + np.abs(arms.d).sum(axis=1) + np.abs(arms.a).sum(axis=1)
    assert not datasets.possibly_reachable(arms, T).any()


def test_prefilter_does_not_change_numerical_labels():
    # spherical-wrist arms on the 125-node grid: positives, and far nodes the filter rules out
    spec = small("table1_r3_step05", 4, method="numerical", starts=2)
    arms, fixed = datasets.draw_samples(spec)
    with_filter = datasets.labels_for(arms, spec, fixed)
    without = datasets.labels_for(arms, spec, fixed, prefilter=False)
    np.testing.assert_array_equal(with_filter, without)
    assert with_filter.any()
    T = ws.target_poses(datasets.spec_nodes(spec), (0.0, 0.0, 0.0))
    possible = datasets.possibly_reachable(DHRobot(arms.d[:, None], arms.a[:, None], arms.alpha[:, None]), T)
    assert 0 < possible.mean() < 0.5 and not np.any(with_filter & ~possible)


def test_starts_recall_small():
    rows = datasets.starts_recall(STARTS_STUDY_SPEC, n_poses=100, counts=(1, 5), seed=2)
    assert [r["starts"] for r in rows] == [1, 5]
    # q0 = 0 alone misses many reachable poses of arbitrary arms; 5 starts find nearly all
    assert rows[0]["recall"] < 0.9 and rows[1]["recall"] > 0.9


def test_half_turn_success_is_rejected():
    # pose_error vanishes at a half turn: an LM "success" there must not become a label
    from wsmap.kinematics import rotz

    arms, _ = datasets.draw_samples(small("table3_nosubspace", 4))
    q = np.full((4, 6), 0.3)
    T = arms.fkine(q)
    T[1, :3, :3] = T[1, :3, :3] @ rotz(np.pi)  # same position, orientation off by pi
    T[2, :3, 3] += 2e-6  # beyond FK_CHECK_TOL in position
    ok = labels_module.fk_confirmed(arms, T, q, np.array([True, True, True, False]))
    np.testing.assert_array_equal(ok, [True, False, False, False])
    one = DHRobot(arms.d[0], arms.a[0], arms.alpha[0])  # one arm for every target
    T0 = one.fkine(np.stack([q[0], q[0] + 0.1]))
    np.testing.assert_array_equal(labels_module.fk_confirmed(one, T0, np.stack([q[0], q[0]]), np.ones(2, bool)),
                                  [True, False])


def test_labels_run_the_paper_solver_per_arm():
    # solve_confirmed groups pairs by arm and calls the solver "paper" once per arm: the same answer
    # as the paper's LM on each pair alone (ikine_LM, one arm per target), confirmed by FK
    from wsmap.kinematics import ikine_LM

    spec = small("table3_nosubspace", 3)
    arms, _ = datasets.draw_samples(spec)
    rng = np.random.default_rng(4)
    b_idx = np.array([2, 0, 2, 1, 0, 2, 1, 1])
    q = rng.uniform(-np.pi, np.pi, (len(b_idx), 6))
    T = DHRobot(arms.d[b_idx], arms.a[b_idx], arms.alpha[b_idx]).fkine(q)
    T[5, :3, 3] += 10.0  # out of reach
    q0 = rng.uniform(-np.pi, np.pi, (3, 6))
    ok = labels_module.solve_confirmed(arms, b_idx, T, q0, spec)
    pairs = DHRobot(arms.d[b_idx], arms.a[b_idx], arms.alpha[b_idx])
    ref = ikine_LM(pairs, T, q0=q0[b_idx], tol=spec.tol, ilimit=spec.ilimit, rlimit=spec.rlimit)
    np.testing.assert_array_equal(ok, labels_module.fk_confirmed(pairs, T, ref.q, ref.success))
    assert not ok[5] and ok.sum() >= 3
    with pytest.raises(ValueError, match="^tol must be at least 1e-14"):
        datasets.labels_for(arms, spec.replace(tol=1e-15))


def test_audit_small():
    row = datasets.audit_labels(P["table1_r3_step05"], n_arms=4, seed=1)
    assert row["pairs"] == 4 * 125 and row["nodes"] == 125
    assert row["false_negatives"] + row["false_positives"] == round((1 - row["agreement"]) * row["pairs"])
    assert row["false_positives"] == 0  # LM can only fail to find a solution, not invent one
    assert 0 <= row["fn_rate"] <= 1
    with pytest.raises(ValueError, match="no exact labels"):
        datasets.audit_labels(P["table3_nosubspace"], n_arms=2)
    rows = datasets.audit_table([P["table1_r3_step1"]], n_arms=2)
    assert len(rows) == 1 and rows[0]["spec"] == "table1_r3_step1"


def test_starts_study_small():
    spec = P["table3_nosubspace"].replace(step=1.0, select=None, fixed=(0.0, 0.0, 0.0))
    rows = datasets.starts_study(spec, n_arms=2, counts=(1, 2, 3), progress=False)
    assert [r["starts"] for r in rows] == [1, 2, 3]
    reach = [r["reachable"] for r in rows]
    assert reach == sorted(reach) and sum(r["new"] for r in rows) == reach[-1]


def test_build_by_name(tmp_path):
    # what `wsmap data build table1_r3_step1 --samples 5 --test-samples 3 --out cli.npz` runs
    out = tmp_path / "cli.npz"
    written = datasets.build_dataset_files("table1_r3_step1", out, samples=5, test_samples=3, catalogue=P, progress=False)
    assert written == [out, tmp_path / "cli.test.npz"]
    ds = datasets.load_dataset(out, expect_spec=datasets.scaled(P["table1_r3_step1"], 5))
    assert ds.labels.shape == (5, 27)
    assert len(datasets.load_dataset(written[1], expect_spec=datasets.test_spec(P["table1_r3_step1"], 3))) == 3
    assert not hasattr(datasets, "main")  # the command line is `wsmap data`
