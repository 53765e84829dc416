import json

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


def test_demo_json_reports_measured_round_trips():
    result = runner.invoke(app, ["demo", "--json", "--n", "300", "--seed", "3"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert data["configurations"] == 300
    closed = data["closed_form_ik"]
    assert closed["original_configuration_found"] == 1.0
    assert closed["max_position_error_mm"] < 1e-6
    numeric = data["numerical_ik_calibrated_model"]
    assert numeric["success_rate"] == 1.0
    assert numeric["max_position_error_mm"] < 1e-6
    assert numeric["nominal_vs_calibrated_mean_mm"] > 1.0  # the perturbation is real
