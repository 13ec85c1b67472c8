"""Collision options beyond what the work can use (issue 41): link radii of 1e308, NaN or below 0,
matrix samples of 0 or 10^11 (which ran for days), and errors that printed Python lists. Each is
one line naming the option, before any work and before any file is written."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wsmap import cli, load
from wsmap.collision import (CollisionError, CollisionModel, Link, Shape, arm_model, build_acm, capsules_along_links)
from wsmap.collision.acm import acm_from_record
from wsmap.collision.sources import CollisionSource


def _run(argv, tmp_path, capsys):
    try:
        code = cli.main(["map", "--robot", "ur5e", "--step", "0.5", "--quiet", "--out", str(tmp_path / "m.npz"),
                         *argv])
    except SystemExit as e:  # argparse's own refusals
        code = e.code
    return code, capsys.readouterr().err.strip()


@pytest.mark.parametrize("argv, message", [
    (["--link-radius", "1e308"], "--link-radius must be a positive number of metres, at most 10 (a capsule around a "
                                 "link), got 1e+308"),
    (["--link-radius", "0.05", "11"], "--link-radius must be a positive number of metres, at most 10"),
    (["--link-radius", "nan"], "argument --link-radius: not a finite number"),
    (["--link-radius", "-0.1"], "argument --link-radius: must be positive"),
    (["--collision", "--acm-samples", "0"], "--acm-samples must be a whole number from 1 to 1000000"),
    (["--collision", "--acm-samples", "100000000000"], "--acm-samples must be a whole number from 1 to 1000000 "
                                                       "(random configurations of the matrix's 'never in collision' "
                                                       "test), got 100000000000"),
])
def test_collision_options_beyond_their_bounds_exit_2_in_one_line_and_write_nothing(tmp_path, capsys, argv, message):
    code, err = _run(argv, tmp_path, capsys)
    assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert message in err, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs, message", [
    (dict(link_radius=[math.nan]), "--link-radius must be a positive number of metres, at most 10 (a capsule around "
                                   "a link), got nan"),
    (dict(link_radius=[-1.0]), "got -1"),
    (dict(collision=True, acm_samples=10**7), "got 10000000"),
    (dict(collision=True, acm_samples=2.5), "got 2.5"),
    (dict(collision=True, acm_samples=True), "got True"),
])
def test_the_job_record_checks_them_too(kwargs, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        CollisionSource(**kwargs).check()


def test_the_library_bounds_radii_and_samples_in_sentences():
    with pytest.raises(CollisionError, match=r"^link_radius must be a positive number of metres, at most 10; body 2 "
                                             r"has 1e\+308$"):
        capsules_along_links(load("ur5e"), [0.05, 0.05, 1e308, 0.05, 0.05, 0.05, 0.05])
    with pytest.raises(CollisionError, match=r"^samples must be a whole number from 0 to 1000000, got 10000000$"):
        build_acm(arm_model("ur5e"), samples=10**7)


def test_errors_name_the_links_instead_of_printing_lists():
    robot = load("ur5e")
    ball = Shape("sphere", (0.05,), np.eye(4))
    with pytest.raises(CollisionError, match=r"^collision links must have distinct names; 'a' is given more than "
                                             r"once$"):
        CollisionModel(robot, (Link("a", 1, (ball,)), Link("b", 2, (ball,)), Link("a", 3, (ball,))))
    model = arm_model("ur5e")
    record = {"links": ["x", "y"], "disabled": []}
    with pytest.raises(CollisionError) as e:
        acm_from_record(model, record)
    msg = str(e.value)
    assert msg.startswith("allowed-collision matrix names the links x, y; the model has ") and "[" not in msg
    with pytest.raises(CollisionError, match=r"disable takes pairs of link names, got 'a', 'b', 'c'$"):
        build_acm(model, samples=0, disable=[("a", "b", "c")])
