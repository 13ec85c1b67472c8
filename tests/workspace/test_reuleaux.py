"""Reuleaux's HDF5 reachability maps: the layout of map_creator's writer, and round trips both ways.

The layout is read off ``map_creator/src/hdf5_dataset.cpp`` (ros-industrial-consortium/reuleaux,
``saveReachMapsToDataset``) and ``sphere_discretization.cpp`` (``convertPoseToVector``: position, then
the quaternion x, y, z, w). ``_reuleaux_file`` below writes a file as that code does, with h5py,
independently of :mod:`wsmap.workspace.reuleaux`.
"""

from __future__ import annotations

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")

from scipy.spatial.transform import Rotation  # noqa: E402

from wsmap import cli, robots  # noqa: E402
from wsmap import workspace as ws  # noqa: E402
from wsmap.workspace.reuleaux import ReuleauxMap, load_reuleaux, save_reuleaux  # noqa: E402


def _reuleaux_file(path, centres, per_sphere, reach, resolution, radius=None):
    """A file as map_creator writes it: every sphere has the same ``per_sphere`` (K, 4) quaternions
    (x, y, z, w); ``reach`` (S, K) which are reachable; Reuleaux's pose positions lie on a small
    sphere (``radius``) around the centre, along the pose's z axis (pointing at the centre)."""
    radius = resolution if radius is None else radius
    # the centres are octomap point3d (float) widened to double: float32 values in both datasets
    centres = np.asarray(centres, dtype=np.float32).astype(np.float64)
    rows, spheres = [], []
    for c, r in zip(centres, reach):
        if not r.any():
            continue  # unreachable spheres are not stored
        for q in per_sphere[r]:
            z = Rotation.from_quat(q).as_matrix()[:, 2]
            rows.append([*c, *(c - radius * z), *q])
        # D = R / N * 100, computed in float (float32 in C++), stored as double
        spheres.append([*c, np.float32(r.sum()) / np.float32(len(r)) * np.float32(100)])
    rows = np.asarray(rows, dtype=np.float32)
    chunk = (len(rows) + 1) // 2
    with h5py.File(path, "w") as f:
        f.create_group("Poses").create_dataset("poses_dataset", data=rows, maxshape=(None, 10), chunks=(chunk, 10))
        ds = f.create_group("Spheres").create_dataset("sphere_dataset", data=np.asarray(spheres, dtype=np.float64))
        ds.attrs.create("Resolution", np.array([resolution], dtype=np.float32))


def _ur5e_index(K=8):
    arm = robots.load("ur5e")
    grid = ws.grid_spec("R3", -0.6, 0.6, 0.3)
    nodes = ws.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    R = ws.orientation_samples(K, seed=0)
    index, bits = ws.reachability_index(arm, nodes, R, return_bits=True)
    return grid, nodes, R, index, bits


def test_the_layout_is_map_creators(tmp_path):
    grid, nodes, R, index, bits = _ur5e_index()
    path = save_reuleaux(tmp_path / "ur5e_r0.3_reachability.h5", grid, bits, R)
    with h5py.File(path, "r") as f:
        assert set(f) == {"Poses", "Spheres"} and list(f["Poses"]) == ["poses_dataset"]
        assert list(f["Spheres"]) == ["sphere_dataset"]
        poses, spheres = f["/Poses/poses_dataset"], f["/Spheres/sphere_dataset"]
        assert poses.dtype == np.float32 and poses.shape == (bits.sum(), 10)
        assert poses.maxshape == (None, 10) and poses.chunks == ((bits.sum() + 1) // 2, 10)
        assert spheres.dtype == np.float64 and spheres.shape == (bits.any(axis=1).sum(), 4)
        res = spheres.attrs["Resolution"]
        assert res.dtype == np.float32 and res.shape == (1,) and res[0] == np.float32(0.3)
        assert list(spheres.attrs) == ["Resolution"] and not poses.attrs
        s, p = spheres[()], poses[()]
    reached = bits.any(axis=1)
    np.testing.assert_allclose(s[:, :3], nodes[reached])
    np.testing.assert_allclose(s[:, 3], 100 * index[reached])  # percent
    # every pose: its sphere centre, its position (the centre: T = transl(p)·R_k), quaternion x y z w
    node, k = np.nonzero(bits)
    np.testing.assert_allclose(p[:, :3], nodes[node], atol=1e-7)
    np.testing.assert_allclose(p[:, 3:6], nodes[node], atol=1e-7)
    q = p[:, 6:].astype(np.float64)
    T = np.zeros((len(q), 4, 4))
    T[:, :3, :3] = Rotation.from_quat(q).as_matrix()  # scipy's scalar-last order is geometry_msgs'
    T[:, :3, 3], T[:, 3, 3] = p[:, 3:6], 1.0
    np.testing.assert_allclose(T[:, :3, :3], R[k], atol=1e-6)
    # the poses are reachable: an IK search confirms each one
    assert ws.reachable(robots.load("ur5e"), T[:40], starts=32).all()


def test_wsmap_map_to_reuleaux_and_back(tmp_path):
    grid, nodes, R, index, bits = _ur5e_index()
    m = load_reuleaux(save_reuleaux(tmp_path / "m.h5", grid, bits, R))
    back_index, back_grid, back_bits, back_R = m.to_map(grid, R)
    assert back_grid == grid
    np.testing.assert_array_equal(back_bits, bits)
    np.testing.assert_allclose(back_index, index, atol=1e-12)
    # without the grid and orientations: the spheres' bounding box and the poses' distinct orientations
    index2, grid2, bits2, R2 = m.to_map()
    assert len(R2) == int(bits.any(axis=0).sum())
    sub = ws.cartesian_grid(grid2["lo"], grid2["hi"], grid2["step"])
    pos = {tuple(np.round(p, 9)): i for i, p in enumerate(nodes)}
    rows = [pos[tuple(np.round(p, 9))] for p in sub]
    np.testing.assert_allclose(index2, index[rows], atol=1e-12)
    match = np.abs(Rotation.from_matrix(R2).as_quat() @ Rotation.from_matrix(R).as_quat().T).argmax(axis=1)
    np.testing.assert_array_equal(bits2, bits[rows][:, match])


def test_a_reuleaux_file_to_a_wsmap_map_and_back(tmp_path):
    rng = np.random.default_rng(3)
    res = 0.08
    axes = np.arange(-2, 3) * res
    centres = np.stack(np.meshgrid(axes, axes, axes, indexing="ij"), -1).reshape(-1, 3)
    per_sphere = Rotation.random(12, random_state=4).as_quat()
    reach = rng.random((len(centres), 12)) < 0.4
    reach[:5] = False  # spheres with nothing reachable are left out of the file
    path = tmp_path / "robot_r0.08_reachability.h5"
    _reuleaux_file(path, centres, per_sphere, reach, res)
    m = load_reuleaux(path)
    assert m.resolution == pytest.approx(res) and len(m.spheres) == int(reach.any(axis=1).sum())
    index, grid, bits, R = m.to_map()
    assert len(R) == 12 and grid["shape"] == [5, 5, 5] and np.allclose(grid["step"], res)
    # the index: the file's D / 100 at its spheres (a wsmap index), 0 where no sphere
    nodes = ws.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    order = {tuple(np.round(c / res).astype(int)): i for i, c in enumerate(nodes)}
    rows = [order[tuple(np.round(c / res).astype(int))] for c in centres]
    np.testing.assert_allclose(index[rows], reach.mean(axis=1), atol=1e-6)
    np.testing.assert_allclose(bits[rows].mean(axis=1), index[rows], atol=1e-6)
    # and back: the same spheres, indices and orientations (wsmap's pose positions are the centres)
    again = load_reuleaux(save_reuleaux(tmp_path / "again.h5", grid, bits, R))
    key = lambda a: np.lexsort(np.round(a, 6).T)  # noqa: E731
    np.testing.assert_allclose(again.spheres[key(again.spheres)], m.spheres[key(m.spheres)], atol=1e-9)
    np.testing.assert_allclose(again.ri[key(again.spheres)], m.ri[key(m.spheres)], atol=1e-4)
    np.testing.assert_allclose(again.pose_spheres, again.poses[:, :3], atol=1e-7)
    a = np.abs(again.poses[:, 3:] @ m.poses[:, 3:].T).max(axis=1)
    assert np.all(a > 1 - 1e-6)
    # a map as read is written back exactly (the file's own arrays)
    m.save(tmp_path / "copy.h5")
    with h5py.File(path) as f, h5py.File(tmp_path / "copy.h5") as g:
        for name in ("/Spheres/sphere_dataset", "/Poses/poses_dataset"):
            assert f[name].dtype == g[name].dtype
            np.testing.assert_array_equal(f[name][()], g[name][()])
        assert g["/Spheres/sphere_dataset"].attrs["Resolution"] == f["/Spheres/sphere_dataset"].attrs["Resolution"]


def test_bad_input_is_refused_before_writing(tmp_path):
    grid, nodes, R, index, bits = _ur5e_index(4)
    with pytest.raises(ValueError, match=r"\.h5 file"):
        save_reuleaux(tmp_path / "m.hdf5", grid, bits, R)
    with pytest.raises(ValueError, match="one resolution"):
        save_reuleaux(tmp_path / "m.h5", {**grid, "step": [0.3, 0.3, 0.2]}, bits, R)
    with pytest.raises(ValueError, match="bits must be bool of shape"):
        save_reuleaux(tmp_path / "m.h5", grid, bits[:, :2], R)
    with pytest.raises(ValueError, match="an R3 grid"):
        save_reuleaux(tmp_path / "m.h5", ws.grid_spec("SO3"), bits, R)
    assert not list(tmp_path.iterdir())
    (tmp_path / "x.h5").write_bytes(b"junk")
    with pytest.raises(ValueError, match="not an HDF5 file"):
        load_reuleaux(tmp_path / "x.h5")
    with h5py.File(tmp_path / "y.h5", "w") as f:
        f.create_group("Spheres")
    with pytest.raises(ValueError, match="not a Reuleaux reachability map"):
        load_reuleaux(tmp_path / "y.h5")
    with pytest.raises(ValueError, match="not on a node"):
        ReuleauxMap(np.array([[0.05, 0, 0]]), [50.0], np.zeros((0, 3)), np.zeros((0, 7)), 0.1).to_map(
            ws.grid_spec("R3", -0.2, 0.2, 0.1))


def test_cli_h5_writes_the_index_and_refuses_kinds_that_do_not_export(tmp_path, capsys):
    h5 = tmp_path / "ur5e.h5"
    out = tmp_path / "ur5e.npz"
    argv = ["map", "--robot", "ur5e", "--kind", "index", "--orientations", "8", "--lo", "-0.6", "--hi", "0.6",
            "--step", "0.3", "-q"]
    assert cli.main(argv + ["--h5", str(h5), "--out", str(out)]) == 0
    flat, nodes, grid, _ = ws.load_map(out)
    with np.load(out) as f:
        R = f["orientations"]
    index, _, bits, _ = load_reuleaux(h5).to_map(grid, R)
    np.testing.assert_allclose(index, flat, atol=1e-12)
    np.testing.assert_allclose(bits.mean(axis=1), flat, atol=1e-12)
    # alone, without --out
    h5b = tmp_path / "alone.h5"
    assert cli.main(argv + ["--h5", str(h5b)]) == 0 and h5b.is_file()
    capsys.readouterr()
    for kind in ("reach", "manipulability"):
        bad = tmp_path / f"{kind}.h5"
        assert cli.main(["map", "--robot", "ur5e", "--kind", kind, "--h5", str(bad), "-q"]) == 2
        assert f"which the {kind} map is not" in capsys.readouterr().err and not bad.exists()
    assert cli.main(["map", "--robot", "puma560", "--convention", "paper", "--h5", str(tmp_path / "p.h5")]) == 2
    assert "standard convention" in capsys.readouterr().err


def test_the_constant_map_exports_its_one_orientation(tmp_path):
    h5, out = tmp_path / "puma.h5", tmp_path / "puma.npz"
    assert cli.main(["map", "--robot", "puma560", "--step", "0.25", "--rpy", "pi", "0", "0", "--h5", str(h5),
                     "--out", str(out), "-q"]) == 0
    flat, nodes, grid, _ = ws.load_map(out)
    m = load_reuleaux(h5)
    np.testing.assert_allclose(m.spheres, nodes[flat])
    assert np.all(m.ri == 100.0) and len(m.poses) == flat.sum()
    np.testing.assert_allclose(m.orientations(), Rotation.from_euler("x", np.pi).as_matrix()[None], atol=1e-6)


def _pair_as_reuleaux(path):
    """Reuleaux's inverse-map loader (``h5ToMultiMapPosesAndSpheres``): pose rows read as float and
    widened to double, sphere rows read as double, then paired by *exact* equality of the centres
    (``std::multimap<std::vector<double>, ...>`` keys). Returns, per sphere, how many poses it found,
    and the number of poses that found no sphere."""
    with h5py.File(path, "r") as f:
        poses = f["/Poses/poses_dataset"][()].astype(np.float64)
        spheres = f["/Spheres/sphere_dataset"][()]
    keys = {tuple(s[:3]): 0 for s in spheres}
    orphans = 0
    for row in poses:
        key = tuple(row[:3])
        if key in keys:
            keys[key] += 1
        else:
            orphans += 1
    return np.array([keys[tuple(s[:3])] for s in spheres]), orphans


def test_every_sphere_finds_its_poses_by_exact_equality(tmp_path):
    # a grid whose centres are not float32 numbers (-0.2 + k*0.1 in float64: -0.19999999999999996)
    arm = robots.load("ur5e")
    grid = ws.grid_spec("R3", -0.5, 0.5, 0.1)
    nodes = ws.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    R = ws.orientation_samples(4, seed=1)
    _, bits = ws.reachability_index(arm, nodes, R, return_bits=True)
    path = save_reuleaux(tmp_path / "m.h5", grid, bits, R)
    found, orphans = _pair_as_reuleaux(path)
    assert orphans == 0
    np.testing.assert_array_equal(found, bits[bits.any(axis=1)].sum(axis=1))
    with h5py.File(path, "r") as f:
        s = f["/Spheres/sphere_dataset"][()]
        assert s.dtype == np.float64
        # bit for bit the float32 pose centres, widened
        np.testing.assert_array_equal(s[:, :3], s[:, :3].astype(np.float32).astype(np.float64))


def test_a_pose_without_its_sphere_is_refused(tmp_path):
    res = 0.1
    centres = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]])
    per_sphere = Rotation.random(3, random_state=0).as_quat()
    path = tmp_path / "r.h5"
    _reuleaux_file(path, centres, per_sphere, np.ones((2, 3), dtype=bool), res)
    with h5py.File(path, "r+") as f:
        s = f["/Spheres/sphere_dataset"][()]
        del f["/Spheres/sphere_dataset"]
        ds = f["Spheres"].create_dataset("sphere_dataset", data=s[:1])  # the second sphere dropped
        ds.attrs.create("Resolution", np.array([res], dtype=np.float32))
    with pytest.raises(ValueError, match=r"r\.h5: 3 poses lie at no sphere of the file \(the first at "
                                         r"\[0\.1, 0\.0, 0\.0\] m\)$"):
        load_reuleaux(path)
