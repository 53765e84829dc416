import numpy as np
import pytest

from robocal.errors import InputError
from robocal.io.library import builtin_names, load_robot
from robocal.kinematics import Chain, to_dh, to_mdh, to_poe
from robocal.spatial import so3_log

ALL = builtin_names()


def test_kr150_at_dh_zero_matches_hand_computed_pose():
    kr = load_robot("kr150-2")
    # DH q = 0 is A = (0, -90, 90, 0, 0, 0): upper arm up, forearm forward, flange down the x axis.
    T = kr.fk(np.radians([0.0, -90.0, 90.0, 0.0, 0.0, 0.0]))
    np.testing.assert_allclose(T[:3, 3], [1680.0, 0.0, 1945.0], atol=1e-9)
    np.testing.assert_allclose(T[:3, 2], [1.0, 0.0, 0.0], atol=1e-12)  # tool z along +x


def test_kr150_controller_signs():
    kr = load_robot("kr150-2")
    home = np.radians([0.0, -90.0, 90.0, 0.0, 0.0, 0.0])
    # KUKA A1 positive turns the arm clockwise seen from above: the flange goes to -y.
    turned = kr.fk_positions(home + np.radians([10, 0, 0, 0, 0, 0]))
    assert turned[1] < -100.0


def test_irb120_at_zero():
    T = load_robot("irb120").fk(np.zeros(6))
    np.testing.assert_allclose(T[:3, 3], [374.0, 0.0, 630.0], atol=1e-9)


def test_fanuc_coupling_keeps_forearm_horizontal_when_j2_moves():
    fanuc = load_robot("fanuc-r2000ic-165f")
    q = np.radians([[0, 0, 0, 0, 0, 0], [0, 30, 0, 0, 0, 0]])
    T = fanuc.fk(q)
    np.testing.assert_allclose(T[0, :3, 3], [1807.0, 0.0, 1300.0], atol=1e-9)
    # J3 is measured from the horizontal: with J3 = 0 the forearm (tool z) stays horizontal.
    np.testing.assert_allclose(T[1, 2, 2], 0.0, atol=1e-12)


@pytest.mark.parametrize("name", ALL)
def test_fk_batch_equals_single_and_positions_path(name):
    chain = load_robot(name)
    q = chain.random_configurations(50, 1)
    T = chain.fk(q)
    np.testing.assert_allclose(chain.fk(q[3]), T[3], atol=1e-12)
    np.testing.assert_allclose(chain.fk_positions(q), T[:, :3, 3], atol=1e-9)


@pytest.mark.parametrize("name", ALL)
def test_dh_mdh_poe_forms_agree(name):
    chain = load_robot(name)
    q = chain.random_configurations(1000, 2)
    reference = chain.fk(q)
    for convert in (to_dh, to_mdh, to_poe, lambda c: to_dh(to_poe(c)), lambda c: to_mdh(to_poe(c))):
        other = convert(chain)
        assert np.abs(other.fk(q) - reference).max() < 1e-9


@pytest.mark.parametrize("name", ["kr150-2", "panda", "ur10"])
def test_conversions_exact_for_calibrated_models_with_beta(name):
    chain = load_robot(name)
    names = chain.parameter_names()
    rng = np.random.default_rng(3)
    calibrated = chain.perturbed(names, rng.normal(size=len(names)) * 0.01)
    q = chain.random_configurations(1000, 4)
    reference = calibrated.fk(q)
    for convert in (to_dh, to_mdh, to_poe, lambda c: to_mdh(to_poe(c))):
        assert np.abs(convert(calibrated).fk(q) - reference).max() < 1e-9


def _pose_difference(T1, T0):
    """[dp; dw] of T1 relative to T0 in the world frame."""
    dw = so3_log(T1[..., :3, :3] @ np.swapaxes(T0[..., :3, :3], -1, -2))
    return np.concatenate([T1[..., :3, 3] - T0[..., :3, 3], dw], axis=-1)


@pytest.mark.parametrize("name", ALL)
def test_geometric_jacobian_matches_central_differences(name):
    chain = load_robot(name).replace(tool=np.array([[1, 0, 0, 20.0], [0, 1, 0, -10], [0, 0, 1, 150], [0, 0, 0, 1]]))
    q = chain.random_configurations(20, 5)
    _, J = chain.fk_jacobian(q)
    h = 1e-6
    for j in range(chain.n_joints):
        dq = np.zeros(chain.n_joints)
        dq[j] = h
        numeric = (_pose_difference(chain.fk(q + dq), chain.fk(q - dq))) / (2 * h)
        np.testing.assert_allclose(J[:, :, j], numeric, atol=2e-6 * max(1.0, np.abs(numeric).max()))


@pytest.mark.parametrize("convert", [lambda c: c, to_mdh, to_poe], ids=["dh", "mdh", "poe"])
@pytest.mark.parametrize("name", ["kr150-2", "panda", "ur5"])
def test_identification_jacobian_matches_central_differences(name, convert):
    base = load_robot(name)
    rng = np.random.default_rng(11)
    names0 = base.parameter_names()
    chain = convert(base.perturbed(names0, rng.normal(size=len(names0)) * 0.01))
    chain = chain.replace(base=chain.base @ np.array([[0, -1, 0, 500.0], [1, 0, 0, -200], [0, 0, 1, 30], [0, 0, 0, 1]]))
    names = chain.parameter_names(chain._groups())
    q = chain.random_configurations(15, 6)
    J = chain.identification_jacobian(q, names)
    h = 1e-6
    for j, name_j in enumerate(names):
        plus = chain.perturbed([name_j], [h]).fk(q)
        minus = chain.perturbed([name_j], [-h]).fk(q)
        numeric = _pose_difference(plus, minus) / (2 * h)
        scale = max(1.0, np.abs(numeric).max())
        np.testing.assert_allclose(J[:, :, j], numeric, atol=2e-6 * scale, err_msg=name_j)


def test_identification_jacobian_of_offsets_equals_geometric_columns_for_unit_signs():
    chain = load_robot("ur10")
    q = chain.random_configurations(10, 8)
    J_id = chain.identification_jacobian(q, chain.parameter_names(("offsets",)))
    np.testing.assert_allclose(J_id, chain.jacobian(q), atol=1e-9)


def test_prismatic_joint_chain():
    chain = Chain("gantry", "dh", ("prismatic", "revolute"), theta=[0.0, 0.0], d=[100.0, 0.0],
                  a=[0.0, 300.0], alpha=[np.pi / 2, 0.0])
    T = chain.fk(np.array([50.0, 0.0]))
    np.testing.assert_allclose(T[:3, 3], [300.0, 0.0, 150.0], atol=1e-12)
    q = chain.random_configurations(100, 1) + [200.0, 0.0]
    for convert in (to_mdh, to_poe):
        np.testing.assert_allclose(convert(chain).fk(q), chain.fk(q), atol=1e-9)


def test_bad_joint_count_is_a_clear_error():
    with pytest.raises(InputError, match="6 joints"):
        load_robot("kr150-2").fk(np.zeros(5))


def test_unknown_parameter_name():
    with pytest.raises(InputError, match="does not exist"):
        load_robot("kr150-2").identification_jacobian(np.zeros((1, 6)), ["alpha9"])


@pytest.mark.parametrize("convert", [lambda c: c, to_mdh, to_poe])
def test_parameter_space_records_match_the_names(convert):
    chain = convert(load_robot("kr150-2"))
    space = chain.parameters
    assert list(space.names) == chain.parameter_names(chain._groups()[:1] + ("gains",) + chain._groups()[1:])
    for k, p in enumerate(space):
        assert space.index(p.name) == p.index == k and space[p.name] is p
    theta3, base_rz, tool_y, gain4 = (space[n] for n in ("theta3", "base_rz", "tool_y", "gain4"))
    assert (theta3.group, theta3.joint, theta3.kind, theta3.unit, theta3.angular) == ("link", 3, "theta", "rad", True)
    assert (base_rz.group, base_rz.joint, base_rz.kind, base_rz.unit) == ("base", None, "rz", "rad")
    assert (tool_y.unit, tool_y.angular, tool_y.file_factor) == ("mm", False, 1.0)
    assert (gain4.group, gain4.joint, gain4.unit, gain4.file_factor) == ("gains", 4, "fraction", 1e6)
    assert theta3.file_factor == pytest.approx(180 / np.pi)
    if chain.convention == "poe":
        assert space["wx2"].angular and not space["ux2"].angular and "home_z" in space and "alpha2" not in space
    else:
        assert space["alpha2"].angular and not space["a2"].angular and "home_z" not in space
    with pytest.raises(InputError, match="does not exist"):
        space["theta7"]


def test_prismatic_offsets_units_follow_the_convention():
    chain = Chain("gantry", "dh", ("prismatic", "revolute"), theta=[0.0, 0.0], d=[100.0, 0.0],
                  a=[0.0, 300.0], alpha=[np.pi / 2, 0.0])
    # A DH prismatic joint's theta still turns about z; a POE one's slides along the axis.
    assert chain.is_angular("theta1") and not chain.is_angular("d1")
    assert not to_poe(chain).is_angular("theta1") and to_poe(chain).is_angular("theta2")
    assert chain.rigid is chain
