"""The jobs of the library: a map or a placement built in Python writes the same bytes as the command
line with the same options, checks everything before any work, and runs without writing."""

from __future__ import annotations

import time

import numpy as np
import pytest

from wsmap import cli, jobs, workspace as ws


@pytest.fixture
def frozen_clock(monkeypatch):
    """A clock that reads the same in both runs: the map file records `seconds` and the zip members of
    `.npz` files carry the wall time."""
    state = {"t": 0.0}

    def counter():
        state["t"] += 0.25
        return state["t"]

    monkeypatch.setattr(time, "perf_counter", counter)
    monkeypatch.setattr(time, "time", lambda: 1.8e9)
    return state


def _same_bytes(cli_argv, job, tmp_path, names, state):
    a, b = tmp_path / "cli", tmp_path / "job"
    a.mkdir()
    b.mkdir()
    state["t"] = 0.0
    argv = [x.replace("{dir}", str(a)) for x in cli_argv]
    assert cli.main(argv) == 0
    state["t"] = 0.0
    job = job(b)
    paths = job.save(job.run(job.check()))
    assert [p.name for p in paths] == names
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name


def test_a_map_job_writes_the_bytes_of_the_command_line(tmp_path, frozen_clock):
    argv = ["map", "--robot", "panda", "--rpy", "pi", "0", "0", "--step", "0.25", "--quiet",
            "--out", "{dir}/m.npz", "--png", "{dir}/m.png"]
    job = lambda d: jobs.MapJob(arm=jobs.ArmSource(robot="panda"), rpy=(np.pi, 0, 0), step=0.25,  # noqa: E731
                                outputs=jobs.MapOutputs(out=str(d / "m.npz"), png=str(d / "m.png")))
    _same_bytes(argv, job, tmp_path, ["m.npz", "m.png"], frozen_clock)


def test_an_index_job_with_its_reuleaux_file(tmp_path, frozen_clock):
    pytest.importorskip("h5py")
    argv = ["map", "--robot", "ur5e", "--kind", "index", "--orientations", "6", "--step", "0.4", "--quiet",
            "--out", "{dir}/i.npz", "--h5", "{dir}/i.h5"]
    job = lambda d: jobs.MapJob(arm=jobs.ArmSource(robot="ur5e"), kind="index", orientations=6, step=0.4,  # noqa: E731
                                outputs=jobs.MapOutputs(out=str(d / "i.npz"), h5=str(d / "i.h5")))
    _same_bytes(argv, job, tmp_path, ["i.npz", "i.h5"], frozen_clock)


def test_a_numerical_dh_map_job(tmp_path, frozen_clock):
    argv = ["map", "--d", "0", "0", "0.15", "--a", "0", "0.43", "0.02", "--alpha", "pi/2", "0", "-pi/2",
            "--method", "numerical", "--step", "0.25", "--starts", "2", "--quiet", "--out", "{dir}/d.npz"]
    job = lambda d: jobs.MapJob(  # noqa: E731
        arm=jobs.ArmSource(d=[0, 0, 0.15], a=[0, 0.43, 0.02], alpha=[np.pi / 2, 0, -np.pi / 2]),
        method="numerical", step=0.25, starts=2, outputs=jobs.MapOutputs(out=str(d / "d.npz")))
    _same_bytes(argv, job, tmp_path, ["d.npz"], frozen_clock)


def test_a_collision_free_map_job(tmp_path, frozen_clock):
    pytest.importorskip("coal")
    argv = ["map", "--robot", "ur5e", "--rpy", "pi", "0", "0", "--step", "0.4", "--collision", "--acm-samples", "200",
            "--quiet", "--out", "{dir}/c.npz"]
    job = lambda d: jobs.MapJob(arm=jobs.ArmSource(robot="ur5e"), rpy=(np.pi, 0, 0), step=0.4,  # noqa: E731
                                collision=jobs.CollisionSource(collision=True, acm_samples=200),
                                outputs=jobs.MapOutputs(out=str(d / "c.npz")))
    _same_bytes(argv, job, tmp_path, ["c.npz"], frozen_clock)
    _, _, _, settings = ws.load_map(tmp_path / "job" / "c.npz")
    assert settings["collision"]["stats"]["configurations"] > 0


def test_a_placement_job_writes_the_ranking_of_the_command_line(tmp_path, frozen_clock):
    targets = tmp_path / "t.csv"
    targets.write_text("x,y,z,r1,r2,r3\n0.4,0.1,0.2,3.14159,0,0\n0.5,-0.2,0.1,3.14159,0,0\n")
    argv = ["place", "--robot", "ur5e", "--targets", str(targets), "--x", "-0.3", "0.3", "--y", "-0.3", "0.3",
            "--step", "0.3", "--yaws", "2", "--quiet", "--out", "{dir}/r.csv"]
    job = lambda d: jobs.PlacementJob(targets=str(targets), arm=jobs.ArmSource(robot="ur5e"),  # noqa: E731
                                      x=(-0.3, 0.3), y=(-0.3, 0.3), step=0.3, yaws=2, out=str(d / "r.csv"))
    _same_bytes(argv, job, tmp_path, ["r.csv"], frozen_clock)


def test_a_job_without_outputs_runs_and_returns_its_values():
    job = jobs.MapJob(arm=jobs.ArmSource(robot="puma560"), step=0.5)
    with pytest.raises(ValueError, match="^nothing to write"):
        job.check()
    result = job.run()  # check(need_output=False): the values alone
    nodes = ws.cartesian_grid(-1, 1, 0.5)
    expected = ws.constant_orientation_map(jobs.ArmSource(robot="puma560").build(), nodes, (0, 0, 0))
    np.testing.assert_array_equal(result.values, expected)
    assert result.settings["method"] == "exact" and result.settings["kind"] == "constant"


@pytest.mark.parametrize("job, message", [
    (jobs.MapJob(arm=jobs.ArmSource(robot="panda", urdf="x.urdf")), "give one arm: --robot and --urdf"),
    (jobs.MapJob(kind="index", rpy=(0, 0, 0)), "--kind index does not read --rpy"),
    (jobs.MapJob(method="exact", starts=3), "--starts is used by the numerical method"),
    (jobs.MapJob(collision=jobs.CollisionSource(mount="base")), "--mount is used with --collision or --scene"),
    (jobs.MapJob(arm=jobs.ArmSource(d=[0, 0], a=[1, 1], alpha=[0, 0]), collision=jobs.CollisionSource(collision=True)),
     "DH columns carry no collision geometry"),
    (jobs.MapJob(lo=(0, 1)), "--lo takes one value or three, got 2"),
])
def test_a_bad_job_is_one_line_before_any_work(job, message, tmp_path):
    with pytest.raises(ValueError) as e:
        job.check(need_output=False)
    assert message in str(e.value) and "\n" not in str(e.value)
    assert list(tmp_path.iterdir()) == []


def test_a_placement_job_takes_poses_as_an_array():
    T = np.stack([ws.target_poses((0.4, 0.1, 0.2), (np.pi, 0, 0)), ws.target_poses((0.5, -0.2, 0.1), (np.pi, 0, 0))])
    job = jobs.PlacementJob(targets=T, arm=jobs.ArmSource(robot="ur5e"), x=(-0.3, 0.3), y=(-0.3, 0.3), step=0.3,
                            yaws=2)
    result = job.run()
    assert result.placement.score.shape == (3 * 3 * 2,) and job.save(result) == []
    with pytest.raises(ValueError, match=r"^--x: lo \(1\) is above hi \(0\)"):
        jobs.PlacementJob(targets=T, x=(1, 0)).check()
