"""Simulation layer: true robots (deviations, compliance, backlash, noise, truth files),
presets and sampling plans."""
import numpy as np
import pytest

from robocal.errors import InputError
from robocal.io.library import load_robot
from robocal.kinematics.ik import ik_all
from robocal.simulation import (
    GRAVITY,
    Compliance,
    TrueRobot,
    grid,
    latin_hypercube_box,
    liu2022_plan,
    make_true_robot,
    read_truth,
    uniform_joints,
    write_truth,
)
from robocal.spatial import rpy_to_matrix, so3_log

KR150 = load_robot("kr150-2")
UR5 = load_robot("ur5")
FANUC = load_robot("fanuc-r2000ic-165f")  # coupled J2/J3 joint map
STRETCHED = np.zeros(6)  # KR 150-2 controller zero: arm stretched out horizontally
DOWN = KR150.fk(np.radians([0, -90, 90, 0, 90, 0]))[:3, :3]  # flange pointing down


def deg(*values):
    return np.radians(values)


# ------------------------------------------------------------------ liu2022 reproduction
def test_liu2022_reproduces_published_errors_before_compensation():
    q, targets, train, test = liu2022_plan(KR150)
    assert q.shape == (150, 6) and targets.shape == (150, 4, 4)
    np.testing.assert_array_equal(train, np.arange(50))
    np.testing.assert_array_equal(test, np.arange(50, 150))
    truth = make_true_robot(KR150, "liu2022")
    e = truth.pose(q)[:, :3, 3] - targets[:, :3, 3]
    # Published statistics are over all 150 points (see robocal.simulation.liu2022).
    assert np.linalg.norm(e, axis=1).mean() == pytest.approx(1.690, abs=0.005)
    assert np.abs(e[:, 1]).mean() == pytest.approx(1.560, abs=0.005)
    assert np.abs(e[:, 1]).max() == pytest.approx(1.910, abs=0.005)
    assert np.abs(e[:, 2]).mean() == pytest.approx(0.271, abs=0.005)
    # Commanded posture: A4 = 0, wrist not flipped; the nominal model reaches every target.
    np.testing.assert_allclose(q[:, 3], 0.0, atol=1e-9)
    assert np.all(q[:, 4] > 0)
    np.testing.assert_allclose(KR150.fk(q), targets, atol=1e-9)


def test_liu2022_is_pure_geometry():
    truth = make_true_robot(KR150, "liu2022")
    assert truth.compliance is None and truth.backlash is None
    assert truth.noise == 0.0 and truth.noise_orientation == 0.0
    q = KR150.random_configurations(20, rng=3)
    np.testing.assert_array_equal(truth.measure(q, rng=0), truth.actual.fk_positions(q))


# ------------------------------------------------------------------------------ presets
@pytest.mark.parametrize("chain", [KR150, UR5, FANUC])
def test_preset_none_has_no_error(chain):
    truth = make_true_robot(chain, "none")
    q = chain.random_configurations(50, rng=1)
    assert np.all(truth.error(q) == 0.0)
    assert np.all(truth.measure(q, rng=2) == chain.fk_positions(q))


def test_typical_preset_perturbs_every_parameter_by_plausible_amounts():
    truth = make_true_robot(KR150, "typical", seed=4)
    assert set(truth.deviations) == set(KR150.parameter_names())
    links = np.array([v for k, v in truth.deviations.items() if not k.startswith(("base", "tool"))])
    assert 0.0 < np.abs(links).max() < 1.5  # a few tenths of a mm / hundredths of a degree
    assert truth.noise == pytest.approx(0.02)
    assert make_true_robot(KR150, "typical", seed=4).deviations == truth.deviations
    assert make_true_robot(KR150, "typical", seed=5).deviations != truth.deviations


def test_typical_compliance_deflects_a_few_tenths_of_a_mm_at_full_reach():
    rigid = TrueRobot(KR150)
    compliant = TrueRobot(KR150, compliance=make_true_robot(KR150, "typical").compliance)
    sag = np.linalg.norm(compliant.positions(STRETCHED) - rigid.positions(STRETCHED))
    assert 0.1 < sag < 1.0


def test_unknown_preset_and_liu2022_on_another_robot_are_refused():
    with pytest.raises(InputError, match="none, typical, liu2022"):
        make_true_robot(KR150, "perfect")
    with pytest.raises(InputError, match="KR 150-2.*'kr150-2'"):
        make_true_robot(UR5, "liu2022")
    with pytest.raises(InputError, match="KR 150-2"):
        liu2022_plan(UR5)


# --------------------------------------------------------------------------- compliance
def tcp_sag(chain, q, stiffness, payload):
    masses = make_true_robot(chain, "typical").compliance.link_masses
    compliant = TrueRobot(chain, compliance=Compliance(np.full(chain.n_joints, stiffness), masses, payload))
    return np.linalg.norm(compliant.error(q), axis=-1)


def test_deflection_grows_with_payload_and_reach_and_vanishes_when_rigid():
    assert (tcp_sag(KR150, STRETCHED, 1e8, 150.0) > tcp_sag(KR150, STRETCHED, 1e8, 50.0)
            > tcp_sag(KR150, STRETCHED, 1e8, 0.0) > 0)
    # The stretched arm swung down from vertical (A2 = -90) to horizontal (A2 = 0): the reach
    # and with it the sag grow all the way.
    swing = np.zeros((10, 6))
    swing[:, 1] = np.radians(np.linspace(-90, 0, 10))
    sag = tcp_sag(KR150, swing, 1e8, 150.0)
    assert np.all(np.diff(sag) > 0)
    assert np.all(tcp_sag(KR150, swing, np.inf, 150.0) == 0.0)


@pytest.mark.parametrize("chain", [KR150, UR5, FANUC])
def test_gravity_torque_is_minus_the_gradient_of_the_potential_energy(chain):
    compliance = make_true_robot(chain, "typical").compliance
    q = chain.random_configurations(8, rng=7)
    step = 1e-6
    shifts = np.eye(chain.n_joints) * step
    mass_model = compliance.mass_model

    def potential_energy(joints):  # (N,) J, heights of the link masses and payload in m
        return GRAVITY * (mass_model.mass_points(chain, joints)[..., 2] * 1e-3) @ mass_model.masses

    energy_up = potential_energy((q[:, None, :] + shifts).reshape(-1, chain.n_joints))
    energy_down = potential_energy((q[:, None, :] - shifts).reshape(-1, chain.n_joints))
    gradient = (energy_up - energy_down).reshape(q.shape) / (2 * step)  # dV / d(controller joint)
    # The torque is per model joint; q_model = q @ joint_map.T, so dV/dq = dV/dq_model @ joint_map.
    torque = compliance.gravity_torque(chain, q) @ chain.joint_map
    np.testing.assert_allclose(torque, -gradient, rtol=1e-6, atol=1e-6 * np.abs(gradient).max())


# ----------------------------------------------------------------------------- backlash
def test_backlash_follows_the_direction_of_the_last_motion():
    half_width = np.full(6, 0.01)  # deg
    truth = TrueRobot(KR150, backlash=half_width)
    b = np.radians(0.01)
    # Joint 2 moves up, up, stays, down, stays, up; joint 1 never moves.
    a2 = np.radians([-80, -70, -70, -75, -75, -60])
    q = np.tile(deg(0, -90, 90, 0, 60, 0), (6, 1))
    q[:, 1] = a2
    previous = deg(0, -90, 90, 0, 60, 0)
    expected = q.copy()
    expected[:, 1] += b * np.array([1, 1, 1, -1, -1, 1])
    np.testing.assert_allclose(truth.pose(q, previous=previous), KR150.fk(expected), atol=1e-12)
    # Joint 5 rises from the previous posture in the first row and keeps that side; joint 1
    # never moves and stays in the middle of its play.
    q[:, 4] += 0.1
    expected[:, 4] = q[:, 4] + b
    np.testing.assert_allclose(truth.pose(q, previous=previous), KR150.fk(expected), atol=1e-12)


def test_backlash_acts_on_model_joints_through_the_joint_map():
    # KR 150-2 joint 1 has sign -1: a positive controller move is a negative model move, and
    # the offset still lies on the side the controller moved to.
    truth = TrueRobot(KR150, backlash=np.full(6, 0.02))
    q = deg(10, -90, 90, 0, 60, 0)
    expected = q + np.radians(0.02) * np.sign(q)  # every joint moved from zero (joint 4, 6: not)
    np.testing.assert_allclose(truth.pose(q), KR150.fk(expected), atol=1e-12)


# ---------------------------------------------------------------------- noise and truth file
def test_measurement_noise_has_the_requested_spread():
    truth = TrueRobot(KR150, noise=0.05, noise_orientation=0.02)
    q = np.tile(deg(0, -90, 90, 0, 60, 0), (4000, 1))
    positions, rotations = truth.measure(q, np.random.default_rng(0), orientation=True)
    assert positions.std(axis=0) == pytest.approx([0.05] * 3, rel=0.05)
    turns = so3_log(rotations @ np.swapaxes(truth.pose(q)[:, :3, :3], 1, 2))
    assert np.degrees(turns.std(axis=0)) == pytest.approx([0.02] * 3, rel=0.05)
    table = truth.measurements(q[:3], rng=1, orientation=True)
    np.testing.assert_array_equal(table.joints, np.degrees(q[:3]))
    np.testing.assert_array_equal(table.sigmas, 0.05)
    # The same draws in internal units: rotation matrices, joints in rad.
    observed = truth.observations(q[:3], rng=1, orientation=True)
    np.testing.assert_array_equal(observed.joints, q[:3])
    np.testing.assert_allclose(rpy_to_matrix(np.radians(table.orientations)), observed.rotations, atol=1e-12)


def test_truth_file_round_trip_reproduces_the_robot_exactly(tmp_path):
    truth = make_true_robot(KR150, "typical", seed=11)
    path = write_truth(tmp_path / "truth.json", truth)
    again = read_truth(path)
    q = KR150.random_configurations(30, rng=5)
    start = deg(1, -80, 80, 5, 40, 3)
    np.testing.assert_array_equal(again.pose(q, previous=start), truth.pose(q, previous=start))
    np.testing.assert_array_equal(again.measure(q, rng=3, orientation=True)[1],
                                  truth.measure(q, rng=3, orientation=True)[1])
    assert again.to_dict() == truth.to_dict()
    assert again.seed == 11 and again.preset == "typical"


def test_a_bad_truth_file_says_what_is_wrong(tmp_path):
    path = tmp_path / "truth.json"
    path.write_text('{"format": "something else"}')
    with pytest.raises(InputError, match="not a robocal truth file"):
        read_truth(path)


# ----------------------------------------------------------------------------- sampling
def branch_indices(chain, q, targets):
    """The closed-form IK branch each (q, target) pair lies on."""
    branches, _ = ik_all(chain, targets)
    difference = np.angle(np.exp(1j * (branches - q[:, None, :])))
    return np.nanargmin(np.linalg.norm(difference, axis=2), axis=1)


def test_latin_hypercube_points_share_one_branch_within_limits():
    hint = deg(0, -60, 100, 0, 50, 0)
    q, targets = latin_hypercube_box(KR150, 60, (1000, -600, 300), (1800, 600, 1200), DOWN, seed=2, hint=hint)
    assert np.all(KR150.within_limits(q))
    np.testing.assert_allclose(KR150.fk_positions(q), targets[:, :3, 3], atol=1e-9)
    assert np.all(targets[:, :3, :3] == DOWN)
    assert np.all(np.sign(q[:, 4]) == np.sign(hint[4]))  # no wrist flip
    assert len(set(branch_indices(KR150, q, targets))) == 1
    # The flipped wrist is a different branch with the same targets.
    flipped = hint + deg(0, 0, 0, 180, -100, 180)
    q_flip, _ = latin_hypercube_box(KR150, 60, (1000, -600, 300), (1800, 600, 1200), DOWN, seed=2, hint=flipped)
    assert np.all(q_flip[:, 4] < 0)


def test_grid_without_hint_uses_one_branch():
    q, targets = grid(UR5, (-400, 150, 100), (-200, 350, 300), (3, 2, 4), np.diag([1.0, -1.0, -1.0]))
    assert q.shape == (24, 6) and targets.shape == (24, 4, 4)
    np.testing.assert_allclose(targets[:4, :3, 3], [[-400, 150, 100 + 200 * k / 3] for k in range(4)])
    assert len(set(branch_indices(UR5, q, targets))) == 1
    np.testing.assert_allclose(UR5.fk(q), targets, atol=1e-9)


def test_unreachable_box_is_refused_with_advice():
    with pytest.raises(InputError, match=r"of 20 points.*smaller box"):
        latin_hypercube_box(KR150, 20, (2500, -800, 400), (3500, 800, 1400), DOWN, hint=deg(0, -90, 90, 0, 90, 0))


def test_uniform_joints_within_limits():
    q = uniform_joints(KR150, 1000, np.random.default_rng(0))
    assert q.shape == (1000, 6)
    assert np.all(KR150.within_limits(q))
    span = KR150.upper - KR150.lower
    assert np.all(q.max(axis=0) - q.min(axis=0) > 0.95 * span)
    np.testing.assert_array_equal(uniform_joints(KR150, 5, 3), uniform_joints(KR150, 5, 3))
