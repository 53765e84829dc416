"""Model files whose entries have the wrong type although their checksum matches (the editor
recomputed it): every verb that reads a model refuses them with one line naming the entry,
never a traceback (:func:`refusals.assert_refused`).  Each row edits one entry of a model that
``robocal calibrate`` wrote, recomputes the checksum and runs the verb in a fresh folder."""
import hashlib
import json

import pytest

from refusals import EXAMPLES, assert_refused, copy_files, copy_inputs, run_ok
from robocal.io.model_file import _canonical

# (model, entry as a dotted path, the value written there, what the error line names)
CORRUPTED = [
    ("model.json", "training", "text", "'training'"),
    ("model.json", "training", [1], "'training'"),
    ("model.json", "options", 5, "'options'"),
    ("model.json", "options.register", 3, "'options.register'"),
    ("model.json", "options.loss", "cauchy", "'options.loss'"),
    ("model.json", "created", 5, "'created'"),
    ("model.json", "software_version", [], "'software_version'"),
    ("model.json", "training.n_poses", "sixty", "'training.n_poses'"),
    ("model.json", "training.residual_before", "x", "'training.residual_before'"),
    ("model.json", "training.residual_before.rms_mm", "x", "'training.residual_before.rms_mm'"),
    ("model.json", "training.fingerprint", 3, "'training.fingerprint'"),
    ("model.json", "training.fingerprint.joints", 7, "'training.fingerprint.joints'"),
    ("model.json", "training.fingerprint.n_joints", "x", "'training.fingerprint.n_joints'"),
    ("model.json", "training.fingerprint.resolution", "x", "'training.fingerprint.resolution'"),
    ("model.json", "training.predicted_error", 3, "'training.predicted_error'"),
    ("model.json", "training.predicted_error.mean_mm", "x", "'training.predicted_error.mean_mm'"),
    ("model.json", "training.registered", "yes", "'training.registered'"),
    ("model.json", "training.calibration.parameters.a1.deviation", "x",
     "'training.calibration.parameters.a1.deviation'"),
    ("model.json", "training.calibration.identifiability.rank", 2.5, "'training.calibration.identifiability.rank'"),
    ("model.json", "domain.joints", 3, "'domain.joints'"),
    ("model.json", "domain.joints.min", "x", "'domain.joints.min'"),
    ("model.json", "domain.joints.max", [1, "2", 3, 4, 5, 6], "'domain.joints.max[1]'"),
    ("model.json", "domain.n_poses", "x", "'domain.n_poses'"),
    ("model.json", "domain.box.margin", "x", "'domain.box.margin'"),
    ("model.json", "domain.branches", "x", "'domain.branches'"),
    ("model.json", "domain.neighbours.radius", "x", "'domain.neighbours.radius'"),
    ("model.json", "bound", [], "'bound'"),
    ("model.json", "bound.residual_mm", "x", "'bound.residual_mm'"),
    ("model.json", "bound.coverage", None, "'bound.coverage'"),
    ("model.json", "bound.training_joints_rad", "x", "'bound.training_joints_rad'"),
    ("model.json", "bound.posterior.names", 3, "'bound.posterior.names'"),
    ("model.json", "robot.hash", 3, "'robot.hash'"),
    ("model.json", "robot.model.convention", 5, "convention must be one of"),  # robot documents: robot_file's
    ("model.json", "kinematics.tool", {"xyz": "x", "rpy": [0, 0, 0]}, "[tool] xyz must be"),
    ("model.json", "error_model", "kriging", "'error_model'"),
    ("hybrid.json", "error_model.type", 3, "'error_model.type'"),
    ("hybrid.json", "error_model.parameters", "x", "'error_model.parameters'"),
    ("hybrid.json", "error_model.parameters.X", "x", "'error_model.parameters.X'"),
    ("hybrid.json", "error_model.parameters.theta", [["a"]], "'error_model.parameters.theta'"),
    ("hybrid.json", "error_model.parameters.settings", 3, "'error_model.parameters.settings'"),
    ("hybrid.json", "options.trend", 2, "'options.trend'"),
    ("auto.json", "outside_domain", "kinematic", "'outside_domain'"),
    ("auto.json", "outside_domain.label", 3, "'outside_domain.label'"),
    ("auto.json", "bound.fallback", "x", "'bound.fallback'"),
    ("auto.json", "bound.fallback.inside_factor", "x", "'bound.fallback.inside_factor'"),
    ("auto.json", "training.comparison", 3, "'training.comparison'"),
    ("cmodel.json", "training.residual_before.socket_distance.rms_mm", "x",
     "'training.residual_before.socket_distance.rms_mm'"),
    ("cmodel.json", "training.fixture.sockets.B", "far", "'training.fixture.sockets.B'"),
    ("cmodel.json", "domain.placements", [1, 2], "'domain.placements[0]'"),
    ("cmodel.json", "options.pairs", True, "'options.pairs'"),
    # Of the right type but damaged: refused by every verb, export included (it rebuilds the
    # whole model although it writes only the kinematics).
    ("model.json", "method", "teleport", "unknown method 'teleport'"),
    ("model.json", "domain.joints.min", [1.0, 2.0], "the domain of validity is damaged"),
    ("cmodel.json", "method", "teleport", "unknown method 'teleport'"),
    # hostile pass 5: a whole section of the wrong type
    ("model.json", "kinematics", [1, 2], "'kinematics' has the wrong type (a table expected, got a list)"),
    ("model.json", "robot", "ur5", "'robot' has the wrong type (a table expected, got text)"),
    ("model.json", "domain", "everywhere", "'domain' has the wrong type (a table or null expected, got text)"),
    ("model.json", "options", ["full"], "'options' has the wrong type (a table or null expected, got a list)"),
]

VERBS = {
    "model.json": ["evaluate {model} meas.csv", "compensate {model} ur5-targets.csv --out c.csv",
                   "report {model} meas.csv --out r.html", "export {model} --out k.toml"],
    "hybrid.json": ["evaluate {model} meas.csv", "compensate {model} ur5-targets.csv --out c.csv"],
    "auto.json": ["evaluate {model} meas.csv", "compensate {model} ur5-targets.csv --out c.csv"],
    "cmodel.json": ["evaluate {model} sockets.csv", "export {model} --out k.toml"],
}


@pytest.fixture(scope="module")
def model_inputs(tmp_path_factory, ur5_files, kr150_socket_files):
    """The UR5 kinematic model, a hybrid one (a calibration and a Kriging error model) and an
    auto one (a model with its fallback outside the domain) of the same data, the KR 150-2
    constraint model and the data and targets they are run on."""
    root = copy_files(kr150_socket_files, copy_files(ur5_files, tmp_path_factory.mktemp("models")))
    run_ok("calibrate", "ur5", root / "meas.csv", "--method", "hybrid", "--accept-extrapolation",
           "--out", root / "hybrid.json")
    run_ok("calibrate", "ur5", root / "meas.csv", "--method", "auto", "--out", root / "auto.json")
    assert "outside_domain" in json.loads((root / "auto.json").read_text())  # what its rows break
    (root / "ur5-targets.csv").write_text((EXAMPLES / "ur5-targets.csv").read_text())
    return root


def _edit(document, entry, value):
    """``document`` with ``entry`` (a dotted path) set to ``value`` and its checksum recomputed."""
    *parents, last = entry.split(".")
    node = document
    for key in parents:
        node = node[key]
    assert last in node, f"{entry} is not in the model file: the table is out of date"
    node[last] = value
    body = {k: v for k, v in document.items() if k != "checksum"}
    document["checksum"] = hashlib.sha256(_canonical(body).encode()).hexdigest()
    return document


ROWS = [(model, entry, value, says, verb) for model, entry, value, says in CORRUPTED for verb in VERBS[model]]


@pytest.mark.parametrize("model, entry, value, says, verb", ROWS,
                         ids=[f"{r[4].split()[0]}-{r[0]}-{r[1]}={r[2]!r}" for r in ROWS])
def test_a_checksummed_model_file_with_an_entry_of_the_wrong_type_is_refused(model_inputs, tmp_path, monkeypatch,
                                                                             model, entry, value, says, verb):
    document = _edit(json.loads((model_inputs / model).read_text()), entry, value)
    before = copy_inputs(model_inputs, tmp_path, monkeypatch)
    (tmp_path / "edited.json").write_text(json.dumps(document))
    before["edited.json"] = (tmp_path / "edited.json").stat().st_mtime_ns
    assert_refused(verb.format(model="edited.json").split(), says, tmp_path, before)


@pytest.mark.parametrize("model", sorted(VERBS))
def test_the_model_files_robocal_writes_pass_the_schema(model_inputs, tmp_path, monkeypatch, model):
    # The schema must accept what calibrate writes, else every row above would pass for
    # the wrong reason.
    copy_inputs(model_inputs, tmp_path, monkeypatch)
    for verb in VERBS[model]:
        run_ok(*verb.format(model=model).split())
