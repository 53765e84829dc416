"""The constraint method from the command line: simulate ball-in-socket data, calibrate,
evaluate on held-out placements, report, compensate and export; and its refusals."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from refusals import run_ok
from robocal.interfaces.cli import app
from robocal.io.model_file import load_model
from robocal.io.library import load_robot

runner = CliRunner()
FIXTURE = """name = "plate with three sockets"
[sockets]
A = [0.0, 0.0, 0.0]
B = [150.0, 0.0, 0.0]
C = [0.0, 120.0, 0.0]
"""


@pytest.fixture(scope="module")
def socket_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sockets")
    (folder / "fix.toml").write_text(FIXTURE)
    run_ok("simulate", "kr150-2", "--sampling", "sockets", "--fixture", folder / "fix.toml", "--placements", 9,
         "--per-socket", 12, "--joint-noise", 0.002, "--errors", "typical", "--seed", 4, "--out", folder / "all.csv")
    lines = (folder / "all.csv").read_text().splitlines(keepends=True)
    header, rows = lines[0], lines[1:]
    held_out = (",P7,", ",P8,", ",P9,")
    (folder / "train.csv").write_text(header + "".join(r for r in rows if not any(p in r for p in held_out)))
    (folder / "test.csv").write_text(header + "".join(r for r in rows if any(p in r for p in held_out)))
    run_ok("calibrate", "kr150-2", folder / "train.csv", "--method", "constraint", "--fixture", folder / "fix.toml",
         "--out", folder / "model.json")
    return folder


def test_held_out_placements_become_consistent(socket_files):
    result = json.loads(run_ok("evaluate", socket_files / "model.json", socket_files / "test.csv", "--json").stdout)
    assert result["n"] == 3 * 3 * 12
    assert result["mean_mm"] < 0.2 * result["nominal"]["mean_mm"]
    assert result["socket_distance"]["mean_mm"] < result["nominal"]["socket_distance"]["mean_mm"]
    # The model file keeps the fixture, and says the base frame cannot be seen.
    model = load_model(socket_files / "model.json")
    assert model.training["fixture"]["sockets"]["B"] == [150.0, 0.0, 0.0]
    assert "base frame" in model.training["calibration"]["unobservable"]


def test_report_compensate_and_export_on_a_constraint_model(socket_files, tmp_path):
    report = json.loads(run_ok("report", socket_files / "model.json", socket_files / "test.csv",
                             "--out", tmp_path / "r.html", "--json").stdout)
    evaluated = json.loads(run_ok("evaluate", socket_files / "model.json", socket_files / "test.csv", "--json").stdout)
    assert report["mean_mm"] == evaluated["mean_mm"] and "Socket distances" in (tmp_path / "r.html").read_text()
    run_ok("compensate", socket_files / "model.json", "examples/kr150-targets.csv", "--out", tmp_path / "c.csv")
    run_ok("export", socket_files / "model.json", "--convention", "mdh", "--out", tmp_path / "cal.toml")
    exported, calibrated = load_robot(str(tmp_path / "cal.toml")), load_model(socket_files / "model.json").kinematics
    assert exported.convention == "mdh"
    q = calibrated.random_configurations(100, rng=3)
    np.testing.assert_allclose(exported.fk_positions(q), calibrated.fk_positions(q), atol=1e-8)


def test_constraint_refusals(socket_files, tmp_path):
    no_fixture = runner.invoke(app, ["calibrate", "kr150-2", str(socket_files / "train.csv"), "--method",
                                     "constraint", "--out", str(tmp_path / "m.json")])
    assert no_fixture.exit_code == 2 and "--fixture" in no_fixture.output
    kinematic = runner.invoke(app, ["calibrate", "kr150-2", str(socket_files / "train.csv"), "--out",
                                    str(tmp_path / "m.json")])
    assert kinematic.exit_code == 2 and "no x, y, z" in kinematic.output
    run_ok("simulate", "kr150-2", "--n", 50, "--out", tmp_path / "tracker.csv")
    positions = runner.invoke(app, ["calibrate", "kr150-2", str(tmp_path / "tracker.csv"), "--method", "constraint",
                                    "--fixture", str(socket_files / "fix.toml"), "--out", str(tmp_path / "m.json")])
    assert positions.exit_code == 2 and "fixture and socket" in positions.output
    assert not (tmp_path / "m.json").exists()


def test_mukca_dataset_split_by_placement(tmp_path):
    prefix = tmp_path / "p3"
    split = json.loads(run_ok("dataset", "mukca-panda-3", "--out", prefix, "--split", 0.5, "--json").stdout)
    train = (tmp_path / "p3_train.csv").read_text()
    test = (tmp_path / "p3_test.csv").read_text()
    for placement in split["train_placements"]:
        assert f",{placement}," in train and f",{placement}," not in test
    run_ok("calibrate", f"{prefix}.toml", tmp_path / "p3_train.csv", "--method", "constraint",
         "--fixture", tmp_path / "p3_fixture.toml", "--out", tmp_path / "p3.json")
    result = json.loads(run_ok("evaluate", tmp_path / "p3.json", tmp_path / "p3_test.csv", "--json").stdout)
    assert result["mean_mm"] < 0.25 * result["nominal"]["mean_mm"]


def test_validate_leaves_one_placement_out(socket_files):
    result = json.loads(run_ok("validate", "kr150-2", socket_files / "train.csv", "--method", "constraint",
                             "--fixture", socket_files / "fix.toml", "--json").stdout)
    folds = result["cross_validation"]["folds"]
    assert [f["fold"] for f in folds] == [f"P{k}" for k in range(1, 7)]
    assert all(f["n_train"] == 5 * 3 * 12 for f in folds)
    pooled, nominal = result["cross_validation"]["pooled"], result["nominal_cross_validation"]["pooled"]
    assert pooled["n"] == nominal["n"] == 6 * 3 * 12
    assert pooled["mean_mm"] < 0.2 * nominal["mean_mm"]
    curve = runner.invoke(app, ["validate", "kr150-2", str(socket_files / "train.csv"), "--method", "constraint",
                                "--fixture", str(socket_files / "fix.toml"), "--sizes", "20,40"])
    assert curve.exit_code == 2 and "placement by placement" in curve.output
