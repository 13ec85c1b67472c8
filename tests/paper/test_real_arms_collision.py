"""What collisions remove, for the named arms (the real_arms part's collision section), and what it
stands on: a checker asked from many bases (``CollisionChecker.at_bases``) against the same scene
moved into each base's frame, base placement around a world-frame table, the volumes of the three
ways nested and known where they must be."""

import numpy as np
import pytest

from wsmap import load, paths
from wsmap.collision import CollisionChecker, CollisionError, Obstacle, Scene, Shape, arm_model, build_acm
from wsmap.kinematics.transforms import rotz
from wsmap.paper.parts import real_arms
from wsmap.workspace import base_placement, floor_poses, orientation_samples, target_poses

SMOKE = paths.load_params("real_arms", paths.ROOT / "params.smoke.yaml")["collision"]
DOWN = (np.pi, 0.0, 0.0)


def _at(xyz, yaw=0.0):
    T = np.eye(4)
    T[:3, :3] = rotz(yaw)
    T[:3, 3] = xyz
    return T


@pytest.fixture(scope="module")
def panda_model():
    model = arm_model("panda")
    model.acm = build_acm(model, samples=1000)
    return model


def test_at_bases_is_the_scene_moved_into_each_base_frame(panda_model):
    # the checker asked from base B with the table in the world equals a checker whose table is
    # given in the base frame as B⁻¹·P (its standing exemptions off: none touches at q = 0), by the
    # fast layer and by coal alone
    robot = load("panda")
    table = Shape("box", (0.6, 0.8, 0.4), _at([0.0, 0.0, 0.2]))
    world = CollisionChecker(panda_model, Scene(0.0, (Obstacle("table", table, frame="world"),)))
    rng = np.random.default_rng(3)
    q = robot.random_q(240, rng)
    bases = floor_poses(rng.uniform(-0.8, 0.8, 240), rng.uniform(-0.8, 0.8, 240), rng.uniform(0, 2 * np.pi, 240))
    want = np.empty(len(q), dtype=bool)
    for b in np.unique(np.arange(len(q)) // 40):  # 6 bases, 40 configurations each
        rows = slice(40 * b, 40 * b + 40)
        B = bases[40 * b]
        bases[rows] = B
        moved = Shape("box", table.size, np.linalg.inv(B) @ table.origin)
        chk = CollisionChecker(panda_model, Scene(0.0, (Obstacle("table", moved, frame="base"),)))
        chk.scene_allowed[:] = False  # the world checker exempts no link from the table
        chk.scene_allowed[:, -1] = world.scene_allowed[:, -1]  # the floor's exemptions are the same
        want[rows] = chk.exact(q[rows])
    got = world.at_bases(q, bases)
    np.testing.assert_array_equal(got, want)
    assert 0 < (~got).sum() < len(q)  # some collide, some are free: the test can fail


def test_at_bases_refuses_base_frame_obstacles_and_bad_bases(panda_model):
    chk = CollisionChecker(panda_model, Scene(0.0, (Obstacle("post", Shape("sphere", (0.1,), _at([1, 0, 1]))),)))
    with pytest.raises(ValueError, match="world-frame obstacles only"):
        chk.at_bases(np.zeros((1, 7)), np.eye(4))
    world = CollisionChecker(panda_model, Scene(0.0))
    with pytest.raises(ValueError, match=r"bases must have shape \(2, 4, 4\)"):
        world.at_bases(np.zeros((2, 7)), np.stack([np.eye(4)] * 3))
    with pytest.raises(ValueError, match="bases"):
        world.at_bases(np.zeros((1, 7)), 2 * np.eye(4))


def test_placement_around_a_world_table_moves_the_best_base(panda_model):
    # the chain alone stands the Panda under the middle of the table; collision-aware it stands
    # beside it, and every solution of the chosen base is free by coal with the table moved into
    # that base's frame
    spec = SMOKE["placement"]
    robot = load("panda")
    table = real_arms.table_obstacle(spec["table"], "world")
    targets = np.stack([target_poses(p, spec["rpy"], "standard") for p in spec["positions"]])
    kw = dict(x=spec["x"], y=spec["y"], step=spec["step"], yaws=spec["yaws"], tiebreak="centre")  # by reach alone
    chain = base_placement(robot, targets, **kw)
    free = base_placement(robot, targets, collision=CollisionChecker(panda_model, Scene(0.0, (table,))), **kw)
    sx, sy = spec["table"]["size"][:2]
    assert abs(chain.x[0]) < sx / 2 and abs(chain.y[0]) < sy / 2 and chain.score[0] == 1.0
    assert abs(free.x[0]) > sx / 2 or abs(free.y[0]) > sy / 2
    assert free.score[0] == 1.0
    got = np.isfinite(free.q[:, 0])
    assert got.all()
    np.testing.assert_allclose(free.poses[0] @ robot.fkine(free.q), targets, atol=1e-6)
    moved = Shape("box", table.shape.size, np.linalg.inv(free.poses[0]) @ table.shape.origin)
    there = CollisionChecker(panda_model, Scene(0.0, (Obstacle("table", moved, frame="base"),)))
    there.scene_allowed[:, 0] = False
    assert there.exact(free.q).all()


def test_collision_part_of_the_smoke_params():
    rows, maps = real_arms.collision_volumes(["panda", "ur5e"], SMOKE["step"], {"panda": 1.2, "ur5e": 1.0},
                                             orientation_samples(SMOKE["orientations"], seed=0),
                                             real_arms.table_obstacle(SMOKE["table"], "base"), log=lambda *_: None)
    assert [(r["arm"], r["kind"], r["way"]) for r in rows] == [
        (a, k, w) for a in ("panda", "ur5e") for k in ("tooldown", "index") for w in real_arms.WAYS]
    cell = SMOKE["step"] ** 3
    for name, m in maps.items():
        assert len(m["tooldown"]["chain"]) == np.prod(m["grid"]["shape"])
        for kind in ("tooldown", "index"):
            chain, sf, tb = (np.asarray(m[kind][w], dtype=np.float64) for w in real_arms.WAYS)
            # each way keeps a subset of the one before (the index at each node no larger)
            assert np.all(sf <= chain + 1e-12) and np.all(tb <= sf + 1e-12)
            assert (chain > 0).sum() > (sf > 0).sum() > (tb > 0).sum()
        got = [r for r in rows if r["arm"] == name]
        for r in got:
            base = next(b for b in got if b["kind"] == r["kind"] and b["way"] == "chain")
            assert r["volume_m3"] == pytest.approx(r["nodes"] * cell)
            assert r["lost_pct"] == pytest.approx(100 * (1 - r["volume_m3"] / base["volume_m3"]))
            assert r["index_volume_m3"] <= r["volume_m3"] + 1e-12
    # nothing under the floor survives the floor (the tool's last capsule would be in it)
    from wsmap import workspace

    g = maps["panda"]["grid"]
    nodes = workspace.cartesian_grid(g["lo"], g["hi"], g["step"])
    assert maps["panda"]["tooldown"]["chain"][nodes[:, 2] < 0].any()
    assert not maps["panda"]["tooldown"]["self_floor"][nodes[:, 2] < 0].any()


def test_collision_placement_summary_of_the_smoke_params():
    out = real_arms.collision_placement(SMOKE["placement"], log=lambda *_: None)
    m = out["metrics"]
    assert m["best_changed"] and m["chain_best"][3] == 1.0 and m["chain_best_free_score"] < 1.0
    assert m["free_best"][3] == 1.0 and m["targets"] == len(SMOKE["placement"]["positions"])
    t = out["table"]
    assert list(t["ranking"].unique()) == ["chain", "free"]
    # the chain's score of a base is never below its collision-aware score
    assert (t["score_chain"] >= t["score_free"]).all()
    assert t.loc[t["ranking"] == "chain", "score_chain"].iloc[0] == 1.0
    assert t.loc[t["ranking"] == "chain", "score_free"].iloc[0] == m["chain_best_free_score"]
    sc = out["scores"]
    assert sc["chain"].shape == sc["free"].shape == (len(sc["y"]), len(sc["x"]))
    assert np.all(sc["free"] <= sc["chain"]) and sc["chain"].max() == 1.0


def test_the_table_of_params_is_checked():
    with pytest.raises(CollisionError, match="params real_arms table"):
        real_arms.table_obstacle({"size": [0.8, -1.0, 0.3], "xyz": [0.7, 0, 0.15]}, "base")
    with pytest.raises(CollisionError, match="params real_arms table"):
        real_arms.table_obstacle({"size": [0.8, 1.0, 0.3], "xyz": [0.7, float("nan"), 0.15]}, "base")


def test_closed_form_placement_around_a_world_table():
    # the UR5e's closed form: every branch is asked from its candidate base; the best base's
    # solutions are free with the table moved into its frame, and the table costs some candidates
    model = arm_model("ur5e")
    model.acm = build_acm(model, samples=1000)
    spec = SMOKE["placement"]
    table = real_arms.table_obstacle(spec["table"], "world")
    robot = load("ur5e")
    targets = np.stack([target_poses(p, spec["rpy"], "standard") for p in spec["positions"]])
    kw = dict(x=(-0.8, 0.8), y=(-0.8, 0.8), step=0.2, yaws=4)
    free = base_placement(robot, targets, collision=CollisionChecker(model, Scene(0.0, (table,))), **kw)
    floor_only = base_placement(robot, targets, collision=CollisionChecker(model, Scene(0.0)), **kw)
    assert free.method == "exact" and free.score[0] > 0
    assert free.reached.sum() < floor_only.reached.sum()
    got = np.isfinite(free.q[:, 0])
    assert got.sum() == free.reached[0].sum()
    np.testing.assert_allclose(free.poses[0] @ robot.fkine(free.q[got]), targets[got], atol=1e-9)
    moved = Shape("box", table.shape.size, np.linalg.inv(free.poses[0]) @ table.shape.origin)
    there = CollisionChecker(model, Scene(0.0, (Obstacle("table", moved, frame="base"),)))
    there.scene_allowed[:, 0] = False
    assert there.exact(free.q[got]).all()


def test_the_inline_3d_view_on_every_second_node_keeps_each_node_where_it_was():
    from types import SimpleNamespace

    from wsmap import workspace
    from wsmap.paper.parts import real_arms

    grid = workspace.grid_spec("R3", [-0.5, -0.4, -0.3], [0.5, 0.4, 0.3], 0.1)
    nodes = workspace.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    index = np.linspace(0, 1, len(nodes))
    result = SimpleNamespace(cfg={"show_3d": "arm", "orientations": 4}, index_maps={"arm": (index, grid)})
    nx, ny, nz = grid["shape"]
    keep = np.arange(len(nodes)).reshape(nz, ny, nx)[::2, ::2, ::2].ravel()
    fig = real_arms.figure_3d_of_shown(result, stride=2)
    full = real_arms.figure_3d_of_shown(result)
    xs = np.concatenate([np.asarray(t.x, dtype=float) for t in fig.data if t.x is not None])
    assert set(np.round(xs, 9)) <= set(np.round(nodes[keep, 0], 9)) and len(fig.data) == len(full.data)
    with pytest.raises(ValueError, match="stride must be a positive integer, got 0"):
        real_arms.figure_3d_of_shown(result, stride=0)
