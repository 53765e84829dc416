import json

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
