"""Mimic joints on a URDF chain whose driver is off it: the driver's value is the chain's variable.
Checked against yourdfpy, which moves a mimic joint with its driver (`update_cfg`). Drivers on the
chain (coupled joints) and other multipliers: `test_urdf_coupled.py`."""

import io
import re

import numpy as np
import pytest

from wsmap import cli
from wsmap import workspace as ws
from wsmap.kinematics.urdf import URDFError, from_urdf

yourdfpy = pytest.importorskip("yourdfpy")
LIM = 'effort="1" velocity="1"'

#: j2 mimics 'side' (multiplier -1, offset 0.3), j4 (continuous, tilted axis) mimics 'side2' (offset
#: -0.5); both drivers hang off the chain from the base; j3 is prismatic.
URDF = f"""<robot name="mimic_arm">
 <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="tool"/>
 <link name="side"/><link name="side2"/>
 <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.3" rpy="0.1 0 0"/>
  <axis xyz="0 0 1"/><limit lower="-2" upper="2" {LIM}/></joint>
 <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.2 0 0.1" rpy="0 0.3 0"/>
  <axis xyz="0 1 0"/><limit lower="-1.2" upper="0.9" {LIM}/><mimic joint="side" multiplier="-1" offset="0.3"/></joint>
 <joint name="j3" type="prismatic"><parent link="l2"/><child link="l3"/><origin xyz="0.3 0 0"/>
  <axis xyz="1 0 0"/><limit lower="0" upper="0.2" {LIM}/></joint>
 <joint name="j4" type="continuous"><parent link="l3"/><child link="tool"/><origin xyz="0.1 0 0" rpy="0 0 0.2"/>
  <axis xyz="0.6 0 0.8"/><mimic joint="side2" offset="-0.5"/></joint>
 <joint name="side" type="revolute"><parent link="base"/><child link="side"/><axis xyz="0 0 1"/>
  <limit lower="-1" upper="1" {LIM}/></joint>
 <joint name="side2" type="continuous"><parent link="base"/><child link="side2"/><axis xyz="0 0 1"/></joint>
</robot>"""
NAMES = ["j1", "side", "j3", "side2"]  # the chain's variables: a mimic joint's place takes its driver


def _model():
    return yourdfpy.URDF.load(io.StringIO(URDF), build_scene_graph=True, load_meshes=False)


def _tool(model, q):
    model.update_cfg(dict(zip(NAMES, q)))
    return model.get_transform("tool", "base")


def test_forward_kinematics_and_limits_agree_with_yourdfpy():
    chain = from_urdf(URDF, ee_link="tool")
    assert chain.kinds == ("R", "R", "P", "R")
    # j2 = -side + 0.3 inside [-1.2, 0.9]: side in [-0.6, 1.5], and side's own [-1, 1]
    np.testing.assert_allclose(chain.qlim, [[-2, 2], [-0.6, 1.0], [0, 0.2], [-np.inf, np.inf]], atol=1e-15)
    model = _model()
    for q in chain.random_q(50, np.random.default_rng(0)):
        np.testing.assert_allclose(chain.fkine(q), _tool(model, q), atol=1e-14)


def test_the_jacobian_is_the_derivative_through_the_drivers():
    chain = from_urdf(URDF, ee_link="tool")
    model = _model()
    h = 1e-6
    for q in chain.random_q(5, np.random.default_rng(1)):
        J = chain.jacob0(q)
        for i in range(4):
            dq = np.zeros(4)
            dq[i] = h
            Tp, Tm = _tool(model, q + dq), _tool(model, q - dq)
            np.testing.assert_allclose(J[:3, i], (Tp[:3, 3] - Tm[:3, 3]) / (2 * h), atol=1e-8)
            dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ _tool(model, q)[:3, :3].T  # [omega]x
            np.testing.assert_allclose(J[3:, i], [dR[2, 1], dR[0, 2], dR[1, 0]], atol=1e-8)


def test_a_map_of_it_runs_and_its_solutions_reach_in_yourdfpy(tmp_path):
    chain = from_urdf(URDF, ee_link="tool")
    nodes = ws.cartesian_grid(-0.8, 0.8, 0.2)
    reach, q = ws.position_map(chain, nodes, return_q=True)
    assert 10 < reach.sum() < len(nodes)
    model = _model()
    assert np.all(chain.within_limits(q[reach]))
    for node, qi in zip(nodes[reach], q[reach]):
        np.testing.assert_allclose(_tool(model, qi)[:3, 3], node, atol=1e-8)
    (tmp_path / "m.urdf").write_text(URDF)
    out = tmp_path / "m.npz"
    assert cli.main(["map", "--urdf", str(tmp_path / "m.urdf"), "--ee", "tool", "--kind", "reach", "--step", "0.2",
                     "--lo", "-0.8", "--hi", "0.8", "--out", str(out), "-q"]) == 0
    np.testing.assert_array_equal(ws.load_map(out)[0], reach)


@pytest.mark.parametrize("change, message", [
    (('joint="side" multiplier="-1"', 'joint="nope" multiplier="-1"'),
     "joint 'j2' on the chain mimics 'nope', which is not a joint of the URDF"),
    (('<mimic joint="side2" offset="-0.5"/>', '<mimic joint="j3"/>'),
     "joint 'j4' on the chain mimics 'j3', a prismatic joint driving a continuous one"),
    (('<axis xyz="0 0 1"/>\n  <limit lower="-1" upper="1"', '<axis xyz="0 0 1"/>\n  <limit lower="-5" upper="-4"'),
     "no value of 'side' inside its limits [-5, -4] keeps 'j2' (-1 x 'side' + 0.3) inside its own [-1.2, 0.9]"),
    (('joint="side" multiplier="-1"', 'joint="side" multiplier="0"'),
     "joint 'j2' on the chain mimics 'side' with multiplier 0: a joint that never moves"),
    (('offset="0.3"', 'offset="nan"'), "joint 'j2' has a NaN or infinite <mimic offset='nan'>"),
])
def test_what_is_not_read_is_one_line_naming_the_joints(change, message):
    text = URDF.replace(*change)
    assert text != URDF
    with pytest.raises(URDFError, match=re.escape(message)) as err:
        from_urdf(text, ee_link="tool")
    assert "\n" not in str(err.value)


def test_a_prismatic_driver_of_a_revolute_mimic_is_refused():
    text = URDF.replace('<joint name="side" type="revolute">', '<joint name="side" type="prismatic">')
    with pytest.raises(URDFError, match=re.escape("mimics 'side', a prismatic joint driving a revolute one")):
        from_urdf(text, ee_link="tool")


def test_collision_refuses_geometry_that_moves_with_a_driver_off_the_chain(tmp_path, capsys):
    box = '<collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision>'
    (tmp_path / "m.urdf").write_text(URDF.replace('<link name="l2"/>', f'<link name="l2">{box}</link>'))
    argv = ["map", "--urdf", str(tmp_path / "m.urdf"), "--ee", "tool", "--kind", "constant", "--step", "0.4",
            "--collision", "--acm-samples", "50", "--out", str(tmp_path / "o.npz"), "-q"]
    assert cli.main(argv) == 0  # the drivers' links carry no geometry
    (tmp_path / "m.urdf").write_text(URDF.replace('<link name="side"/>', f'<link name="side">{box}</link>')
                                     .replace('<link name="l2"/>', f'<link name="l2">{box}</link>'))
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "--collision: link 'side' hangs below the driver of a mimic joint of the chain" in err and err.count("\n") == 1
