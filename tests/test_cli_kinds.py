"""`wsmap map --kind ...` and `wsmap place`: outputs, agreement with the library, bad input."""

import numpy as np
import pytest

from wsmap import cli, robots
from wsmap import workspace as ws


def run(argv, capsys):
    code = cli.main(argv)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.mark.parametrize("kind", ["index", "reach", "dexterous", "manipulability"])
def test_map_kinds_write_the_library_result_with_their_settings(tmp_path, capsys, kind):
    out = tmp_path / f"{kind}.npz"
    argv = ["map", "--robot", "ur5e", "--kind", kind, "--step", "0.25", "--out", str(out), "--png",
            str(tmp_path / "s.png"), "--ply", str(tmp_path / "c.ply")]
    if kind in ("index", "dexterous"):
        argv += ["--orientations", "6"]
    code, stdout, err = run(argv, capsys)
    assert code == 0, err
    flat, nodes, grid, settings = ws.load_map(out)
    assert settings["kind"] == kind and settings["robot"] == "ur5e"
    arm = robots.load("ur5e")
    if kind in ("index", "dexterous"):
        R = settings["orientations"]
        np.testing.assert_array_equal(R, ws.orientation_samples(6, seed=0))
        expected = (ws.reachability_index(arm, nodes, R) if kind == "index" else ws.dexterous_map(arm, nodes, R))
    elif kind == "reach":
        expected = ws.position_map(arm, nodes)
    else:
        expected = ws.manipulability_map(arm, nodes)
    assert flat.dtype == (np.float64 if kind in ("index", "manipulability") else bool)
    np.testing.assert_array_equal(flat, expected)
    assert (tmp_path / "s.png").stat().st_size > 1000 and (tmp_path / "c.ply").stat().st_size > 100


@pytest.mark.parametrize("argv, message", [
    (["--kind", "reach", "--orientations", "5"],
     "--kind reach does not read --orientations (it is read by --kind index/dexterous)"),
    (["--kind", "index", "--scope", "SO3"], "--scope SO3 does not go with --kind index"),
    (["--kind", "index", "--method", "model", "--model", "x.pt"], "--method model predicts the paper's maps"),
    (["--kind", "index", "--paper-lm"], "--paper-lm is the paper's solver of its own maps"),
    (["--kind", "index", "--orientations", "0"], "must be at least 1"),
    (["--kind", "volume"], "invalid choice: 'volume'"),
])
def test_bad_kind_arguments_are_one_line_errors_and_write_nothing(tmp_path, capsys, argv, message):
    out = tmp_path / "x.npz"
    try:
        code, _, err = run(["map", "--robot", "ur5e", *argv, "--quiet", "--out", str(out)], capsys)
    except SystemExit as e:
        code, err = e.code, capsys.readouterr().err
    assert code == 2 and message in err, err
    assert len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_same_output_twice_is_refused(tmp_path, capsys):
    out = tmp_path / "x.npz"
    code, _, err = run(["map", "--robot", "ur5e", "--out", str(out), "--html", str(out)], capsys)
    assert code == 2 and "are the same file" in err


def _targets_csv(path, T):
    from wsmap.kinematics import rotx  # noqa: F401 - the rows below are rpy
    from scipy.spatial.transform import Rotation

    rpy = Rotation.from_matrix(T[:, :3, :3]).as_euler("XYZ")  # R = Rx Ry Rz (intrinsic x-y-z)
    with open(path, "w") as f:
        f.write("x,y,z,r1,r2,r3\n")
        for t, a in zip(T, rpy):
            f.write(",".join(f"{v:.12f}" for v in (*t[:3, 3], *a)) + "\n")


def test_place_finds_the_base_the_targets_came_from(tmp_path, capsys):
    arm = robots.load("ur5e")
    T0 = arm.fkine(arm.random_q(200, np.random.default_rng(3)))
    far = np.argsort(-np.linalg.norm(T0[:, :3, 3], axis=1))[:15]
    T = ws.floor_poses(0.2, 0.1, 0.0) @ T0[far]
    _targets_csv(tmp_path / "t.csv", T)
    code, out, err = run(["place", "--robot", "ur5e", "--targets", str(tmp_path / "t.csv"), "--x", "-0.4", "0.4",
                          "--y", "-0.4", "0.4", "--out", str(tmp_path / "rank.csv")], capsys)
    assert code == 0, err
    first = out.splitlines()[2].split()
    assert (float(first[1]), float(first[2])) == (0.2, 0.1) and first[4] == "15/15"
    rank = np.genfromtxt(tmp_path / "rank.csv", delimiter=",", names=True)
    assert rank["score"][0] == 1.0 and np.all(np.diff(rank["score"]) <= 0)
    # the 16-column form of the same poses gives the same ranking
    np.savetxt(tmp_path / "t16.csv", T.reshape(-1, 16), delimiter=",")
    code, out16, _ = run(["place", "--robot", "ur5e", "--targets", str(tmp_path / "t16.csv"), "--x", "-0.4", "0.4",
                          "--y", "-0.4", "0.4"], capsys)
    assert code == 0 and out16.splitlines()[2] == out.splitlines()[2]


@pytest.mark.parametrize("content, message", [
    ("", "no poses in the file"),
    ("1,2,3\n", "every row needs 6 values"),
    ("x,y,z,a,b,c\n0,0,0.5,0,0,0\nfoo,1,2,3,4,5\n", "line 3, cell 1 is not a number: 'foo'"),
    ("0,0,0.5,0,0,nan\n", "NaN or infinite"),
    (",".join(["1"] * 16) + "\n", "targets is not a rigid transform"),
])
def test_place_bad_target_files(tmp_path, capsys, content, message):
    (tmp_path / "t.csv").write_text(content)
    code, _, err = run(["place", "--robot", "ur5e", "--targets", str(tmp_path / "t.csv"), "--out",
                        str(tmp_path / "r.csv")], capsys)
    assert code == 2 and message in err, err
    assert not (tmp_path / "r.csv").exists()


def test_place_bad_region(tmp_path, capsys):
    (tmp_path / "t.csv").write_text("0.5,0,0.3,0,0,0\n")
    code, _, err = run(["place", "--robot", "ur5e", "--targets", str(tmp_path / "t.csv"), "--y", "1", "0"], capsys)
    assert code == 2 and "--y: lo (1.0) is above hi (0.0)" in err
