"""Kriging compensation end to end: model files, the Compensator, the command line."""
import json
from pathlib import Path
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.compensation import Compensator
from robocal.errors import FileFormatError, InputError, RobocalWarning
from robocal.interfaces.cli import app
from robocal.interfaces.jobs import load_fitted
from robocal.io.observations import Observations
from robocal.methods import KrigingMethod
from robocal.io.model_file import load_model, save_model
from robocal.io.library import builtin
from robocal.io.tables import read_measurements, write_measurements
from robocal.simulation import liu2022_plan, make_true_robot, read_truth, uniform_joints

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def liu():
    chain = builtin("kr150-2")
    truth = make_true_robot(chain, "liu2022")
    q, targets, train, test = liu2022_plan(chain)
    return chain, truth, q, targets, train, test


@pytest.fixture(scope="module")
def fitted(liu):
    chain, truth, q, targets, train, test = liu
    method = KrigingMethod(register="no").fit(chain, Observations.of(q[train], truth.positions(q[train])))
    return method.compensator_, method


def test_compensation_brings_the_simulated_robot_onto_held_out_targets(liu, fitted):
    chain, truth, q, targets, train, test = liu
    compensator, _ = fitted
    before = np.linalg.norm(truth.positions(q[test]) - targets[test, :3, 3], axis=1)
    result = compensator.commands(targets[test], hint=q[test])
    assert result.success.all()
    after = np.linalg.norm(truth.positions(result.q) - targets[test, :3, 3], axis=1)
    # 1.7 mm before; a Kriging model trained on 50 other points must remove >99 % of it.
    assert before.mean() > 1.6
    assert after.mean() < before.mean() / 100 and after.max() < before.max() / 50


def test_fixed_point_iteration_is_at_least_as_good_as_one_step(liu, fitted):
    chain, truth, q, targets, train, test = liu
    compensator, _ = fitted
    one = compensator.commands(targets[test], hint=q[test])
    fixed = compensator.commands(targets[test], hint=q[test], iterate=True)
    err = lambda r: np.linalg.norm(truth.positions(r.q) - targets[test, :3, 3], axis=1).mean()  # noqa: E731
    assert err(fixed) <= err(one) + 1e-9


def test_no_error_model_means_plain_ik(liu):
    chain, truth, q, targets, train, test = liu
    result = Compensator(chain).commands(targets[:5], hint=q[:5])
    # The controller is the chain itself: its FK of the commands gives the targets back.
    np.testing.assert_allclose(result.corrected, targets[:5], atol=1e-8)
    np.testing.assert_allclose(chain.fk(result.q), targets[:5], atol=1e-8)


def _save(tmp_path, liu, fitted, name="model.json"):
    chain = liu[0]
    path = tmp_path / name
    save_model(fitted[1].to_model_file(chain), path)
    return path


def test_model_file_round_trip_predicts_identically(tmp_path, liu, fitted):
    path = _save(tmp_path, liu, fitted)
    loaded = load_fitted(path)[1].compensator_
    x = liu[3][:, :3, 3]
    np.testing.assert_array_equal(loaded.error_model.predict(x), fitted[0].error_model.predict(x))
    np.testing.assert_array_equal(loaded.chain.fk(liu[2]), fitted[0].chain.fk(liu[2]))


def _rewrite(path, change):
    import hashlib

    doc = json.loads(path.read_text())
    change(doc)
    body = {k: v for k, v in doc.items() if k != "checksum"}
    doc["checksum"] = hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    path.write_text(json.dumps(doc))


def test_model_file_refusals(tmp_path, liu, fitted):
    path = _save(tmp_path, liu, fitted)
    with pytest.raises(InputError, match="belongs to robot"):
        load_model(path, robot=builtin("ur5"))

    edited = tmp_path / "edited.json"

    doc = json.loads(path.read_text())
    doc["kinematics"]["joints"][1]["a"] += 0.5
    edited.write_text(json.dumps(doc))
    with pytest.raises(FileFormatError, match="checksum"):
        load_model(edited)

    newer = tmp_path / "newer.json"
    newer.write_text(path.read_text())
    _rewrite(newer, lambda d: d.update(schema_version=99))
    with pytest.raises(FileFormatError, match="newer"):
        load_model(newer)

    missing = tmp_path / "missing.json"
    missing.write_text(path.read_text())
    _rewrite(missing, lambda d: d.pop("kinematics"))
    with pytest.raises(FileFormatError, match="no 'kinematics'"):
        load_model(missing)

    def reshape(d):
        params = d["error_model"]["parameters"]
        key = next(k for k, v in params.items() if isinstance(v, list) and len(v) > 3)
        params[key] = params[key][:-2]

    shaped = tmp_path / "shaped.json"
    shaped.write_text(path.read_text())
    _rewrite(shaped, reshape)
    with pytest.raises(FileFormatError, match="damaged"):
        load_fitted(shaped)

    with pytest.raises(FileFormatError, match="not JSON"):
        (tmp_path / "junk.json").write_text("{not json")
        load_model(tmp_path / "junk.json")


def test_command_line_workflow(tmp_path, liu):
    chain, truth, q, targets, train, test = liu
    meas, truth_file = tmp_path / "meas.csv", tmp_path / "truth.json"
    result = runner.invoke(app, ["simulate", "kr150-2", "--errors", "liu2022", "--sampling", "lhs",
                                 "--out", str(meas), "--truth", str(truth_file), "--json"])
    assert result.exit_code == 0, result.output
    data = read_measurements(meas, n_joints=6)
    assert data.n_poses == 150
    write_measurements(tmp_path / "train.csv", data.subset(np.arange(50)))
    write_measurements(tmp_path / "test.csv", data.subset(np.arange(50, 150)))

    result = runner.invoke(app, ["calibrate", "kr150-2", str(tmp_path / "train.csv"), "--method", "kriging",
                                 "--out", str(tmp_path / "model.json"), "--json"])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["evaluate", str(tmp_path / "model.json"), str(tmp_path / "test.csv"), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert report["n"] == 100
    assert report["nominal"]["mean_mm"] > 1.6 and report["mean_mm"] < 0.01

    # Targets: the held-out poses, plus one far out of reach.
    rows = ["x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6"]
    from robocal.spatial import pose_to_xyz_rpy

    xyz, rpy = pose_to_xyz_rpy(targets[test])
    hints = chain.joints_to_file(q[test])
    for p, r, h in zip(xyz, np.degrees(rpy), hints):
        rows.append(",".join(repr(float(v)) for v in (*p, *r, *h)))
    rows.append("9000,0,0,180,0,0,0,-90,90,0,90,0")
    (tmp_path / "targets.csv").write_text("\n".join(rows) + "\n")
    with pytest.warns(RobocalWarning, match="extrapolates"):  # the far target, outside the training box
        result = runner.invoke(app, ["compensate", str(tmp_path / "model.json"), str(tmp_path / "targets.csv"),
                                     "--out", str(tmp_path / "commands.csv")])
    assert result.exit_code == 0, result.output
    assert "cannot be reached" in result.output and "102" in result.output
    lines = (tmp_path / "commands.csv").read_text().splitlines()
    header = lines[0].split(",")
    table = [line.split(",") for line in lines[1:]]
    assert table[-1][header.index("reachable")] == "0" and table[-1][0] == ""
    commands = np.array([[float(c) for c in row[:6]] for row in table[:-1]])
    true_robot = read_truth(truth_file)
    reached = true_robot.positions(chain.joints_from_file(commands))
    assert np.linalg.norm(reached - targets[test, :3, 3], axis=1).mean() < 0.01


def test_calibrate_refuses_constraint_data_and_unknown_method(tmp_path):
    csv = tmp_path / "c.csv"
    csv.write_text("q1,q2,q3,q4,q5,q6,fixture,socket\n" + "\n".join(
        f"{i},{-90 + i},90,0,{i},0,A,{i % 2}" for i in range(10)) + "\n")
    result = runner.invoke(app, ["calibrate", "kr150-2", str(csv), "--out", str(tmp_path / "m.json")])
    assert result.exit_code == 2 and "needs measured positions" in result.output
    result = runner.invoke(app, ["calibrate", "kr150-2", str(csv), "--method", "magic", "--out",
                                 str(tmp_path / "m.json")])
    assert result.exit_code == 2 and "not available" in result.output


@pytest.mark.parametrize("name, settings", [("kinematic", {}), ("kinematic", {"parameters": "full+compliance"}),
                                            ("kriging", {}), ("hybrid", {}),
                                            ("ann", {"hidden": (8, 8), "generations": 5})])
def test_corrected_cartesian_targets_make_an_unchanged_controller_command_the_compensated_joints(name, settings):
    """A controller that keeps its nominal model, given the corrected Cartesian targets, must
    reach them with the compensated joint commands: same landing point to 1e-6 mm."""
    from robocal.kinematics.ik import solve_ik
    from robocal.methods import make_method

    chain = builtin("kr150-2")
    truth = replace(make_true_robot(chain, "typical", seed=3), noise=0.0)
    rng = np.random.default_rng(5)
    q = uniform_joints(chain, 200, rng)
    fitted = make_method(name, **settings).fit(chain, Observations.of(q, truth.positions(q)))
    q_targets = uniform_joints(chain, 40, rng)
    targets = fitted.reference_.fk(q_targets)  # reachable poses in the measurement frame
    result = fitted.compensator_.commands(targets, hint=q_targets)
    assert result.success.sum() >= 30
    ok = result.success
    sent = solve_ik(chain, result.corrected[ok], hint=result.q[ok])  # what the controller does
    assert sent.success.all()
    landed_by_joints = truth.positions(result.q[ok])
    landed_by_targets = truth.positions(sent.q)
    assert np.abs(landed_by_targets - landed_by_joints).max() < 1e-6
    # The correction is real: the corrected targets are not the controller's view of the inputs.
    uncorrected = chain.fk(solve_ik(fitted.reference_, targets[ok], hint=q_targets[ok]).q)
    assert np.linalg.norm(result.corrected[ok, :3, 3] - uncorrected[:, :3, 3], axis=1).mean() > 0.05
    # And the predicted error is the one the uncompensated robot would make.
    assert np.all(np.isfinite(result.predicted_error[ok]))
    assert np.linalg.norm(result.predicted_error[ok], axis=1).mean() > 0.05


def test_the_commands_file_says_which_frame_its_cartesian_columns_are_in(tmp_path, liu, fitted):
    import csv

    from robocal.io.observations import COMMANDS_FRAME

    path = _save(tmp_path, liu, fitted)
    out = tmp_path / "c.csv"
    result = runner.invoke(app, ["compensate", str(path), str(EXAMPLES / "kr150-targets.csv"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    with open(out, newline="") as stream:
        rows = list(csv.DictReader(stream))
    assert rows and all(row["frame"] == COMMANDS_FRAME for row in rows)
    assert "robot base" in COMMANDS_FRAME


def test_an_error_model_moved_to_another_frame_is_an_error_model_with_its_fit_diagnostics():
    from robocal.compensation import ErrorModel
    from robocal.estimation.kriging import Kriging
    from robocal.methods.reframed import ReframedErrorModel

    rng = np.random.default_rng(8)
    x = rng.uniform(-500.0, 500.0, (40, 3))
    kriging = Kriging(random_state=0).fit(x, np.column_stack([np.sin(x[:, 0] / 200.0), x[:, 1] / 500.0, x[:, 2] * 0.0]))
    wrapper = ReframedErrorModel(kriging, np.eye(4))
    assert isinstance(wrapper, ErrorModel) and isinstance(kriging, ErrorModel)
    assert wrapper.diagnostics_ == kriging.diagnostics_
    # A Kriging has no training history: the report's getattr(..., None) finds none.
    assert getattr(wrapper, "history_", None) is None
    # Nothing else of the wrapped model shows through by accident.
    assert not hasattr(wrapper, "theta_")
