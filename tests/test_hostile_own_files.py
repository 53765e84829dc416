# ruff: noqa: E501  (one input per table row)
"""Hostile inputs: robocal's own files given back to it as the wrong kind (a model as
measurements, compensate's commands as targets, a design plan as a fleet file, a report as a
model...), data of one robot given as another's, and ball-in-socket data given to the position
methods and back. Each row is refused in one line that names what the file is, and nothing
is written."""
import json

import pytest

from hostile import invoke, nominal_fk, prepare, refuse

REFUSED = [
    # (id, args, extra files, what the error line says)
    ("calibrate-commands", ["calibrate", "ur5", "cmds.csv", "--out", "m.json"], None, "written by 'robocal compensate', not a measurement file"),
    ("calibrate-per-pose", ["calibrate", "ur5", "perpose.csv", "--out", "m.json"], None, "written by 'robocal evaluate --per-pose'"),
    ("calibrate-plan", ["calibrate", "ur5", "plan.csv", "--out", "m.json"], None, "planned poses, written by 'robocal design'"),
    ("calibrate-model-as-robot", ["calibrate", "ur5_model.json", "ur5.csv", "--out", "m.json"], None, "a robot file must end in .toml or .urdf"),
    ("calibrate-report-as-robot", ["calibrate", "report.html", "ur5.csv", "--out", "m.json"], None, "a robot file must end in .toml or .urdf"),
    ("calibrate-iso-plan", ["calibrate", "ur5", "iso.csv", "--out", "m.json"], None, "neither measured positions nor constraint data"),
    ("calibrate-truth-as-robot", ["calibrate", "ur5_truth.json", "ur5.csv", "--out", "m.json"], None, "a robot file must end in .toml or .urdf"),
    ("calibrate-fixture-as-robot", ["calibrate", "plate.toml", "ur5.csv", "--out", "m.json"], None, "unknown key 'sockets'"),
    ("calibrate-sockets-as-positions", ["calibrate", "kr150-2", "sockets.csv", "--out", "m.json"], None, "has no x, y, z columns"),
    ("calibrate-positions-with-fixture", ["calibrate", "kr150-2", "kr.csv", "--method", "constraint", "--fixture", "plate.toml", "--out", "m.json"], None, "has no fixture and socket columns"),
    ("calibrate-robot-file-as-fixture", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "ur5_cal.toml", "--out", "m.json"], None, "has no [sockets] table"),
    ("calibrate-model-as-fixture", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "sock_model.json", "--out", "m.json"], None, "is not valid TOML"),
    ("frames-from-built-in-name", ["calibrate", "ur5", "ur5.csv", "--method", "frames", "--out", "m.json"], None, "check the path of the model file"),
    ("frames-from-report", ["calibrate", "report.html", "ur5.csv", "--method", "frames", "--out", "m.json"], None, "not a robocal model file"),
    ("evaluate-commands-as-model", ["evaluate", "cmds.csv", "ur5.csv"], None, "not a robocal model file"),
    ("evaluate-commands-as-measurements", ["evaluate", "ur5_model.json", "cmds.csv"], None, "written by 'robocal compensate'"),
    ("evaluate-report-as-model", ["evaluate", "report.html", "ur5.csv"], None, "not a robocal model file"),
    ("evaluate-truth-as-model", ["evaluate", "ur5_truth.json", "ur5.csv"], None, 'no "schema": "robocal.model"'),
    ("evaluate-per-pose-as-measurements", ["evaluate", "ur5_model.json", "perpose.csv"], None, "written by 'robocal evaluate --per-pose'"),
    ("evaluate-plan-as-measurements", ["evaluate", "ur5_model.json", "plan.csv"], None, "written by 'robocal design'"),
    ("evaluate-robot-file-as-model", ["evaluate", "ur5_cal.toml", "ur5.csv"], None, "not a robocal model file"),
    ("evaluate-iso-plan", ["evaluate", "ur5_model.json", "iso.csv"], None, "neither measured positions nor constraint data"),
    ("evaluate-sockets-on-position-model", ["evaluate", "ur5_model.json", "sockets.csv"], None, "stores no fixture"),
    ("evaluate-per-pose-over-its-input", ["evaluate", "ur5_model.json", "ur5.csv", "--per-pose", "ur5.csv"], None, "is also an input of this command"),
    ("compensate-commands-as-targets", ["compensate", "ur5_model.json", "cmds.csv", "--out", "o.csv"], None, "not a targets file"),
    ("compensate-measurements-as-targets", ["compensate", "ur5_model.json", "ur5.csv", "--out", "o.csv"], None, "lacks columns rx, ry, rz"),
    ("compensate-plan-as-targets", ["compensate", "ur5_model.json", "plan.csv", "--out", "o.csv"], None, "written by 'robocal design', not a targets file"),
    ("compensate-per-pose-as-targets", ["compensate", "ur5_model.json", "perpose.csv", "--out", "o.csv"], None, "not a targets file"),
    ("compensate-iso-plan-as-targets", ["compensate", "ur5_model.json", "iso.csv", "--out", "o.csv"], None, "lacks columns x, y, z, rx, ry, rz"),
    ("compensate-report-as-model", ["compensate", "report.html", "targets.csv", "--out", "o.csv"], None, "not a robocal model file"),
    ("compensate-truth-as-model", ["compensate", "ur5_truth.json", "targets.csv", "--out", "o.csv"], None, "not a robocal model file"),
    ("compensate-out-over-targets", ["compensate", "ur5_model.json", "targets.csv", "--out", "targets.csv"], None, "is also an input"),
    ("compensate-out-over-model", ["compensate", "ur5_model.json", "targets.csv", "--out", "ur5_model.json"], None, "names a JSON file"),
    ("report-commands-as-measurements", ["report", "ur5_model.json", "cmds.csv", "--out", "r.html"], None, "written by 'robocal compensate'"),
    ("report-report-as-model", ["report", "report.html", "ur5.csv", "--out", "r.html"], None, "not a robocal model file"),
    ("report-model-as-validation", ["report", "ur5_model.json", "ur5.csv", "--validation", "ur5_model.json", "--out", "r.html"], None, "no 'cross_validation' in it"),
    ("report-report-as-validation", ["report", "ur5_model.json", "ur5.csv", "--validation", "report.html", "--out", "r.html"], None, "not the JSON 'robocal validate --json' prints"),
    ("report-measurements-as-iso", ["report", "ur5_model.json", "ur5.csv", "--iso", "ur5.csv", "--out", "r.html"], None, "lacks columns x_cmd, y_cmd, z_cmd"),
    ("report-commands-as-iso", ["report", "ur5_model.json", "ur5.csv", "--iso", "cmds.csv", "--out", "r.html"], None, "lacks columns x_cmd, y_cmd, z_cmd"),
    ("report-out-over-model", ["report", "ur5_model.json", "ur5.csv", "--out", "ur5_model.json"], None, "names a JSON file"),
    ("export-report", ["export", "report.html", "--out", "e.toml"], None, "not a robocal model file"),
    ("export-truth", ["export", "ur5_truth.json", "--out", "e.toml"], None, "not a robocal model file"),
    ("export-commands", ["export", "cmds.csv", "--out", "e.toml"], None, "not a robocal model file"),
    ("export-robot-file", ["export", "ur5_cal.toml", "--out", "e.toml"], None, "not a robocal model file"),
    ("export-toml-as-urdf-base", ["export", "ur5_model.json", "--format", "urdf", "--urdf", "ur5_cal.toml", "--out", "e.urdf"], None, "is not well-formed XML"),
    ("design-existing-commands", ["design", "ur5", "--n", "5", "--pool", "200", "--existing", "cmds.csv", "--out", "p.csv"], None, "written by 'robocal compensate'"),
    ("design-existing-per-pose", ["design", "ur5", "--n", "5", "--pool", "200", "--existing", "perpose.csv", "--out", "p.csv"], None, "written by 'robocal evaluate --per-pose'"),
    ("design-candidates-model", ["design", "ur5", "--n", "5", "--candidates", "ur5_model.json", "--out", "p.csv"], None, "ur5_model.json is a robocal model file (JSON), not a table"),
    ("design-fixture-model", ["design", "kr150-2", "--n", "6", "--fixture", "sock_model.json", "--region", "1000,1500,-300,300,0,200", "--out", "p.csv"], None, "is not valid TOML"),
    ("design-placements-plan", ["design", "kr150-2", "--n", "6", "--fixture", "plate.toml", "--placements", "plan.csv", "--out", "p.csv"], None, "a placements file gives the fixture frame"),
    ("fleet-plan", ["fleet", "plan.csv", "--out", "F"], None, "is not valid TOML"),
    ("fleet-model", ["fleet", "ur5_model.json", "--out", "F"], None, "is not valid TOML"),
    ("fleet-fixture", ["fleet", "plate.toml", "--out", "F"], None, "a fleet file holds [[robot]] tables only"),
    ("fleet-robot-file", ["fleet", "ur5_cal.toml", "--out", "F"], None, "a fleet file holds [[robot]] tables only"),
    ("simulate-errors-model", ["simulate", "ur5", "--n", "10", "--errors", "ur5_model.json", "--out", "s.csv"], None, "not a robocal truth file"),
    ("simulate-errors-report", ["simulate", "ur5", "--n", "10", "--errors", "report.html", "--out", "s.csv"], None, "--errors must be one of"),
    ("simulate-model-as-robot", ["simulate", "ur5_model.json", "--n", "10", "--out", "s.csv"], None, "a robot file must end in .toml or .urdf"),
    ("simulate-robot-file-as-fixture", ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", "ur5_cal.toml", "--out", "s.csv"], None, "has no [sockets] table"),
    ("iso-measurements", ["iso9283", "ur5.csv"], None, "lacks columns x_cmd, y_cmd, z_cmd"),
    ("iso-commands", ["iso9283", "cmds.csv"], None, "lacks columns x_cmd, y_cmd, z_cmd"),
    ("iso-design-plan", ["iso9283", "plan.csv"], None, "lacks columns x_cmd, y_cmd, z_cmd, x, y, z"),
    ("iso-own-plan-as-campaign", ["iso9283", "iso.csv", "--model", "ur5_model.json"], None, "lacks columns x, y, z"),
    ("validate-commands", ["validate", "ur5", "cmds.csv", "--folds", "3"], None, "written by 'robocal compensate'"),
    ("compare-per-pose", ["compare", "ur5", "perpose.csv"], None, "written by 'robocal evaluate --per-pose'"),
    ("import-plan-as-joint-log", ["import", "--points", "ur5.csv", "--joints", "plan.csv", "--out", "i.csv"], None, "has no name column"),
    ("import-model-as-points", ["import", "--points", "ur5_model.json", "--joints", "ur5.csv", "--out", "i.csv"], None, "ur5_model.json is a robocal model file (JSON), not a table"),
    ("serve-report", ["serve", "report.html", "--port", "0"], None, "not a robocal model file"),
    ("serve-commands", ["serve", "cmds.csv", "--port", "0"], None, "not a robocal model file"),
    # wrong robot
    ("ur5-data-as-ur10", ["calibrate", "ur10", "ur5.csv", "--out", "o.json"], None, "tolerances"),
    ("ur5-data-as-kr150", ["calibrate", "kr150-2", "ur5.csv", "--out", "o.json"], None, "lies beyond joint 2's limits"),
    ("kr150-data-as-ur5", ["calibrate", "ur5", "kr.csv", "--out", "o.json"], None, "explains 0% of the error"),
    ("kr150-data-as-irb120", ["calibrate", "irb120", "kr.csv", "--out", "o.json"], None, "limits -110 to 70 deg of the robot 'ABB IRB 120'"),
    ("kr150-data-as-fanuc", ["calibrate", "fanuc-r2000ic-165f", "kr.csv", "--out", "o.json"], None, "of the robot 'FANUC R-2000iC/165F'"),
    ("ur5-data-as-panda", ["calibrate", "panda", "ur5.csv", "--out", "o.json"], None, "but the robot has 7 joints"),
    ("ur5-data-on-kr150-model", ["evaluate", "kr_model.json", "ur5.csv"], None, "of the robot 'KUKA KR 150-2'"),
    ("ur5-targets-on-kr150-model", ["compensate", "kr_model.json", "targets.csv", "--out", "o.csv"], None, "can be reached by the calibrated robot"),
    ("ur5-data-kr150-report", ["report", "kr_model.json", "ur5.csv", "--out", "r.html"], None, "of the robot 'KUKA KR 150-2'"),
    ("kr150-data-reregistering-ur5", ["calibrate", "ur5_model.json", "kr.csv", "--method", "frames", "--out", "o.json"], None, "explains 0% of the error"),
    ("validate-ur5-data-as-ur10", ["validate", "ur10", "ur5.csv", "--folds", "3"], None, "tolerances"),
    ("kr150-sockets-as-ur5", ["calibrate", "ur5", "sockets.csv", "--method", "constraint", "--fixture", "plate.toml", "--out", "o.json"], None, "these ball"),
    ("kr150-sockets-as-panda", ["calibrate", "panda", "sockets.csv", "--method", "constraint", "--fixture", "plate.toml", "--out", "o.json"], None, "but the robot has 7 joints"),
    ("kr150-data-evaluated-by-ur5-model", ["evaluate", "ur5_model.json", "kr.csv"], None, "explains 0% of the error"),
    ("kr150-data-reported-by-ur5-model", ["report", "ur5_model.json", "kr.csv", "--out", "r.html"], None, "explains 0% of the error"),
    ("ur5-data-evaluated-by-kr150-model", ["evaluate", "kr_model.json", "ur5.csv"], None, "of the robot 'KUKA KR 150-2'"),
    # a model calibrated on ball-in-socket data has no measurement frame to score positions in
    ("tracker-data-on-socket-model", ["evaluate", "sock_model.json", "kr.csv"], None, "calibrated on ball-in-socket data"),
    ("tracker-data-on-socket-model-report", ["report", "sock_model.json", "kr.csv", "--out", "r.html"], None, "calibrated on ball-in-socket data"),
    # targets given as measurements: the shipped example says what it is ...
    ("calibrate-example-targets", ["calibrate", "ur5", "targets.csv", "--out", "m.json"], None, "is a targets file (desired poses"),
    ("evaluate-example-targets", ["evaluate", "ur5_model.json", "targets.csv"], None, "is a targets file (desired poses"),
    ("design-existing-example-targets", ["design", "ur5", "--n", "5", "--pool", "200", "--existing", "targets.csv", "--out", "p.csv"], None, "is a targets file"),
    # ... and positions computed from the joints by the nominal robot, at any written precision, are not measured
    ("calibrate-nominal-fk", ["calibrate", "ur5", "fk.csv", "--out", "m.json"], {"fk.csv": lambda base: nominal_fk(base)}, "the nominal robot's own forward kinematics"),
    ("calibrate-nominal-fk-3-decimals", ["calibrate", "ur5", "fk.csv", "--out", "m.json"], {"fk.csv": lambda base: nominal_fk(base, "{:.3f}")}, "the nominal robot's own forward kinematics"),
    ("calibrate-kriging-nominal-fk", ["calibrate", "ur5", "fk.csv", "--method", "kriging", "--out", "m.json"], {"fk.csv": lambda base: nominal_fk(base)}, "the nominal robot's own forward kinematics"),
    ("calibrate-no-prior-nominal-fk", ["calibrate", "ur5", "fk.csv", "--prior", "none", "--out", "m.json"], {"fk.csv": lambda base: nominal_fk(base)}, "the nominal robot's own forward kinematics"),
    ("evaluate-nominal-fk", ["evaluate", "ur5_model.json", "fk.csv"], {"fk.csv": lambda base: nominal_fk(base)}, "the nominal robot's own forward kinematics"),
    ("validate-nominal-fk", ["validate", "ur5", "fk.csv", "--folds", "3"], {"fk.csv": lambda base: nominal_fk(base)}, "the nominal robot's own forward kinematics"),
]



@pytest.mark.parametrize("args, files, says", [row[1:] for row in REFUSED], ids=[row[0] for row in REFUSED])
def test_own_file_of_the_wrong_kind_is_refused(tmp_path, args, files, says):
    refuse(tmp_path, args, files, says)


def test_a_calibrated_urdf_export_is_a_robot_file(tmp_path):
    """robocal export's URDF given back as the robot: calibrates to what the model did."""
    prepare(tmp_path)
    outcome = invoke(tmp_path, ["calibrate", "ur5_cal.urdf", "ur5.csv", "--out", "again.json"])
    assert outcome.code == 0, outcome.output
    outcome = invoke(tmp_path, ["evaluate", "again.json", "ur5.csv", "--json"])
    assert json.loads(outcome.result.stdout)["mean_mm"] < 0.1



@pytest.mark.parametrize("args, files", [
    (["evaluate", "sock_model.json", "sockets.csv"], None),
    (["evaluate", "kr_model.json", "kr.csv"], None),
    (["report", "ur5_model.json", "ur5.csv", "--out", "r.html"], None),
    (["compensate", "ur5_model.json", "targets.csv", "--out", "o.csv"], None),
    # a robot exactly as its file says, measured with a tracker's noise (0.01 mm): measurements
    (["calibrate", "ur5", "fk.csv", "--out", "m.json"], {"fk.csv": lambda base: nominal_fk(base, noise_mm=0.01)}),
], ids=["sockets-on-socket-model", "kr150-data-on-kr150-model", "report-on-own-robot", "example-targets-as-targets",
        "nominal-robot-measured-with-noise"])
def test_the_right_data_of_the_same_shape_pass(tmp_path, args, files):
    prepare(tmp_path, files)
    outcome = invoke(tmp_path, args)
    assert outcome.code == 0, outcome.output
