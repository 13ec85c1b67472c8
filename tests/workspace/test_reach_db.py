"""REACH's own demo database (`data/cells/reach_demo/reach.db.xml`, from ros-industrial/reach_ros):
read as REACH wrote it, its goals equal wsmap's tool poses of the same cloud, its joint solutions
reach those goals through wsmap's model of the SIA20D and are collision-free by wsmap's checker, and
wsmap's study reaches exactly the targets REACH reached."""

from pathlib import Path

import numpy as np
import pytest

from wsmap.jobs.study import StudyJob
from wsmap.workspace.reach_db import ReachDbError, read_reach_db
from wsmap.workspace.study import REACHED, evaluate_targets

CELL = Path(__file__).resolve().parents[2] / "data" / "cells" / "reach_demo"
JOINTS = ("joint_s", "joint_l", "joint_e", "joint_u", "joint_r", "joint_b", "joint_t")


@pytest.fixture(scope="module")
def db():
    return read_reach_db(CELL / "reach.db.xml")


@pytest.fixture(scope="module")
def plan():
    job = StudyJob.from_file(CELL / "study.yaml")
    return job, job.check()


def test_the_demo_database_reads_as_reach_wrote_it(db):
    assert db.reached.shape == (3, 262) and db.goal_states.shape == (3, 262, 7)
    assert db.reached.sum(axis=1).tolist() == [158, 160, 160]  # REACH's three optimisation steps
    assert sorted(db.joints) == list(db.joints) and set(db.joints) == set(JOINTS)
    assert np.all(db.scores[db.final][~db.reached[db.final]] == 0)


def test_reach_goals_are_the_tool_poses_of_the_cloud(db, plan):
    _, p = plan
    # REACH's goals are single precision: equal to wsmap's float64 poses to float32 rounding
    np.testing.assert_allclose(p.targets.poses, db.goals[db.final], atol=2e-6)


def test_reach_solutions_reach_their_goals_through_wsmaps_model_and_do_not_collide(db, plan):
    _, p = plan
    robot, checker = p.robots[0], p.checkers[0]
    ok = db.reached[db.final]
    q = db.states(JOINTS)[ok]
    F = robot.fkine(q)
    np.testing.assert_allclose(F[:, :3, 3], db.goals[db.final][ok][:, :3, 3], atol=1e-4)
    assert robot.within_limits(q).all()
    assert checker.at_bases(q, np.eye(4)).all()  # free of the part and of itself, as MoveIt found


def test_wsmap_reaches_exactly_the_targets_reach_reached(db, plan):
    job, p = plan
    pick = np.arange(0, 262, 3)  # a third of the cell, every third target (the whole cell: the stage)
    res = evaluate_targets(p.robots[0], p.targets.poses[pick], tcp=np.asarray(job.tcp).reshape(4, 4),
                           collision=p.checkers[0], method=job.method, starts=job.starts, seed=job.seed)
    np.testing.assert_array_equal(res.status == REACHED, db.reached[db.final][pick])


@pytest.mark.parametrize("text, message", [
    ("not xml", "is not XML"),
    ("<boost_serialization><db><results/></db></boost_serialization>", "no result sets"),
    ("<boost_serialization><db><results><item><item><reached>1</reached><goal><matrix><item>1</item></matrix>"
     "</goal><score>0</score></item></item></results></db></boost_serialization>", "has 1 numbers, not 16"),
])
def test_bad_databases_are_one_line_errors(tmp_path, text, message):
    f = tmp_path / "reach.db.xml"
    f.write_text(text)
    with pytest.raises(ReachDbError, match=message):
        read_reach_db(f)


def test_a_missing_database_names_the_file(tmp_path):
    with pytest.raises(ReachDbError, match="nothing.xml.*no such file"):
        read_reach_db(tmp_path / "nothing.xml")
