"""MJCF as a source of chains and collision geoms, against MuJoCo's own kinematics and contacts."""

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from wsmap.collision import exact_pairs  # noqa: E402
from wsmap.collision.mjcf import MJCFError, from_mjcf, from_mjcf_collision  # noqa: E402

ARM = """<mujoco model="arm3">
  <compiler angle="radian"/>
  <asset>
    <mesh name="tip" vertex="0 0 0  0.06 0 0  0 0.06 0  0 0 0.08  0.06 0.06 0.08"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="base" pos="0.1 0 0" quat="0.9659 0 0 0.2588">
      <geom type="cylinder" size="0.08 0.05" pos="0 0 0.05"/>
      <geom type="sphere" size="0.01" contype="0" conaffinity="0"/>
      <body name="link1" pos="0 0 0.1">
        <joint name="j1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.05"/>
        <body name="link2" pos="0 0 0.3" euler="0.3 0 0">
          <joint name="j2" type="hinge" axis="0 1 0" pos="0 0 0.02" range="-2.5 2.5" limited="true" ref="0.2"/>
          <geom type="capsule" fromto="0 0 0 0.35 0 0" size="0.04"/>
          <body name="link3" pos="0.35 0 0">
            <joint name="j3" type="hinge" axis="0 1 0" range="-2.9 2.9" limited="true"/>
            <geom type="box" size="0.15 0.03 0.03" pos="0.15 0 0"/>
            <geom type="mesh" mesh="tip" pos="0.3 0 0"/>
            <site name="tool" pos="0.33 0 0" euler="0 1.5708 0"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""


@pytest.fixture
def arm(tmp_path):
    p = tmp_path / "arm.xml"
    p.write_text(ARM)
    return p


def test_the_chain_agrees_with_mujoco_forward_kinematics(arm):
    chain = from_mjcf(arm, "tool")
    m = mujoco.MjModel.from_xml_path(str(arm))
    d = mujoco.MjData(m)
    assert chain.n == 3 and chain.kinds == ("R", "R", "R")
    np.testing.assert_allclose(chain.qlim, [[-3, 3], [-2.5, 2.5], [-2.9, 2.9]])
    for q in chain.random_q(20, np.random.default_rng(0)):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        T = chain.fkine(q)
        np.testing.assert_allclose(T[:3, 3], d.site_xpos[0], atol=1e-9)
        np.testing.assert_allclose(T[:3, :3], d.site_xmat[0].reshape(3, 3), atol=1e-9)


def test_geoms_and_contacts_agree_with_mujoco(arm):
    model = from_mjcf_collision(arm, "tool")
    assert model.names == ("base", "link1", "link2", "link3")
    assert [len(lk.shapes) for lk in model.links] == [1, 1, 1, 2]  # the visual-only sphere is not collision
    m = mujoco.MjModel.from_xml_path(str(arm))
    d = mujoco.MjData(m)
    body_of = {model.index(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)): b for b in range(1, m.nbody)}
    # every pair MuJoCo checks: not the same body, not parent and child
    pairs = [(i, j) for i in range(4) for j in range(i + 1, 4) if j - i > 1]
    q = model.chain.random_q(400, np.random.default_rng(1))
    ours = exact_pairs(model, pairs, q)
    poses, link_of = model.shape_poses(q)
    agree = 0
    for c in range(len(q)):
        d.qpos[:] = q[c]
        mujoco.mj_forward(m, d)
        # the geoms' world poses (collision geoms in body order: ours skip the visual sphere)
        gids = [g for g in range(m.ngeom) if m.geom_bodyid[g] > 0 and (m.geom_contype[g] or m.geom_conaffinity[g])]
        np.testing.assert_allclose(poses[c][:, :3, 3], d.geom_xpos[gids], atol=1e-9)
        theirs = set()
        for k in range(d.ncon):
            ct = d.contact[k]
            b1, b2 = int(m.geom_bodyid[ct.geom1]), int(m.geom_bodyid[ct.geom2])
            if b1 and b2 and ct.dist < 0:
                theirs.add(tuple(sorted((b1, b2))))
        for p, (i, j) in enumerate(pairs):
            mj = tuple(sorted((body_of[i], body_of[j]))) in theirs
            agree += mj == ours[c, p]
    total = len(q) * len(pairs)
    assert ours.any() and agree >= total - 2  # a grazing contact may read differently


def test_bad_mjcf_input_is_one_line(tmp_path, arm):
    with pytest.raises(MJCFError, match="no site or body 'hand'"):
        from_mjcf(arm, "hand")
    with pytest.raises(MJCFError, match="no such MJCF file"):
        from_mjcf(tmp_path / "none.xml", "tool")
    (tmp_path / "bad.xml").write_text("<mujoco><worldbody><body><geom type='cone'/></body></worldbody></mujoco>")
    with pytest.raises(MJCFError, match="mujoco cannot read it") as e:
        from_mjcf(tmp_path / "bad.xml", "tool")
    assert "\n" not in str(e.value)


def test_the_command_line_maps_an_mjcf_arm_with_its_geoms(arm, tmp_path, capsys):
    from wsmap import cli
    from wsmap import workspace as ws

    out = tmp_path / "m.npz"
    argv = ["map", "--mjcf", str(arm), "--ee", "tool", "--step", "0.25", "--out", str(out), "--quiet"]
    assert cli.main(argv) == 0
    chain_map = ws.load_map(out)[0]
    assert cli.main(argv + ["--collision", "--acm-samples", "300"]) == 0
    free, _, _, settings = ws.load_map(out)
    assert settings["mjcf"] == str(arm) and settings["collision"]["geometry"]["links"][0]["name"] == "base"
    assert not (free & ~chain_map).any()
    assert cli.main(["map", "--mjcf", str(arm), "--out", str(out)]) == 2
    assert "--mjcf needs the tool's site or body" in capsys.readouterr().err
