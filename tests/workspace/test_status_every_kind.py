"""Every kind of map carries its three answers (issue 44 item 1): reached, certified unreachable, not
found — in the map file (the index and the dexterous map per node and orientation too), on the job's
result, on the command line and in the pictures; a file without them reads as before."""

from __future__ import annotations

import json
import re
import time
import zipfile

import numpy as np
import pytest

import wsmap
from wsmap import cli, jobs, robots
from wsmap import workspace as ws
from wsmap.kinematics import as_chain
from wsmap.workspace.files import MapFileError, load_status
from wsmap.workspace.kinds import MapKind, get_kind
from wsmap.workspace.status import (CERTIFIED, NOT_FOUND, REACHED, node_status, node_status_every, node_status_over,
                                    orientation_status, pose_grid, position_status)

#: (kind, options, arm): each kind on a small grid; the index and dexterous maps of the UR5e by its
#: closed form, the others numerically on the Panda.
KINDS = [
    ("constant", ["--rpy", "pi", "0", "0"], "panda"),
    ("index", ["--orientations", "6"], "ur5e"),
    ("index", ["--orientations", "6", "--method", "numerical"], "panda"),
    ("dexterous", ["--orientations", "4"], "ur5e"),
    ("reach", [], "panda"),
    ("manipulability", ["--rpy", "pi", "0", "0"], "ur5e"),
]


def _counts(status):
    return [int((np.asarray(status) == c).sum()) for c in (REACHED, CERTIFIED, NOT_FOUND)]


def _line(what, counts):
    return f"{what}: {counts[0]} reached, {counts[1]} certified unreachable, {counts[2]} not found"


@pytest.fixture(scope="module")
def index_map():
    """A UR5e index (exact) on a 0.5 m grid over 6 orientations, with its statuses: `(grid, values,
    status (N,), pose_status (N, K), R)`."""
    grid = ws.grid_spec("R3", -1, 1, 0.5)
    R = ws.orientation_samples(6)
    index, bits, pose, node = ws.reachability_index(robots.load("ur5e"), ws.cartesian_grid(-1, 1, 0.5), R,
                                                    return_bits=True, return_status=True)
    return grid, index, node, pose, R


@pytest.mark.parametrize(("kind", "options", "arm"), KINDS, ids=[f"{k}-{a}-{len(o)}" for k, o, a in KINDS])
def test_the_command_line_prints_and_the_file_stores_the_three_answers_of_every_kind(kind, options, arm, tmp_path,
                                                                                      capsys):
    out = tmp_path / "m.npz"
    assert cli.main(["map", "--robot", arm, "--kind", kind, *options, "--step", "0.25", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    flat, _, _, settings = ws.load_map(out)
    status = load_status(out)
    assert status.dtype == np.int8 and status.shape == flat.shape
    np.testing.assert_array_equal(status == REACHED, flat > 0 if flat.dtype != bool else flat)
    counts = _counts(status)
    assert _line("nodes", counts) in printed
    assert counts[0] > 0 and counts[1] > 0  # the test tests something
    if get_kind(kind).over is not None:  # per node and orientation, and the node's answer from them
        pose = load_status(out, per_pose=True)
        assert pose.shape == (flat.size, len(settings["orientations"])) and pose.dtype == np.int8
        np.testing.assert_array_equal(get_kind(kind).over(pose), status)
        assert _line("poses (node x orientation)", _counts(pose)) in printed
    else:
        assert "pose_status" not in settings and "poses (node x orientation)" not in printed
        with pytest.raises(MapFileError, match="stores no status per node and orientation"):
            load_status(out, per_pose=True)


def test_the_job_result_holds_the_counts_and_the_statuses(tmp_path):
    job = jobs.MapJob(arm=jobs.ArmSource(robot="ur5e"), kind="index", orientations=6, step=0.4)
    result = job.run(job.check(need_output=False))
    assert result.status.shape == result.values.shape and result.pose_status.shape == (result.values.size, 6)
    assert result.counts == dict(zip(wsmap.STATUS, _counts(result.status)))
    assert result.pose_counts == dict(zip(wsmap.STATUS, _counts(result.pose_status)))
    assert sum(result.counts.values()) == result.values.size and result.status_seconds >= 0
    # the index is the fraction of reached orientations, and the statuses are the library's
    np.testing.assert_array_equal(result.values, (result.pose_status == REACHED).mean(axis=1))
    nodes = ws.cartesian_grid(-1, 1, 0.4)
    expect = node_status(robots.load("ur5e"), pose_grid(nodes, job.check(need_output=False).orientations)
                         .reshape(-1, 4, 4), (result.pose_status == REACHED).reshape(-1), "exact", budget=0)
    np.testing.assert_array_equal(result.pose_status.reshape(-1), expect)
    # a network's prediction has none: the model method is the only one without a status
    assert jobs.MapResult(plan=None, values=result.values, settings={}, summary="", seconds=0.0).counts is None


def test_orientation_status_is_node_status_by_blocks(monkeypatch):
    panda = robots.load("panda")
    nodes, R = ws.cartesian_grid(-1, 1, 0.4), ws.orientation_samples(5)
    _, bits = ws.reachability_index(panda, nodes, R, return_bits=True)
    whole = node_status(panda, pose_grid(nodes, R).reshape(-1, 4, 4), bits.reshape(-1), budget=0).reshape(bits.shape)
    from wsmap.workspace import status as S

    monkeypatch.setattr(S, "POSE_BLOCK", 7)  # many blocks, the last a short one
    np.testing.assert_array_equal(orientation_status(panda, nodes, R, bits, budget=0), whole)
    with pytest.raises(ValueError, match=r"reached must have shape \(216, 5\)"):
        orientation_status(panda, nodes, R, bits.T)


def test_a_dexterous_node_is_certified_where_one_orientation_is():
    status = np.array([[REACHED, REACHED], [REACHED, CERTIFIED], [NOT_FOUND, CERTIFIED], [REACHED, NOT_FOUND]],
                      dtype=np.int8)
    np.testing.assert_array_equal(node_status_every(status), [REACHED, CERTIFIED, CERTIFIED, NOT_FOUND])
    np.testing.assert_array_equal(node_status_over(status), [REACHED, REACHED, NOT_FOUND, REACHED])


def test_the_reach_maps_certificate_is_the_links_length():
    # a 2-link planar arm of 0.3 + 0.2 m: a node 0.6 m from its first axis is certified, one at
    # 0.45 m not reached (by assumption) is only "not found"
    arm = robots.from_dh(d=[0, 0], a=[0.3, 0.2], alpha=[0, 0])
    nodes = np.array([[0.6, 0, 0], [0.45, 0, 0], [0.4, 0.0, 0.0]])
    status = position_status(arm, nodes, np.array([False, False, True]))
    np.testing.assert_array_equal(status, [CERTIFIED, NOT_FOUND, REACHED])


def test_index_status_round_trips_and_a_file_without_it_reads_as_before(index_map, tmp_path):
    grid, index, node, pose, R = index_map
    settings = {"kind": "index", "robot": "ur5e"}
    path = ws.save_map(tmp_path / "i.npz", index, grid, settings, orientations=R, status=node, pose_status=pose)
    back, _, _, got = ws.load_map(path)
    np.testing.assert_array_equal(back, index)
    for key, want in (("status", node), ("pose_status", pose)):
        assert got[key].dtype == np.int8
        np.testing.assert_array_equal(got[key], want)
    np.testing.assert_array_equal(load_status(path), node)
    np.testing.assert_array_equal(load_status(path, per_pose=True), pose)
    old = ws.save_map(tmp_path / "old.npz", index, grid, settings, orientations=R)
    np.testing.assert_array_equal(load_status(old), np.where(index > 0, REACHED, NOT_FOUND))
    with pytest.raises(MapFileError, match="stores no status per node and orientation"):
        load_status(old, per_pose=True)


def test_a_file_without_the_new_members_keeps_the_bytes_of_the_format(index_map, tmp_path, monkeypatch):
    # what save_map wrote before the statuses: map, nodes, grid, settings (and orientations), compressed
    monkeypatch.setattr(time, "time", lambda: 1.8e9)  # the zip members' dates
    grid, index, _, _, R = index_map
    settings = {"kind": "index", "robot": "ur5e"}
    path = ws.save_map(tmp_path / "i.npz", index, grid, settings, orientations=R)
    with open(tmp_path / "by_hand.npz", "wb") as f:
        np.savez_compressed(f, map=index, nodes=ws.cartesian_grid(-1, 1, 0.5), grid=json.dumps(grid),
                            settings=json.dumps(settings), orientations=R)
    assert path.read_bytes() == (tmp_path / "by_hand.npz").read_bytes()
    with zipfile.ZipFile(path) as z:
        assert z.namelist() == ["map.npy", "nodes.npy", "grid.npy", "settings.npy", "orientations.npy"]


def _bad_statuses(index, node, pose):
    """(what is wrong, node status, pose status, message) of statuses a file must refuse."""
    zero = int(np.flatnonzero(node == CERTIFIED)[0])  # a node certified at every orientation
    some = int(np.flatnonzero((pose == REACHED).sum(axis=1) >= 2)[0])  # reached at two orientations or more
    reached_at_zero = node.copy()
    reached_at_zero[zero] = REACHED
    code3 = pose.copy()
    code3[0, 0] = 3
    other_over = pose.copy()
    other_over[zero] = NOT_FOUND  # the node's own status stays certified (where it was)
    unreached = pose.copy()
    row = np.flatnonzero(unreached[some] == REACHED)[0]
    unreached[some, row] = CERTIFIED  # the node still reached at another orientation: only its index changes
    return [
        ("code", node, code3, r"codes are 0 \(reached\), 1 \(certified unreachable\) or 2 \(not found\), got 0..3"),
        ("reached at 0", reached_at_zero, pose, f"status and map disagree at node {zero} \\(status 0, map 0\\)"),
        ("shape", node, pose[:, :5], r"must be integer codes of shape \(125, 6\), got int8 \(125, 5\)"),
        ("over", node, other_over, f"the status of node {zero} .* is not its orientations'"),
        ("from_bits", node, unreached, f"the map at node {some} \\(0.\\d+\\) is not what its orientations' status "
                                        "gives"),
    ]


def test_bad_or_inconsistent_statuses_are_refused_before_writing_and_on_loading(index_map, tmp_path):
    grid, index, node, pose, R = index_map
    assert (node[index == 0] == CERTIFIED).any()
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    for what, st, ps, message in _bad_statuses(index, node, pose):
        target = tmp_path / f"{what}.npz"
        with pytest.raises(ValueError, match=message):
            ws.save_map(target, index, grid, {"kind": "index"}, orientations=R, status=st, pose_status=ps)
        assert not target.exists(), what
        np.savez(target, map=index, nodes=nodes, grid=json.dumps(grid), settings=json.dumps({"kind": "index"}),
                 orientations=R, status=st, pose_status=ps)
        with pytest.raises(MapFileError, match=message) as info:
            ws.load_map(target)
        assert "\n" not in str(info.value) and str(target) in str(info.value)
    # a status per orientation without its kind, its orientations or the nodes' status
    for kw, message in (({"settings": {}}, "belongs to a kind over a set of orientations, not to a map without a kind"),
                        ({"settings": {"kind": "index"}, "orientations": None}, "comes with the nodes' status and "
                                                                                  "the orientations"),
                        ({"settings": {"kind": "index"}, "status": None}, "comes with the nodes' status")):
        args = {"settings": {"kind": "index"}, "orientations": R, "status": node, **kw}
        with pytest.raises(ValueError, match=message):
            ws.save_map(tmp_path / "x.npz", index, grid, args["settings"], orientations=args["orientations"],
                        status=args["status"], pose_status=pose)
    assert not (tmp_path / "x.npz").exists()


def test_a_kinds_status_fields_are_checked():
    index = get_kind("index")
    fields = {f: getattr(index, f) for f in ("name", "scope", "value_type", "compute", "function", "description",
                                              "priority", "inputs")}
    with pytest.raises(ValueError, match="over and from_bits go together"):
        MapKind(**{**fields, "name": "x"}, over=node_status_over, convention="standard")
    with pytest.raises(ValueError, match="status_budget must be None or a non-negative int, got -1"):
        MapKind(**{**fields, "name": "x"}, status_budget=-1, convention="standard")
    assert get_kind("index").status_budget == 0 and get_kind("constant").status_budget is None


def test_the_status_budget_option(tmp_path, capsys):
    out = tmp_path / "m.npz"
    argv = ["map", "--robot", "panda", "--rpy", "pi", "0", "0", "--step", "0.25", "--out", str(out)]
    assert cli.main([*argv, "--status-budget", "0"]) == 0
    filters_only = load_status(out)
    assert ws.load_map(out)[3]["status_budget"] == 0
    assert cli.main(argv) == 0
    full = load_status(out)
    assert "status_budget" not in ws.load_map(out)[3]  # recorded only when given: the file as before
    np.testing.assert_array_equal(full == REACHED, filters_only == REACHED)
    assert ((filters_only == CERTIFIED) <= (full == CERTIFIED)).all()  # the budget only adds certificates
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        cli.main([*argv, "--status-budget", "-1"])
    assert info.value.code == 2
    assert "--status-budget" in capsys.readouterr().err
    with pytest.raises(ValueError, match="--status-budget must be a non-negative integer"):
        jobs.MapJob(arm=jobs.ArmSource(robot="panda"), status_budget=1.5).check(need_output=False)


# ------------------------------------------------------------------------------------------ pictures
def _index_statuses():
    values = np.zeros(27)
    values[13] = 0.5
    status = np.full(27, CERTIFIED, dtype=np.int8)
    status[13] = REACHED
    status[[4, 10, 22]] = NOT_FOUND
    return values, status


def test_value_slices_draw_the_nodes_not_found_apart_and_count_them():
    import matplotlib.pyplot as plt
    from wsmap import viz

    values, status = _index_statuses()
    fig = viz.plot_value_slices(values, (3, 3, 3), -1.0, 1.0, label="index", vmin=0, vmax=1, status=status)
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["certified unreachable (0): 23", "not found (0): 3"]
    panels = [ax for ax in fig.axes if ax.images]
    assert len(panels) == 3  # the layers holding only nodes not found are drawn too
    drawn = sum(int((~np.ma.getmaskarray(ax.images[1].get_array())).sum()) for ax in panels if len(ax.images) > 1)
    assert drawn == 3
    plt.close(fig)
    # without a status: the picture as before (one image a panel, one legend entry)
    fig = viz.plot_value_slices(values, (3, 3, 3), -1.0, 1.0, label="index", vmin=0, vmax=1)
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["unreachable (0)"]
    assert all(len(ax.images) == 1 for ax in fig.axes if ax.images)
    assert len([ax for ax in fig.axes if ax.images]) == 1
    plt.close(fig)
    for kw, message in (({"status": status[:5]}, r"status must have the map's shape \(27,\)"),
                        ({"status": status, "unreachable": None}, "it needs unreachable=")):
        with pytest.raises(ValueError, match=message):
            viz.plot_value_slices(values, (3, 3, 3), -1.0, 1.0, label="index", **kw)


def test_the_3d_view_has_a_trace_of_the_nodes_not_found_and_one_of_the_certified():
    pytest.importorskip("plotly")
    from wsmap.views import figure_3d

    values, status = _index_statuses()
    grid = ws.grid_spec("R3", -1, 1, 1.0)
    fig = figure_3d(values, grid, status=status, thresholds=[0.0, 0.25])
    names = [t.name for t in fig.data]
    assert names[-2:] == ["not found (3)", "certified unreachable (23)"]
    found, certified = fig.data[-2], fig.data[-1]
    assert len(found.x) == 3 and found.visible is True and found.marker.symbol == "diamond-open"
    assert len(certified.x) == 23 and certified.visible == "legendonly"
    nodes = ws.cartesian_grid(-1, 1, 1.0)
    np.testing.assert_allclose(np.c_[found.x, found.y, found.z], nodes[status == NOT_FOUND])
    # the threshold slider restyles the map's traces only
    assert all(list(step["args"][1]) == [0, 1] for step in fig.layout.sliders[0].steps)
    assert [t.name for t in figure_3d(values, grid, thresholds=[0.0, 0.25]).data] == names[:-2]
    with pytest.raises(ValueError, match=r"status must have the map's shape \(27,\)"):
        figure_3d(values, grid, status=status[:3])


def test_the_command_lines_pictures_name_the_three_counts(tmp_path):
    pytest.importorskip("plotly")
    pytest.importorskip("trimesh")
    pytest.importorskip("skimage")
    import trimesh

    png, html, ply, glb = (tmp_path / f"i.{e}" for e in ("png", "html", "ply", "glb"))
    assert cli.main(["map", "--robot", "ur5e", "--kind", "index", "--orientations", "6", "--step", "0.25",
                     "--quiet", "--out", str(tmp_path / "i.npz"), "--png", str(png), "--html", str(html),
                     "--ply", str(ply), "--glb", str(glb)]) == 0
    status = load_status(tmp_path / "i.npz")
    counts = _counts(status)
    raw = trimesh.load(ply).metadata["_ply_raw"]["vertex"]["data"]
    assert (raw["status"] == 2).sum() == counts[2] and (raw["status"] == 0).sum() == counts[0]
    scene = trimesh.load(glb)
    assert len(scene.geometry["not found"].vertices) == counts[2] if counts[2] else "not found" not in scene.geometry
    from PIL import Image

    title = Image.open(png).text["Title"]
    assert _line("nodes", counts) in title
    text = html.read_text()
    assert f'"name":"not found ({counts[2]})"' in text and f'"name":"certified unreachable ({counts[1]})"' in text
    assert re.search(_line("nodes", counts), text)


@pytest.mark.parametrize("name", ["panda", "ur5e", "iiwa14"])
def test_no_position_an_arm_reaches_is_certified_by_the_reach_maps_status(name):
    # soundness: the tool origins of random configurations inside the limits are never certified,
    # and the certificate is not empty (nodes far outside the arm's reach are)
    arm = robots.load(name)
    lim = np.asarray(as_chain(arm).limits, dtype=np.float64)
    lim = np.where(np.isfinite(lim), lim, np.array([-np.pi, np.pi]))
    q = np.random.default_rng(4).uniform(lim[:, 0], lim[:, 1], (2000, arm.n))
    tips = arm.fkine(q)[:, :3, 3]
    assert not (position_status(arm, tips, np.zeros(len(tips), dtype=bool)) == CERTIFIED).any()
    far = tips * 3.0 + 2.0
    assert (position_status(arm, far, np.zeros(len(far), dtype=bool)) == CERTIFIED).mean() > 0.9
