"""Coupled joints: a joint driven by another joint of the chain (a palletiser's parallelogram, URDF
`<mimic>` with its driver on the chain) or at a rate other than ±1. The chain's variables are the
drivers; checked against Pinocchio and yourdfpy, which read the mimic joints themselves, against
finite differences, and against the same arm uncoupled."""

import hashlib
import io
import re
from pathlib import Path

import numpy as np
import pytest

from test_urdf_mimic import URDF as MIMIC
from wsmap import cli, robots
from wsmap import workspace as ws
from wsmap.kinematics.chain import Coupling, SerialChain, as_chain
from wsmap.kinematics.ik.registry import closed_form_for
from wsmap.kinematics.urdf import URDFError, from_urdf
from wsmap.workspace.status import CERTIFIED, REACHED

yourdfpy = pytest.importorskip("yourdfpy")
ROOT = Path(__file__).resolve().parents[2]
LIM = 'effort="1" velocity="1"'

#: the palletiser (tests/data/palletiser.urdf): j3 follows j2 (multiplier -1, offset 0.2: the parallelogram keeps
#: the forearm level), j5 turns at half j1's rate; the variables are j1, j2, j4, j6. benchmarks/maps/bench_coupled.py
#: times the same arm with its wrist.
DATA = ROOT / "tests" / "data"
URDF = (DATA / "palletiser.urdf").read_text()
VARIABLES = ["j1", "j2", "j4", "j6"]
#: j1 in [-3, 3] and 0.5·j1 in [-1, 1]; j2 in [-1, 1.2] and 0.2 - j2 in [-1.5, 0.9]
QLIM = [[-2, 2], [-0.7, 1.2], [-2, 2], [-2.5, 2.5]]

#: a telescoping slide: s2 moves twice as far as s1, 5 cm ahead
SLIDES = f"""<robot name="slides">
 <link name="a"/><link name="b"/><link name="c"/><link name="d"/>
 <joint name="r" type="continuous"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>
 <joint name="s1" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0.1 0 0"/><axis xyz="1 0 0"/>
  <limit lower="0" upper="0.3" {LIM}/></joint>
 <joint name="s2" type="prismatic"><parent link="c"/><child link="d"/><origin xyz="0 0 0.2" rpy="0 0 0.3"/>
  <axis xyz="1 0 0"/><limit lower="0" upper="0.5" {LIM}/><mimic joint="s1" multiplier="2" offset="0.05"/></joint>
</robot>"""


def _yourdfpy(text, end):
    model = yourdfpy.URDF.load(io.StringIO(text), build_scene_graph=True, load_meshes=False)

    def tool(cfg):
        model.update_cfg(cfg)  # yourdfpy moves the mimic joints with their drivers
        return model.get_transform(end, model.base_link)

    return tool


def test_the_chain_s_variables_and_limits():
    chain = from_urdf(URDF, ee_link="tool")
    assert (chain.n, chain.n_joints, chain.kinds) == (4, 6, ("R",) * 6)
    assert chain.coupling.var.tolist() == [0, 1, 1, 2, 0, 3]
    assert chain.coupling.mult.tolist() == [1, 1, -1, 1, 0.5, 1] and chain.coupling.const.tolist() == [0, 0, 0.2, 0, 0, 0]
    np.testing.assert_array_equal(chain.qlim, QLIM)
    # the relaxation: every joint its own variable in its own limits
    free = chain.uncoupled()
    assert free.coupling is None and free.n == 6
    np.testing.assert_array_equal(free.qlim, [[-3, 3], [-1, 1.2], [-1.5, 0.9], [-2, 2], [-1, 1], [-2.5, 2.5]])
    q = chain.random_q(20, np.random.default_rng(0))
    assert np.all(chain.within_limits(q)) and np.all(free.within_limits(chain.full_q(q)))
    np.testing.assert_array_equal(free.fkine(chain.full_q(q)), chain.fkine(q))


def test_forward_kinematics_agrees_with_yourdfpy_and_pinocchio():
    chain = from_urdf(URDF, ee_link="tool")
    tool = _yourdfpy(URDF, "tool")
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromXML(URDF, mimic=True)  # Pinocchio's own mimic joints: nq = 4
    data, frame = model.createData(), model.getFrameId("tool")
    assert model.nq == 4 and [model.names[i] for i in range(1, model.njoints)] == ["j1", "j2", "j3", "j4", "j5", "j6"]
    for q in chain.random_q(50, np.random.default_rng(1)):
        T = chain.fkine(q)
        np.testing.assert_allclose(T, tool(dict(zip(VARIABLES, q))), atol=1e-14)
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(T, data.oMf[frame].homogeneous, atol=1e-14)
        # Pinocchio's Jacobian of its four configuration variables, at the tool, world-aligned: [v; omega]
        J = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)
        np.testing.assert_allclose(chain.jacob0(q), J, atol=1e-13)


def test_the_jacobian_is_the_derivative_of_forward_kinematics():
    chain = from_urdf(URDF, ee_link="tool")
    h = 1e-6
    for q in chain.random_q(5, np.random.default_rng(2)):
        J = chain.jacob0(q)
        assert J.shape == (6, 4)
        for i in range(4):
            dq = np.zeros(4)
            dq[i] = h
            Tp, Tm = chain.fkine(q + dq), chain.fkine(q - dq)
            np.testing.assert_allclose(J[:3, i], (Tp[:3, 3] - Tm[:3, 3]) / (2 * h), atol=1e-8)
            dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ chain.fkine(q)[:3, :3].T  # [omega]x
            np.testing.assert_allclose(J[3:, i], [dR[2, 1], dR[0, 2], dR[1, 0]], atol=1e-8)


def test_slides_at_twice_the_rate():
    chain = from_urdf(SLIDES, ee_link="d")
    assert (chain.n, chain.n_joints, chain.variable_kinds) == (2, 3, ("R", "P"))
    # s1 in [0, 0.3] and 2·s1 + 0.05 in [0, 0.5]: s1 in [0, 0.225]
    np.testing.assert_allclose(chain.qlim, [[-np.inf, np.inf], [0, 0.225]], rtol=0, atol=1e-17)
    tool = _yourdfpy(SLIDES, "d")
    for q in chain.random_q(20, np.random.default_rng(3)):
        np.testing.assert_allclose(chain.fkine(q), tool({"r": q[0], "s1": q[1]}), atol=1e-14)


def _check_solutions(chain, nodes, reach, q, tool, names=VARIABLES, R=None):
    assert np.all(chain.within_limits(q[reach]))  # the variables inside their limits ...
    assert np.all(chain.uncoupled().within_limits(chain.full_q(q[reach])))  # ... so every joint inside its own
    for node, qi in zip(nodes[reach], q[reach]):
        T = tool(dict(zip(names, qi)))
        np.testing.assert_allclose(T[:3, 3], node, atol=1e-8)
        if R is not None:
            np.testing.assert_allclose(T[:3, :3], R, atol=1e-8)


def test_a_map_of_the_coupled_arm_reaches_where_yourdfpy_says(tmp_path):
    chain = from_urdf(URDF, ee_link="tool")
    nodes = ws.cartesian_grid(-1.2, 1.2, 0.2)
    reach, q = ws.position_map(chain, nodes, return_q=True)
    assert 100 < reach.sum() < len(nodes) and q.shape == (len(nodes), 4)
    _check_solutions(chain, nodes, reach, q, _yourdfpy(URDF, "tool"))
    # the relaxation (each joint free in its own limits) reaches every node the coupled arm does
    assert np.all(ws.position_map(chain.uncoupled(), nodes)[reach])
    (tmp_path / "p.urdf").write_text(URDF)
    out = tmp_path / "p.npz"
    assert cli.main(["map", "--urdf", str(tmp_path / "p.urdf"), "--ee", "tool", "--kind", "reach", "--step", "0.2",
                     "--lo", "-1.2", "--hi", "1.2", "--out", str(out), "-q"]) == 0
    np.testing.assert_array_equal(ws.load_map(out)[0], reach)


#: the palletiser with a two-joint wrist after its tool link: six variables, so a tool orientation is held
WRIST = (DATA / "palletiser_wrist.urdf").read_text()


def test_a_constant_orientation_map_with_its_status():
    chain = from_urdf(WRIST, ee_link="w2")
    assert (chain.n, chain.n_joints) == (6, 8)
    nodes = ws.cartesian_grid(-1.0, 1.0, 0.25)
    reach, q, status = ws.constant_orientation_map(chain, nodes, rpy=(np.pi, 0, 0), convention="standard",
                                                   return_q=True, return_status=True)
    assert reach.sum() > 20
    R = ws.target_poses(nodes[:1], (np.pi, 0, 0), "standard")[0, :3, :3]
    _check_solutions(chain, nodes, reach, q, _yourdfpy(WRIST, "w2"), VARIABLES + ["w1", "w2"], R)
    # the certificate is its relaxation's (each joint free in its own limits): it certifies the far nodes, and
    # none that the relaxation reaches
    assert np.array_equal(status == REACHED, reach) and (status == CERTIFIED).sum() > 100
    free = ws.constant_orientation_map(chain.uncoupled(), nodes, rpy=(np.pi, 0, 0), convention="standard")
    assert not np.any(free & (status == CERTIFIED)) and np.all(free[reach])


def test_an_identity_coupling_maps_as_the_uncoupled_arm():
    arm = as_chain(robots.load("puma560"))
    same = arm.couple(np.arange(arm.n))
    assert same.coupling is not None and closed_form_for(same) is None and closed_form_for(arm) is not None
    nodes = ws.cartesian_grid(-0.8, 0.8, 0.2)
    from wsmap.kinematics import lm_lanes

    with lm_lanes.use_kernel("scalar"):  # the numba kernel, whose arithmetic the coupled kernel repeats
        reach, q = ws.constant_orientation_map(arm, nodes, rpy=(np.pi, 0, 0), method="numerical", return_q=True)
    reach_c, q_c = ws.constant_orientation_map(same, nodes, rpy=(np.pi, 0, 0), method="numerical", return_q=True)
    assert reach.sum() > 50
    np.testing.assert_array_equal(reach_c, reach)
    np.testing.assert_allclose(q_c[reach], q[reach], rtol=0, atol=1e-9)
    with pytest.raises(ValueError, match="has no closed form for puma560"):
        ws.constant_orientation_map(same, nodes, rpy=(np.pi, 0, 0), method="exact")


#: Digests of uncoupled chains read from URDF (their fixed transforms, axes, kinds, offsets, limits) and of
#: their maps, by the reader before coupled joints existed (commit ca0a7ef): the same bytes now. The maps'
#: were taken on the lane kernel's AVX-512 build (a kernel agrees with another to rounding, so another
#: build may differ at a node on a border): checked where that build runs.
DIGESTS = {"mimic_arm": "ac5811abf3ab6e10", "sia20d": "24157e5c4c8c40f5"}
MAP_DIGESTS = {"mimic_arm": (394, "52e2f597d081164a"), "sia20d": (2280, "1d37590db8104e52")}


def _digest(*arrays):
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


@pytest.mark.parametrize("name", sorted(DIGESTS))
def test_an_uncoupled_chain_keeps_its_bytes(name):
    chain = from_urdf(MIMIC, ee_link="tool") if name == "mimic_arm" else \
        from_urdf(ROOT / "data/cells/reach_demo/sia20d.urdf", ee_link="tool0")
    assert chain.coupling is None and chain.n_joints == chain.n
    assert _digest(chain.fixed, chain.axes, np.array(chain.kinds), chain.offset, chain.qlim) == DIGESTS[name]
    from wsmap.kinematics import lm_lanes

    if not (lm_lanes.available() and lm_lanes.kernel() == "lanes" and lm_lanes.isa() == "avx512"):
        pytest.skip("the map digests were taken on the lane kernel's AVX-512 build")
    nodes = ws.cartesian_grid(-0.8, 0.8, 0.1)
    reach = ws.position_map(chain, nodes) if name == "mimic_arm" else \
        ws.constant_orientation_map(chain, nodes, rpy=(np.pi, 0, 0), method="numerical")
    assert (int(reach.sum()), _digest(reach)) == MAP_DIGESTS[name]


# --------------------------------------------------------------------------- what is refused
@pytest.mark.parametrize("change, message", [
    (('<mimic joint="j1" multiplier="0.5"/>', '<mimic joint="j1" multiplier="0"/>'),
     "URDF text: joint 'j5' on the chain mimics 'j1' with multiplier 0: a joint that never moves (make it a fixed "
     "joint)"),
    (('<mimic joint="j1" multiplier="0.5"/>', '<mimic joint="j1" multiplier="0.1" offset="2"/>'),
     "URDF text: no value of 'j1' inside its limits [-inf, inf] keeps 'j1' (1 x 'j1' + 0) inside its own [-3, 3] and "
     "'j5' (0.1 x 'j1' + 2) inside its own [-1, 1]"),
    (('<mimic joint="j2" multiplier="-1" offset="0.2"/>', '<mimic joint="j3"/>'),
     "URDF text: joint 'j3' on the chain mimics 'j3', itself"),
])
def test_what_is_refused_is_one_line_naming_the_joints(change, message):
    text = URDF.replace(*change)
    assert text != URDF
    with pytest.raises(URDFError, match="^" + re.escape(message) + "$") as err:
        from_urdf(text, ee_link="tool")
    assert "\n" not in str(err.value)


def test_mixing_kinds_is_refused_in_one_line():
    text = SLIDES.replace('<mimic joint="s1" multiplier="2" offset="0.05"/>', '<mimic joint="r" multiplier="2"/>')
    with pytest.raises(URDFError, match=re.escape("URDF text: joint 's2' on the chain mimics 'r', a continuous joint "
                                                  "driving a prismatic one: the chain's variable would change units")):
        from_urdf(text, ee_link="d")


def test_the_chain_checks_its_coupling():
    arm = as_chain(robots.load("puma560"))
    with pytest.raises(ValueError, match=r"^the multiplier of joint 3 is 0: a coupling multiplier must be finite and "
                                         r"non-zero$"):
        arm.couple(np.array([0, 1, 1, 2, 3, 4]), mult=[1, 1, 0, 1, 1, 1])
    with pytest.raises(ValueError, match=r"^coupling var must number the variables 0 \.\. n - 1, each driving a joint"):
        arm.couple(np.array([0, 1, 1, 2, 3, 5]))
    with pytest.raises(ValueError, match=r"^couple takes an uncoupled chain"):
        arm.couple(np.arange(6)).couple(np.arange(6))
    with pytest.raises(TypeError, match="coupling must be a Coupling"):
        SerialChain(arm.fixed, arm.axes, arm.kinds, coupling=(np.arange(6),))
    slides = from_urdf(SLIDES, ee_link="d").uncoupled()
    with pytest.raises(ValueError, match=r"^variable 1 drives revolute and prismatic joints \(1, 2\)"):
        slides.couple(np.array([0, 0, 1]))
    with pytest.raises(ValueError, match=r"^no value of 'variable 2' inside its limits \[-inf, inf\] keeps 'joint 2'"):
        slides.couple(np.array([0, 1, 1]), mult=[1, 1, 1], const=[0, 0, 1])
    assert isinstance(from_urdf(URDF, ee_link="tool").coupling, Coupling)


def test_without_joint_limits_the_relaxation_drops_them_too():
    chain = from_urdf(URDF, ee_link="tool")
    free = chain.without_revolute_limits()
    assert free.qlim is None and free.uncoupled().qlim is None and free.coupling.var.tolist() == chain.coupling.var.tolist()
    slides = from_urdf(SLIDES, ee_link="d").without_revolute_limits()
    np.testing.assert_array_equal(slides.uncoupled().qlim, [[-np.inf, np.inf], [0, 0.3], [0, 0.5]])
    # a map that ignores the limits reaches what the limited one does, and more
    nodes = ws.cartesian_grid(-1.2, 1.2, 0.3)
    limited = ws.position_map(chain, nodes)
    unlimited = ws.position_map(chain, nodes, ik={"joint_limits": False})
    assert np.all(unlimited[limited]) and unlimited.sum() > limited.sum()


def test_collision_bodies_follow_every_joint(tmp_path):
    from wsmap.collision import body_frames

    chain = from_urdf(WRIST, ee_link="w2")
    q = chain.random_q(10, np.random.default_rng(4))
    B = body_frames(chain, q)
    assert B.shape == (10, 9, 4, 4)  # the base and one body per joint: a coupled joint moves its link too
    np.testing.assert_array_equal(B, body_frames(chain.uncoupled(), chain.full_q(q)))
    box = '<collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision>'
    (tmp_path / "w.urdf").write_text(WRIST.replace('<link name="l3"/>', f'<link name="l3">{box}</link>'))
    argv = ["map", "--urdf", str(tmp_path / "w.urdf"), "--ee", "w2", "--kind", "constant", "--step", "0.4",
            "--rpy", "pi", "0", "0", "--convention", "standard", "-q"]
    assert cli.main(argv + ["--out", str(tmp_path / "free.npz")]) == 0
    assert cli.main(argv + ["--collision", "--acm-samples", "50", "--out", str(tmp_path / "c.npz")]) == 0
    free, hit = ws.load_map(tmp_path / "free.npz")[0], ws.load_map(tmp_path / "c.npz")[0]
    assert free.sum() >= 5 and not np.any(hit & ~free)


def test_whole_turns_only_where_they_leave_the_pose_alone():
    from wsmap.workspace.study import evaluate_targets, fit_to_limits

    chain = from_urdf(WRIST, ee_link="w2")
    # j1 also drives j5 at half its rate: a turn of j1 is half a turn of j5, another pose
    assert chain.periodic.tolist() == [False, True, True, True, True, True]
    q = chain.random_q(1, np.random.default_rng(5))[0]
    moved = q + 2 * np.pi * np.array([1, 1, 0, 0, 0, 0])
    assert not np.allclose(chain.fkine(moved), chain.fkine(q), atol=1e-9)
    fitted = fit_to_limits(chain, moved)
    np.testing.assert_allclose(fitted[1:], q[1:], atol=1e-12)
    assert fitted[0] == moved[0]
    T = chain.fkine(chain.random_q(4, np.random.default_rng(6)))
    res = evaluate_targets(chain, T)
    assert np.all(res.reached) and np.all(chain.within_limits(res.q))
    np.testing.assert_allclose(chain.fkine(res.q), T, atol=1e-8)


def test_the_numpy_reference_and_the_paper_s_lm_refuse_a_coupled_chain():
    from wsmap.kinematics.ik.lm_reference import ikine_search_reference

    chain = from_urdf(WRIST, ee_link="w2")
    T = chain.fkine(np.zeros(6))
    with pytest.raises(ValueError, match="^the numpy reference search takes chains without coupled joints"):
        ikine_search_reference(chain, T)
    nodes = ws.cartesian_grid(-0.5, 0.5, 0.5)
    with pytest.raises(ValueError, match=r"^the paper's solver \(ikine_LM\) is for DHRobot arms; use solver 'search'$"):
        ws.constant_orientation_map(chain, nodes, method="numerical", ik={"solver": "paper"})
