"""full+compliance calibration: the compliant model's Jacobian, recovery of a simulated
robot's joint stiffness, commands that land a bending robot on its targets, model files."""
import json

import numpy as np
import pytest

from robocal.compensation import Compensator
from robocal.errors import FileFormatError, InputError
from robocal.estimation.calibration import KinematicCalibration
from robocal.io.model_file import ModelFile, load_model, save_model
from robocal.io.library import builtin
from robocal.kinematics.compliant import CompliantChain
from robocal.kinematics.gravity import default_mass_model
from robocal.simulation import TrueRobot, make_true_robot, uniform_joints

KR150 = builtin("kr150-2")


def _bending_robot(chain, seed, noise=0.02):
    """Geometric deviations and gravity compliance of the typical preset, no backlash."""
    typical = make_true_robot(chain, "typical", seed=seed)
    return TrueRobot(nominal=chain, deviations=typical.deviations, compliance=typical.compliance,
                     noise=noise, seed=seed)


@pytest.mark.parametrize("name", ["kr150-2", "fanuc-r2000ic-165f", "panda"])
def test_compliant_identification_jacobian_matches_finite_differences(name):
    rigid = builtin(name)
    chain = CompliantChain(rigid, default_mass_model(rigid), np.linspace(1e-8, 3e-8, rigid.n_joints))
    q = rigid.random_configurations(5, rng=2)
    geometric = ["theta2", "d3", "base_rx", "tool_y"]
    names = geometric + [f"compliance{k}" for k in range(2, rigid.n_joints + 1)]

    def numeric(model, name):
        step = 1e-9 if name.startswith("compliance") else 1e-6
        up = model.perturbed([name], [step]).fk_positions(q)
        return (up - model.perturbed([name], [-step]).fk_positions(q)) / (2 * step)

    jac = chain.identification_jacobian(q, names)
    for j, name in enumerate(names):
        expected = numeric(chain, name)
        # Geometric columns leave out how the torque itself changes with the geometry,
        # c * dtau/dp: a relative 1e-4 at this compliance.  Compliance columns are exact.
        rtol = 1e-3 if name in geometric else 1e-6
        np.testing.assert_allclose(jac[:, :3, j], expected, atol=rtol * np.abs(expected).max() + 1e-20, err_msg=name)
    # At zero compliance the geometric columns are the rigid chain's, exactly.
    stiff = CompliantChain(rigid, default_mass_model(rigid), np.zeros(rigid.n_joints))
    for name in geometric:
        expected = numeric(stiff, name)
        np.testing.assert_allclose(stiff.identification_jacobian(q, [name])[:, :3, 0], expected,
                                   atol=1e-6 * np.abs(expected).max(), err_msg=name)


def test_full_compliance_recovers_the_stiffness_and_beats_rigid_calibration():
    truth = _bending_robot(KR150, seed=3)
    rng = np.random.default_rng(1)
    q, q_test = uniform_joints(KR150, 300, rng), uniform_joints(KR150, 300, rng)
    measured = truth.measure(q, rng)
    held_out = truth.positions(q_test)
    rigid = KinematicCalibration("full").fit(KR150, q, measured)
    bending = KinematicCalibration("full+compliance").fit(KR150, q, measured)
    error_rigid = np.linalg.norm(rigid.predict(q_test) - held_out, axis=1).mean()
    error_bending = np.linalg.norm(bending.predict(q_test) - held_out, axis=1).mean()
    assert error_bending < 0.2 * error_rigid
    # Axes 2 and 3 carry the arm: their compliance is identified to a few percent (the
    # simulation and the calibration share the mass model, so the value itself is comparable).
    true = 1.0 / truth.compliance.stiffness
    found = bending.chain_.compliance
    np.testing.assert_allclose(found[1:3], true[1:3], rtol=0.05)
    # Joint 1 turns about the vertical: gravity never loads it, so it gets no parameter.
    assert "compliance1" not in bending.result_.names and found[0] == 0.0
    report = bending.result_.to_dict(bending.chain_)
    assert report["parameters"]["compliance2"]["deviation"] == pytest.approx(true[1] * 1e6, rel=0.05)


def test_commands_land_a_bending_robot_on_its_targets():
    truth = _bending_robot(KR150, seed=5, noise=0.0)
    rng = np.random.default_rng(4)
    q = uniform_joints(KR150, 300, rng)
    cal = KinematicCalibration("full+compliance").fit(KR150, q, truth.positions(q))
    targets = truth.actual.fk(uniform_joints(KR150, 50, rng))
    result = Compensator(cal.chain_, nominal=KR150).commands(targets)
    assert result.success.all()
    reached = truth.positions(result.q)
    # Without the compliance step the commands miss by the deflection itself (tenths of a mm).
    rigid_commands = Compensator(cal.chain_.rigid, nominal=KR150).commands(targets).q
    missed = np.linalg.norm(truth.positions(rigid_commands) - targets[:, :3, 3], axis=1)
    landed = np.linalg.norm(reached - targets[:, :3, 3], axis=1)
    assert landed.max() < 0.01 < missed.max()


def test_model_file_keeps_the_compliance_and_refuses_a_damaged_one(tmp_path):
    chain = CompliantChain(KR150, default_mass_model(KR150), np.array([0, 1e-8, 2e-8, 0, 5e-9, 0]))
    path = tmp_path / "model.json"
    save_model(ModelFile(method="kinematic", nominal=KR150, kinematics=chain), path)
    loaded = load_model(path, robot=KR150).kinematics
    q = KR150.random_configurations(20, rng=0)
    np.testing.assert_allclose(loaded.fk_positions(q), chain.fk_positions(q), atol=1e-9)
    doc = json.loads(path.read_text())
    doc["joint_compliance"]["compliance_urad_per_nm"] = [0.01, 0.02]
    body = {k: v for k, v in doc.items() if k != "checksum"}
    import hashlib

    from robocal.io.model_file import _canonical
    doc["checksum"] = hashlib.sha256(_canonical(body).encode()).hexdigest()
    path.write_text(json.dumps(doc))
    with pytest.raises(FileFormatError, match="joint_compliance"):
        load_model(path)


def test_constraint_calibration_with_compliance_beats_the_rigid_one_on_a_bending_robot():
    from robocal.estimation.constraint import ConstraintCalibration, socket_errors
    from robocal.io.fixtures import Fixture
    from robocal.simulation.sampling import socket_plan

    truth = _bending_robot(KR150, seed=6, noise=0.0)
    fixture = Fixture("plate", {"A": [0, 0, 0], "B": [150, 0, 0], "C": [0, 120, 0]})
    plan = socket_plan(truth, fixture, 9, 10, np.random.default_rng(2))
    train = np.isin(plan.fixture_ids, [f"P{k}" for k in range(1, 7)])
    held_out = {}
    for compliance in (False, True):
        cal = ConstraintCalibration(compliance=compliance).fit(
            KR150, plan.joints[train], plan.fixture_ids[train], plan.socket_ids[train], fixture)
        held_out[compliance] = socket_errors(cal.chain_, plan.joints[~train], plan.fixture_ids[~train],
                                             plan.socket_ids[~train], fixture)["mean_mm"]
    assert held_out[True] < 0.3 * held_out[False]


def test_the_payload_given_shapes_the_deflection_model():
    from robocal.simulation import Compliance

    typical = make_true_robot(KR150, "typical", seed=8)
    unloaded = Compliance(typical.compliance.stiffness, typical.compliance.link_masses, payload=0.0)
    truth = TrueRobot(nominal=KR150, deviations=typical.deviations, compliance=unloaded, noise=0.0, seed=8)
    rng = np.random.default_rng(3)
    q, q_test = uniform_joints(KR150, 300, rng), uniform_joints(KR150, 300, rng)
    held_out = {}
    for payload in (None, 0.0):
        cal = KinematicCalibration("full+compliance", payload=payload).fit(KR150, q, truth.positions(q))
        assert cal.chain_.mass_model.payload == pytest.approx(150.0 if payload is None else 0.0, abs=0.1)
        held_out[payload] = np.linalg.norm(cal.predict(q_test) - truth.positions(q_test), axis=1).mean()
    # The right payload makes the model exact; the rated one leaves a torque shape it cannot fit.
    assert held_out[0.0] < 1e-3 < held_out[None]
    unchecked = KinematicCalibration("full+compliance", payload=-1.0)
    assert unchecked.payload == -1.0
    with pytest.raises(InputError, match="payload must be"):
        unchecked.fit(KR150, q, truth.positions(q))


def test_compliant_chain_declares_its_api_and_its_model_file_entry():
    rigid = builtin("kr150-2")
    chain = CompliantChain(rigid, default_mass_model(rigid, 40.0), np.linspace(1e-8, 3e-8, rigid.n_joints))
    assert chain.rigid is rigid and rigid.rigid is rigid
    for name in ("name", "n_joints", "joint_map", "lower", "upper", "base", "tool", "convention"):
        assert (getattr(chain, name) is getattr(rigid, name)
                or np.array_equal(getattr(chain, name), getattr(rigid, name)))
    q = rigid.random_configurations(20, rng=3)
    assert np.array_equal(chain.within_limits(q), rigid.within_limits(q))
    np.testing.assert_array_equal(chain.joints_to_file(q), rigid.joints_to_file(q))
    # What is not declared is the rigid chain's alone: no silent rigid Jacobian for a compliant robot.
    assert not hasattr(chain, "jacobian") and not hasattr(chain, "joint_frames")
    assert chain.parameters["compliance2"].group == "compliance" and not chain.is_angular("compliance2")
    assert chain.parameters.file_units(["compliance2", "gain1", "a2"]).tolist() == [1e6, 1e6, 1.0]
    doc = json.loads(json.dumps(chain.compliance_document()))
    assert doc == {"link_masses_kg": chain.mass_model.link_masses.tolist(), "payload_kg": 40.0,
                   "compliance_urad_per_nm": (chain.compliance * 1e6).tolist(), "gravity": "-z of the robot base"}
    back = CompliantChain.from_document(rigid, doc)
    np.testing.assert_allclose(back.compliance, chain.compliance, rtol=1e-15)
    np.testing.assert_allclose(back.fk_positions(q), chain.fk_positions(q), atol=1e-9)
    for key in ("payload_kg", "compliance_urad_per_nm"):
        with pytest.raises(FileFormatError, match="joint_compliance"):
            CompliantChain.from_document(rigid, {k: v for k, v in doc.items() if k != key})
    with pytest.raises(FileFormatError, match="joint_compliance"):
        CompliantChain.from_document(rigid, {**doc, "compliance_urad_per_nm": [0.01] * 5})


def test_a_compliance_the_poses_cannot_tell_from_zero_leaves_the_joint_rigid():
    """A rigid robot measured with noise: the compliance the fit finds is noise, and a joint
    given a compliance it does not have would bend commands wherever the posture changes."""
    truth = TrueRobot(nominal=KR150, deviations=_bending_robot(KR150, seed=4).deviations, noise=0.02, seed=4)
    rng = np.random.default_rng(5)
    q = uniform_joints(KR150, 200, rng)
    fitted = KinematicCalibration("full+compliance").fit(KR150, q, truth.measure(q, rng))
    fixed = {n: why for n, why in fitted.result_.identifiability.fixed.items() if n.startswith("compliance")}
    assert fixed, "no compliance was left out on a rigid robot"
    for name, why in fixed.items():
        assert "not told from zero" in why and "\n" not in why
        assert name not in fitted.result_.names
        assert fitted.chain_.compliance[int(name[len("compliance"):]) - 1] == 0.0
    # A real compliance is kept (the bending robot of the test above identifies joints 2, 3).
    bending = _bending_robot(KR150, seed=3)
    real = KinematicCalibration("full+compliance").fit(KR150, q, bending.measure(q, rng))
    assert {"compliance2", "compliance3"} <= set(real.result_.names)


def test_a_compliance_that_would_bend_a_joint_beyond_any_arm_is_refused():
    from robocal.estimation.identification import MAX_GRAVITY_DEFLECTION_DEG, loose_compliances

    q = KR150.random_configurations(50, rng=3)
    torque = np.abs(CompliantChain(KR150, default_mass_model(KR150), np.zeros(6)).gravity_torque(q)).max(axis=0)
    # Joint 2 bent by twice the limit under its largest torque, joint 3 by half of it; both
    # determined to a tenth of their value.
    compliance = np.zeros(6)
    compliance[1:3] = np.radians([2.0, 0.5]) * MAX_GRAVITY_DEFLECTION_DEG / torque[1:3]
    fitted = CompliantChain(KR150, default_mass_model(KR150), compliance)
    found = loose_compliances(fitted, ("d2", "compliance2", "compliance3"), np.array([1e-3, *compliance[1:3] / 10]), q)
    assert list(found) == ["compliance2"] and "would bend the joint by 0.50 deg" in found["compliance2"]
    # Determined to a third of their value only: both within two standard errors of zero.
    assert set(loose_compliances(fitted, ("compliance2", "compliance3"), compliance[1:3] / 1.9, q)) == {
        "compliance2", "compliance3"}
    # No joints given (a caller that has none): nothing is judged.
    assert loose_compliances(fitted, ("compliance2",), np.array([1.0]), None) == {}
