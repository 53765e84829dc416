"""An output's name says what it holds: an --out whose suffix names another kind of file
robocal writes is refused before any work (calibrate --out m.csv used to write JSON into it),
export takes its format from the name, dataset's --out is a prefix; whole-number options
beyond any sensible count are refused with one line (beyond 64 bits they used to reach NumPy
and fail with a traceback)."""
import shutil

import pytest
from typer.testing import CliRunner

from refusals import assert_refused, copy_inputs
from robocal.interfaces.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def files(tmp_path_factory, ur5_files):
    """The shared UR5 model file (``conftest.ur5_files``) and 30 of its poses: too few for
    ``compare``'s default folds."""
    root = tmp_path_factory.mktemp("outputs")
    shutil.copy(ur5_files / "model.json", root / "model.json")
    lines = (ur5_files / "meas.csv").read_text().splitlines(keepends=True)
    (root / "meas.csv").write_text("".join(lines[:31]))
    return root


HUGE = "99999999999999999999"
ROWS = [
    (["calibrate", "ur5", "meas.csv", "--out", "m2.csv"], "name it m2.json"),
    (["compensate", "model.json", "meas.csv", "--out", "c.json"], "name it c.csv"),
    (["report", "model.json", "meas.csv", "--out", "r.pdf"], "name it r.html"),
    (["report", "model.json", "meas.csv", "--out", "r.html", "--pdf", "r2.html"], "name it r2.pdf"),
    (["simulate", "ur5", "--out", "s.json"], "name it s.csv"),
    (["simulate", "ur5", "--out", "s.csv", "--truth", "t.csv"], "name it t.json"),
    (["export", "model.json", "--format", "toml", "--out", "x.urdf"], "name it x.toml"),
    (["dataset", "ur5-tsinghua", "--out", "d.csv"], "give 'd'"),
    (["simulate", "ur5", "--n", HUGE, "--out", "s.csv"], "<= 1,000,000"),
    (["simulate", "ur5", "--seed", HUGE, "--out", "s.csv"], "--seed must be a whole number"),
    (["validate", "ur5", "meas.csv", "--folds", HUGE], "--folds must be a whole number"),
    (["validate", "ur5", "meas.csv", "--sizes", f"10,{HUGE}"], "--sizes must be"),
    # compare, auto and frames, new in issue 15
    (["compare", "ur5", "meas.csv", "--folds", "1"], "--folds must be"),
    (["calibrate", "ur5", "meas.csv", "--method", "auto", "--parameters", "full", "--out", "a.json"],
     "--method auto chooses"),
    (["calibrate", "model.json", "meas.csv", "--method", "frames", "--loss", "huber", "--out", "f.json"],
     "leave out --loss"),
    (["calibrate", "ur5", "meas.csv", "--parameters", "frames", "--out", "f.json"], "give --method frames"),
]


@pytest.mark.parametrize("args, says", ROWS, ids=[" ".join(r[0][:1] + r[0][-2:]) for r in ROWS])
def test_refused(args, says, files, tmp_path, monkeypatch):
    before = copy_inputs(files, tmp_path, monkeypatch)
    assert_refused(args, says, tmp_path, before)


def test_export_takes_its_format_from_the_name(files, tmp_path, monkeypatch):
    copy_inputs(files, tmp_path, monkeypatch)
    result = runner.invoke(app, ["export", "model.json", "--out", "calibrated.urdf"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "calibrated.urdf").read_text().lstrip().startswith("<?xml")
    result = runner.invoke(app, ["export", "model.json", "--out", "calibrated"])
    assert result.exit_code == 0, result.output
    assert "[[joints]]" in (tmp_path / "calibrated").read_text()


def test_garbled_inputs_are_refused_in_one_line(files, tmp_path, monkeypatch):
    """A split that leaves no training pose, noise of 1e300 mm,
    export to a .json name, a model file holding NaN, text joints in Python."""
    import json

    import numpy as np

    from robocal.errors import FileFormatError, InputError
    from robocal.estimation.calibration import KinematicCalibration
    from robocal.interfaces.jobs import load_fitted
    from robocal.io.library import builtin
    from robocal.kinematics.ik import solve_ik

    before = copy_inputs(files, tmp_path, monkeypatch)
    for args, says in ((["dataset", "ur5-tsinghua", "--split", "0.00001", "--out", "q"], "leaves no training"),
                       (["simulate", "ur5", "--noise", "1e300", "--out", "s.csv"], "<= 1,000"),
                       (["export", "model.json", "--out", "x.json"], "name it x.toml")):
        assert_refused(args, says, tmp_path, before)
    document = json.loads((tmp_path / "model.json").read_text())
    document["training"]["residual_before"]["mean_mm"] = float("nan")
    (tmp_path / "nan.json").write_text(json.dumps(document))
    with pytest.raises(FileFormatError, match="NaN"):
        load_fitted(tmp_path / "nan.json")
    _, fitted = load_fitted(tmp_path / "model.json")
    chain = builtin("ur5")
    for call in (lambda: fitted.predict([["a"] * 6]), lambda: solve_ik(chain, [[["x"] * 4] * 4]),
                 lambda: KinematicCalibration().fit(chain, [["a"] * 6] * 10, np.zeros((10, 3)))):
        with pytest.raises(InputError, match="numbers"):
            call()
