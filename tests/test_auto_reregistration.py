"""Re-registering a model of ``calibrate --method auto`` (issue 24 part 3): the chosen model and
the fallback that answers outside its training domain move together, by one change of frames
identified from the poses each answers for.  Simulated UR5s whose tracker move is known."""
import copy
import dataclasses
import warnings

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.estimation.metrics import error_stats
from robocal.interfaces.cli import app
from robocal.io.model_file import load_model, save_model
from robocal.io.tables import write_measurements
from robocal.methods import make_method
from robocal.methods.fallback import DomainFallback
from robocal.methods.reregistration import reregister
from robocal.simulation import uniform_joints
from robocal.spatial import invert
from simulated_models import ur5_auto_model

runner = CliRunner()
# The tracker of the new set-up stands 2 m away, turned by 35 deg about its vertical.
MOVE = {"base_x": 2000.0, "base_y": -700.0, "base_z": 300.0, "base_rz": 35.0}


@pytest.fixture(scope="module")
def pair():
    """A UR5 measured with q1 in the lower half of its range; an auto-like model fitted there
    (full+gains inside its domain, full+compliance outside), the same robot after the tracker
    moved, 25 poses of it over the whole range to re-register on, and 300 to test on."""
    chain, truth, rng, train, model, fallback = ur5_auto_model()
    deviations = dict(truth.deviations)
    for name, value in MOVE.items():
        deviations[name] = deviations.get(name, 0.0) + value
    new_truth = dataclasses.replace(truth, deviations=deviations)
    new = new_truth.observations(uniform_joints(chain, 325, np.random.default_rng(8)), rng)
    return chain, truth, new_truth, train, model, fallback, new.subset(np.arange(25)), new.subset(np.arange(25, 325))


def test_the_chosen_model_and_its_fallback_move_by_the_same_frames(pair):
    chain, truth, new_truth, _, model, fallback, poses, _ = pair
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        moved = reregister(model, poses, robot=chain)
    assert isinstance(moved.compensator_, DomainFallback) and moved.compensator_.label == "kinematic full+compliance"
    inside, outside = moved.compensator_.inside.chain, moved.compensator_.outside.chain
    # Both bases moved by the tracker's true move (the robot base stays put).
    true_frame = new_truth.actual.base @ invert(truth.actual.base)
    for old, new in ((model.compensator_.inside.chain, inside), (fallback.compensator_.chain, outside)):
        frame = new.base @ invert(old.base)
        assert np.linalg.norm(frame[:3, 3] - true_frame[:3, 3]) < 2.0
        assert np.degrees(np.arccos(np.clip((np.trace(frame[:3, :3] @ true_frame[:3, :3].T) - 1) / 2, -1, 1))) < 0.05
    # One change of frames: the fallback keeps its own calibrated offsets from the chosen model.
    np.testing.assert_allclose(outside.base @ invert(fallback.compensator_.chain.base),
                               inside.base @ invert(model.compensator_.inside.chain.base), atol=1e-9)
    # The poses on both sides of the domain were used: each answered by its own model.
    out = moved.compensator_.outside_mask(poses.joints)
    assert 0 < out.sum() < poses.n_poses
    np.testing.assert_allclose(moved.predict(poses.joints)[out], outside.fk_positions(poses.joints[out]), atol=1e-6)


def test_a_moved_auto_model_predicts_the_new_set_up_as_well_as_a_moved_kinematic_one(pair):
    chain, _, _, train, model, _, poses, test = pair
    kinematic = make_method("kinematic").fit(chain, train)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        auto = error_stats(test.positions - reregister(model, poses, robot=chain).predict(test.joints))
        plain = error_stats(test.positions - reregister(kinematic, poses, robot=chain).predict(test.joints))
        as_it_stood = error_stats(test.positions - model.predict(test.joints))
    assert as_it_stood.mean_mm > 1000.0
    assert auto.mean_mm <= 1.05 * plain.mean_mm, (auto.mean_mm, plain.mean_mm)


def test_the_command_line_re_registers_an_auto_model_and_keeps_its_fallback(pair, tmp_path):
    chain, _, new_truth, _, model, _, _, _ = pair
    save_model(model.to_model_file(chain), tmp_path / "auto.json")
    rng = np.random.default_rng(12)
    write_measurements(tmp_path / "new.csv", new_truth.measurements(uniform_joints(chain, 25, rng), rng))
    write_measurements(tmp_path / "test.csv", new_truth.measurements(uniform_joints(chain, 100, rng), rng))
    result = runner.invoke(app, ["calibrate", str(tmp_path / "auto.json"), str(tmp_path / "new.csv"), "--method",
                                 "frames", "--out", str(tmp_path / "moved.json")])
    assert result.exit_code == 0, result.output
    moved = load_model(tmp_path / "moved.json")
    assert moved.outside is not None and moved.outside[0] == "kinematic full+compliance"
    assert moved.training["reregistration"]["poses"] == 25
    shown = runner.invoke(app, ["evaluate", str(tmp_path / "moved.json"), str(tmp_path / "test.csv"), "--json"])
    assert shown.exit_code == 0, shown.output
    assert "answered by kinematic full+compliance" in shown.output


def test_the_new_poses_choose_what_answers_outside_between_the_fallback_and_its_alternative(pair):
    # The new set-up lost the heavy tool: the old bending under gravity is gone, and a
    # compliance identified with it no longer holds.  The auto model keeps the rigid
    # calibration as its fallback's alternative; the 25 new poses decide which answers.
    chain, truth, _, train, model, fallback, _, _ = pair
    rigid = make_method("kinematic", parameters="full").fit(chain, train)
    # The module fixture's model is shared: work on copies.
    with_alternative = copy.copy(model)
    with_alternative.outside_alternative_ = ("kinematic full", rigid.compensator_)
    deviations = dict(truth.deviations)
    for name, value in MOVE.items():
        deviations[name] = deviations.get(name, 0.0) + value
    stiff = dataclasses.replace(truth.compliance, stiffness=truth.compliance.stiffness * 1e6)
    new_truth = dataclasses.replace(truth, deviations=deviations, compliance=stiff)
    new = new_truth.observations(uniform_joints(chain, 425, np.random.default_rng(9)), np.random.default_rng(10))
    poses, test = new.subset(np.arange(25)), new.subset(np.arange(25, 425))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        chosen = reregister(with_alternative, poses, robot=chain)
        each = {}
        for label, compensator in (("kinematic full+compliance", fallback.compensator_),
                                   ("kinematic full", rigid.compensator_)):
            alone = copy.copy(model)
            alone.compensator_ = dataclasses.replace(model.compensator_, outside=compensator, label=label)
            each[label] = error_stats(test.positions - reregister(alone, poses, robot=chain).predict(test.joints))
    choice = chosen.reregistration_.outside_choice
    better = min(each, key=lambda label: each[label].mean_mm)
    assert choice["answers_outside"] == better == chosen.compensator_.label
    assert chosen.outside_alternative_[0] == choice["alternative"] != better
    assert error_stats(test.positions - chosen.predict(test.joints)).mean_mm <= each[better].mean_mm * 1.001
    assert each["kinematic full+compliance"].mean_mm != pytest.approx(each["kinematic full"].mean_mm, rel=0.05)


def test_the_fallbacks_alternative_survives_the_model_file(pair, tmp_path):
    chain, _, _, train, model, _, _, _ = pair
    rigid = make_method("kinematic", parameters="full").fit(chain, train)
    with_alternative = copy.copy(model)
    with_alternative.outside_alternative_ = ("kinematic full", rigid.compensator_)
    save_model(with_alternative.to_model_file(chain), tmp_path / "auto.json")
    from robocal.interfaces.jobs import load_fitted

    _, loaded = load_fitted(tmp_path / "auto.json")
    label, compensator = loaded.outside_alternative_
    assert label == "kinematic full"
    np.testing.assert_allclose(compensator.predict_positions(train.joints), rigid.predict(train.joints), atol=1e-9)
