"""Data that do not belong to a model are warned about: another robot's ball-in-socket data
evaluated with a constraint model, a validation of other data given to the report."""
import warnings
from pathlib import Path

import pytest

from refusals import PLATE, copy_files, run_ok
from robocal.errors import RobocalWarning


@pytest.fixture(scope="module")
def socket_files(tmp_path_factory, kr150_socket_files):
    """The KR 150-2's socket data and constraint model (``conftest.kr150_socket_files``) and a
    UR5's balls in the same fixture's sockets."""
    root = copy_files(kr150_socket_files, tmp_path_factory.mktemp("sockets"))
    run_ok("simulate", "ur5", "--sampling", "sockets", "--fixture", PLATE, "--placements", "3", "--per-socket", "6",
           "--out", root / "ur5.csv")
    return root


def test_another_robots_socket_data_are_warned_about(socket_files):
    from robocal.io.observations import read_observations
    from robocal.io.model_file import load_model
    from robocal.methods import fitted_from_model_file
    from robocal.methods.evaluation import socket_scores, with_fixture

    path = socket_files / "cmodel.json"
    model = load_model(path)
    fitted = fitted_from_model_file(model, path)
    own = with_fixture(fitted, read_observations(socket_files / "sockets.csv", model.kinematics), path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert socket_scores(fitted, own)["mean_mm"] < 1.0
    other = with_fixture(fitted, read_observations(socket_files / "ur5.csv", model.kinematics, beyond_limits=True),
                         path)
    with pytest.warns(RobocalWarning, match="from robot 'KUKA KR 150-2'"):
        socket_scores(fitted, other)


def test_a_validation_of_other_data_is_warned_about_in_the_report(tmp_path, monkeypatch):
    import json

    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    for args in (["simulate", "ur5", "--n", "40", "--out", "meas.csv"],
                 ["calibrate", "ur5", "meas.csv", "--out", "m.json"]):
        assert runner.invoke(app, args).exit_code == 0

    def validation(name, file, poses):
        Path(name).write_text(json.dumps({"method": "kinematic", "file": file, "poses": poses, "folds": 5,
                                          "cross_validation": {"pooled": {"mean_mm": 0.1}},
                                          "nominal_cross_validation": {"pooled": {"mean_mm": 2.0}}}))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = runner.invoke(app, ["report", "m.json", "meas.csv", "--out", "r.html", "--validation", name])
        assert result.exit_code == 0, result.output
        return [str(w.message) for w in caught if issubclass(w.category, RobocalWarning)]

    assert not validation("same.json", "meas.csv", 40)
    for name, file, poses in (("other.json", "other.csv", 40), ("edited.json", "meas.csv", 80)):
        said = validation(name, file, poses)
        assert len(said) == 1 and "but the model was trained on meas.csv (40 poses)" in said[0], said
