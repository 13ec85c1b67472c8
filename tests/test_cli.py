"""The one command line: results, and bad input (exit 2, one line, nothing written, nothing lost)."""

import os
import subprocess
import sys

from pathlib import Path

import numpy as np
import pytest

from wsmap import cli, robots
from wsmap import workspace as ws


def run(argv, capsys):
    code = cli.main(argv)
    err = capsys.readouterr().err
    return code, err


def test_map_command_writes_the_exact_map(tmp_path):
    out = tmp_path / "puma.npz"
    png = tmp_path / "puma.png"
    assert cli.main(["map", "--robot", "puma560", "--out", str(out), "--png", str(png), "--quiet"]) == 0
    flat, nodes, grid, settings = ws.load_map(out)
    expected = ws.constant_orientation_map(robots.puma560(), ws.cartesian_grid(-1, 1, 0.1))
    np.testing.assert_array_equal(flat, expected)
    assert grid["shape"] == [21, 21, 21] and nodes.shape == (9261, 3)
    assert settings["method"] == "exact" and settings["convention"] == "standard"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["puma.npz", "puma.png"]


def test_dh_columns_with_pi_expressions_equal_the_named_arm(tmp_path):
    out = tmp_path / "dh.npz"
    argv = ["map", "--d", "0", "0", "0.15005", "0.4318", "0", "0", "--a", "0", "0.4318", "0.0203", "0", "0", "0",
            "--alpha", "pi/2", "0", "-pi/2", "pi/2", "-pi/2", "0", "--lo", "-1", "--step", "0.5", "--quiet",
            "--out", str(out)]
    assert cli.main(argv) == 0
    flat = ws.load_map(out)[0]
    np.testing.assert_array_equal(flat, ws.constant_orientation_map(robots.puma560(), ws.cartesian_grid(-1, 1, 0.5)))


def test_numerical_so3_map(tmp_path):
    out = tmp_path / "so3.npz"
    assert cli.main(["map", "--scope", "SO3", "--step", "pi/3", "--method", "numerical", "--quiet",
                     "--out", str(out)]) == 0
    flat, nodes, grid, _ = ws.load_map(out)
    assert flat.shape == (343,) and grid["scope"] == "SO3"
    exact = ws.orientation_map(robots.puma560(), nodes, (0.5, 0.5, 0.5))
    assert not np.any(flat & ~exact)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--robot", "kuka"], "unknown robot 'kuka'"),
        (["--step", "0"], "step must be positive"),
        (["--d", "0", "0", "--a", "0", "0"], "need all three of --d, --a and --alpha"),
        (["--robot", "puma560", "--d", "0", "--a", "0", "--alpha", "0"], "give one arm: --robot and the DH columns"),
        (["--robot", "panda", "--urdf", "x.urdf"], "give one arm: --robot and --urdf"),
        (["--ee", "tool0"], "--ee names the end link of a --urdf arm"),
        (["--urdf", "/nonexistent.urdf"], "no such file"),
        (["--mdh"], "--mdh and --offset describe DH columns"),
        (["--robot", "panda", "--method", "exact"], "no closed form for panda"),
        (["--robot", "puma560", "--starts", "4"], "--starts is used by the numerical method (method is 'exact')"),
        (["--robot", "panda", "--paper-lm", "--starts", "4"], "takes no --starts"),
        (["--d", "0", "0", "--a", "1", "1", "--alpha", "0", "0", "--joint-limits"], "needs the limits: --qlim-deg"),
        (["--robot", "panda", "--qlim-deg", "10", "-10", "0", "1", "0", "1", "0", "1", "0", "1", "0", "1", "0", "1"],
         "qlim of joint 1 has its lower limit above its upper limit"),
        (["--starts", "-1"], "must be at least 0"),
        (["--robot", "ur5e", "--method", "exact", "--starts", "2"], "--starts is used by the numerical method"),
        (["--method", "model"], "needs a model file"),
        (["--method", "model", "--model", "/nonexistent/m.pt"], "no such file"),
        (["--model", "m.pt"], "only used with --method model"),
        (["--allow-extrapolation"], "only used with --method model"),
        (["--qlim-deg", "0", "1"], "2 values per joint"),
        # 1e-300 used to overflow the node count and write a 0-node map with exit 0
        (["--step", "1e-300"], "use a coarser step"),
        (["--step", "0.1", "0.1"], "--step takes one value or three"),
        (["--lo", "2", "--hi", "1"], "lo must not exceed hi"),
        (["--d", "0", "0", "0.15", "0.43", "0", "0", "--a", "0", "0.43", "0.02", "0", "0", "0",
          "--alpha", "1", "0", "-1", "1", "-1", "0", "--method", "exact"], "has no closed form for custom"),
        (["--d", "0", "--a", "0", "0", "--alpha", "0"], "DH columns disagree"),
        # argparse-level errors: one line too
        (["--alpha", "9**9**9"], "not a finite number or pi expression: '9**9**9'"),
        (["--alpha", "1e999"], "not a finite number"),
        (["--alpha", "__import__('os')"], "not a finite number or pi expression"),
        (["--ilimit", "0"], "must be at least 1"),
        (["--tol", "-1"], "must be positive"),
        (["--method", "magic"], "invalid choice: 'magic'"),
        (["--scope", "SE3"], "invalid choice: 'SE3'"),
    ],
)
def test_bad_arguments_exit_2_with_one_line_naming_the_problem(tmp_path, capsys, argv, message):
    out = tmp_path / "x.npz"
    try:
        code, err = run(["map", *argv, "--quiet", "--out", str(out)], capsys)
    except SystemExit as e:  # argparse
        code, err = e.code, capsys.readouterr().err
    assert code == 2
    assert message in err, err
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("out", ["", ".", "/", "sub/"])
def test_output_paths_that_cannot_be_files(tmp_path, capsys, monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    code, err = run(["map", "--step", "0.5", "--quiet", "--out", out], capsys)
    assert code == 2 and ("is empty" in err or "is a directory" in err), err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_unwritable_folder_is_named(tmp_path, capsys):  # pragma: no cover - CI runs as root
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    code, err = run(["map", "--step", "0.5", "--quiet", "--out", str(ro / "m.npz")], capsys)
    assert code == 2 and str(ro) in err


def test_output_in_a_file_used_as_folder_is_named(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    code, err = run(["map", "--step", "0.5", "--quiet", "--out", str(tmp_path / "afile" / "m.npz")], capsys)
    assert code == 2 and "afile" in err and "is not a directory" in err


def test_a_failed_png_leaves_the_existing_map_untouched(tmp_path, capsys):
    out = tmp_path / "keep.npz"
    assert cli.main(["map", "--step", "0.5", "--quiet", "--out", str(out)]) == 0
    before = out.read_bytes()
    # a PNG in an unknown image format fails after the map is computed: the old map must survive
    code, err = run(["map", "--step", "1", "--quiet", "--out", str(out), "--png", str(tmp_path / "x.notanimage")],
                    capsys)
    assert code == 2 and "notanimage" in err
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.npz"]


def test_a_failed_run_keeps_the_previous_file(tmp_path):
    out = tmp_path / "keep.npz"
    assert cli.main(["map", "--step", "0.5", "--quiet", "--out", str(out)]) == 0
    before = out.read_bytes()
    assert cli.main(["map", "--step", "-1", "--quiet", "--out", str(out)]) == 2
    assert out.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["keep.npz"]


def test_same_file_for_out_and_png(tmp_path, capsys):
    code, err = run(["map", "--quiet", "--out", str(tmp_path / "a.npz"), "--png", str(tmp_path / "a.npz")], capsys)
    assert code == 2 and "same file" in err


def test_load_map_rejects_garbage(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a readable wsmap map file"):
        ws.load_map(bad)
    with pytest.raises(ValueError, match="is not a file"):
        ws.load_map(tmp_path)
    with pytest.raises(FileNotFoundError):
        ws.load_map(tmp_path / "missing.npz")


@pytest.mark.parametrize(
    "argv, message",
    [
        (["data", "build", "nosuch", "--out", "X"], "unknown dataset 'nosuch'"),
        (["data", "build", "sec61", "--samples", "0", "--out", "X"], "must be at least 1"),
        (["data", "build", "sec61", "--samples", "-3", "--out", "X"], "must be at least 1"),
        (["data", "build", "sec61", "--samples", "10", "--test-samples", "0", "--out", "X"], "must be at least 1"),
        (["data", "build", "sec61", "--test", "--test-samples", "5", "--out", "X"], "give one of them"),
        (["data", "build", "sec61", "--samples", "10", "--out", ""], "empty"),
        (["paper", "run"], "name at least one notebook"),
        (["paper", "run", "nosuch"], "unknown notebook 'nosuch'"),
        (["paper", "run", "sec61_subspace", "--all"], "not both"),
        (["paper", "run", "sec61_subspace", "--params", "/nonexistent.yaml"], "no parameters file"),
        (["nosuch"], "invalid choice: 'nosuch'"),
    ],
)
def test_data_and_paper_bad_input(tmp_path, capsys, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    try:
        code, err = run(argv, capsys)
    except SystemExit as e:
        code, err = e.code, capsys.readouterr().err
    assert code == 2 and message in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_every_subcommand_has_help():
    for argv in (["--help"], ["map", "--help"], ["data", "--help"], ["data", "build", "--help"],
                 ["paper", "--help"], ["paper", "run", "--help"]):
        with pytest.raises(SystemExit) as e:
            cli.main(argv)
        assert e.value.code == 0


def test_the_installed_command_prints_no_traceback(tmp_path):
    r = subprocess.run([sys.executable, "-m", "wsmap", "map", "--step", "1e-300", "--out", str(tmp_path / "m.npz")],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and r.stderr.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_mesh_of_puma560_is_closed():
    from wsmap.views import iso_mesh

    flat = ws.constant_orientation_map(robots.puma560(), ws.cartesian_grid(-1, 1, 0.1))
    mesh = iso_mesh(flat, ws.grid_spec("R3", -1, 1, 0.1), 0.5)
    assert mesh.is_watertight
    assert np.all(mesh.bounds[0] >= -1.0 - 1e-9) and np.all(mesh.bounds[1] <= 1.0 + 1e-9)
    # the reachable volume is a thick shell of radius ~0.86 m: mesh volume between the grid
    # count's bounds (nodes x 0.001 m^3 give 2.6; marching cubes cuts corners)
    assert 1.5 < mesh.volume < 2.7


def test_named_real_arm_uses_the_numerical_search_within_its_limits(tmp_path, capsys):
    out = tmp_path / "panda.npz"
    assert cli.main(["map", "--robot", "panda", "--step", "0.5", "--out", str(out)]) == 0
    summary = capsys.readouterr().out
    s = ws.MAP_SETTINGS
    assert (f"numerical constant map (start at q = 0, {s['starts']} random, neighbours' solutions, {s['retry']} retries, "
            "seed 0, joint limits on)") in summary
    flat, nodes, grid, settings = ws.load_map(out)
    assert settings["method"] == "numerical" and settings["ik"]["retry"] == s["retry"]
    assert "Franka" in settings["source"] and np.isfinite(settings["qlim"]).all()
    expected = ws.constant_orientation_map(robots.load("panda"), nodes, method="numerical")
    np.testing.assert_array_equal(flat, expected)
    assert 0 < flat.sum() < flat.size


def test_auto_method_is_exact_for_the_closed_form_families(tmp_path, capsys):
    assert cli.main(["map", "--robot", "puma560", "--step", "0.5", "--out", str(tmp_path / "p.npz")]) == 0
    assert "exact constant map (closed form (spherical-wrist family), joint limits off)" in capsys.readouterr().out
    assert cli.main(["map", "--robot", "ur5e", "--step", "0.5", "--out", str(tmp_path / "u.npz")]) == 0
    assert "exact constant map (closed form (ur family), joint limits on)" in capsys.readouterr().out
    flat, nodes, grid, settings = ws.load_map(tmp_path / "u.npz")
    assert settings["method"] == "exact"
    np.testing.assert_array_equal(flat, ws.constant_orientation_map(robots.load("ur5e"), nodes, method="numerical"))


def test_urdf_arm_equals_the_named_arm(tmp_path):
    import rtbdata  # test-only: the URDFs of real arms

    urdf = Path(rtbdata.__file__).parent / "xacro/kuka_description/kuka_lbr_iiwa/urdf/lbr_iiwa_14_r820.urdf"
    out = tmp_path / "iiwa.npz"
    assert cli.main(["map", "--urdf", str(urdf), "--ee", "tool0", "--step", "0.5", "--quiet", "--out", str(out)]) == 0
    flat, nodes, _, settings = ws.load_map(out)
    assert settings["urdf"] == str(urdf) and settings["ee"] == "tool0" and settings["n"] == 7
    named = ws.constant_orientation_map(robots.load("iiwa14"), nodes, method="numerical",
                                        ik=dict(starts=ws.DEFAULT_STARTS, seed=0))
    # the URDF differs from KUKA's dimensions by 0.4 mm side offsets: at 0.5 m spacing the maps agree
    assert np.mean(flat == named) >= 0.99


def test_modified_dh_columns(tmp_path):
    d, a = [0.333, 0, 0.316, 0, 0.384, 0, 0], [0, 0, 0, 0.0825, -0.0825, 0, 0.088]
    alpha = ["0", "-pi/2", "pi/2", "pi/2", "-pi/2", "pi/2", "pi/2"]
    out = tmp_path / "mdh.npz"
    argv = ["map", "--mdh", "--d", *map(str, d), "--a", *map(str, a), "--alpha", *alpha, "--starts", "4",
            "--step", "0.5", "--quiet", "--out", str(out)]
    assert cli.main(argv) == 0
    flat, nodes, _, settings = ws.load_map(out)
    assert settings["qlim"] is None and settings["ik"]["starts"] == 4
    chain = robots.from_dh(d, a, [0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2], modified=True)
    np.testing.assert_array_equal(flat, ws.constant_orientation_map(chain, nodes, method="numerical",
                                                                    ik=dict(starts=4, seed=0)))


def test_paper_lm_is_the_one_start_paper_solver(tmp_path, capsys):
    out = tmp_path / "p.npz"
    assert cli.main(["map", "--method", "numerical", "--paper-lm", "--step", "0.25", "--out", str(out)]) == 0
    assert "the paper's LM, one start at q = 0" in capsys.readouterr().out
    flat, nodes, _, _ = ws.load_map(out)
    np.testing.assert_array_equal(flat, ws.constant_orientation_map(robots.puma560(), nodes, method="numerical",
                                                                    ik=dict(solver="paper")))


def test_a_urdf_that_is_not_xml_is_one_line(tmp_path, capsys):
    bad = tmp_path / "arm.urdf"
    bad.write_text("this is not xml")
    code, err = run(["map", "--urdf", str(bad), "--quiet", "--out", str(tmp_path / "m.npz")], capsys)
    assert code == 2 and "arm.urdf" in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["arm.urdf"]


def test_robots_lists_every_named_arm_with_its_source(capsys):
    assert cli.main(["robots"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in out] == list(robots.ROBOTS)
    assert all(";" in line for line in out)
