"""wsmap.workspace.kinds: the registry of map kinds, every kind end to end through `wsmap map`, and a
kind registered from outside the package reaching the command line and the map files."""

import pkgutil
from pathlib import Path

import numpy as np
import pytest

from wsmap import cli, robots
from wsmap import workspace as ws
from wsmap.workspace import kinds
from wsmap.workspace.files import MapFileError


def run(argv, capsys):
    code = cli.main(argv)
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def _tiny_grid_args(kind):
    """A grid of a few nodes of the kind's scope, and the kind's own inputs set small."""
    args = ["--step", "0.5"] if kind.scope == "R3" else ["--step", "pi/2"]
    if "orientations" in kind.inputs:
        args += ["--orientations", "3"]
    return args


# ---------------------------------------------------------------------------------------------
# every registered kind, end to end
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", kinds.kind_names())
def test_every_kind_runs_through_the_cli_and_its_file_reproduces_it(tmp_path, capsys, name):
    kind = kinds.get_kind(name)
    out = tmp_path / f"{name}.npz"
    code, stdout, err = run(["map", "--robot", "puma560", "--kind", name, *_tiny_grid_args(kind), "--out", str(out),
                             "--png", str(tmp_path / "s.png")], capsys)
    assert code == 0, err
    assert f" {name} map " in stdout and (tmp_path / "s.png").stat().st_size > 1000
    flat, nodes, grid, settings = ws.load_map(out)
    assert settings["kind"] == name and grid["scope"] == kind.scope and flat.dtype == kind.dtype
    assert flat.shape == (len(nodes),) == (int(np.prod(grid["shape"])),)
    # the settings a file records are the request that computes the same map again
    request = kinds.MapRequest(method=settings["method"], convention=settings["convention"], rpy=tuple(settings["rpy"]),
                           point=tuple(settings["point"]), orientations=settings.get("orientations"),
                           ik=settings["ik"], seed=0)
    np.testing.assert_array_equal(kind.compute(robots.puma560(), grid, request), flat)
    assert kind.summary(flat) in stdout


def test_the_kinds_and_their_functions():
    assert kinds.kind_names() == ("constant", "orientation", "index", "reach", "dexterous", "manipulability")
    assert kinds.default_kind("R3").name == "constant" and kinds.default_kind("SO3").name == "orientation"
    assert [k.name for k in kinds.kinds_taking("orientations")] == ["index", "dexterous"]
    assert kinds.get_kind("index").function is ws.reachability_index
    assert kinds.get_kind("manipulability").function is ws.manipulability_map
    assert kinds.get_kind("constant").function is ws.constant_orientation_map
    assert {k.name for k in kinds.kinds() if k.value_type is float} == {"index", "manipulability"}
    assert kinds.get_kind("manipulability").levels(np.array([0.0, 1.0, 2.0, 3.0, 4.0])) == (1.75, 2.5, 3.25)
    assert kinds.get_kind("reach").levels(np.zeros(3)) == (0.5,)
    assert kinds.get_kind("dexterous").summary(np.array([True, False, True])) == "2 of 3 nodes dexterous"
    # the mean over the reachable nodes, not the box (the unreachable 0 would make it 0.500)
    assert (kinds.get_kind("index").summary(np.array([0.0, 0.5, 1.0]))
            == "2 of 3 nodes reachable, mean reachability index over reachable nodes 0.750")
    assert kinds.get_kind("index").summary(np.zeros(3)) == "0 of 3 nodes reachable"


def test_every_module_of_the_package_registers_one_kind():
    folder = Path(kinds.__file__).parent
    modules = [m.name for m in pkgutil.iter_modules([str(folder)]) if m.name != "registry"]
    registered = {k.name: k for k in kinds.kinds()}
    for name in modules:
        module = getattr(kinds, name, None)
        assert module is not None, f"wsmap/workspace/kinds/{name}.py is not imported by the package's __init__"
        assert registered[module.KIND.name] is module.KIND
    assert len(modules) == len(registered)


def test_unknown_kind_is_an_error_naming_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown map kind 'volume'; known kinds: constant, orientation, index"):
        kinds.get_kind("volume")
    with pytest.raises(ValueError, match="already registered"):
        kinds.register(kinds.get_kind("index"))


@pytest.mark.parametrize("change, message", [
    (dict(name="Big Kind"), "lower case letters"),
    (dict(scope="R6"), "scope must be one of R3, SO3"),
    (dict(value_type=int), "value_type must be bool or float"),
    (dict(inputs=("colour",)), "inputs must be a tuple of rpy, point, orientations, convention"),
    (dict(methods=("exact",)), "every kind has the numerical method"),
    (dict(inputs=("convention",), convention="standard"), "either takes the caller's convention"),
    (dict(compute=None), "compute must be callable"),
    (dict(priority="first"), "priority must be an int"),
])
def test_a_bad_kind_record_is_refused(change, message):
    fields = dict(name="toy", scope="R3", value_type=bool, compute=_distance_compute, function=np.linalg.norm,
                  description="toy", priority=100, convention="standard")
    with pytest.raises(ValueError, match=message):
        kinds.MapKind(**{**fields, **change})


# ---------------------------------------------------------------------------------------------
# a kind from outside the package: one record, registered; nothing in the CLI or files changes
# ---------------------------------------------------------------------------------------------


def _distance_compute(robot, grid, request):
    """The toy kind: each node's distance from the base (m)."""
    nodes = ws.cartesian_grid(grid["lo"], grid["hi"], grid["step"])
    return np.linalg.norm(nodes, axis=1)


@pytest.fixture
def distance_kind():
    kind = kinds.register(kinds.MapKind(
        name="distance", scope="R3", value_type=float, compute=_distance_compute, function=np.linalg.norm,
        description="the distance of each position from the base (a test's toy kind)", priority=100,
        label="distance (m)",
        convention="standard", levels=lambda v: (0.5,), value_range=(0.0, None)))
    try:
        yield kind
    finally:
        kinds.unregister("distance")
    assert "distance" not in kinds.kind_names()


def test_a_registered_kind_reaches_the_command_line_and_the_map_files(tmp_path, capsys, distance_kind):
    with pytest.raises(SystemExit):
        cli.main(["map", "--help"])
    help_text = capsys.readouterr().out
    assert "distance" in help_text.split("--kind")[1] and "the distance of each position" in help_text
    out = tmp_path / "d.npz"
    code, stdout, err = run(["map", "--robot", "puma560", "--kind", "distance", "--step", "0.5", "--out", str(out),
                             "--png", str(tmp_path / "d.png"), "--glb", str(tmp_path / "d.glb")], capsys)
    assert code == 0, err
    assert "124 of 125 nodes reachable, mean distance (m)" in stdout  # all but the origin
    flat, nodes, grid, settings = ws.load_map(out)
    assert settings["kind"] == "distance" and settings["convention"] == "standard" and flat.dtype == np.float64
    np.testing.assert_allclose(flat, np.linalg.norm(nodes, axis=1))
    assert (tmp_path / "d.glb").stat().st_size > 100
    # a kind that is not registered: its files do not load, its name is not a choice
    kinds.unregister("distance")
    try:
        with pytest.raises(MapFileError, match="unknown map kind 'distance'; known kinds: constant"):
            ws.load_map(out)
        with pytest.raises(SystemExit) as e:
            cli.main(["map", "--kind", "distance", "--out", str(tmp_path / "e.npz")])
        assert e.value.code == 2 and "invalid choice: 'distance'" in capsys.readouterr().err
    finally:
        kinds.register(distance_kind)


def test_map_files_check_the_kind_before_writing_and_when_loading(tmp_path, distance_kind):
    grid = ws.grid_spec("R3", -0.5, 0.5, 0.5)
    with pytest.raises(ValueError, match="a 'constant' map holds bool values, not float64"):
        ws.save_map(tmp_path / "a.npz", np.zeros(27), grid, {"kind": "constant"})
    with pytest.raises(ValueError, match="a 'distance' map holds float64 values, not bool"):
        ws.save_map(tmp_path / "a.npz", np.zeros(27, dtype=bool), grid, {"kind": "distance"})
    so3 = ws.grid_spec("SO3", 0, np.pi, np.pi / 2)
    with pytest.raises(ValueError, match="a 'constant' map lies on an R3 grid, not 'SO3'"):
        ws.save_map(tmp_path / "a.npz", np.zeros(27, dtype=bool), so3, {"kind": "constant"})
    with pytest.raises(ValueError, match="unknown map kind 'volume'"):
        ws.save_map(tmp_path / "a.npz", np.zeros(27, dtype=bool), grid, {"kind": "volume"})
    assert list(tmp_path.iterdir()) == []
    # a file whose map does not fit its recorded kind does not load
    ws.save_map(tmp_path / "b.npz", np.zeros(27), grid, {"kind": "distance"})
    with np.load(tmp_path / "b.npz") as z:
        arrays = dict(z)
    arrays["settings"] = np.array('{"kind": "constant"}')
    np.savez(tmp_path / "c.npz", **arrays)
    with pytest.raises(MapFileError, match="a 'constant' map holds bool values, not float64"):
        ws.load_map(tmp_path / "c.npz")
    # no kind recorded: as before, any bool or float map
    ws.save_map(tmp_path / "d.npz", np.arange(27.0), grid, {})
    np.testing.assert_array_equal(ws.load_map(tmp_path / "d.npz")[0], np.arange(27.0))


@pytest.mark.parametrize("values, levels", [
    ([0.0, 0.2, 0.0], (0.1,)),  # one reachable node: half its value (its quartiles are all 0.2)
    ([0.3, 0.3, 0.3, 0.0], (0.15,)),  # many of one value
    ([0.0, 0.0], ()),  # nothing reachable: no level (and no IndexError)
    ([0.1, 0.2, 0.3, 0.4, 0.5], (0.2, 0.3, 0.4)),  # the quartiles of the reachable nodes
])
def test_manipulability_levels_are_distinct_and_below_the_largest_value(values, levels):
    got = kinds.get_kind("manipulability").levels(np.array(values))
    np.testing.assert_allclose(got, levels, rtol=1e-12)
    assert len(set(got)) == len(got) and all(v < max(values) for v in got)
