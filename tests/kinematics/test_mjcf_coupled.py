"""MJCF joint equalities (`<equality><joint joint1 joint2 polycoef>`, linear) as coupled joints: the chain's
variables are the drivers; checked against MuJoCo's own forward kinematics with the driven joints' `qpos`
set as MuJoCo's joint equality defines them, and mapped."""

import re

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from wsmap import cli  # noqa: E402
from wsmap import workspace as ws  # noqa: E402
from wsmap.kinematics.mjcf import MJCFError, from_mjcf  # noqa: E402

#: j3 follows j2 (a parallelogram: -1, 0.1 rad apart from the references), j2 has ref 0.2 and j3 ref -0.1;
#: j4 follows `side`, a hinge off the chain, at twice its rate
ARM = """<mujoco model="pallet">
  <compiler angle="radian"/>
  <worldbody>
    <body name="side"><joint name="side" type="hinge" axis="0 0 1" range="-0.4 0.4" limited="true"/>
      <geom type="sphere" size="0.01"/></body>
    <body name="l1" pos="0 0 0.3">
      <joint name="j1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="sphere" size="0.01"/>
      <body name="l2" pos="0.1 0 0.2">
        <joint name="j2" type="hinge" axis="0 1 0" range="-1 1.2" limited="true" ref="0.2"/>
        <geom type="sphere" size="0.01"/>
        <body name="l3" pos="0 0 0.5" euler="0 0.1 0">
          <joint name="j3" type="hinge" axis="0 1 0" range="-1.5 0.9" limited="true" ref="-0.1"/>
          <geom type="sphere" size="0.01"/>
          <body name="l4" pos="0.45 0 0">
            <joint name="j4" type="hinge" axis="1 0 0" range="-1 1" limited="true"/>
            <geom type="sphere" size="0.01"/>
            <site name="tool" pos="0.1 0 0.15"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="j3" joint2="j2" polycoef="0.1 -1 0 0 0"/>
    <joint joint1="j4" joint2="side" polycoef="0 2 0 0 0"/>
  </equality>
</mujoco>"""


@pytest.fixture
def arm(tmp_path):
    p = tmp_path / "pallet.xml"
    p.write_text(ARM)
    return p


def test_the_chain_follows_mujoco_s_joint_equalities(arm):
    chain = from_mjcf(arm, "tool")
    assert (chain.n, chain.n_joints) == (3, 4)  # variables j1, j2, side
    # j3 = -0.1 + 0.1 - (j2 - 0.2) = 0.2 - j2 in [-1.5, 0.9]: j2 in [-0.7, 1.7]; j4 = 2·side in [-1, 1]
    np.testing.assert_allclose(chain.qlim, [[-3, 3], [-0.7, 1.2], [-0.4, 0.4]], rtol=0, atol=1e-15)
    m = mujoco.MjModel.from_xml_string(ARM)
    d = mujoco.MjData(m)
    adr = {n: int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in ("j1", "j2", "j3", "j4",
                                                                                                "side")}
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tool")
    for q in chain.random_q(30, np.random.default_rng(0)):
        j1, j2, side = q
        d.qpos[:] = m.qpos0
        d.qpos[adr["j1"]], d.qpos[adr["j2"]], d.qpos[adr["side"]] = j1, j2, side
        # MuJoCo's joint equality: y - y0 = a0 + a1 (x - x0), y0 and x0 the joints' qpos0
        d.qpos[adr["j3"]] = m.qpos0[adr["j3"]] + 0.1 - (j2 - m.qpos0[adr["j2"]])
        d.qpos[adr["j4"]] = m.qpos0[adr["j4"]] + 2 * (side - m.qpos0[adr["side"]])
        mujoco.mj_kinematics(m, d)
        T = chain.fkine(q)
        np.testing.assert_allclose(T[:3, 3], d.site_xpos[site], atol=1e-12)
        np.testing.assert_allclose(T[:3, :3], d.site_xmat[site].reshape(3, 3), atol=1e-12)


def test_a_map_of_it(arm):
    chain = from_mjcf(arm, "tool")
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.2)
    reach, q = ws.position_map(chain, nodes, return_q=True)
    assert reach.sum() > 20 and np.all(chain.within_limits(q[reach]))
    assert np.all(chain.uncoupled().within_limits(chain.full_q(q[reach])))
    np.testing.assert_allclose(chain.fkine(q[reach])[:, :3, 3], nodes[reach], atol=1e-8)
    out = arm.parent / "m.npz"
    assert cli.main(["map", "--mjcf", str(arm), "--ee", "tool", "--kind", "reach", "--step", "0.2", "--lo", "-1",
                     "--hi", "1", "--out", str(out), "-q"]) == 0
    np.testing.assert_array_equal(ws.load_map(out)[0], reach)


@pytest.mark.parametrize("change, message", [
    (('polycoef="0.1 -1 0 0 0"', 'polycoef="0.1 -1 0.5 0 0"'),
     "the joint equality on 'j3' is a polynomial of degree 2 in 'j2'; only a linear coupling (polycoef a0 a1 0 0 0) "
     "is read"),
    (('polycoef="0.1 -1 0 0 0"', 'polycoef="0.1 0 0 0 0"'),
     "the joint equality on 'j3' holds it at a constant (no joint2, or polycoef's a1 = 0): make it a fixed part of "
     "its body instead"),
    (('<joint joint1="j4" joint2="side" polycoef="0 2 0 0 0"/>', '<joint joint1="j4" joint2="j3"/>'),
     "joint 'j4' follows 'j3', which follows 'j2' itself; couple both to one driver"),
    (('<joint joint1="j4" joint2="side" polycoef="0 2 0 0 0"/>', '<joint joint1="j3" joint2="side"/>'),
     "the joint equality on 'j3': two joint equalities drive 'j3'"),
    (('range="-0.4 0.4"', 'range="2 3"'),
     "no value of 'side' inside its limits [2, 3] keeps 'j4' (2 x 'side' + 0) inside its own [-1, 1]"),
    (('<joint name="side" type="hinge"', '<joint name="side" type="slide"'),
     "the joint equality on 'j4' couples it to 'side', a joint of another kind (hinge and slide)"),
])
def test_what_is_refused_is_one_line(tmp_path, change, message):
    text = ARM.replace(*change)
    assert text != ARM
    (tmp_path / "bad.xml").write_text(text)
    path = str(tmp_path / "bad.xml")
    with pytest.raises(MJCFError, match="^" + re.escape(f"MJCF file {path!r}: {message}") + "$"):
        from_mjcf(path, "tool")


def test_an_inactive_equality_or_one_off_the_chain_changes_nothing(tmp_path):
    plain = re.sub(r"<equality>.*</equality>", "", ARM, flags=re.S)
    (tmp_path / "plain.xml").write_text(plain)
    base = from_mjcf(tmp_path / "plain.xml", "tool")
    assert base.coupling is None
    for text in (ARM.replace("<equality>", "<equality>").replace('polycoef="0 2 0 0 0"/>', 'polycoef="0 2 0 0 0" '
                                                                'active="false"/>')
                 .replace('polycoef="0.1 -1 0 0 0"/>', 'polycoef="0.1 -1 0 0 0" active="false"/>'),
                 ARM.replace('<joint joint1="j3" joint2="j2" polycoef="0.1 -1 0 0 0"/>\n    '
                             '<joint joint1="j4" joint2="side" polycoef="0 2 0 0 0"/>',
                             '<joint joint1="side" joint2="j1"/>')):
        assert text != ARM
        (tmp_path / "x.xml").write_text(text)
        chain = from_mjcf(tmp_path / "x.xml", "tool")
        assert chain.coupling is None
        np.testing.assert_array_equal(chain.fixed, base.fixed)
        np.testing.assert_array_equal(chain.qlim, base.qlim)
