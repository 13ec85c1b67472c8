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
        # (d5 = 0.1: no spherical wrist, twists of 1 rad: not the UR type)
        (["--d", "0", "0", "0.15", "0.43", "0.1", "0", "--a", "0", "0.43", "0.02", "0", "0", "0",
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


def test_a_bad_kernel_in_the_environment_is_one_line_before_any_work(tmp_path):
    import os

    out = tmp_path / "m.npz"
    r = subprocess.run([sys.executable, "-m", "wsmap", "map", "--robot", "panda", "--step", "0.5", "--out", str(out)],
                       capture_output=True, text=True, env={**os.environ, "WSMAP_KERNEL": "fast"})
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines() == ["wsmap: error: WSMAP_KERNEL must be one of lanes, scalar, not 'fast'"]
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


# ------------------------------------------------------------------ issue 29: a new user's bad and edge inputs
def _one_line_error(code, err, *parts):
    assert code == 2, err
    assert err.startswith("wsmap: error: ") or err.startswith("wsmap map: error: ") or \
        err.startswith("wsmap place: error: "), err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for p in parts:
        assert p in err, err


_URDF = """<?xml version="1.0"?>
<robot name="r3"><link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="t"/>
<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
<limit lower="LO" upper="HI" effort="1" velocity="1"/></joint>
<joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="j3" type="revolute"><parent link="c"/><child link="d"/><origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>
<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
<joint name="tool" type="fixed"><parent link="d"/><child link="t"/><origin xyz="TOOL 0 0"/></joint>
</robot>"""


def _urdf(tmp_path, lo="-3", hi="3", tool="0.3", name="arm.urdf"):
    path = tmp_path / name
    path.write_text(_URDF.replace("LO", lo).replace("HI", hi).replace("TOOL", tool))
    return path


@pytest.mark.parametrize("flag", ["--out", "--png", "--html"])
def test_an_output_that_is_the_input_urdf_is_refused_and_the_urdf_kept(tmp_path, capsys, flag):
    urdf = _urdf(tmp_path)
    before = urdf.read_bytes()
    argv = ["map", "--urdf", str(urdf), "--kind", "reach", "--step", "0.5", "--quiet", "--out", str(tmp_path / "m.npz")]
    argv += [flag, str(urdf)] if flag != "--out" else []
    if flag == "--out":
        argv[-1] = str(urdf)
    code, err = run(argv, capsys)
    _one_line_error(code, err, f"{flag} {str(urdf)!r} is the input --urdf")
    assert urdf.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["arm.urdf"]


def test_two_outputs_that_are_one_file_through_a_symlink_are_refused(tmp_path, capsys):
    (tmp_path / "real").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "real")
    code, err = run(["map", "--step", "0.5", "--quiet", "--out", str(tmp_path / "real" / "m.npz"),
                     "--html", str(tmp_path / "alias" / "m.npz")], capsys)
    _one_line_error(code, err, "are the same file")
    assert list((tmp_path / "real").iterdir()) == []


def test_an_unwritable_folder_is_found_by_writing_there_even_as_root(tmp_path, capsys):
    import tempfile

    try:  # /sys refuses new files to root too
        fd, probe = tempfile.mkstemp(dir="/sys")
    except OSError:
        pass
    else:  # pragma: no cover
        os.close(fd)
        os.unlink(probe)
        pytest.skip("/sys is writable here")
    code, err = run(["map", "--step", "0.5", "--quiet", "--out", str(tmp_path / "m.npz"), "--png", "/sys/m.png"],
                    capsys)
    _one_line_error(code, err, "--png path '/sys/m.png': no permission to write in '/sys'")
    assert list(tmp_path.iterdir()) == []


def test_a_png_name_without_the_png_suffix_is_refused_before_the_work(tmp_path, capsys):
    for name in ("slices", "s.xyz", "s.svg"):
        code, err = run(["map", "--step", "0.5", "--quiet", "--out", str(tmp_path / "n.npz"), "--png",
                         str(tmp_path / name)], capsys)
        _one_line_error(code, err, f"--png {str(tmp_path / name)!r}: the file name must end in .png")
    assert not list(tmp_path.iterdir())
    assert cli.main(["map", "--step", "0.5", "--quiet", "--out", str(tmp_path / "m.npz"), "--png",
                     str(tmp_path / "s.png")]) == 0
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_map_with_nothing_reachable_writes_its_npz_and_warns_that_the_views_are_skipped(tmp_path, capsys):
    # the map of nothing is a valid answer (exit 0); views of nothing are not possible: a warning on
    # stderr, even with --quiet, and no view file (an old one is left as it was)
    out = tmp_path / "m.npz"
    out.write_bytes(b"an older map")
    views = [tmp_path / "m.glb", tmp_path / "m.html", tmp_path / "m.ply"]
    views[1].write_text("an older view")
    code, err = run(["map", "--kind", "manipulability", "--lo", "5", "--hi", "5.2", "--step", "0.1", "--quiet",
                     "--out", str(out), "--glb", str(views[0]), "--html", str(views[1]), "--ply", str(views[2])],
                    capsys)
    assert code == 0, err
    assert err == ("wsmap: warning: --html and --ply and --glb: nothing to draw, no node of the map is reachable "
                   "(its values are all 0); the views were not written\n")
    flat = ws.load_map(out)[0]
    assert flat.shape == (27,) and not flat.any()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.html", "m.npz"]
    assert views[1].read_text() == "an older view"


def test_views_alone_of_a_map_with_nothing_reachable_write_nothing_and_say_so(tmp_path, capsys):
    code, err = run(["map", "--lo", "5", "--hi", "5.2", "--step", "0.1", "--ply", str(tmp_path / "m.ply")], capsys)
    assert code == 0, err
    assert "wsmap: warning: --ply: nothing to draw" in err and "the view was not written" in err
    assert not list(tmp_path.iterdir())


def test_one_reachable_node_draws_an_iso_surface(tmp_path):
    import trimesh

    glb = tmp_path / "m.glb"
    assert cli.main(["map", "--kind", "manipulability", "--lo", "0.6", "0", "0", "--hi", "0.62", "0", "0.01",
                     "--step", "0.1", "--quiet", "--out", str(tmp_path / "m.npz"), "--glb", str(glb)]) == 0
    flat = ws.load_map(tmp_path / "m.npz")[0]
    assert flat.shape == (1,) and flat[0] > 0
    assert len(trimesh.load(glb).geometry) == 1


@pytest.mark.parametrize("argv, message", [
    (["--tol", "1e-300"], "argument --tol: must be at least 1e-14"),
    (["--seed", str(2**70)], f"argument --seed: must be below 2**64 = {2**64}"),
    (["--kind", "index", "--orientations", "10000000"], "--orientations must be at most 100000"),
])
def test_values_beyond_what_the_work_can_use_are_refused(tmp_path, capsys, argv, message):
    try:
        code, err = run(["map", *argv, "--method", "numerical", "--step", "0.5", "--quiet",
                         "--out", str(tmp_path / "m.npz")], capsys)
    except SystemExit as e:  # argparse
        code, err = e.code, capsys.readouterr().err
    _one_line_error(code, err, message)
    assert list(tmp_path.iterdir()) == []


def test_a_urdf_with_two_roots_names_the_option_that_picks_the_base(tmp_path, capsys):
    urdf = tmp_path / "two.urdf"
    urdf.write_text(_URDF.replace("LO", "-3").replace("HI", "3").replace("TOOL", "0.3")
                    .replace('<link name="t"/>', '<link name="t"/><link name="world"/>'))
    code, err = run(["map", "--urdf", str(urdf), "--kind", "reach", "--step", "0.5", "--quiet",
                     "--out", str(tmp_path / "m.npz")], capsys)
    _one_line_error(code, err, "several root links (a, world); give base_link (wsmap map/place: --base LINK)")
    assert cli.main(["map", "--urdf", str(urdf), "--base", "a", "--kind", "reach", "--step", "0.5", "--quiet",
                     "--out", str(tmp_path / "m.npz")]) == 0
    code, err = run(["map", "--robot", "ur5e", "--base", "a", "--quiet", "--out", str(tmp_path / "n.npz")], capsys)
    _one_line_error(code, err, "--base names the first link of a --urdf arm")


def test_a_tool_origin_at_1e308_maps_nothing_reachable_without_a_traceback(tmp_path, capsys):
    urdf = _urdf(tmp_path, tool="1e308")
    code, err = run(["map", "--urdf", str(urdf), "--kind", "reach", "--step", "0.5", "--quiet",
                     "--out", str(tmp_path / "m.npz")], capsys)
    assert code == 0 and "Traceback" not in err, err
    assert not ws.load_map(tmp_path / "m.npz")[0].any()


def test_limits_of_1e308_map_like_a_joint_without_limits(tmp_path, capsys):
    wide, turn = _urdf(tmp_path, "-1e308", "1e308", name="wide.urdf"), _urdf(tmp_path, "-3.1416", "3.1416")
    for urdf in (wide, turn):
        assert cli.main(["map", "--urdf", str(urdf), "--kind", "reach", "--step", "0.25", "--quiet",
                         "--out", str(urdf.with_suffix(".npz"))]) == 0
    a, b = ws.load_map(wide.with_suffix(".npz"))[0], ws.load_map(turn.with_suffix(".npz"))[0]
    assert a.sum() > 0 and a.sum() == b.sum()


# ------------------------------------------------------------------ wsmap place: the targets file and the sizes
def _place(tmp_path, capsys, text, *extra):
    targets = tmp_path / "t.csv"
    targets.write_bytes(text if isinstance(text, bytes) else text.encode())
    argv = ["place", "--robot", "puma560", "--targets", str(targets), "--step", "1", "--yaws", "1", "--quiet",
            "--out", str(tmp_path / "r.csv"), *extra]
    try:
        code, err = run(argv, capsys)
    except SystemExit as e:
        code, err = e.code, capsys.readouterr().err
    return code, err, tmp_path / "r.csv"


def _ranked_targets(csv):
    return csv.read_text().splitlines()[0].count("target_")


@pytest.mark.parametrize("text", [
    "0.5,0,0.3,0,0,0\n0.4,0,0.3,0,0,0\n",
    "\ufeffx,y,z,r1,r2,r3\n0.5,0,0.3,0,0,0\n0.4,0,0.3,0,0,0\n",  # Excel's UTF-8 byte-order mark
    "\ufeff0.5,0,0.3,0,0,0\n0.4,0,0.3,0,0,0\n",
    "0.5 0 0.3 0 0 0\n0.4  0  0.3 0 0 0\n",  # space-separated
    "0.5;0;0.3;0;0;0\n0.4\t0\t0.3\t0\t0\t0\n",
])
def test_every_target_row_is_read(tmp_path, capsys, text):
    code, err, out = _place(tmp_path, capsys, text)
    assert code == 0, err
    assert _ranked_targets(out) == 2


@pytest.mark.parametrize("text, message", [
    ("0.5,0,O.3,0,0,0\n0.5,0,0.3,0,0,0\n", "line 1, cell 3 is not a number: 'O.3'"),
    ("x,y,z,r1,r2,r3\n0.5,0,O.3,0,0,0\n0.5,0,0.3,0,0,0\n", "line 2, cell 3 is not a number: 'O.3'"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe", "not a text file (byte 0 is not UTF-8)"),
    (b"0.5,0,0.3,0,0,0\x00\n", "not a text file (it holds NUL bytes)"),
])
def test_a_bad_targets_file_is_named_not_dropped(tmp_path, capsys, text, message):
    code, err, out = _place(tmp_path, capsys, text)
    _one_line_error(code, err, f"--targets {tmp_path / 't.csv'}: {message}")
    assert not out.exists()


def test_place_refuses_its_input_as_output_and_sizes_beyond_the_bounds(tmp_path, capsys):
    targets = tmp_path / "t.csv"
    targets.write_text("0.5,0,0.3,0,0,0\n")
    code, err = run(["place", "--targets", str(targets), "--out", str(targets), "--quiet"], capsys)
    _one_line_error(code, err, f"--out {str(targets)!r} is the input --targets")
    assert targets.read_text() == "0.5,0,0.3,0,0,0\n"
    for extra, message in ((["--yaws", str(2**40)], "yaws must be at most 3600"),
                           (["--x", "-1e200", "1e200"], "candidate bases, more than 1e+07")):
        code, err = run(["place", "--targets", str(targets), "--quiet", *extra], capsys)
        _one_line_error(code, err, message)
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


# ------------------------------------------------------------------ wsmap data build: the cluster
@pytest.mark.parametrize("argv, message", [
    (["--workers", str(4 * len(os.sched_getaffinity(0)) + 1)], f"(4 per core of the {len(os.sched_getaffinity(0))} here)"),
    (["--scheduler", "tcp://127.0.0.1:1", "--connect-timeout", "1e308"], "connect_timeout must be at most 3600 s"),
])
def test_cluster_settings_beyond_the_machine_are_refused(tmp_path, capsys, argv, message):
    code, err = run(["data", "build", "sec61", "--samples", "2", "--out", str(tmp_path / "d.npz"), "--quiet", *argv],
                    capsys)
    _one_line_error(code, err, message)
    assert list(tmp_path.iterdir()) == []


def test_a_bad_scheduler_address_is_one_line_and_nothing_after_it(tmp_path):
    p = subprocess.run([sys.executable, "-m", "wsmap", "data", "build", "sec61", "--samples", "2", "--quiet",
                        "--out", str(tmp_path / "d.npz"), "--scheduler", "tcp://", "--connect-timeout", "1"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2
    assert p.stderr.startswith("wsmap: error: 'tcp://' is not a Dask scheduler address"), p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr  # no "Exception ignored in: Client.__del__"
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ wsmap paper: the parameters file
@pytest.mark.parametrize("text, message", [
    ("datasets:\n  a: [1, 2\n", "is not valid YAML at line 3, column 1: expected ',' or ']'"),
    (b"\x7fELF\x02\x01\x01\x00\xff\xfe", "is not a text file (byte 8 is not UTF-8)"),
    ("a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\nb: &b [" + ", ".join(["*a"] * 10) + "]\nc: &c [" +
     ", ".join(["*b"] * 10) + "]\nd: &d [" + ", ".join(["*c"] * 10) + "]\ne: [" + ", ".join(["*d"] * 10) + "]\n",
     "holds more than 100000 values once its YAML aliases (*name) are expanded"),
])
@pytest.mark.parametrize("command", [["paper", "run", "sec61_subspace"], ["paper", "full", "--list"]])
def test_a_bad_parameters_file_is_one_line_naming_it(tmp_path, capsys, text, message, command):
    params = tmp_path / "p.yaml"
    params.write_bytes(text if isinstance(text, bytes) else text.encode())
    code, err = run([*command, "--params", str(params)], capsys)
    _one_line_error(code, err, f"{params} {message}")


# ------------------------------------------------------------------ wsmap paper without the paper extra
@pytest.mark.parametrize("command", [["paper", "list"], ["paper", "run", "sec61_subspace"], ["paper", "full", "--list"]])
def test_wsmap_paper_without_pandas_names_the_extra(capsys, monkeypatch, command):
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas fails, as where it is not installed
    code, err = run(command, capsys)
    sub = " ".join(command[:2])
    assert err == f"wsmap: error: wsmap {sub} needs pandas, which is not installed: pip install 'wsmap[paper]'\n"
    assert code == 2


def test_wsmap_paper_outside_a_checkout_says_where_it_looked(tmp_path, capsys, monkeypatch):
    from wsmap import paths

    monkeypatch.delenv("WSMAP_ROOT", raising=False)
    monkeypatch.setattr(paths, "ROOT", tmp_path / "site-packages")
    monkeypatch.setattr(paths, "NOTEBOOKS", tmp_path / "site-packages" / "notebooks")
    monkeypatch.chdir(tmp_path)
    code, err = run(["paper", "list"], capsys)
    _one_line_error(code, err, f"neither {tmp_path / 'site-packages'} (where wsmap is installed) nor a folder above "
                               f"the working directory {tmp_path} is one")
    monkeypatch.setenv("WSMAP_ROOT", str(tmp_path / "site-packages"))
    code, err = run(["paper", "list"], capsys)
    _one_line_error(code, err, f"WSMAP_ROOT ({tmp_path / 'site-packages'}) is not one: set it to the checkout")


def test_place_prints_its_tie_break_and_no_negative_zero(tmp_path, capsys):
    arm = robots.load("ur5e")
    q = np.array([[0.3, -1.2, 1.4, -1.5, -1.4, 0.2], [-0.4, -1.0, 1.1, -1.3, -1.6, 0.5]])
    np.savetxt(tmp_path / "t.csv", arm.fkine(q).reshape(-1, 16), delimiter=",")
    code = cli.main(["place", "--robot", "ur5e", "--targets", str(tmp_path / "t.csv"), "--x", "-0.3", "0.3",
                     "--y", "-0.3", "0.3", "--yaws", "4", "--top", "40", "--out", str(tmp_path / "r.csv")])
    out = capsys.readouterr().out
    assert code == 0
    assert "-0.000" not in out and "-0.0 " not in out
    lines = out.splitlines()
    assert lines[1].split() == ["rank", "x", "(m)", "y", "(m)", "yaw", "(deg)", "reached", "mean", "manip.", "margin"]
    rows = [line.split() for line in lines[2:42]]
    manip = [float(r[-2]) for r in rows if r[4] == "2/2"]
    assert len(manip) > 5 and manip == sorted(manip, reverse=True)
    assert "ties: the higher mean manipulability of the solutions first, then the higher mean joint-limit margin" in out
    rank = np.genfromtxt(tmp_path / "r.csv", delimiter=",", names=True)
    assert rank.dtype.names[:6] == ("rank", "x_m", "y_m", "yaw_rad", "score", "mean_manipulability")
    assert not np.any(np.signbit(rank["x_m"]) & (rank["x_m"] == 0))
    with open(tmp_path / "r.csv") as f:
        assert "-0.000000" not in f.read()
