import json

import numpy as np
import pytest

from typer.testing import CliRunner

from robocal.interfaces.cli import app

runner = CliRunner()


def test_robots_lists_every_builtin():
    result = runner.invoke(app, ["robots"])
    assert result.exit_code == 0
    for name in ("kr150-2", "ur5", "ur10", "panda", "iiwa14", "irb120", "fanuc-r2000ic-165f"):
        assert name in result.output


def test_show_prints_parameter_table():
    result = runner.invoke(app, ["show", "irb120"])
    assert result.exit_code == 0
    assert "ABB IRB 120" in result.output and "374" in result.output


def test_unknown_robot_is_one_line_and_nonzero_exit():
    result = runner.invoke(app, ["show", "kr16"])
    assert result.exit_code == 2
    assert "no built-in robot named 'kr16'" in result.output
    assert "Traceback" not in result.output


@pytest.fixture(scope="module")
def demo_result():
    result = runner.invoke(app, ["demo", "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.output)


def test_demo_reproduces_the_liu2022_setup_and_compensates(demo_result):
    before = demo_result["before_all"]
    # The published experiment's before-compensation figures (all 150 points).
    assert abs(before["mean_mm"] - 1.690) < 0.005
    assert abs(before["y_mean_mm"] - 1.560) < 0.005 and abs(before["y_max_mm"] - 1.910) < 0.005
    assert abs(before["z_mean_mm"] - 0.271) < 0.005
    after = demo_result["after"]
    assert demo_result["reachable"] == demo_result["test_points"] == 100
    # Compensation removes more than 99.5 % of the 1.7 mm error on the held-out targets.
    assert after["mean_mm"] < 0.005 * demo_result["before"]["mean_mm"]


@pytest.mark.xfail(strict=True, reason="our maximum-likelihood Kriging reaches about 0.002-0.003 mm mean and "
                   "0.013-0.016 mm max on liu2022, not the published 0.0018 / 0.0084 mm (see README)")
def test_demo_reaches_the_published_after_compensation_figures(demo_result):
    assert demo_result["after"]["mean_mm"] <= 0.0018
    assert demo_result["after"]["max_mm"] <= 0.0084


def test_dataset_export_splits_without_overlap(tmp_path):
    from robocal.io.robot_file import read_robot
    from robocal.io.tables import read_measurements

    prefix = tmp_path / "ur5"
    result = runner.invoke(app, ["dataset", "ur5-tsinghua", "--out", str(prefix), "--split", "0.3", "--json"])
    assert result.exit_code == 0, result.output
    chain = read_robot(f"{prefix}.toml")
    train = read_measurements(f"{prefix}_train.csv", n_joints=chain.n_joints)
    test = read_measurements(f"{prefix}_test.csv", n_joints=chain.n_joints)
    assert (train.n_poses, test.n_poses) == (300, 700)
    joined = np.vstack([train.joints, test.joints])
    assert len(np.unique(joined, axis=0)) == 1000  # a partition: no pose in both
    assert np.abs(chain.d[4] - 94.56) < 1e-12  # the authors' model, not UR's


def test_dataset_rejects_unknown_name_and_bad_split(tmp_path):
    result = runner.invoke(app, ["dataset", "kuka-secret", "--out", str(tmp_path / "x")])
    assert result.exit_code == 2 and "dataset must be one of ur5-tsinghua" in result.output
    result = runner.invoke(app, ["dataset", "ur5-tsinghua", "--out", str(tmp_path / "x"), "--split", "1.5"])
    assert result.exit_code == 2 and "between 0 and 1" in result.output


def test_validate_cross_validates_against_the_registered_nominal(tmp_path):
    meas = tmp_path / "meas.csv"
    result = runner.invoke(app, ["simulate", "ur10", "--errors", "typical", "--n", "120", "--noise", "0.02",
                                 "--out", str(meas), "--json"])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["validate", "ur10", str(meas), "--folds", "4", "--sizes", "40,80", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    pooled = data["cross_validation"]["pooled"]
    assert pooled["n"] == 120  # every pose predicted once, by a model that did not see it
    assert pooled["mean_mm"] < 0.5 * data["nominal_cross_validation"]["pooled"]["mean_mm"]
    assert [p["n_train"] for p in data["learning_curve"]] == [40, 80]
