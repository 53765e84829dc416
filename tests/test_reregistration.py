"""Re-registration of a calibrated model on a new set-up (the tracker moved, the tool changed,
the robot re-mastered): simulated robots whose frame changes are known."""
import warnings

import numpy as np
import pytest

from robocal.compensation import Compensator
from robocal.errors import FileFormatError, InputError, RobocalWarning
from robocal.estimation.kriging import Kriging
from robocal.estimation.metrics import error_stats
from robocal.io.library import builtin
from robocal.io.observations import Observations
from robocal.methods import ConstraintMethod, make_method
from robocal.methods.reregistration import (ReframedErrorModel, ReregistrationRecord, is_reframed, reframed_document,
                                            reframed_from_document, reregister)
from robocal.simulation import make_true_robot, uniform_joints
from robocal.spatial import invert, make_transform, so3_exp, so3_log
from simulated_models import with_deviations

# The tracker of the new set-up stands 2.4 m away and turned by 40 deg about its vertical
# and 3 deg about x; the new tool reaches 25 mm further and 4 mm aside.
MOVE = {"base_x": 2400.0, "base_y": -900.0, "base_z": 350.0, "base_rz": 40.0, "base_rx": 3.0}
TOOL_CHANGE = {"tool_x": 4.0, "tool_z": 25.0}


@pytest.fixture(scope="module")
def setup():
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=3)
    rng = np.random.default_rng(7)
    train = truth.observations(uniform_joints(chain, 150, rng), rng)
    new_truth = with_deviations(truth, {**MOVE, **TOOL_CHANGE})
    q_new = uniform_joints(chain, 315, rng)
    new = new_truth.observations(q_new, rng)
    return chain, truth, new_truth, train, new.subset(np.arange(15)), new.subset(np.arange(15, 315))


def held_out(model, test):
    return error_stats(test.positions - model.predict(test.joints))


def oracle(fitted, truth, new_truth):
    """The fitted model with the true change of frames applied: what a calibration on the new
    set-up would give if it knew the links and the frames exactly."""
    frame = new_truth.actual.base @ invert(truth.actual.base)
    chain = fitted.compensator_.chain
    tool = chain.tool.copy()
    tool[:3, 3] += new_truth.actual.tool[:3, 3] - truth.actual.tool[:3, 3]
    return chain.replace(base=frame @ chain.base, tool=tool)


def test_frames_from_15_poses_give_what_the_true_frames_give(setup):
    chain, truth, new_truth, train, poses, test = setup
    fitted = make_method("kinematic").fit(chain, train)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RobocalWarning)
        again = reregister(fitted, poses)
    as_it_stands = held_out(fitted, test)
    ideal = error_stats(test.positions - oracle(fitted, truth, new_truth).fk_positions(test.joints))
    after = held_out(again, test)
    assert as_it_stands.mean_mm > 1000.0
    # Nine frame parameters from 45 equations add their estimation error to the model's own:
    # about P/m of its variance, P parameters and m equations; twice that is the bound.
    record = again.reregistration_
    assert after.rms_mm <= ideal.rms_mm * np.sqrt(1.0 + 2.0 * 9 / 45)
    assert after.rms_mm < 0.2
    # The record: the tracker's move and the tool change recovered, the poses named.
    true_frame = new_truth.actual.base @ invert(truth.actual.base)
    assert record.tracker_shift_mm == pytest.approx(np.linalg.norm(true_frame[:3, 3]), abs=0.5)
    assert np.allclose(record.tool_change_mm, new_truth.actual.tool[:3, 3] - truth.actual.tool[:3, 3], atol=0.5)
    assert record.poses == 15 and record.rows == tuple(poses.rows)
    assert record.identifiability.rank == 9 and not record.identifiability.fixed
    assert record.residual_before["mean_mm"] > 1000.0 and record.residual_after["rms_mm"] < 0.2
    # The "before" of the new set-up is the nominal robot registered to its poses.
    nominal = error_stats(test.positions - again.reference_.fk_positions(test.joints))
    assert after.mean_mm < nominal.mean_mm
    # The original is untouched, and the copy keeps what the fit left.
    assert fitted.compensator_.chain.base is not again.compensator_.chain.base
    assert held_out(fitted, test).mean_mm == as_it_stands.mean_mm
    assert again.calibration_ is fitted.calibration_
    assert again.record_ == fitted.record_.replace(reregistration=record.to_dict())
    # The training box of the domain moves with the frame: the held-out poses stay inside it.
    new_positions = again.predict(test.joints)
    assert fitted.domain_.check(test.joints, new_positions).n_outside == test.n_poses
    assert (again.domain_.check(test.joints, new_positions).n_outside
            <= fitted.domain_.check(test.joints, fitted.predict(test.joints)).n_outside)
    back = ReregistrationRecord.from_dict(record.to_dict())
    assert back.to_dict() == record.to_dict()


@pytest.mark.slow
@pytest.mark.parametrize("inputs", ["position", "joints"])
def test_an_error_model_moves_with_the_frame(setup, inputs):
    """A tracker move alone, with the readings of the same poses: the re-registered hybrid
    (calibration plus Kriging of its residual over the TCP position or the joints) misses the
    new readings as the original missed the old ones, to what 40 poses determine of the frame."""
    chain, truth, _, train, _, _ = setup
    fitted = make_method("hybrid", inputs=inputs).fit(chain, train)
    frame = make_transform(so3_exp(np.radians([3.0, -2.0, 40.0])), [2400.0, -900.0, 350.0])
    rng = np.random.default_rng(11)
    q = uniform_joints(chain, 225, rng)
    old = truth.observations(q, rng)
    new = Observations.of(q, old.positions @ frame[:3, :3].T + frame[:3, 3], sigmas=old.sigmas)
    again = reregister(fitted, new.subset(np.arange(40)))
    model = again.compensator_.error_model
    assert isinstance(model, ReframedErrorModel) and model.error_model is fitted.compensator_.error_model
    assert np.abs(model.frame[:3, 3] - frame[:3, 3]).max() < 1.0
    turn = np.linalg.norm(so3_log(model.frame[:3, :3] @ frame[:3, :3].T))
    assert np.degrees(turn) < 0.01
    test = np.arange(40, 225)
    in_old = error_stats(old.positions[test] - fitted.predict(q[test])).rms_mm
    in_new = error_stats(new.positions[test] - again.predict(q[test])).rms_mm
    # The bound of the test above, with the model's own error as the noise.  40 poses: what a
    # residual model leaves is correlated between nearby poses, so its rows are fewer
    # independent equations than a calibration's.
    assert in_new <= in_old * np.sqrt(1.0 + 2.0 * 9 / 120)
    nominal = error_stats(new.positions[test] - again.reference_.fk_positions(q[test])).rms_mm
    assert in_new < 0.2 * nominal


def test_the_wrapper_predicts_the_same_physical_error():
    rng = np.random.default_rng(2)
    points = rng.uniform(-800, 800, (60, 3))
    errors = np.column_stack([np.sin(points[:, 0] / 300), np.cos(points[:, 1] / 400), points[:, 2] / 1000])
    kriging = Kriging().fit(points, errors)
    frame = make_transform(so3_exp([0.3, -1.1, 2.0]), [1500.0, -200.0, 40.0])
    wrapper = ReframedErrorModel(kriging, frame)
    probe = rng.uniform(-700, 700, (25, 3))
    mean, mse = kriging.predict(probe, return_mse=True)
    new_mean, new_mse = wrapper.predict(probe @ frame[:3, :3].T + frame[:3, 3], return_mse=True)
    rotation = frame[:3, :3]
    assert np.allclose(new_mean, mean @ rotation.T, atol=1e-9)
    covariance = np.einsum("ij,nj,kj->nik", rotation, mse, rotation)
    assert np.allclose(new_mse, np.diagonal(covariance, axis1=1, axis2=2), atol=1e-12)
    # The wrapped model's fitted attributes show through.
    assert wrapper.diagnostics_ == kriging.diagnostics_
    # Joint space: the vector turns, the input does not move (but shifts with the offsets).
    joints = rng.uniform(-2, 2, (40, 6))
    in_joints = Kriging().fit(joints, errors[:40])
    shift = np.radians([0.0, 0.2, -0.1, 0.0, 0.05, 0.0])
    turned = ReframedErrorModel(in_joints, frame, "joints", shift)
    assert np.allclose(turned.predict(joints[:5]), in_joints.predict(joints[:5] + shift) @ rotation.T, atol=1e-9)
    # Carried on once more: one wrapper, frames composed.
    again = turned.moved(frame, shift)
    assert again.error_model is in_joints and np.allclose(again.frame, frame @ frame)
    assert np.allclose(again.predict(joints[:5]), in_joints.predict(joints[:5] + 2 * shift) @ (rotation @ rotation).T)
    # The document round trips through the wrapped model's own loader.
    def load(inner):
        return Kriging.from_dict(inner), "joints"

    document = turned.to_dict(in_joints.to_dict(), revolute=np.ones(6, bool))
    assert is_reframed(document) and document["joint_units"] == ["deg"] * 6
    back, error_input = reframed_from_document(document, load)
    assert error_input == "joints"
    assert np.allclose(back.predict(joints[:5]), turned.predict(joints[:5]), atol=1e-9)
    with pytest.raises(FileFormatError, match="reframed error model is damaged"):
        reframed_from_document({**document, "frame": [[1, 0]]}, load)
    with pytest.raises(FileFormatError, match="reframed error model is damaged"):
        reframed_from_document({**document, "error_input": "position"}, load)


@pytest.mark.slow
def test_a_reregistered_model_writes_its_moved_error_model(setup):
    chain, _, _, train, poses, test = setup
    again = reregister(make_method("hybrid").fit(chain, train), poses)
    document = reframed_document(again)
    assert document["type"] == "reframed" and document["error_model"]["type"] == "kriging"
    model, error_input = reframed_from_document(document, lambda d: type(again).error_model_from_document(d, "x"))
    rebuilt = Compensator(again.compensator_.chain, model, error_input=error_input)
    assert np.allclose(rebuilt.predict_positions(test.joints[:20]), again.predict(test.joints[:20]), atol=1e-9)


def test_frames_and_offsets_recover_a_remastered_joint(setup):
    chain, truth, _, train, _, _ = setup
    fitted = make_method("kinematic").fit(chain, train)
    injected = {"theta2": 0.30, "theta3": -0.20, "theta4": 0.25, "theta5": -0.15}
    remastered = with_deviations(truth, {**MOVE, **injected})
    rng = np.random.default_rng(5)
    new = remastered.observations(uniform_joints(chain, 225, rng), rng)
    poses, test = new.subset(np.arange(25)), new.subset(np.arange(25, 225))
    frames_only = reregister(fitted, poses)
    with_offsets = reregister(fitted, poses, "frames+offsets")
    record = with_offsets.reregistration_
    # theta1 is the base's turn about z, theta6 the tool's about the flange axis: reported, kept.
    assert set(record.identifiability.fixed) == {"theta1", "theta6"}
    for name, value in injected.items():
        assert record.offset_changes[name] == pytest.approx(value, abs=max(4 * record.std_errors[name], 0.005))
    assert held_out(with_offsets, test).rms_mm < 0.5 * held_out(frames_only, test).rms_mm
    assert held_out(with_offsets, test).rms_mm < 0.2


def test_implausible_results_warn(setup):
    chain, truth, _, train, _, _ = setup
    fitted = make_method("kinematic").fit(chain, train)
    rng = np.random.default_rng(9)
    q = uniform_joints(chain, 20, rng)
    long_tool = with_deviations(truth, {**MOVE, "tool_z": 150.0}).observations(q, rng)
    with pytest.warns(RobocalWarning, match="the TCP moved by 15[0-9] mm on the flange"):
        again = reregister(fitted, long_tool)
    assert again.reregistration_.warnings
    bent = with_deviations(truth, {**MOVE, "a2": 3.0, "a3": -2.5, "d4": 2.0}).observations(q, rng)
    with pytest.warns(RobocalWarning, match="misses these poses by .* where its kinematics fitted"):
        reregister(fitted, bent)


def test_refusals(setup):
    chain, truth, new_truth, train, poses, _ = setup
    fitted = make_method("kinematic").fit(chain, train)
    with pytest.raises(InputError, match="needs at least 6 poses"):
        reregister(fitted, poses.subset(np.arange(5)))
    with pytest.raises(InputError, match="re-registering 15 parameters needs at least 10 poses"):
        reregister(fitted, poses.subset(np.arange(9)), "frames+offsets")
    with pytest.raises(InputError, match="must be one of frames, frames\\+offsets"):
        reregister(fitted, poses, "full")
    sockets = Observations.of(poses.joints, placement=["a"] * 15, socket=["1"] * 15)
    with pytest.raises(InputError, match="re-registration is for measured TCP positions"):
        reregister(fitted, sockets)
    constraint = ConstraintMethod()
    constraint.compensator_ = Compensator(chain)
    with pytest.raises(InputError, match="ball-in-socket data.*re-registration is for models of measured TCP"):
        reregister(constraint, poses)
    with pytest.raises(InputError, match="not fitted"):
        reregister(make_method("kinematic"), poses)
    with pytest.raises(InputError, match="belongs to robot"):
        reregister(fitted, poses, robot=builtin("ur10"))
    # Another robot's poses (a UR10's, same joint count) are not explained by any frames.
    ur10 = make_true_robot(builtin("ur10"), "typical", seed=1)
    rng = np.random.default_rng(1)
    with pytest.raises(InputError, match="misses these data by .* mm RMS.*not this robot.s"):
        reregister(fitted, ur10.observations(uniform_joints(chain, 20, rng), rng))
    # Poses that turn joint 1 only cannot tell the base from the tool.
    q = np.zeros((20, 6)) + [0.0, -1.0, 1.2, -0.5, 1.0, 0.3]
    q[:, 0] = np.linspace(-2.5, 2.5, 20)
    with pytest.raises(InputError, match="these poses do not determine .*tool_"):
        reregister(fitted, new_truth.observations(q, rng))
