"""``progress=`` of every map function: a callable sees the work as it is done (many calls that add up
to the total, not one at the end), ``True`` draws a bar on stderr, and the map is the same either way."""

from __future__ import annotations

import numpy as np
import pytest

from wsmap import cli, robots
from wsmap import workspace as ws
from wsmap.kinematics import map_search
from wsmap.workspace.kinds import MapRequest, get_kind, kinds


class Counter:
    def __init__(self):
        self.calls = []

    def __call__(self, n):
        assert isinstance(n, int) and n > 0
        self.calls.append(n)


@pytest.fixture(scope="module")
def panda():
    return robots.load("panda")


def test_the_neighbour_search_reports_as_it_solves(panda):
    nodes = ws.cartesian_grid(-0.8, 0.8, 0.2)
    T = ws.target_poses(nodes, (np.pi, 0, 0))
    seen = Counter()
    res = map_search(panda, T, ws.node_neighbours(nodes), progress=seen)
    assert sum(seen.calls) == len(nodes)
    # the reach filter's verdicts, the first pass, waves, retries: many updates, not one at the end
    assert len(seen.calls) >= 5 and max(seen.calls) < len(nodes)
    np.testing.assert_array_equal(res.success, map_search(panda, T, ws.node_neighbours(nodes)).success)


@pytest.mark.parametrize("method", ["exact", "numerical"])
def test_the_constant_map_moves_during_the_search(method):
    arm = robots.load("ur5e")
    grid = ws.grid_spec("R3", -0.8, 0.8, 0.2)
    seen = Counter()
    flat = ws.grid_map(arm, grid, rpy=(np.pi, 0, 0), method=method, progress=seen)
    assert sum(seen.calls) == flat.size
    if method == "numerical":
        assert len(seen.calls) >= 5
    np.testing.assert_array_equal(flat, ws.grid_map(arm, grid, rpy=(np.pi, 0, 0), method=method))


@pytest.mark.parametrize("method", ["exact", "numerical"])
def test_the_index_moves_orientation_by_orientation(method):
    arm = robots.load("ur5e")
    nodes = ws.cartesian_grid(-0.6, 0.6, 0.3)
    R = ws.orientation_samples(6, seed=1)
    seen = Counter()
    index = ws.reachability_index(arm, nodes, R, method=method, progress=seen)
    # numerically the reach map's position-only targets come first: N x (K + 1) poses in all
    total = len(nodes) * (len(R) + (method == "numerical"))
    assert sum(seen.calls) == total and len(seen.calls) >= len(R)
    np.testing.assert_array_equal(index, ws.reachability_index(arm, nodes, R, method=method))


def test_every_kind_passes_progress_on(panda):
    grid = ws.grid_spec("R3", -0.6, 0.6, 0.3)
    R = ws.orientation_samples(3, seed=0)
    for kind in kinds():
        if kind.scope != "R3":
            continue
        seen = Counter()
        request = MapRequest(method="numerical", orientations=R, ik=dict(kind.search_settings), progress=seen)
        flat = kind.compute(panda, grid, request)
        total = flat.size * (len(R) + 1 if "orientations" in kind.inputs else 1)
        assert sum(seen.calls) == total, kind.name
    so3 = get_kind("orientation")
    seen = Counter()
    flat = so3.compute(robots.puma560(), ws.grid_spec("SO3", step=np.pi / 2), MapRequest(progress=seen))
    assert sum(seen.calls) == flat.size


def test_true_draws_a_bar_on_stderr_and_quiet_draws_none(tmp_path, capsys):
    ws.manipulability_map(robots.load("ur5e"), ws.cartesian_grid(-0.5, 0.5, 0.5), progress=True)
    assert "manipulability" in capsys.readouterr().err
    out = tmp_path / "m.npz"
    assert cli.main(["map", "--robot", "ur5e", "--kind", "index", "--orientations", "4", "--step", "0.5",
                     "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "index" in err and "pose" in err
    assert cli.main(["map", "--robot", "ur5e", "--kind", "index", "--orientations", "4", "--step", "0.5",
                     "--out", str(out), "-q"]) == 0
    assert capsys.readouterr() == ("", "")


def test_a_bad_progress_is_refused():
    with pytest.raises(ValueError, match="progress must be True, False, None or a callable"):
        ws.position_map(robots.load("ur5e"), ws.cartesian_grid(-0.5, 0.5, 0.5), progress="yes")
