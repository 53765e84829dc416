"""An output's name says what it holds: an --out whose suffix names another kind of file
robocal writes is refused before any work (calibrate --out m.csv used to write JSON into it),
export takes its format from the name, dataset's --out is a prefix; whole-number options
beyond any sensible count are refused with one line (beyond 64 bits they used to reach NumPy
and fail with a traceback)."""
import pytest
from typer.testing import CliRunner

from refusals import assert_refused, copy_inputs
from robocal.interfaces.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("outputs")
    for args in (["simulate", "ur5", "--n", "30", "--seed", "3", "--out", root / "meas.csv"],
                 ["calibrate", "ur5", root / "meas.csv", "--out", root / "model.json"]):
        result = runner.invoke(app, [str(a) for a in args])
        assert result.exit_code == 0, result.output
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
