"""URDF import and export: exact round trips, the real Panda description, helpful errors."""
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from robocal.errors import FileFormatError, InputError
from robocal.io.datasets import dataset_dir
from robocal.io.urdf import chain_to_urdf, read_urdf, write_urdf
from robocal.kinematics import Chain, to_poe
from robocal.spatial import compose_pose, translation

PANDA_URDF = dataset_dir() / "mukca" / "panda.urdf"
N_CONFIGURATIONS = 1000
POSITION_TOL_MM = 1e-9
ROTATION_TOL = 1e-12


def kr150():
    """KUKA KR150-2-like DH chain with signed joints, limits, a base and a tool."""
    return Chain(
        "KR150-2", "dh", ("revolute",) * 6,
        theta=np.radians([0, -90, 0, 0, 0, 0]),
        d=[750, 0, 0, 1100, 0, 230],
        a=[350, 1250, -55, 0, 0, 0],
        alpha=np.radians([-90, 0, -90, 90, -90, 0]),
        joint_map=np.diag([-1, 1, 1, -1, 1, -1.0]),
        lower=np.radians([-185, -140, -120, -350, -125, -350]),
        upper=np.radians([185, -5, 155, 350, 125, 350]),
        base=compose_pose([1500.0, -300.0, 20.0], np.radians([0.5, -0.3, 30.0])),
        # A tool tilted to pitch = 90 deg exercises the rpy singularity on export.
        tool=compose_pose([12.0, -8.0, 180.0], np.radians([10.0, 90.0, 20.0])),
    )


def panda_mdh():
    """Franka Panda in Craig's modified DH form, flange 107 mm past joint 7."""
    return Chain(
        "Panda", "mdh", ("revolute",) * 7,
        theta=np.zeros(7),
        a=[0, 0, 0, 82.5, -82.5, 0, 88],
        d=[333, 0, 316, 0, 384, 0, 0],
        alpha=np.radians([0, -90, 90, 90, -90, 90, 90]),
        lower=[-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973],
        upper=[2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973],
        flange=translation(z=107.0),
    )


def perturbed(chain, seed):
    """The chain with every parameter (beta, base and tool included) randomly off."""
    names = chain.parameter_names()
    return chain.perturbed(names, np.random.default_rng(seed).normal(size=len(names)) * 0.01)


def with_prismatic():
    """A DH chain with prismatic joints (one reversed, one unlimited) and a continuous joint."""
    return Chain(
        "gantry", "dh", ("prismatic", "revolute", "prismatic", "revolute"),
        theta=np.radians([10.0, -30.0, 5.0, 0.0]),
        d=[400.0, 120.0, -50.0, 80.0],
        a=[100.0, 300.0, 0.0, 20.0],
        alpha=np.radians([90.0, 0.0, -90.0, 0.0]),
        beta=np.radians([0.0, 0.3, 0.0, 0.0]),
        joint_map=np.diag([1.0, -1.0, -1.0, 1.0]),
        lower=[-200.0, -np.pi, 0.0, -np.inf],
        upper=[300.0, np.pi, np.inf, np.inf],
        tool=compose_pose([0.0, 5.0, 60.0], np.radians([0.0, 0.0, 45.0])),
    )


def near_singular_rpy():
    """Base and tool within 1e-7 rad of pitch = ±90 deg, where rpy extraction loses digits."""
    return kr150().replace(
        base=compose_pose([1.0, 2.0, 3.0], [0.1, -np.pi / 2 + 1e-9, 2.0]),
        tool=compose_pose([1.0, 2.0, 300.0], [0.4, np.pi / 2 - 3e-8, -0.2]),
    )


CHAINS = {
    "kr150_dh": kr150,
    "panda_mdh": panda_mdh,
    "kr150_perturbed": lambda: perturbed(kr150(), 1),
    "panda_perturbed": lambda: perturbed(panda_mdh(), 2),
    "kr150_poe_perturbed": lambda: perturbed(to_poe(kr150()), 3),
    "prismatic": with_prismatic,
    "near_singular_rpy": near_singular_rpy,
}


def assert_same_fk(expected, actual, q, q_actual=None):
    pose_expected = expected.fk(q)
    pose_actual = actual.fk(q if q_actual is None else q_actual)
    assert np.abs(pose_actual[:, :3, 3] - pose_expected[:, :3, 3]).max() < POSITION_TOL_MM
    assert np.abs(pose_actual[:, :3, :3] - pose_expected[:, :3, :3]).max() < ROTATION_TOL


@pytest.mark.parametrize("key", list(CHAINS))
def test_export_then_import_reproduces_fk_and_limits(key, tmp_path):
    chain = CHAINS[key]()
    path = write_urdf(chain, tmp_path / "robot.urdf")
    back = read_urdf(path, tip="tcp")
    q = chain.random_configurations(N_CONFIGURATIONS, rng=7)
    assert_same_fk(chain, back, q)
    assert back.joint_types == chain.joint_types
    np.testing.assert_allclose(back.lower, chain.lower, rtol=1e-14)
    np.testing.assert_allclose(back.upper, chain.upper, rtol=1e-14)


def test_exported_file_layout(tmp_path):
    chain = with_prismatic()
    robot = ET.fromstring(chain_to_urdf(chain, robot_name="my gantry & co"))
    assert robot.get("name") == "my gantry & co"
    assert [link.get("name") for link in robot.findall("link")] == [
        "world", "base_link", "link_1", "link_2", "link_3", "link_4", "flange", "tcp"]
    joints = {joint.get("name"): joint for joint in robot.findall("joint")}
    assert [joints[f"joint_{k}"].get("type") for k in range(1, 5)] == [
        "prismatic", "revolute", "prismatic", "continuous"]
    # Axis signs follow the joint map; limits are in metres for prismatic joints.
    assert joints["joint_2"].find("axis").get("xyz") == "0.0 0.0 -1.0"
    assert joints["joint_3"].find("axis").get("xyz") == "0.0 0.0 -1.0"
    assert float(joints["joint_1"].find("limit").get("upper")) == pytest.approx(0.3)
    assert joints["joint_3"].find("limit").get("upper") is None  # unbounded: left out
    assert joints["joint_4"].find("limit") is None
    for name, parent, child in (("world_to_base", "world", "base_link"),
                                ("flange_joint", "link_4", "flange"), ("tcp_joint", "flange", "tcp")):
        assert joints[name].get("type") == "fixed"
        assert joints[name].find("parent").get("link") == parent
        assert joints[name].find("child").get("link") == child


def test_urdf_joint_values_are_controller_values():
    """Offsets are folded into the origins: the URDF at q matches the chain at q."""
    chain = kr150()
    robot = ET.fromstring(chain_to_urdf(chain))
    origin = {j.get("name"): j.find("origin") for j in robot.findall("joint")}
    # Joint 2's zero offset (-90 deg about z) is part of its origin.
    assert origin["joint_2"].get("rpy") != "0.0 0.0 0.0"
    assert origin["joint_3"].get("rpy") == "0.0 0.0 0.0"
    assert origin["joint_3"].get("xyz") == "1.25 0.0 0.0"


def test_write_replaces_existing_file_atomically(tmp_path):
    target = tmp_path / "robot.urdf"
    target.write_text("old")
    assert write_urdf(kr150(), target) == target
    assert target.read_text().startswith('<?xml version="1.0"?>')
    assert sorted(p.name for p in tmp_path.iterdir()) == ["robot.urdf"]


def test_write_into_missing_directory_fails_clearly(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        write_urdf(kr150(), tmp_path / "nowhere" / "robot.urdf")


def test_coupled_joint_map_is_refused_unless_allowed(tmp_path):
    joint_map = np.eye(6)
    joint_map[2, 1] = 1.0  # FANUC-style: the J3 model angle includes J2
    chain = kr150().replace(joint_map=joint_map)
    with pytest.raises(InputError, match="couples joints.*allow_coupled=True"):
        chain_to_urdf(chain)
    text = chain_to_urdf(chain, allow_coupled=True)
    assert "model variables q_model = joint_map . q" in text
    path = tmp_path / "coupled.urdf"
    path.write_text(text)
    back = read_urdf(path, tip="tcp")
    q = chain.random_configurations(N_CONFIGURATIONS, rng=3)
    assert_same_fk(chain, back, q, q_actual=chain.model_joints(q))
    # Limits bound the model variable over the controller's limit box: J3 + J2 here.
    assert back.lower[2] == pytest.approx(chain.lower[1] + chain.lower[2])
    assert back.upper[2] == pytest.approx(chain.upper[1] + chain.upper[2])


# ------------------------------------------------------------------ the real Panda file
def test_panda_urdf_matches_craig_model():
    urdf = read_urdf(PANDA_URDF, tip="panda_link8")
    assert urdf.name == "panda"
    assert urdf.n_joints == 7
    mdh = panda_mdh()
    assert np.abs(urdf.fk(np.zeros(7))[:3, 3] - mdh.fk(np.zeros(7))[:3, 3]).max() < 1e-6
    q = mdh.random_configurations(N_CONFIGURATIONS, rng=5)
    assert np.abs(urdf.fk(q) - mdh.fk(q)).max() < 1e-6
    np.testing.assert_allclose(urdf.lower, mdh.lower)
    np.testing.assert_allclose(urdf.upper, mdh.upper)


def test_panda_tip_after_fixed_joints_goes_into_home():
    to_flange = read_urdf(PANDA_URDF, root="panda_link0", tip="panda_link8")
    to_tcp = read_urdf(PANDA_URDF, root="panda_link0", tip="panda_hand_tcp")
    expected = to_flange.home @ compose_pose([0.0, 0.0, 103.4], [0.0, 0.0, -np.pi / 4])
    np.testing.assert_allclose(to_tcp.home, expected, atol=1e-12)


def test_panda_from_an_inner_root():
    inner = read_urdf(PANDA_URDF, root="panda_link3", tip="panda_link8", name="wrist")
    assert inner.name == "wrist"
    assert inner.n_joints == 4


# -------------------------------------------------------------- hand-written files
def write_robot(tmp_path, body, name="hand.urdf"):
    path = tmp_path / name
    path.write_text(f'<?xml version="1.0"?>\n<robot name="hand">\n{body}\n</robot>\n')
    return path


def links(*names):
    return "\n".join(f'<link name="{n}"/>' for n in names)


def test_defaults_fixed_joints_continuous_and_prismatic(tmp_path):
    path = write_robot(tmp_path, links("a", "b", "c", "d", "e") + """
      <joint name="j1" type="continuous"><parent link="a"/><child link="b"/></joint>
      <joint name="mount" type="fixed"><parent link="b"/><child link="c"/>
        <origin xyz="0.1 0 0" rpy="0 0 1.5707963267948966"/></joint>
      <joint name="j2" type="prismatic"><parent link="c"/><child link="d"/>
        <origin xyz="0 0 0.2"/><axis xyz="0 0 -2"/>
        <limit lower="-0.05" upper="0.25" effort="1" velocity="1"/></joint>
      <joint name="end" type="fixed"><parent link="d"/><child link="e"/>
        <origin xyz="0 0.03 0"/></joint>""")
    chain = read_urdf(path)  # root "a" and the single leaf "e" are found alone
    assert chain.joint_types == ("revolute", "prismatic")
    np.testing.assert_allclose(chain.axes, [[1, 0, 0], [0, 0, -1]], atol=1e-15)  # missing axis = x
    np.testing.assert_allclose(chain.points, [[0, 0, 0], [100, 0, 200]], atol=1e-12)
    np.testing.assert_allclose(chain.home[:3, 3], [100 - 30, 0, 200], atol=1e-12)
    np.testing.assert_allclose(chain.lower, [-np.inf, -50.0])
    np.testing.assert_allclose(chain.upper, [np.inf, 250.0])
    # Prismatic travel is in mm along the (normalised, negative) axis.
    np.testing.assert_allclose(chain.fk([0.0, 40.0])[:3, 3], [70, 0, 160], atol=1e-12)


# ----------------------------------------------------------------------------- errors
def test_several_leaves_need_a_tip():
    with pytest.raises(InputError, match="--tip") as error:
        read_urdf(PANDA_URDF)
    message = str(error.value)
    assert str(PANDA_URDF) in message
    for leaf in ("ball_link", "panda_leftfinger", "panda_rightfinger"):
        assert leaf in message


def test_unknown_link():
    with pytest.raises(InputError, match="no link 'panda_link9'.*panda_link8"):
        read_urdf(PANDA_URDF, tip="panda_link9")
    with pytest.raises(InputError, match="as the root"):
        read_urdf(PANDA_URDF, root="base", tip="panda_link8")


def test_mimic_joint_on_the_path():
    with pytest.raises(InputError, match="panda_finger_joint2.*mimic"):
        read_urdf(PANDA_URDF, tip="panda_rightfinger")


def test_no_path_from_root_to_tip():
    with pytest.raises(InputError, match="no path from link 'panda_link8' down to link 'panda_link3'"):
        read_urdf(PANDA_URDF, root="panda_link8", tip="panda_link3")


def test_no_movable_joint():
    with pytest.raises(InputError, match="no movable joint"):
        read_urdf(PANDA_URDF, root="panda_link8", tip="panda_hand_tcp")


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="absent.urdf does not exist"):
        read_urdf(tmp_path / "absent.urdf")


def test_malformed_xml(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text('<robot name="r"><link name="a"></robot>')
    with pytest.raises(FileFormatError, match="broken.urdf is not well-formed XML.*line 1"):
        read_urdf(path)


def test_not_a_urdf(tmp_path):
    path = tmp_path / "other.xml"
    path.write_text("<config><link name='a'/></config>")
    with pytest.raises(FileFormatError, match="not <robot>"):
        read_urdf(path)


def test_xacro_file(tmp_path):
    path = tmp_path / "arm.urdf.xacro"
    path.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r">'
                    '<xacro:property name="l" value="1"/><link name="a"/></robot>')
    with pytest.raises(FileFormatError, match="xacro file: expand it first"):
        read_urdf(path)


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_unsupported_joint_types(tmp_path, kind):
    path = write_robot(tmp_path, links("a", "b") + f"""
      <joint name="free" type="{kind}"><parent link="a"/><child link="b"/></joint>""")
    with pytest.raises(InputError, match=f"joint 'free' is {kind}"):
        read_urdf(path)


@pytest.mark.parametrize("joint, match", [
    ('<joint name="j" type="revolute"><parent link="a"/><child link="zz"/></joint>',
     "child link 'zz', which has no <link>"),
    ('<joint name="j" type="revolute"><child link="b"/></joint>', "has no <parent"),
    ('<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
     '<origin xyz="0 0"/></joint>', 'xyz="0 0" is not three numbers'),
    ('<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
     '<axis xyz="0 0 0"/></joint>', "zero-length axis"),
    ('<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
     '<limit lower="1" upper="-1"/></joint>', "lower limit 1.0 above upper limit -1.0"),
    ('<joint name="j" type="hinge"><parent link="a"/><child link="b"/></joint>', "type 'hinge'"),
])
def test_bad_joint_elements(tmp_path, joint, match):
    path = write_robot(tmp_path, links("a", "b") + joint)
    with pytest.raises(FileFormatError, match=match) as error:
        read_urdf(path)
    assert str(path) in str(error.value)


def test_not_a_tree(tmp_path):
    path = write_robot(tmp_path, links("a", "b", "c") + """
      <joint name="j1" type="revolute"><parent link="a"/><child link="c"/></joint>
      <joint name="j2" type="revolute"><parent link="b"/><child link="c"/></joint>""")
    with pytest.raises(FileFormatError, match="child of two joints"):
        read_urdf(path)


def test_separate_trees_need_a_root(tmp_path):
    path = write_robot(tmp_path, links("a", "b", "c", "d") + """
      <joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>
      <joint name="j2" type="revolute"><parent link="c"/><child link="d"/></joint>""")
    with pytest.raises(InputError, match=r"2 separate link trees \(roots: a, c\).*--root"):
        read_urdf(path)
    assert read_urdf(path, root="c").n_joints == 1


def test_joint_loop(tmp_path):
    path = write_robot(tmp_path, links("a", "b") + """
      <joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>
      <joint name="j2" type="revolute"><parent link="b"/><child link="a"/></joint>""")
    with pytest.raises(FileFormatError, match="form a loop"):
        read_urdf(path)


def test_link_masses_travel_through_robot_files_urdf_and_conversions(tmp_path):
    from robocal.io.library import builtin
    from robocal.io.robot_file import read_robot, write_robot
    from robocal.kinematics import to_dh, to_mdh
    from robocal.kinematics.gravity import default_mass_model, scaled_mass_model

    panda = builtin("panda")
    assert panda.masses is not None and panda.masses.size == 7
    write_robot(panda, tmp_path / "panda.toml")
    np.testing.assert_array_equal(read_robot(tmp_path / "panda.toml").masses, panda.masses)
    write_urdf(panda, tmp_path / "panda.urdf")
    np.testing.assert_allclose(read_urdf(tmp_path / "panda.urdf", tip="tcp").masses, panda.masses)
    np.testing.assert_array_equal(to_mdh(to_poe(panda)).masses, panda.masses)
    # The gravity model takes the robot's own masses, and the scaled design without them.
    np.testing.assert_array_equal(default_mass_model(panda).link_masses, panda.masses)
    bare = panda.replace(masses=None)
    np.testing.assert_array_equal(default_mass_model(bare).link_masses, scaled_mass_model(bare).link_masses)
    # Measured masses come without an invented payload (the scaled design's would be 8 kg on a
    # 3 kg robot); the scaled design keeps its rated payload; a given payload is used as is.
    assert default_mass_model(panda).payload == 0.0
    assert default_mass_model(bare).payload == scaled_mass_model(bare).payload > 0
    assert default_mass_model(panda, 1.5).payload == default_mass_model(bare, 1.5).payload == 1.5
    kr = builtin("kr150-2")
    assert kr.masses is None and to_dh(kr).masses is None
    # A URDF whose moved links declare no <inertial> gives no masses, rather than zeros.
    assert read_urdf(PANDA_URDF, tip="ball_link").masses is None


def test_bad_masses_are_refused(tmp_path):
    text = (Path(__file__).resolve().parents[1] / "robocal/io/robots/ur5.toml").read_text()
    (tmp_path / "some.toml").write_text(text.replace("mass = 3.7\n", "", 1))
    with pytest.raises(FileFormatError, match="mass"):
        from robocal.io.robot_file import read_robot

        read_robot(tmp_path / "some.toml")
    with pytest.raises(InputError, match="masses"):
        kr150().replace(masses=[1.0, 2.0])
