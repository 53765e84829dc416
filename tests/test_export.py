"""robocal export: the calibrated kinematics as a robot file and a URDF that reproduce the
model's forward kinematics, and a say on what a robot file cannot carry."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.interfaces.cli import app
from robocal.io.model_file import load_model
from robocal.io.library import load_robot

runner = CliRunner()


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    meas = folder / "meas.csv"
    result = runner.invoke(app, ["simulate", "ur10", "--out", str(meas), "--n", "150", "--seed", "2"])
    assert result.exit_code == 0, result.output
    return folder, meas


@pytest.mark.parametrize("parameters", ["full", "full+gains", "full+compliance"])
@pytest.mark.parametrize("fmt", ["toml", "urdf"])
def test_exported_robot_reproduces_the_calibrated_kinematics(measured, parameters, fmt):
    folder, meas = measured
    model = folder / f"{parameters}.json"
    result = runner.invoke(app, ["calibrate", "ur10", str(meas), "--parameters", parameters, "--out", str(model)])
    assert result.exit_code == 0, result.output
    out = folder / f"{parameters}.{fmt}"
    result = runner.invoke(app, ["export", str(model), "--format", fmt, "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    calibrated = load_model(model).kinematics
    rigid = calibrated.rigid
    exported = load_robot(str(out))
    q = rigid.random_configurations(200, rng=1)
    # URDF has no joint gains: its joints are the model variables, and the export says so.
    gains_left_out = parameters == "full+gains" and fmt == "urdf"
    np.testing.assert_allclose(exported.fk(rigid.model_joints(q) if gains_left_out else q), rigid.fk(q), atol=1e-8)
    # The geometry differs from the nominal robot's: the file holds the calibration.
    assert np.abs(exported.fk_positions(q) - load_robot("ur10").fk_positions(q)).max() > 0.05
    assert bool(report["left_out"]) == (parameters == "full+compliance" or gains_left_out)


def test_export_refuses_an_unknown_format(measured, tmp_path):
    folder, meas = measured
    model = tmp_path / "m.json"
    assert runner.invoke(app, ["calibrate", "ur10", str(meas), "--out", str(model)]).exit_code == 0
    result = runner.invoke(app, ["export", str(model), "--format", "xml", "--out", str(tmp_path / "x")])
    assert result.exit_code == 2 and "format must be one of toml, urdf" in result.output
    assert not (tmp_path / "x").exists()
