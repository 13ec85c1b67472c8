"""wsmap.learn.morph_model: training with learn.train, file round trip, refusals (arm, grid,
orientation, file kind), the nearest-arm baseline, and ``wsmap map --method model`` on a URDF."""

import math
import os

import numpy as np
import pytest
import torch

import wsmap
from wsmap import cli, learn
from wsmap import workspace as ws
from wsmap.kinematics import from_dh
from wsmap.kinematics.morphology import MorphologyError, describe, morphology_distance
from wsmap.learn import morph_model as mm
from wsmap.learn.files import ModelFileError
from wsmap.learn.training_range import ExtrapolationError, ExtrapolationWarning
from wsmap.robots.morph import HOLD_OUT_RADIUS, MORPH6

rtbdata = pytest.importorskip("rtbdata")
IIWA_URDF = os.path.join(os.path.dirname(rtbdata.__file__), "xacro",
                         "kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf")


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    torch.set_num_threads(1)
    root = tmp_path_factory.mktemp("morph")
    sets = []
    for n in (6, 7):
        built, secs = mm.build_morph_shards(root, n, 2, 6, step=0.5, test_samples=4)
        assert len(built) == 3 and all(s > 0 for s in secs)
        again, secs = mm.build_morph_shards(root, n, 2, 6, step=0.5, test_samples=4)  # resumed: nothing rebuilt
        assert secs == [0.0, 0.0] and np.array_equal(again[1].labels, built[1].labels)
        sets += built[:2]
    tc = learn.TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 3e-3}, loss="crossentropy", batch_size=4,
                           lr_decay="cosine", max_epochs=15, max_fail=1000, fractions=(0.9, 0.1, 0.0))
    model, result = mm.fit_morph_model(sets, mm.MorphModelConfig(encoder=(32,), latent=16, decoder=(32,)), tc)
    path = mm.save_morph_model(model, root / "morph.pt")
    return model, result, sets, path


def test_training_lowers_the_loss_and_forward_is_the_nodes(trained):
    model, result, sets, _ = trained
    assert result.history.loss[-1] < result.history.loss[0]
    assert model.families == ("morph6", "morph7") and model.nodes.shape == (343, 3)
    X = torch.as_tensor(mm.morph_features(list(sets[0].features[:3, :42])), dtype=torch.float32)
    with torch.no_grad():
        assert torch.equal(model(X), model.logits_at(X, model.nodes))


def test_file_round_trip_and_its_errors(trained, tmp_path):
    model, _, _, path = trained
    back, meta = mm.load_morph_model(path)
    arm = wsmap.load("ur5e")
    nodes = ws.cartesian_grid(-1.5, 1.5, 0.25)
    assert np.array_equal(mm.predict_morph_map(back, arm, nodes), mm.predict_morph_map(model, arm, nodes))
    assert meta["format"] == mm.FORMAT and len(meta["dataset_specs"]) == 4
    # a flipped weight: the checksum refuses the file
    payload = torch.load(path, weights_only=True)
    payload["state_dict"]["decoder.1.bias"] += 1.0
    bad = tmp_path / "bad.pt"
    torch.save(payload, bad)
    with pytest.raises(ModelFileError, match="checksum mismatch"):
        mm.load_morph_model(bad)
    # a model file of another kind (a family map model)
    other = learn.SubspaceMLP(learn.MLPConfig(n_inputs=4, n_outputs=3, hidden=[2]))
    learn.save(other, tmp_path / "family.pt", training_data=np.zeros((2, 4)))
    with pytest.raises(ModelFileError, match="it is a 'wsmap.subspace_mlp' file \\(a family map model\\), not a "
                                             "morphology model"):
        mm.load_morph_model(tmp_path / "family.pt")
    with pytest.raises(ModelFileError, match="format tag 'wsmap.morph_model' is not 'wsmap.subspace_mlp'"):
        learn.load(path)
    (tmp_path / "junk.pt").write_bytes(b"not a model")
    with pytest.raises(ModelFileError, match="not a wsmap model file"):
        mm.load_morph_model(tmp_path / "junk.pt")


def test_refusals(trained):
    model = trained[0]
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.5)
    p = MORPH6.params_of(wsmap.load("ur5e"))
    p[12] = 0.9  # a_3 beyond the family's 0.7 m
    with pytest.warns(wsmap.robots.FamilyRangeWarning):
        long = MORPH6.arms(p, allow_extrapolation=True)
    with pytest.raises(ExtrapolationError, match="outside the model's training range \\(morph6, morph7\\): a_3 = 0.9 m"):
        mm.predict_morph_map(model, long, nodes)
    with pytest.warns(ExtrapolationWarning, match="a_3 = 0.9 m"):
        assert mm.predict_morph_map(model, long, nodes, allow_extrapolation=True).shape == (len(nodes),)
    with pytest.raises(ExtrapolationError, match="nodes lie outside the model's box"):
        mm.predict_morph_map(model, wsmap.load("ur5e"), ws.cartesian_grid(-2, 2, 0.5))
    with pytest.raises(ValueError, match="maps orientation rpy"):
        mm.predict_morph_map(model, wsmap.load("ur5e"), nodes, rpy=(0, 0, 0))
    with pytest.raises(ValueError, match="convention 'standard', not 'paper'"):
        mm.predict_morph_map(model, wsmap.load("ur5e"), nodes, convention="paper")
    slide = from_dh([0.3, 0, 0.1, 0, 0, 0], [0] * 6, [0, math.pi / 2, 0, 0, 0, 0], prismatic=[0, 0, 1, 0, 0, 0],
                    qlim=np.tile([-1.0, 1.0], (6, 1)), name="slide")
    with pytest.raises(MorphologyError, match="joint 3 is prismatic"):
        mm.predict_morph_map(model, slide, nodes)
    with pytest.raises(MorphologyError, match="has 8 joints"):
        mm.predict_morph_map(model, from_dh([0.1] * 8, [0.1] * 8, [0.5] * 8, name="eight"), nodes)


def test_nearest_arm_baseline_finds_the_arm_itself(trained):
    sets = trained[2]
    F = mm.morph_features(list(sets[0].features[:, :42]))
    maps, dist = mm.nearest_arm_maps(F, sets[0].labels, F[[2, 4]])
    assert np.array_equal(maps, sets[0].labels[[2, 4]]) and np.all(dist == 0)
    maps, dist = mm.nearest_arm_maps(F, sets[0].labels, describe(wsmap.load("ur5e")).features()[None])
    assert maps.shape == (1, 343) and dist[0] > HOLD_OUT_RADIUS


def test_fk_labels_are_each_arms_sampled_map_inside_its_search_labels(trained):
    """The FK-only experience: row i is arm i's fk_sampled_maps (seeded by (seed, i), whatever the
    other arms), and trains a model as the labels would (``labels=``), shapes checked."""
    sets = trained[2]
    ds = sets[0]
    y = mm.fk_labels(ds, samples=20_000, angle_tol=0.5, seed=1)
    assert y.shape == ds.labels.shape and y.dtype == bool and y.any()
    fam = wsmap.robots.FAMILIES[ds.spec.family]
    arm = fam.arms(ds.features[3, :ds.spec.n_arm_features])
    seed = int(np.random.SeedSequence([1, 3]).generate_state(1)[0])
    one = ws.fk_sampled_maps(arm, ds.spec.lo, ds.spec.hi, ds.spec.step, ds.spec.fixed, convention="standard",
                             samples=20_000, angle_tol=0.5, seed=seed)
    assert np.array_equal(y[3], one)
    # on this 0.5 m grid a cell's sample lies up to 0.25 m from its node: the cells overlap the
    # search labels without being inside them (tests/workspace/test_sampled_maps.py measures 0.2 m)
    assert np.sum(y & ds.labels) > 0
    tc = learn.TrainConfig(optimizer="adam", optimizer_kwargs={"lr": 3e-3}, loss="crossentropy", batch_size=4,
                           max_epochs=2, max_fail=1000, fractions=(0.9, 0.1, 0.0))
    small = mm.MorphModelConfig(encoder=(8,), latent=4, decoder=(8,))
    model, _ = mm.fit_morph_model(sets[:1], small, tc, labels=[y])
    assert model.nodes.shape == (343, 3)
    with pytest.raises(ValueError, match="labels: one array per dataset, got 2 for 1 datasets"):
        mm.fit_morph_model(sets[:1], small, tc, labels=[y, y])
    with pytest.raises(ValueError, match=r"labels for dataset .* must have shape \(6, 343\), got \(6, 3\)"):
        mm.fit_morph_model(sets[:1], small, tc, labels=[y[:, :3]])


def test_cli_map_of_a_urdf_arm_and_its_refusals(trained, tmp_path, capsys):
    model, _, _, path = trained
    out = tmp_path / "iiwa.npz"

    def args(model_file=path, rpy=(math.pi, 0, 0), hi=1.5):
        return ["map", "--urdf", IIWA_URDF, "--ee", "tool0", "--method", "model", "--model", str(model_file),
                "--convention", "standard", "--rpy", *map(str, rpy), "--lo", "-1.5", "--hi", str(hi), "--step",
                "0.25", "--quiet", "--out", str(out)]

    assert cli.main(args()) == 0
    with np.load(out) as f:
        maps = [f[k] for k in f.files if f[k].dtype == bool]
    want = mm.predict_morph_map(model, wsmap.from_urdf(IIWA_URDF, ee_link="tool0"), ws.cartesian_grid(-1.5, 1.5, 0.25))
    assert any(m.size == want.size and np.array_equal(m.reshape(-1), want) for m in maps)
    capsys.readouterr()
    for argv, message in [(args(rpy=(0, 0, 0)), "the morphology model maps orientation rpy"),
                          (args(hi=2.0), "outside the model's box"),
                          (args(model_file=tmp_path / "other.pt"), "format tag 'someone.else'")]:
        torch.save({"format": "someone.else"}, tmp_path / "other.pt")
        code = cli.main(argv)
        err = capsys.readouterr().err
        assert code == 2 and err.startswith("wsmap: error: ") and message in err and err.count("\n") == 1, err


def test_nearest_arm_baseline_in_chunks_is_the_brute_force_answer():
    """Queries in chunks (one query at a time at the smallest ``max_numbers``) give the labels and
    distances of the whole-array argmin."""
    rng = np.random.default_rng(3)
    F = rng.normal(size=(300, mm.N_FEATURES))
    Y = rng.random((300, 17)) < 0.3
    Q = rng.normal(size=(25, mm.N_FEATURES))
    d = morphology_distance(Q[:, None, :], F[None, :, :])
    want = d.argmin(axis=1)
    for budget in (1, 300 * mm.N_FEATURES * 7, 1 << 24):
        maps, dist = mm.nearest_arm_maps(F, Y, Q, max_numbers=budget)
        assert np.array_equal(maps, Y[want])
        assert np.array_equal(dist, d[np.arange(25), want])


def test_grid_map_coarse_to_fine_is_the_dense_map_with_fewer_evaluations(trained):
    """predict_morph_grid gives predict_morph_map's map of the same grid (named arms, random arms,
    a grid not centred on the box) while running the decoder on fewer nodes; coarse=1 runs it on
    every node."""
    model = trained[0]
    rows = []
    hook = model.decoder.register_forward_hook(lambda m, i, o: rows.append(o.reshape(-1).shape[0]))
    try:
        arms = [wsmap.load(n) for n in ("ur5e", "panda", "iiwa14")]
        arms += [MORPH6.arms(p) for p in MORPH6.draw(4, seed=5)]
        for lo, hi, step in ((-1.5, 1.5, 0.1), ((-1.2, -0.4, 0.0), (1.3, 0.9, 1.1), 0.1)):
            nodes = ws.cartesian_grid(lo, hi, step)
            for arm in arms:
                dense = mm.predict_morph_map(model, arm, nodes, allow_extrapolation=True)
                rows.clear()
                grid = mm.predict_morph_grid(model, arm, lo, hi, step, allow_extrapolation=True)
                assert np.array_equal(grid, dense)
                assert sum(rows) <= len(nodes) + 1331
                rows.clear()
                assert np.array_equal(mm.predict_morph_grid(model, arm, lo, hi, step, coarse=1,
                                                            allow_extrapolation=True), dense)
                assert rows == [len(nodes)]
        # a tight margin on a sparse map: the decoder runs on a fraction of the nodes
        rows.clear()
        mm.predict_morph_grid(model, arms[0], -1.5, 1.5, 0.1, margin=0.0)
        assert sum(rows) < 0.5 * 29791
        # a margin that leaves every cell near: the coarse pass, then every node once (the dense map)
        rows.clear()
        nodes = ws.cartesian_grid(-1.5, 1.5, 0.1)
        assert np.array_equal(mm.predict_morph_grid(model, arms[0], -1.5, 1.5, 0.1, margin=1e6),
                              mm.predict_morph_map(model, arms[0], nodes))
        assert rows[1:] == [29791, 29791] and rows[0] == 11 ** 3
    finally:
        hook.remove()


def test_grid_map_refuses_bad_settings_before_any_work(trained):
    model = trained[0]
    arm = wsmap.load("ur5e")
    with pytest.raises(ValueError, match="coarse must be a positive integer, got 0"):
        mm.predict_morph_grid(model, arm, -1, 1, 0.1, coarse=0)
    with pytest.raises(ValueError, match="margin must be a non-negative number of logits, got -1"):
        mm.predict_morph_grid(model, arm, -1, 1, 0.1, margin=-1)
    with pytest.raises(ExtrapolationError, match="outside the model's box"):
        mm.predict_morph_grid(model, arm, -2, 2, 0.5)
