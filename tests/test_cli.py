import numpy as np
import pytest

from wsmap import cli, robots
from wsmap import workspace as ws


def test_map_command_writes_the_exact_map(tmp_path):
    out = tmp_path / "puma.npz"
    png = tmp_path / "puma.png"
    assert cli.main(["map", "--robot", "puma560", "--out", str(out), "--png", str(png), "--quiet"]) == 0
    flat, nodes, grid, settings = cli.load_map(out)
    expected = ws.constant_orientation_map(robots.puma560(), ws.cartesian_grid(-1, 1, 0.1))
    np.testing.assert_array_equal(flat, expected)
    assert grid["shape"] == [21, 21, 21] and nodes.shape == (9261, 3)
    assert settings["method"] == "exact" and settings["convention"] == "paper"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_dh_columns_with_pi_expressions_equal_the_named_arm(tmp_path):
    out = tmp_path / "dh.npz"
    argv = ["map", "--d", "0", "0", "0.15005", "0.4318", "0", "0", "--a", "0", "0.4318", "0.0203", "0", "0", "0",
            "--alpha", "pi/2", "0", "-pi/2", "pi/2", "-pi/2", "0", "--lo", "-1", "--step", "0.5", "--quiet",
            "--out", str(out)]
    assert cli.main(argv) == 0
    flat = cli.load_map(out)[0]
    np.testing.assert_array_equal(flat, ws.constant_orientation_map(robots.puma560(), ws.cartesian_grid(-1, 1, 0.5)))


def test_numerical_so3_map(tmp_path):
    out = tmp_path / "so3.npz"
    assert cli.main(["map", "--scope", "SO3", "--step", "pi/3", "--method", "numerical", "--quiet",
                     "--out", str(out)]) == 0
    flat, nodes, grid, _ = cli.load_map(out)
    assert flat.shape == (343,) and grid["scope"] == "SO3"
    exact = ws.orientation_map(robots.puma560(), nodes, (0.5, 0.5, 0.5))
    assert not np.any(flat & ~exact)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--robot", "kuka"], "unknown robot 'kuka'"),
        (["--step", "0"], "step must be positive"),
        (["--d", "0", "0", "--a", "0", "0"], "need all three of --d, --a and --alpha"),
        (["--robot", "puma560", "--d", "0", "--a", "0", "--alpha", "0"], "either --robot or the DH columns"),
        (["--method", "model"], "needs a model file"),
        (["--qlim-deg", "0", "1"], "2 values per joint"),
    ],
)
def test_bad_arguments_exit_2_with_a_named_error(tmp_path, capsys, argv, message):
    out = tmp_path / "x.npz"
    assert cli.main(["map", *argv, "--quiet", "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_failed_run_keeps_the_previous_file(tmp_path):
    out = tmp_path / "keep.npz"
    assert cli.main(["map", "--step", "0.5", "--quiet", "--out", str(out)]) == 0
    before = out.read_bytes()
    assert cli.main(["map", "--step", "-1", "--quiet", "--out", str(out)]) == 2
    assert out.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["keep.npz"]


def test_load_map_rejects_garbage(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a readable wsmap map file"):
        cli.load_map(bad)


def test_render_mesh_of_puma560_is_closed():
    from wsmap.render import map_to_mesh

    flat = ws.constant_orientation_map(robots.puma560(), ws.cartesian_grid(-1, 1, 0.1))
    mesh = map_to_mesh(flat, (21, 21, 21), -1.0, 0.1)
    assert mesh.is_watertight
    assert np.all(mesh.bounds[0] >= -1.0 - 1e-9) and np.all(mesh.bounds[1] <= 1.0 + 1e-9)
    # the reachable volume is a thick shell of radius ~0.86 m: mesh volume between the grid
    # count's bounds (nodes x 0.001 m^3 give 2.6; marching cubes cuts corners)
    assert 1.5 < mesh.volume < 2.7
