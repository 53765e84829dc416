"""Inputs that used to give a quiet wrong answer now give one clear line and leave no file."""
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.errors import InputError
from robocal.interfaces.cli import app
from robocal.io.library import builtin
from robocal.io.observations import Observations
from robocal.methods import make_method

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _refused(args, *unwanted):
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1, result.output
    for path in unwanted:
        assert not Path(path).exists(), path
    return result.output


def test_simulate_refuses_zero_poses(tmp_path):
    out = tmp_path / "m.csv"
    assert "--n" in _refused(["simulate", "ur5", "--n", "0", "--out", out], out)


def test_a_refused_dataset_split_writes_nothing(tmp_path):
    prefix = tmp_path / "ur5"
    message = _refused(["dataset", "ur5-tsinghua", "--out", prefix, "--split", "1.5"], f"{prefix}.toml",
                       f"{prefix}_train.csv")
    assert "--split" in message
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["kriging", "ann"])
def test_error_models_refuse_one_pose_repeated(name):
    chain = builtin("ur5")
    q = np.repeat(chain.random_configurations(1, rng=0), 50, axis=0)
    with pytest.raises(InputError, match="1 distinct pose"):
        make_method(name).fit(chain, Observations.of(q, chain.fk_positions(q)))


def test_compensate_fails_when_no_target_is_reachable(tmp_path):
    meas, model, out = tmp_path / "meas.csv", tmp_path / "m.json", tmp_path / "c.csv"
    assert runner.invoke(app, ["simulate", "ur5", "--n", "60", "--out", str(meas)]).exit_code == 0
    assert runner.invoke(app, ["calibrate", "ur5", str(meas), "--out", str(model)]).exit_code == 0
    far = tmp_path / "far.csv"
    far.write_text("x,y,z,rx,ry,rz\n5000,0,0,180,0,0\n0,7000,0,180,0,0\n")
    assert "none of the 2 targets" in _refused(["compensate", model, far, "--out", out], out)


def test_terminal_tables_show_no_python_reprs(tmp_path):
    meas = tmp_path / "m.csv"
    result = runner.invoke(app, ["simulate", "ur5", "--n", "30", "--out", str(meas)])
    assert result.exit_code == 0 and "None" not in result.output and "true error" in result.output
    model = tmp_path / "m.json"
    assert runner.invoke(app, ["calibrate", "ur5", str(meas), "--out", str(model)]).exit_code == 0
    result = runner.invoke(app, ["compensate", str(model), str(EXAMPLES / "ur5-targets.csv"), "--out",
                                 str(tmp_path / "c.csv")])
    assert result.exit_code == 0 and "[]" not in result.output and "unreachable rows" in result.output
