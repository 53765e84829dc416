"""robocal report: a self-contained HTML report whose numbers are evaluate's, for every
method; ISO 9283-style accuracy on repeated poses; clear refusals."""
import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.estimation.metrics import iso9283_position
from robocal.interfaces.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    result = runner.invoke(app, ["simulate", "kr150-2", "--out", str(folder / "all.csv"), "--n", "180", "--seed", "3"])
    assert result.exit_code == 0, result.output
    lines = (folder / "all.csv").read_text().splitlines(keepends=True)
    (folder / "train.csv").write_text("".join(lines[:121]))
    (folder / "test.csv").write_text("".join(lines[:1] + lines[121:]))
    return folder


@pytest.mark.slow
@pytest.mark.parametrize("method", ["kinematic", "kriging", "hybrid"])
def test_report_renders_and_agrees_with_evaluate(files, method):
    model = files / f"{method}.json"
    # --accept-extrapolation: Kriging from these few spread poses is predicted to miss by more
    # than the registered nominal robot; its report is what is tested here.
    assert runner.invoke(app, ["calibrate", "kr150-2", str(files / "train.csv"), "--method", method,
                               "--out", str(model), "--accept-extrapolation"]).exit_code == 0
    out = files / f"{method}.html"
    result = runner.invoke(app, ["report", str(model), str(files / "test.csv"), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    evaluated = json.loads(runner.invoke(app, ["evaluate", str(model), str(files / "test.csv"), "--json"]).stdout)
    for key in ("n", "mean_mm", "rms_mm", "max_mm", "p95_mm"):
        assert report[key] == evaluated[key]
        assert report["nominal"][key] == evaluated["nominal"][key]
    page = out.read_text()
    # The page shows those numbers, and needs nothing from outside the file.
    assert f"{evaluated['mean_mm']:.4f}" in page and f"{evaluated['nominal']['max_mm']:.4f}" in page
    assert not re.search(r"(src|href)=\"(https?:|file:|/)", page)
    images = re.findall(r"data:image/png;base64,", page)
    assert len(images) == len(report["figures"]) >= 3
    assert ("Kriging uncertainty" in report["figures"]) == (method != "kinematic")
    assert report["held_out"] is True
    if method != "kriging":
        assert "Identified parameters" in page and "axes 2 and 3 are parallel" in page


@pytest.mark.slow
def test_report_with_cross_validation_and_pdf(files):
    model = files / "kin.json"
    assert runner.invoke(app, ["calibrate", "kr150-2", str(files / "train.csv"), "--out", str(model)]).exit_code == 0
    cv = runner.invoke(app, ["validate", "kr150-2", str(files / "train.csv"), "--folds", "3", "--sizes", "40,80",
                             "--json"])
    assert cv.exit_code == 0, cv.output
    (files / "cv.json").write_text(cv.stdout)
    result = runner.invoke(app, ["report", str(model), str(files / "train.csv"), "--out", str(files / "r.html"),
                                 "--validation", str(files / "cv.json"), "--pdf", str(files / "r.pdf"), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert "Learning curve" in report["figures"]
    assert report["held_out"] is False and "not held out" in (files / "r.html").read_text()
    assert (files / "r.pdf").read_bytes().startswith(b"%PDF")


def test_report_refusals(files, tmp_path):
    model = files / "kinematic.json"
    if not model.exists():
        runner.invoke(app, ["calibrate", "kr150-2", str(files / "train.csv"), "--out", str(model)])
    result = runner.invoke(app, ["report", str(model), str(files / "test.csv"), "--out", str(tmp_path / "r.txt")])
    assert result.exit_code == 2 and ".html" in result.output
    (tmp_path / "cv.json").write_text("{}")
    result = runner.invoke(app, ["report", str(model), str(files / "test.csv"), "--out", str(tmp_path / "r.html"),
                                 "--validation", str(tmp_path / "cv.json")])
    assert result.exit_code != 0 and "robocal validate" in result.output
    assert not (tmp_path / "r.html").exists()


def test_iso9283_accuracy_and_repeatability():
    rng = np.random.default_rng(0)
    joints = np.repeat(rng.uniform(-1, 1, size=(4, 6)), 5, axis=0)
    commanded = np.repeat(rng.uniform(0, 1000, size=(4, 3)), 5, axis=0)
    bias = np.array([0.3, 0.0, 0.4])  # every pose lands 0.5 mm off
    attained = commanded + bias + rng.normal(scale=0.01, size=commanded.shape)
    result = iso9283_position(joints, attained, commanded)
    assert result["poses"] == 4 and result["repeated_poses"] == 4
    assert result["ap_mean_mm"] == pytest.approx(0.5, abs=0.02)
    spread = attained - attained.reshape(4, 5, 3).mean(axis=1).repeat(5, axis=0)
    lengths = np.linalg.norm(spread, axis=1).reshape(4, 5)
    assert result["rp_max_mm"] == pytest.approx((lengths.mean(axis=1) + 3 * lengths.std(axis=1, ddof=1)).max())
    single = iso9283_position(joints[::5], attained[::5], commanded[::5])
    assert single["repeated_poses"] == 0 and single["rp_max_mm"] is None
