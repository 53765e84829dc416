"""The 95 % bound of a re-registered model (robocal.methods.moved_bound): checked on the new
set-up's own poses, widened when the new set-up holds what the old one did not."""
import dataclasses
import json
import warnings

import numpy as np
import pytest

from robocal.io.library import builtin
from robocal.methods import make_method
from robocal.methods.bound import fit_bound
from robocal.methods.moved_bound import reregistered_bound
from robocal.methods.reregistration import reregister
from robocal.simulation import make_true_robot, uniform_joints

from refusals import run_ok
from simulated_models import with_deviations

MOVE = {"base_x": 1800.0, "base_y": -600.0, "base_z": 250.0, "base_rz": 35.0, "tool_z": 20.0}
# What frames cannot take up: a link 1.5 mm longer and a joint zero moved by 0.15 deg.
ROBOT_CHANGE = {"a2": 1.5, "theta3": 0.15}
NEW_POSES = 25
TEST_POSES = 400


@pytest.fixture(scope="module")
def calibrated():
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=4)
    rng = np.random.default_rng(11)
    train = truth.observations(uniform_joints(chain, 120, rng), rng)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = make_method("kinematic").fit(chain, train)
        fitted.bound_ = fit_bound(fitted, chain, train)
    return chain, truth, fitted


def new_set_up(chain, truth, changes, seed):
    rng = np.random.default_rng(seed)
    new_truth = with_deviations(truth, changes)
    data = new_truth.observations(uniform_joints(chain, NEW_POSES + TEST_POSES, rng), rng)
    return data.subset(np.arange(NEW_POSES)), data.subset(np.arange(NEW_POSES, NEW_POSES + TEST_POSES))


def coverage(bound, model, test):
    error = np.linalg.norm(test.positions - model.predict(test.joints), axis=1)
    limit = bound.predict(test.joints)
    return float(np.mean(error <= limit)), float(np.median(limit) / np.median(error))


def moved_with_bound(chain, fitted, poses):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        moved = reregister(fitted, poses, robot=chain)
        return moved, reregistered_bound(fitted.bound_, fitted, moved, poses, robot=chain)


def test_a_moved_tracker_keeps_a_bound_that_covers_the_new_set_up(calibrated):
    chain, truth, fitted = calibrated
    poses, test = new_set_up(chain, truth, MOVE, seed=1)
    moved, bound = moved_with_bound(chain, fitted, poses)
    covered, width = coverage(bound, moved, test)
    assert 0.85 <= covered <= 1.0
    assert width <= 3.0
    record = bound.calibration["new_set_up"]
    assert record["poses"] == NEW_POSES and record["factor"] == bound.set_up_factor > 0


def test_a_set_up_the_frames_cannot_explain_widens_the_bound(calibrated):
    chain, truth, fitted = calibrated
    poses, test = new_set_up(chain, truth, {**MOVE, **ROBOT_CHANGE}, seed=2)
    moved, bound = moved_with_bound(chain, fitted, poses)
    unwidened = dataclasses.replace(bound, set_up_factor=1.0)
    before, _ = coverage(unwidened, moved, test)
    after, width = coverage(bound, moved, test)
    # The original's bound, moved as it was, no longer covers; the new poses widen it.
    assert before < 0.85
    assert bound.set_up_factor > 1.0
    assert 0.85 <= after <= 1.0 and width <= 3.0


def test_the_bound_of_a_reregistered_model_file_reaches_evaluate(tmp_path):
    # calibrate, then calibrate --method frames on the same robot with the tracker moved: the
    # re-registered model file holds a bound, and evaluate scores its poses against it.
    run_ok("simulate", "ur5", "--out", tmp_path / "train.csv", "--n", "60", "--seed", "2",
           "--truth", tmp_path / "truth.json")
    run_ok("calibrate", "ur5", tmp_path / "train.csv", "--out", tmp_path / "model.json")
    truth = json.loads((tmp_path / "truth.json").read_text())
    for name, value in MOVE.items():
        truth["deviations"][name] = truth["deviations"].get(name, 0.0) + value
    (tmp_path / "moved-truth.json").write_text(json.dumps(truth))
    run_ok("simulate", "ur5", "--out", tmp_path / "new.csv", "--n", str(NEW_POSES), "--seed", "3",
           "--errors", tmp_path / "moved-truth.json")
    run_ok("calibrate", tmp_path / "model.json", tmp_path / "new.csv", "--method", "frames",
           "--out", tmp_path / "moved.json")
    document = json.loads((tmp_path / "moved.json").read_text())
    assert document["bound"]["calibration"]["new_set_up"]["poses"] == NEW_POSES
    run_ok("simulate", "ur5", "--out", tmp_path / "test.csv", "--n", "100", "--seed", "4",
           "--errors", tmp_path / "moved-truth.json")
    evaluated = json.loads(run_ok("evaluate", tmp_path / "moved.json", tmp_path / "test.csv", "--json").output)
    assert evaluated["bound95"]["poses"] == 100
    assert 0.85 <= evaluated["bound95"]["within_share"] <= 1.0


def test_an_auto_model_whose_new_poses_prefer_the_alternative_is_bounded_by_the_alternatives_bound():
    import copy

    from simulated_models import ur5_auto_model

    chain, truth, _, train, model, _ = ur5_auto_model()
    rigid = make_method("kinematic", parameters="full").fit(chain, train)
    model = copy.copy(model)
    model.outside_alternative_ = ("kinematic full", rigid.compensator_)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.bound_ = fit_bound(model, chain, train)
    assert model.bound_.fallback.calibration["label"] == "kinematic full+compliance"
    assert model.bound_.alternative.calibration["label"] == "kinematic full"
    # The new set-up lost the heavy tool: the rigid calibration carries to it better.
    stiff = dataclasses.replace(truth.compliance, stiffness=truth.compliance.stiffness * 1e6)
    poses, test = new_set_up(chain, dataclasses.replace(truth, compliance=stiff), MOVE, seed=9)
    moved, bound = moved_with_bound(chain, model, poses)
    assert moved.compensator_.label == "kinematic full"
    assert bound.fallback.calibration["label"] == "kinematic full"
    assert bound.alternative.calibration["label"] == "kinematic full+compliance"
    covered, width = coverage(bound, moved, test)
    assert 0.85 <= covered <= 1.0 and width <= 3.0
