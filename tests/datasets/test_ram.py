"""RAM's evaluation protocol (`wsmap.datasets.ram`): its arm distribution, its poses and boundary
set, its labels (IK with capsule self-collision, FK sampling into SE(3) cells) and its F1."""

from __future__ import annotations

import numpy as np
import pytest

from wsmap import datasets

#: A hand-made 5-joint arm: 0.3 m up, then three 0.3 m links in one plane (joints 2-4 parallel),
#: then a short wrist. Capsules: d0 (up), a1, a2, a3, a4, d5 (the tool).
FOLD = np.array([[0.0, 0.0, 0.3], [np.pi / 2, 0.3, 0.0], [0.0, 0.3, 0.0], [0.0, 0.3, 0.0],
                 [np.pi / 2, 0.1, 0.0], [0.0, 0.0, 0.1]])


def _mdh(alpha, a, d, theta):
    """Craig's link transform Rx(alpha) Tx(a) Rz(theta) Tz(d), written out independently."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -d * sa], [st * sa, ct * sa, ca, d * ca], [0, 0, 0, 1]])


def _frames(m, q):
    """Frames after every row (RAM's forward_kinematics): (rows, 4, 4)."""
    T, out = np.eye(4), []
    for (al, a, d), t in zip(m, list(q) + [0.0]):
        T = T @ _mdh(al, a, d, t)
        out.append(T)
    return np.array(out)


def _segment_distance(p0, p1, r0, r1, k=400):
    """Distance of two segments by dense points (independent of the checker's closed form)."""
    s = np.linspace(0, 1, k)[:, None]
    a = p0 + s * (p1 - p0)
    b = r0 + s * (r1 - r0)
    return np.min(np.linalg.norm(a[:, None] - b[None], axis=-1))


def _ram_collides(m, q, radius=0.025):
    """RAM's self_collision.collision_check re-derived from its rules, by brute force."""
    F = np.concatenate([np.eye(4)[None], _frames(m, q)])
    seg = []
    for i in range(len(m)):
        e_d = F[i + 1, :3, 3]
        e_a = e_d - m[i, 2] * F[i + 1, :3, 2]
        seg += [(F[i, :3, 3], e_a), (e_a, e_d)]
    has = [np.linalg.norm(e - s) > 1e-4 for s, e in seg]
    for i in range(len(seg)):
        for j in range(i + 2, len(seg)):
            if has[i] and has[j] and np.linalg.norm(seg[i][1] - seg[j][0]) > 1e-4:
                if _segment_distance(*seg[i], *seg[j]) < 2 * radius:
                    return True
    live = [k for k in range(len(seg)) if has[k]]
    base, tip = seg[0][0], seg[-1][1]
    return bool(_segment_distance(*seg[live[1]], base, base) < 2 * radius
                or _segment_distance(*seg[live[-2]], tip, tip) < 2 * radius)


# --------------------------------------------------------------------------- the arm distribution
@pytest.mark.parametrize("dof", [5, 6, 7])
def test_arms_follow_rams_distribution(dof):
    m = datasets.sample_morphologies(40, dof, seed=3)
    assert m.shape == (40, dof + 1, 3)
    al, a, d = m[..., 0], m[..., 1], m[..., 2]
    assert set(np.unique(al).tolist()) <= {0.0, np.pi / 2, -np.pi / 2}
    np.testing.assert_allclose(np.hypot(a, d).sum(axis=1), 1.0, atol=1e-12)  # lengths on the simplex
    nz = np.concatenate([a[a != 0], d[d != 0]])
    assert np.all(np.abs(nz) >= 0.05) and (nz < 0).any() and (nz > 0).any()  # >= 2 radii, both signs
    assert np.all(np.hypot(a[:, 0], d[:, 0]) <= 1 / (dof + 1)) and np.all(np.hypot(a[:, -1], d[:, -1]) <= 1 / (dof + 1))
    none = (a == 0) & (d == 0)
    assert not np.any(none[:, 1:] & none[:, :-1])  # no two rows without length in a row
    assert not np.any(none & (al == 0))
    z = al == 0
    assert not np.any(z[:, :-2] & z[:, 1:-1] & z[:, 2:])  # no three parallel axes in a row
    general = (a != 0) & (d != 0)
    assert general.any() and ((a == 0) & (d != 0)).any() and ((a != 0) & (d == 0)).any()


def test_arms_are_deterministic_by_seed():
    one = datasets.sample_morphologies(8, 6, seed=11)
    np.testing.assert_array_equal(one, datasets.sample_morphologies(8, 6, seed=11))
    assert not np.array_equal(one, datasets.sample_morphologies(8, 6, seed=12))


def test_ram_arms_have_rams_forward_kinematics():
    m = datasets.sample_morphologies(3, 7, seed=0)
    chain = datasets.ram_arms(m)
    assert chain.batch_shape == (3,) and chain.n == 7 and chain.qlim is None
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (3, 7))
    want = np.array([_frames(m[k], q[k])[-1] for k in range(3)])
    np.testing.assert_allclose(chain.fkine(q), want, atol=1e-12)


# --------------------------------------------------------------------------- self-collision
def test_capsules_fold_and_stretch():
    check = datasets.ram_collision(FOLD)
    names = check.model.names
    assert names == ("d0", "a1", "a2", "a3", "a4", "d5", "base_ball", "eef_ball")
    pairs = {tuple(sorted((names[i], names[j]))) for i, j in check.pairs}
    assert ("a1", "a3") in pairs and ("a1", "a2") not in pairs and ("a1", "base_ball") in pairs
    stretched = np.zeros(5)
    folded = np.array([0.0, 0.0, np.pi, 0.0, 0.0])  # link 3 back over link 2: a3 meets a1's end
    assert check(np.array([stretched, folded])).tolist() == [True, False]


def test_capsule_checker_agrees_with_rams_rules_by_brute_force():
    rng = np.random.default_rng(5)
    checked = 0
    for m in datasets.sample_morphologies(4, 6, seed=2):
        check = datasets.ram_collision(m)
        q = rng.uniform(-np.pi, np.pi, (25, 6))
        free = check(q)
        for k in range(len(q)):
            assert free[k] == (not _ram_collides(m, q[k])), (m, q[k])
            checked += 1
    assert checked == 100


def test_capsules_run_along_the_arm():
    m = datasets.sample_morphologies(1, 7, seed=4)[0]
    check = datasets.ram_collision(m)
    q = np.random.default_rng(1).uniform(-np.pi, np.pi, (3, 7))
    poses, link_of = check.model.shape_poses(q)
    caps = [k for k, lk in enumerate(check.model.links) if lk.shapes[0].kind == "capsule"]
    half = np.array([check.model.links[k].shapes[0].size[1] / 2 for k in caps])
    P = poses[:, caps]
    start = P[..., :3, 3] - half[:, None] * P[..., :3, 2]
    end = P[..., :3, 3] + half[:, None] * P[..., :3, 2]
    np.testing.assert_allclose(end[:, :-1], start[:, 1:], atol=1e-12)  # one polyline
    np.testing.assert_allclose(end[:, -1], datasets.ram_arms(m).fkine(q)[:, :3, 3], atol=1e-12)


# --------------------------------------------------------------------------- poses
def test_random_poses_lie_in_rams_ball():
    m = datasets.sample_morphologies(1, 6, seed=1)[0]
    T, known = datasets.random_poses(m, 500, seed=0)
    assert T.shape == (500, 4, 4) and not known.any()  # FK poses only for 5-joint arms
    centre, radius = datasets.reach_ball(m)
    np.testing.assert_allclose(radius, np.hypot(m[1:-1, 1], m[1:-1, 2]).sum() - 2 / 37)
    wrist = T @ np.linalg.inv(_mdh(*m[-1], 0.0))
    r = np.linalg.norm(wrist[:, :3, 3] - centre, axis=1)
    assert r.max() <= radius + 1e-12 and r.max() > 0.9 * radius
    np.testing.assert_allclose(T[:, :3, :3] @ np.swapaxes(T[:, :3, :3], 1, 2), np.broadcast_to(np.eye(3), (500, 3, 3)),
                               atol=1e-12)


def test_five_joint_arms_get_a_quarter_of_fk_poses_labelled_reachable():
    m = datasets.sample_morphologies(1, 5, seed=6)[0]
    T, known = datasets.random_poses(m, 400, seed=2)
    assert 0 < known.sum() <= 100 and known[: known.sum()].all()
    assert datasets.ik_labels(m, T[known]).all()


def test_boundary_set_is_built_along_geodesics():
    m = datasets.sample_morphologies(1, 6, seed=7)[0]
    G, S = 6, 5
    T, labels = datasets.boundary_poses(m, G, S, seed=1)
    assert T.shape == (G * S, 4, 4) and labels.shape == (G * S,)
    steps = T.reshape(S, G, 4, 4)
    a, b = steps[0], steps[-1]
    for k in range(S):
        t = k / (S - 1)
        np.testing.assert_allclose(steps[k, :, :3, 3], a[:, :3, 3] + t * (b[:, :3, 3] - a[:, :3, 3]), atol=1e-12)
        rel = np.swapaxes(a[:, :3, :3], 1, 2) @ steps[k, :, :3, :3]
        full = np.swapaxes(a[:, :3, :3], 1, 2) @ b[:, :3, :3]
        angle = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
        total = np.arccos(np.clip((np.trace(full, axis1=1, axis2=2) - 1) / 2, -1, 1))
        np.testing.assert_allclose(angle, t * total, atol=1e-7)
    lab = labels.reshape(S, G)
    assert lab[0].all() and not lab[-1].any()  # a reachable and an unreachable end per geodesic
    np.testing.assert_array_equal(labels, datasets.ik_labels(m, T))


# --------------------------------------------------------------------------- labels
def test_a_sampled_configurations_pose_is_reachable_under_both_labels():
    m = datasets.sample_morphologies(1, 7, seed=8)[0]
    q, T = datasets.fk_samples(m, 60, seed=4)
    assert 0 < len(q) <= 60 and datasets.ram_collision(m)(q).all()
    np.testing.assert_allclose(datasets.ram_arms(m).fkine(q), T)
    assert datasets.fk_labels(m, T, 60, seed=4, level=3).all()  # the same stream: every cell hit
    assert datasets.ik_labels(m, T).all()


def test_the_collision_free_branch_is_found():
    # a 6-joint arm has a few IK branches; the retries after a colliding solution must reach the free
    # one (wsmap.reachable's own retries began at the same first start and found 15 of these 19)
    m = datasets.sample_morphologies(1, 6, seed=7)[0]
    q, T = datasets.fk_samples(m, 40, seed=3)
    assert len(q) == 19
    assert datasets.ik_labels(m, T, rounds=0).all()
    assert datasets.ik_labels(m, T).all()


def test_self_collision_only_removes_reachable_poses():
    m = datasets.sample_morphologies(1, 6, seed=9)[0]
    T, _ = datasets.random_poses(m, 300, seed=3)
    free = datasets.ik_labels(m, T)
    kinematic = datasets.ik_labels(m, T, self_collision=False)
    assert not np.any(free & ~kinematic) and kinematic.sum() > free.sum()


def test_fk_labels_grow_with_the_budget_and_the_cells():
    m = datasets.sample_morphologies(1, 6, seed=10)[0]
    T, _ = datasets.random_poses(m, 300, seed=5)
    lab = datasets.fk_labels(m, T, [2000, 20000], seed=0, level=[1, 2])
    assert lab.shape == (2, 2, 300)
    assert np.all(lab[:, 0] <= lab[:, 1])  # more samples: more hits, never fewer
    assert lab[0].sum() > lab[1].sum()  # level 1's cells are larger (not nested in level 2's, so in total)
    np.testing.assert_array_equal(lab[0, 1], datasets.fk_labels(m, T, 20000, seed=0, level=1))


def test_se3_cells_known_values():
    T = np.eye(4)
    # R3: floor((0 + 1) / 2 * 37) = 18 per axis; SO(3): the identity is face w, bins floor(17 / 2) = 8
    assert datasets.se3_cells(T) == 18 * (1 + 37 + 37**2) + 37**3 * (3 * 17**3 + 8 * (1 + 17 + 17**2))
    far = np.eye(4)
    far[:3, 3] = [5.0, -5.0, 0.999]
    assert datasets.se3_cells(far, level=1) % 10**3 == 9 + 0 * 10 + 9 * 100  # clamped to the border cells
    from wsmap.datasets.sampling import uniform_rotations

    R = np.zeros((50000, 4, 4))
    R[:, :3, :3] = uniform_rotations(50000, 0)
    R[:, 3, 3] = 1
    so3 = datasets.se3_cells(R, level=1) // 10**3
    assert len(np.unique(so3)) == 4 * 4**3  # every SO(3) cell of level 1 is hit


def test_ram_f1_known_values():
    truth = np.array([[1, 1, 1, 0, 0], [0, 0, 0, 0, 0], [0, 0, 0, 0, 0], [1, 0, 0, 0, 0]], dtype=bool)
    pred = np.array([[1, 1, 0, 1, 0], [0, 0, 0, 0, 0], [0, 1, 0, 0, 0], [1, 0, 0, 0, 0]], dtype=bool)
    mean, per = datasets.ram_f1(pred, truth)
    np.testing.assert_allclose(per, [2 * 2 / (2 * 2 + 1 + 1), 1.0, 0.0, 1.0])
    assert mean == pytest.approx(np.mean([4 / 6, 1, 0, 1]))


# --------------------------------------------------------------------------- bad arguments
@pytest.mark.parametrize("call, message", [
    (lambda: datasets.sample_morphologies(5, 4), r"dof must be one of 5, 6, 7 \(RAM's arms\), got 4"),
    (lambda: datasets.sample_morphologies(0, 6), "count must be at least 1, got 0"),
    (lambda: datasets.ram_arms(np.zeros((5, 3))), "morph must be RAM's table"),
    (lambda: datasets.ram_collision(np.zeros((2, 7, 3))), "this function takes one arm's table"),
    (lambda: datasets.ik_labels(FOLD, np.eye(3)), r"poses must have shape \(..., 4, 4\), got \(3, 3\)"),
    (lambda: datasets.fk_labels(FOLD, np.eye(4), [100, 10]), "samples must be a positive count or a strictly"),
    (lambda: datasets.fk_labels(FOLD, np.eye(4), 100, level=5), "level must be one of 1, 2, 3, 4"),
    (lambda: datasets.se3_cells(np.eye(4), level=0), "level must be one of 1, 2, 3, 4"),
    (lambda: datasets.boundary_poses(FOLD, 3, 1), "per_geodesic must be at least 2, got 1"),
    (lambda: datasets.ram_f1(np.zeros((2, 3), bool), np.zeros((3, 2), bool)), "pred and truth must both be"),
])
def test_bad_arguments_get_one_line_errors(call, message):
    with pytest.raises(ValueError, match=message) as err:
        call()
    assert "\n" not in str(err.value)
