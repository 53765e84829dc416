"""calibrate MODEL.json NEW.csv --method frames: a model file carried to a new set-up from the
command line, and read back as a working model file (the error model moved with the frame)."""
import dataclasses
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from refusals import run_ok
from robocal.interfaces.cli import app
from robocal.io.library import builtin
from robocal.io.tables import write_measurements
from robocal.simulation import make_true_robot, uniform_joints

runner = CliRunner()


@pytest.fixture(scope="module")
def setups(tmp_path_factory):
    """A UR5 measured on one set-up (training) and, the tracker moved by metres and the tool
    changed, on another (25 poses to re-register on, 100 to test on)."""
    root = tmp_path_factory.mktemp("frames")
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=4)
    rng = np.random.default_rng(4)
    # The tracker 2.5 m away and turned by 40 deg; a tool 12 mm longer (file units: mm, deg).
    change = {"base_x": 2500.0, "base_y": -1200.0, "base_z": 300.0, "base_rz": 40.0, "base_rx": 3.0,
              "tool_z": 12.0}
    moved = dataclasses.replace(truth, deviations={
        name: truth.deviations.get(name, 0.0) + change.get(name, 0.0) for name in {*truth.deviations, *change}})
    files = {}
    for name, robot, n in (("train", truth, 300), ("new", moved, 25), ("test", moved, 100)):
        q = uniform_joints(chain, n, rng)
        data = robot.measurements(q, rng)
        write_measurements(root / f"{name}.csv", data)
        files[name] = root / f"{name}.csv"
    return root, files


@pytest.mark.slow
@pytest.mark.parametrize("method", ["kinematic", "hybrid"])
def test_a_reregistered_model_file_works_on_the_new_set_up(setups, method):
    root, files = setups
    model, moved = root / f"{method}.json", root / f"{method}_moved.json"
    extra = ["--inputs", "sincos"] if method == "hybrid" else []
    run_ok("calibrate", "ur5", files["train"], "--method", method, *extra, "--out", model)
    as_it_stood = json.loads(run_ok("evaluate", model, files["test"], "--json").output)
    shown = run_ok("calibrate", model, files["new"], "--method", "frames", "--out", moved).output
    assert "re-registered" in shown and "condition number" in shown
    after = json.loads(run_ok("evaluate", moved, files["test"], "--json").output)
    # As it stood the model is metres off (the tracker moved); re-registered on 25 poses it is
    # as good on the new set-up's held-out poses as the fitted model on the old one's noise,
    # and far better than the nominal registered to the new poses.
    assert as_it_stood["mean_mm"] > 1000.0
    assert after["mean_mm"] < 0.5 * after["nominal"]["mean_mm"]
    document = json.loads(moved.read_text())
    assert document["method"] == method
    assert document["training"]["reregistration"]["poses"] == 25
    if method == "hybrid":
        assert document["error_model"]["type"] == "reframed"


def test_frames_takes_one_option(setups):
    root, files = setups
    model = root / "plain.json"
    run_ok("calibrate", "ur5", files["train"], "--out", model)
    for args, says in ((["--loss", "huber"], "leave out --loss"),
                       (["--parameters", "full"], "frames+offsets"),):
        result = runner.invoke(app, ["calibrate", str(model), str(files["new"]), "--method", "frames", *args,
                                     "--out", str(root / "x.json")])
        assert result.exit_code == 2 and says in result.output, result.output
        assert not (root / "x.json").exists()
    result = runner.invoke(app, ["calibrate", "ur5", str(files["new"]), "--parameters", "frames",
                                 "--out", str(root / "x.json")])
    assert result.exit_code == 2 and "--method frames" in result.output, result.output
