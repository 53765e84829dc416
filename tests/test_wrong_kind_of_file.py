# ruff: noqa: E501  (one input per table row)
"""robocal's own files given back to it as the wrong kind (a model as
measurements, compensate's commands as targets, a design plan as a fleet file, a report as a
model...), data of one robot given as another's, and ball-in-socket data given to the position
methods and back. Each row is refused in one line that names what the file is, and nothing
is written."""
import atexit
import csv
import functools
import io
import json
import shutil
import tempfile
from pathlib import Path

import pytest

from user_files import EXAMPLES as EXAMPLES_DIR
from user_files import assert_clean_refusal, invoke, nominal_fk, prepare, refuse
from robocal.io.file_kinds import KIND_COLUMN, KINDS, READERS, identify



def _rows(base, name):
    return list(csv.reader(io.StringIO((base / name).read_text())))


def _text(rows):
    return "\n".join(",".join(row) for row in rows) + "\n"


def unlabelled(name):
    """A file of the base folder without its kind column, as a user's script rewrites it."""
    def make(base):
        rows = _rows(base, name)
        keep = [k for k, column in enumerate(rows[0]) if column != KIND_COLUMN]
        return _text([[row[k] for k in keep] for row in rows])
    return make


def six_d(count, tag=False):
    """ur5.csv's first ``count`` rows with measured orientations: a 6-D measurement file
    (``q1 ... q6, x, y, z, sx, sy, sz, rx, ry, rz``); ``tag``: its columns carry their units."""
    def make(base):
        rows = _rows(base, "ur5.csv")
        header = rows[0] + ["rx", "ry", "rz"]
        if tag:
            header = [f"{name}[{'deg' if name.startswith(('q', 'r')) else 'mm'}]" for name in header]
        return _text([header] + [row + ["178.5", "-1.2", f"{30 + k}"] for k, row in enumerate(rows[1:count + 1])])
    return make


def measured_campaign(base):
    """iso.csv's visits measured 0.1 mm off their commands (x, y, z) and at the commanded
    angles (rx, ry, rz), without the kind column: an ISO 9283 campaign as a user's script writes it."""
    rows = _rows(base, "iso.csv")
    header = rows[0]
    kind = header.index(KIND_COLUMN)
    measured = [header.index(c) for c in ("x_cmd", "y_cmd", "z_cmd", "rx_cmd", "ry_cmd", "rz_cmd")]
    out = [[c for k, c in enumerate(header) if k != kind] + ["x", "y", "z", "rx", "ry", "rz"]]
    for i, row in enumerate(rows[1:]):
        out.append([c for k, c in enumerate(row) if k != kind]
                   + [repr(float(row[k]) + 0.1 * (i % 3) * (j < 3)) for j, k in enumerate(measured)])
    return _text(out)


def measured(change):
    """ur5.csv with ``change(header, rows)`` applied (its cells as text), as a user's script
    mangles a measurement file: columns swapped, negated, renamed, rows out of step."""
    def make(base):
        rows = _rows(base, "ur5.csv")
        header, body = change(rows[0], rows[1:])
        return _text([header] + body)
    return make


def columns_swapped(a, b):
    def change(header, rows):
        i, j = header.index(a), header.index(b)
        return header, [[row[j] if k == i else row[i] if k == j else v for k, v in enumerate(row)] for row in rows]
    return change


def cells_changed(columns, change, rows_from=0, rows_to=None):
    """``change`` applied to the cells of ``columns`` in the data rows rows_from..rows_to."""
    def apply(header, rows):
        idx = [header.index(c) for c in columns]
        return header, [[repr(change(float(v))) if i in idx and rows_from <= k < (rows_to or len(rows)) else v
                         for i, v in enumerate(row)] for k, row in enumerate(rows)]
    return apply


def positions_one_row_late(header, rows):
    """x, y, z (and sx, sy, sz) one row later than their joints: a join off by one."""
    idx = [header.index(c) for c in ("x", "y", "z", "sx", "sy", "sz")]
    moved = rows[1:] + rows[:1]
    return header, [[other[i] if i in idx else v for i, v in enumerate(row)] for row, other in zip(rows, moved)]


def joints_reversed(header, rows):
    return [f"q{7 - int(c[1:])}" if c[:1] == "q" else c for c in header], rows


PLACEMENTS = "fixture,x,y,z,rx,ry,rz\nA,1500,0,300,0,0,0\nB,1400,300,250,0,0,30\n"
UR5_PLACEMENTS = ["design", "ur5", "--fixture", "plate.toml", "--placements", "p.csv", "--n", "12", "--per-socket", "2",
                  "--out", "plan2.csv"]

def renamed(name, suffix):
    """The base file ``name``'s joints and positions x{suffix}, y{suffix}, z{suffix} renamed
    x, y, z (the rest dropped): planned positions passed off as measured."""
    def make(base):
        rows = _rows(base, name)
        keep = [rows[0].index(c) for c in [f"q{k}" for k in range(1, 7)] + [a + suffix for a in "xyz"]]
        return _text([["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z"]] + [[row[k] for k in keep] for row in rows[1:]])
    return make


def joint_changed(column, change):
    """ur5.csv with ``change`` applied to the joint ``column`` (degrees)."""
    def make(base):
        rows = _rows(base, "ur5.csv")
        k = rows[0].index(column)
        return _text([rows[0]] + [[repr(change(float(v))) if i == k else v for i, v in enumerate(row)] for row in rows[1:]])
    return make


def noisy(sigma):
    """ur5.csv with Gaussian noise of ``sigma`` mm on every measured x, y, z (seeded)."""
    def make(base):
        import numpy as np

        rows = _rows(base, "ur5.csv")
        k = [rows[0].index(a) for a in "xyz"]
        rng = np.random.default_rng(7)
        return _text([rows[0]] + [[repr(float(v) + rng.normal(0.0, sigma)) if i in k else v for i, v in enumerate(row)]
                                  for row in rows[1:]])
    return make


REFUSED = [
    # (id, args, extra files, what the error line says)
    # A user's files are told apart by their columns: joint columns beside positions are
    # measurements (or targets with posture hints), never fixture placements ...
    ("placements-6d-measurements", UR5_PLACEMENTS, {"p.csv": six_d(6)}, "p.csv is a measurement file (joint columns q1 ... qN"),
    ("placements-6d-measurements-unit-tagged", UR5_PLACEMENTS, {"p.csv": six_d(6, tag=True)}, "p.csv is a measurement file (joint columns q1 ... qN"),
    ("placements-measurements", UR5_PLACEMENTS, {"p.csv": lambda base: (base / "ur5.csv").read_text()}, "p.csv is a measurement file"),
    ("placements-targets-with-hints-unlabelled", UR5_PLACEMENTS, {"p.csv": unlabelled("targets.csv")}, "p.csv is a measurement file (joint columns q1 ... qN"),
    ("placements-commands-unlabelled", UR5_PLACEMENTS, {"p.csv": unlabelled("cmds.csv")}, "written by 'robocal compensate', not a placements file"),
    ("placements-plan-unlabelled", UR5_PLACEMENTS, {"p.csv": unlabelled("plan.csv")}, "written by 'robocal design', not a placements file"),
    ("placements-measured-campaign", UR5_PLACEMENTS, {"p.csv": measured_campaign}, "p.csv is an ISO 9283 campaign (commanded x_cmd"),
    # ... and a placements file (its fixture column) is no measurement or targets file
    ("calibrate-placements", ["calibrate", "ur5", "pl.csv", "--out", "m.json"], {"pl.csv": PLACEMENTS}, "pl.csv is a placements file (fixture frames"),
    ("evaluate-placements", ["evaluate", "ur5_model.json", "pl.csv"], {"pl.csv": PLACEMENTS}, "pl.csv is a placements file (fixture frames"),
    ("compensate-placements-as-targets", ["compensate", "ur5_model.json", "pl.csv", "--out", "o.csv"], {"pl.csv": PLACEMENTS}, "pl.csv is a placements file (fixture frames"),
    ("design-existing-placements", ["design", "ur5", "--n", "5", "--pool", "200", "--existing", "pl.csv", "--out", "p.csv"], {"pl.csv": PLACEMENTS}, "pl.csv is a placements file"),
    ("iso-placements", ["iso9283", "pl.csv"], {"pl.csv": PLACEMENTS}, "pl.csv is a placements file"),
    # a campaign's x, y, z were measured, not desired
    ("compensate-measured-campaign-as-targets", ["compensate", "ur5_model.json", "c.csv", "--out", "o.csv"], {"c.csv": measured_campaign}, "c.csv is an ISO 9283 campaign"),
    ("calibrate-commands", ["calibrate", "ur5", "cmds.csv", "--out", "m.json"], None, "written by 'robocal compensate', not a measurement file"),
    ("calibrate-per-pose", ["calibrate", "ur5", "perpose.csv", "--out", "m.json"], None, "written by 'robocal evaluate --per-pose'"),
    ("calibrate-plan", ["calibrate", "ur5", "plan.csv", "--out", "m.json"], None, "planned poses, written by 'robocal design'"),
    ("calibrate-model-as-robot", ["calibrate", "ur5_model.json", "ur5.csv", "--out", "m.json"], None, "is a robocal model file, written by 'robocal calibrate', not a robot file"),
    ("calibrate-report-as-robot", ["calibrate", "report.html", "ur5.csv", "--out", "m.json"], None, "is robocal's HTML report, written by 'robocal report', not a robot file"),
    ("calibrate-iso-plan", ["calibrate", "ur5", "iso.csv", "--out", "m.json"], None, "written by 'robocal iso9283 plan', not a measurement file"),
    ("calibrate-truth-as-robot", ["calibrate", "ur5_truth.json", "ur5.csv", "--out", "m.json"], None, "written by 'robocal simulate --truth', not a robot file"),
    ("calibrate-fixture-as-robot", ["calibrate", "plate.toml", "ur5.csv", "--out", "m.json"], None, "is a fixture file (socket centres), not a robot file"),
    ("calibrate-sockets-as-positions", ["calibrate", "kr150-2", "sockets.csv", "--out", "m.json"], None, "has no x, y, z columns"),
    ("calibrate-positions-with-fixture", ["calibrate", "kr150-2", "kr.csv", "--method", "constraint", "--fixture", "plate.toml", "--out", "m.json"], None, "has no fixture and socket columns"),
    ("calibrate-robot-file-as-fixture", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "ur5_cal.toml", "--out", "m.json"], None, "written by 'robocal export', not a fixture file"),
    ("calibrate-model-as-fixture", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "sock_model.json", "--out", "m.json"], None, "is a robocal model file, written by 'robocal calibrate', not a fixture file"),
    ("frames-from-built-in-name", ["calibrate", "ur5", "ur5.csv", "--method", "frames", "--out", "m.json"], None, "check the path of the model file"),
    ("frames-from-report", ["calibrate", "report.html", "ur5.csv", "--method", "frames", "--out", "m.json"], None, "is robocal's HTML report, written by 'robocal report', not a model file"),
    ("evaluate-commands-as-model", ["evaluate", "cmds.csv", "ur5.csv"], None, "written by 'robocal compensate', not a model file"),
    ("evaluate-commands-as-measurements", ["evaluate", "ur5_model.json", "cmds.csv"], None, "written by 'robocal compensate'"),
    ("evaluate-report-as-model", ["evaluate", "report.html", "ur5.csv"], None, "written by 'robocal report', not a model file"),
    ("evaluate-truth-as-model", ["evaluate", "ur5_truth.json", "ur5.csv"], None, "written by 'robocal simulate --truth', not a model file"),
    ("evaluate-per-pose-as-measurements", ["evaluate", "ur5_model.json", "perpose.csv"], None, "written by 'robocal evaluate --per-pose'"),
    ("evaluate-plan-as-measurements", ["evaluate", "ur5_model.json", "plan.csv"], None, "written by 'robocal design'"),
    ("evaluate-robot-file-as-model", ["evaluate", "ur5_cal.toml", "ur5.csv"], None, "written by 'robocal export', not a model file"),
    ("evaluate-iso-plan", ["evaluate", "ur5_model.json", "iso.csv"], None, "written by 'robocal iso9283 plan', not a measurement file"),
    ("evaluate-sockets-on-position-model", ["evaluate", "ur5_model.json", "sockets.csv"], None, "stores no fixture"),
    ("evaluate-per-pose-over-its-input", ["evaluate", "ur5_model.json", "ur5.csv", "--per-pose", "ur5.csv"], None, "is also an input of this command"),
    ("compensate-commands-as-targets", ["compensate", "ur5_model.json", "cmds.csv", "--out", "o.csv"], None, "not a targets file"),
    ("compensate-measurements-as-targets", ["compensate", "ur5_model.json", "ur5.csv", "--out", "o.csv"], None, "lacks columns rx, ry, rz"),
    ("compensate-plan-as-targets", ["compensate", "ur5_model.json", "plan.csv", "--out", "o.csv"], None, "written by 'robocal design', not a targets file"),
    ("compensate-per-pose-as-targets", ["compensate", "ur5_model.json", "perpose.csv", "--out", "o.csv"], None, "not a targets file"),
    ("compensate-iso-plan-as-targets", ["compensate", "ur5_model.json", "iso.csv", "--out", "o.csv"], None, "written by 'robocal iso9283 plan', not a targets file"),
    ("compensate-report-as-model", ["compensate", "report.html", "targets.csv", "--out", "o.csv"], None, "written by 'robocal report', not a model file"),
    ("compensate-truth-as-model", ["compensate", "ur5_truth.json", "targets.csv", "--out", "o.csv"], None, "written by 'robocal simulate --truth', not a model file"),
    ("compensate-out-over-targets", ["compensate", "ur5_model.json", "targets.csv", "--out", "targets.csv"], None, "is also an input"),
    ("compensate-out-over-model", ["compensate", "ur5_model.json", "targets.csv", "--out", "ur5_model.json"], None, "names a JSON file"),
    ("report-commands-as-measurements", ["report", "ur5_model.json", "cmds.csv", "--out", "r.html"], None, "written by 'robocal compensate'"),
    ("report-report-as-model", ["report", "report.html", "ur5.csv", "--out", "r.html"], None, "written by 'robocal report', not a model file"),
    ("report-model-as-validation", ["report", "ur5_model.json", "ur5.csv", "--validation", "ur5_model.json", "--out", "r.html"], None, "is a robocal model file, written by 'robocal calibrate', not a validation file"),
    ("report-report-as-validation", ["report", "ur5_model.json", "ur5.csv", "--validation", "report.html", "--out", "r.html"], None, "written by 'robocal report', not a validation file"),
    ("report-measurements-as-iso", ["report", "ur5_model.json", "ur5.csv", "--iso", "ur5.csv", "--out", "r.html"], None, "lacks columns x_cmd, y_cmd, z_cmd"),
    ("report-commands-as-iso", ["report", "ur5_model.json", "ur5.csv", "--iso", "cmds.csv", "--out", "r.html"], None, "written by 'robocal compensate', not an ISO 9283 campaign"),
    ("report-out-over-model", ["report", "ur5_model.json", "ur5.csv", "--out", "ur5_model.json"], None, "names a JSON file"),
    ("export-report", ["export", "report.html", "--out", "e.toml"], None, "written by 'robocal report', not a model file"),
    ("export-truth", ["export", "ur5_truth.json", "--out", "e.toml"], None, "written by 'robocal simulate --truth', not a model file"),
    ("export-commands", ["export", "cmds.csv", "--out", "e.toml"], None, "written by 'robocal compensate', not a model file"),
    ("export-robot-file", ["export", "ur5_cal.toml", "--out", "e.toml"], None, "written by 'robocal export', not a model file"),
    ("export-toml-as-urdf-base", ["export", "ur5_model.json", "--format", "urdf", "--urdf", "ur5_cal.toml", "--out", "e.urdf"], None, "written by 'robocal export', not a URDF file"),
    ("design-existing-commands", ["design", "ur5", "--n", "5", "--pool", "200", "--existing", "cmds.csv", "--out", "p.csv"], None, "written by 'robocal compensate'"),
    ("design-existing-per-pose", ["design", "ur5", "--n", "5", "--pool", "200", "--existing", "perpose.csv", "--out", "p.csv"], None, "written by 'robocal evaluate --per-pose'"),
    ("design-candidates-model", ["design", "ur5", "--n", "5", "--candidates", "ur5_model.json", "--out", "p.csv"], None, "is a robocal model file, written by 'robocal calibrate', not a CSV table"),
    ("design-fixture-model", ["design", "kr150-2", "--n", "6", "--fixture", "sock_model.json", "--region", "1000,1500,-300,300,0,200", "--out", "p.csv"], None, "written by 'robocal calibrate', not a fixture file"),
    ("design-placements-plan", ["design", "kr150-2", "--n", "6", "--fixture", "plate.toml", "--placements", "plan.csv", "--out", "p.csv"], None, "written by 'robocal design', not a placements file"),
    ("show-model-as-robot", ["show", "ur5_model.json"], None, "is a robocal model file, written by 'robocal calibrate', not a robot file"),
    ("design-model-as-robot", ["design", "ur5_model.json", "--n", "12", "--pool", "200", "--out", "p.csv"], None, "is a robocal model file, written by 'robocal calibrate', not a robot file"),
    ("design-fixture-as-placements", ["design", "kr150-2", "--n", "12", "--fixture", "plate.toml", "--placements", "plate.toml", "--out", "p.csv"], None, "plate.toml is a fixture file (socket centres), not a CSV table"),
    ("design-robot-file-as-fixture", ["design", "kr150-2", "--n", "12", "--fixture", "ur5_cal.toml", "--region", "1000,1500,-300,300,0,200", "--out", "p.csv"], None, "written by 'robocal export', not a fixture file"),
    ("validate-example-targets", ["validate", "ur5", "targets.csv", "--folds", "3"], None, "is a targets file (desired poses"),
    ("fleet-plan", ["fleet", "plan.csv", "--out", "F"], None, "written by 'robocal design', not a fleet file"),
    ("fleet-model", ["fleet", "ur5_model.json", "--out", "F"], None, "written by 'robocal calibrate', not a fleet file"),
    ("fleet-fixture", ["fleet", "plate.toml", "--out", "F"], None, "is a fixture file (socket centres), not a fleet file"),
    ("fleet-robot-file", ["fleet", "ur5_cal.toml", "--out", "F"], None, "written by 'robocal export', not a fleet file"),
    ("simulate-errors-model", ["simulate", "ur5", "--n", "10", "--errors", "ur5_model.json", "--out", "s.csv"], None, "written by 'robocal calibrate', not a truth file"),
    ("simulate-errors-report", ["simulate", "ur5", "--n", "10", "--errors", "report.html", "--out", "s.csv"], None, "written by 'robocal report', not a truth file"),
    ("simulate-model-as-robot", ["simulate", "ur5_model.json", "--n", "10", "--out", "s.csv"], None, "written by 'robocal calibrate', not a robot file"),
    ("simulate-robot-file-as-fixture", ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", "ur5_cal.toml", "--out", "s.csv"], None, "written by 'robocal export', not a fixture file"),
    ("iso-measurements", ["iso9283", "ur5.csv"], None, "lacks columns x_cmd, y_cmd, z_cmd"),
    ("iso-commands", ["iso9283", "cmds.csv"], None, "written by 'robocal compensate', not an ISO 9283 campaign"),
    ("iso-design-plan", ["iso9283", "plan.csv"], None, "written by 'robocal design', not an ISO 9283 campaign"),
    ("iso-own-plan-as-campaign", ["iso9283", "iso.csv", "--model", "ur5_model.json"], None, "lacks columns x, y, z"),
    ("validate-commands", ["validate", "ur5", "cmds.csv", "--folds", "3"], None, "written by 'robocal compensate'"),
    ("compare-per-pose", ["compare", "ur5", "perpose.csv"], None, "written by 'robocal evaluate --per-pose'"),
    ("import-plan-as-joint-log", ["import", "--points", "ur5.csv", "--joints", "plan.csv", "--out", "i.csv"], None, "written by 'robocal design', not a joint log"),
    # The joint log's kind is named before the points are judged (their units here).
    ("import-commands-as-joint-log-tiny-points", ["import", "--points", "tiny.txt", "--joints", "cmds.csv", "--out", "i.csv"], {"tiny.txt": "P1 1 2 3\n"}, "written by 'robocal compensate', not a joint log"),
    ("import-model-as-points", ["import", "--points", "ur5_model.json", "--joints", "ur5.csv", "--out", "i.csv"], None, "written by 'robocal calibrate', not a tracker point file"),
    ("serve-report", ["serve", "report.html", "--port", "0"], None, "written by 'robocal report', not a model file"),
    ("serve-commands", ["serve", "cmds.csv", "--port", "0"], None, "written by 'robocal compensate', not a model file"),
    # wrong robot
    ("ur5-data-as-ur10", ["calibrate", "ur10", "ur5.csv", "--out", "o.json"], None, "tolerances"),
    ("ur5-data-as-kr150", ["calibrate", "kr150-2", "ur5.csv", "--out", "o.json"], None, "lies beyond joint 2's limits"),
    ("kr150-data-as-ur5", ["calibrate", "ur5", "kr.csv", "--out", "o.json"], None, "explains 0% of the error"),
    ("joint-2-counted-the-other-way", ["calibrate", "ur5", "f.csv", "--out", "o.json"], {"f.csv": joint_changed("q2", lambda v: -v)}, "explains 0% of the error"),
    ("joint-2-zero-90-deg-off", ["calibrate", "ur5", "f.csv", "--out", "o.json"], {"f.csv": joint_changed("q2", lambda v: v + 90)}, "lies beyond joint 2's limits"),
    ("positions-with-50-mm-noise", ["calibrate", "ur5", "f.csv", "--out", "o.json"], {"f.csv": noisy(50.0)}, "explains 0% of the error"),
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
    # a plan's or ISO plan's nominal positions renamed x, y, z are no measurements either
    ("calibrate-design-plan-renamed-measured", ["calibrate", "ur5", "fk.csv", "--out", "m.json"], {"fk.csv": renamed("plan.csv", "_nominal")}, "the nominal robot's own forward kinematics"),
    ("evaluate-iso-plan-renamed-measured", ["evaluate", "ur5_model.json", "fk.csv"], {"fk.csv": renamed("iso.csv", "_cmd")}, "the nominal robot's own forward kinematics"),
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
    # hostile pass 5 (class 1): robocal's own files given back under another guise
    ("calibrate-commands-kind-column-renamed", ["calibrate", "ur5", "f.csv", "--out", "m.json"], {"f.csv": lambda base: (base / "cmds.csv").read_text().replace(",robocal_file\n", ",kind\n", 1)}, "written by 'robocal compensate', not a measurement file"),
    ("calibrate-kriging-commands-unlabelled", ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "m.json"], {"f.csv": unlabelled("cmds.csv")}, "written by 'robocal compensate', not a measurement file"),
    ("compare-commands", ["compare", "ur5", "cmds.csv", "--folds", "3", "--no-network"], None, "written by 'robocal compensate', not a measurement file"),
    ("report-per-pose-as-measurements", ["report", "ur5_model.json", "perpose.csv", "--out", "r.html"], None, "written by 'robocal evaluate --per-pose', not a measurement file"),
    ("calibrate-per-pose-measured-renamed-x", ["calibrate", "ur5", "f.csv", "--out", "m.json"], {"f.csv": lambda base: (base / "perpose.csv").read_text().replace("x_measured,y_measured,z_measured", "x,y,z", 1)}, "written by 'robocal evaluate --per-pose', not a measurement file"),
    ("design-existing-iso-plan", ["design", "ur5", "--n", "5", "--pool", "300", "--existing", "iso.csv", "--out", "p.csv"], None, "written by 'robocal iso9283 plan', not a file of measured poses"),
    ("design-placements-iso-plan", ["design", "kr150-2", "--fixture", "plate.toml", "--placements", "iso.csv", "--n", "12", "--out", "p.csv"], None, "written by 'robocal iso9283 plan', not a placements file"),
    ("design-candidates-iso-plan", ["design", "ur5", "--candidates", "iso.csv", "--n", "6", "--out", "p.csv"], None, "written by 'robocal iso9283 plan', not a file of candidates"),
    ("compensate-ur-yaml-as-model", ["compensate", "k.yaml", "targets.csv", "--out", "c.csv"], {"k.yaml": "kinematics:\n  shoulder:\n    x: 0\n    y: 0\n    z: 0.089159\n  hash: calib_1\n"}, "k.yaml: not a robocal model file (not JSON"),
    ("filter-report-renamed-as-program", ["filter", "ur5_model.json", "r.script", "--out", "FO"], {"r.script": lambda base: (base / "report.html").read_text(), "FO/x": ""}, "no motion found in r.script: is it a URScript program?"),
    # hostile pass 5 (class 9): the right robot's data mangled, another robot's data
    ("positions-one-row-late", ["calibrate", "ur5", "f.csv", "--out", "m.json"], {"f.csv": measured(positions_one_row_late)}, "explains 0% of the error"),
    ("x-and-y-swapped", ["calibrate", "ur5", "f.csv", "--out", "m.json"], {"f.csv": measured(columns_swapped("x", "y"))}, "explains 0% of the error"),
    ("validate-z-negated", ["validate", "ur5", "f.csv", "--folds", "3"], {"f.csv": measured(cells_changed(["z"], lambda v: -v))}, "explains 0% of the error"),
    ("kriging-q3-counted-the-other-way", ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "m.json"], {"f.csv": measured(cells_changed(["q3"], lambda v: -v))}, "explains 0% of the error"),
    ("joint-columns-reversed", ["calibrate", "ur5", "f.csv", "--out", "m.json"], {"f.csv": measured(joints_reversed)}, "explains 0% of the error"),
    ("q1-turned-by-180", ["calibrate", "ur5", "f.csv", "--out", "m.json"], {"f.csv": measured(cells_changed(["q1"], lambda v: v + 180))}, "lies beyond joint 1's limits -360 to 360 deg"),
    ("ur5-data-as-irb120-hybrid", ["calibrate", "irb120", "ur5.csv", "--method", "hybrid", "--out", "m.json"], None, "lies beyond joint 2's limits -110 to 110 deg of the robot 'ABB IRB 120'"),
    ("kr150-sockets-validated-as-fanuc", ["validate", "fanuc-r2000ic-165f", "sockets.csv", "--method", "constraint", "--fixture", "plate.toml"], None, "of the robot 'FANUC R-2000iC/165F'"),
    ("ur5-truth-simulated-as-irb120", ["simulate", "irb120", "--n", "10", "--errors", "ur5_truth.json", "--out", "s.csv"], None, "ur5_truth.json describes the robot 'Universal Robots UR5', not 'ABB IRB 120'"),
    ("kriging-five-rows-in-metres", ["calibrate", "ur5", "f.csv", "--method", "kriging", "--out", "m.json"], {"f.csv": measured(cells_changed(["x", "y", "z"], lambda v: v / 1000, 0, 5))}, "the calibration cannot explain these data: rows"),
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


# --------------------------------------------------------------------------------------------
# Every kind of file robocal writes x every reader, generated from robocal.io.file_kinds: a new
# kind or a new reader is in this table as soon as it is in KINDS or READERS (and the two
# tests below fail until it has an example file and a command).

def _run_to_file(base, name, args):
    """A robocal command's stdout (its --json) saved as ``name`` in the folder ``base``."""
    outcome = invoke(base, args)
    assert outcome.code == 0, outcome.output
    (base / name).write_text(outcome.result.stdout)


def _iso_campaign(base):
    """The ISO plan with every pose measured 0.1 mm off its command: a campaign."""
    lines = (base / "iso.csv").read_text().splitlines()
    header = lines[0].split(",")
    cmd = [header.index(c) for c in ("x_cmd", "y_cmd", "z_cmd")]
    rows = [line.split(",") for line in lines[1:]]
    (base / "campaign.csv").write_text("\n".join([lines[0] + ",x,y,z"] + [
        ",".join(row + [repr(float(row[k]) + 0.1 * (i % 3)) for k in cmd]) for i, row in enumerate(rows)]) + "\n")
    outcome = invoke(base, ["iso9283", "campaign.csv", "--report", "iso.html"])
    assert outcome.code == 0, outcome.output


def _fleet_summary(base):
    from robocal.interfaces.fleet import SUMMARY_COLUMNS, write_summary

    row = dict.fromkeys(SUMMARY_COLUMNS, "")
    row.update(name="cell-1", status="ok", method="kinematic", n_train=60, n_test=0, mean_mm=0.1, max_mm=0.3)
    (base / "fleet").mkdir()
    write_summary(base / "fleet", [row], "fleet.toml")


def _filter_summary(base):
    from robocal.interfaces.filter import _summary

    (base / "filter-summary.csv").write_text(_summary([["pick.script", 3, "p1", "filtered", "0.12", "0.01", "1",
                                                        "0.3"]]))


# kind -> (how to make it in a folder holding user_files.base_files' files, the file it is)
EXAMPLES = {
    "commands": (None, "cmds.csv"),
    "poses": (None, "plan.csv"),
    "evaluation": (None, "perpose.csv"),
    "fleet-summary": (_fleet_summary, "fleet/summary.csv"),
    "iso-plan": (None, "iso.csv"),
    "filter-summary": (_filter_summary, "filter-summary.csv"),
    "targets": (None, "targets.csv"),
    "model": (None, "ur5_model.json"),
    "truth": (None, "ur5_truth.json"),
    "validation": (lambda base: _run_to_file(base, "val.json", ["validate", "ur5", "ur5.csv", "--folds", "3", "--json"]),
                   "val.json"),
    "evaluation-json": (lambda base: _run_to_file(base, "eval.json", ["evaluate", "ur5_model.json", "ur5.csv", "--json"]),
                        "eval.json"),
    "report": (None, "report.html"),
    "iso-page": (_iso_campaign, "iso.html"),
    "fleet-page": (_fleet_summary, "fleet/summary.html"),
    "robot": (None, "ur5_cal.toml"),
    "urdf": (None, "ur5_cal.urdf"),
    "fixture": (None, "plate.toml"),
    "fleet": (lambda base: shutil.copy(EXAMPLES_DIR / "fleet" / "fleet.toml", base / "fleet.toml"), "fleet.toml"),
}
# A user's kinds, written unmarked (simulated measurements too: a measurement file is what a
# user gives), recognised by their columns: kind -> (how to make it, the file it is).
USERS = {
    "measurements": (None, "ur5.csv"),
    "campaign": (lambda base: (base / "user-campaign.csv").write_text(measured_campaign(base)), "user-campaign.csv"),
    "placements": (lambda base: (base / "placements.csv").write_text(PLACEMENTS), "placements.csv"),
}
UNMARKED = set(USERS)
SUFFIX = {"CSV": ".csv", "JSON": ".json", "HTML": ".html", "TOML": ".toml", "XML": ".urdf"}

# reader -> a command that reads the file F as it (a user's hand-made files beside it)
READS = {
    "measurements": ["calibrate", "ur5", "F", "--out", "m.json"],
    "targets": ["compensate", "ur5_model.json", "F", "--out", "c.csv"],
    "configurations": ["design", "ur5", "--n", "8", "--pool", "200", "--existing", "F", "--out", "p.csv"],
    "campaign": ["iso9283", "F"],
    "joint-log": ["import", "--points", "points.txt", "--joints", "F", "--out", "i.csv"],
    "points": ["import", "--points", "F", "--joints", "joints.csv", "--out", "i.csv"],
    "placements": ["design", "kr150-2", "--n", "12", "--fixture", "plate.toml", "--placements", "F", "--out", "p.csv"],
    "model": ["evaluate", "F", "ur5.csv"],
    "truth": ["simulate", "ur5", "--n", "10", "--errors", "F", "--out", "s.csv"],
    "validation": ["report", "ur5_model.json", "ur5.csv", "--validation", "F", "--out", "r.html"],
    "robot": ["calibrate", "F", "ur5.csv", "--out", "m.json"],
    "urdf": ["export", "ur5_model.json", "--format", "urdf", "--urdf", "F", "--out", "o.urdf"],
    "fixture": ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "F", "--out", "m.json"],
    "fleet": ["fleet", "F", "--out", "fl"],
}
HAND_MADE = {"points.txt": "# mm\nP1 500 100 300\nP2 400 -100 350\n",
             "joints.csv": "name,q1,q2,q3,q4,q5,q6\nP1,0,-90,90,0,90,0\nP2,10,-80,80,0,90,0\n"}


@functools.cache
def examples():
    """A read-only folder of one file of every kind, made as a user makes them."""
    base = Path(tempfile.mkdtemp(prefix="robocal-kinds-"))
    atexit.register(shutil.rmtree, base, True)
    prepare(base)
    for make in dict.fromkeys(make for make, _ in {**EXAMPLES, **USERS}.values() if make is not None):
        make(base)
    return base


def test_every_kind_robocal_writes_has_an_example():
    assert set(EXAMPLES) == set(KINDS) - UNMARKED
    assert set(USERS) == {kind.name for kind in KINDS.values() if kind.columns and not kind.written_by} - {"targets"}


def test_every_reader_has_a_command():
    assert set(READS) == set(READERS)


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_each_file_robocal_writes_says_its_kind(kind):
    text = (examples() / EXAMPLES[kind][1]).read_text()
    assert identify(text) == kind
    if KINDS[kind].form == "CSV":  # in its own column, not only by its columns
        assert text.splitlines()[0].split(",")[-1] == KIND_COLUMN


@pytest.mark.parametrize("kind", sorted(USERS))
def test_a_users_file_is_recognised_by_its_columns(kind):
    text = (examples() / USERS[kind][1]).read_text()
    assert KIND_COLUMN not in text.splitlines()[0]
    assert identify(text) == kind


EVERY = {**EXAMPLES, **USERS}
WRONG = [(kind, reader) for kind in sorted(EVERY) for reader in READERS if kind not in READERS[reader].accepts]


@pytest.mark.parametrize("kind, reader", WRONG, ids=[f"{kind}-as-{reader}" for kind, reader in WRONG])
def test_every_reader_refuses_every_other_kind_naming_it(tmp_path, kind, reader):
    name = "F" + SUFFIX[KINDS[kind].form]
    prepare(tmp_path, {**HAND_MADE, name: (examples() / EVERY[kind][1]).read_bytes()})
    outcome = invoke(tmp_path, [name if arg == "F" else arg for arg in READS[reader]])
    assert_clean_refusal(outcome, f"{name} is {KINDS[kind].what}")
    assert "not a" in outcome.lines[0], outcome.lines[0]


GOOD = [
    # (id, reader, the file's name, its content: text, or a callable of the base folder)
    ("user-measurements", "measurements", "F.csv", lambda base: nominal_fk(base, noise_mm=0.01)),
    ("user-targets", "targets", "F.csv", "x,y,z,rx,ry,rz\n-400,-150,300,180,0,0\n-350,100,350,180,0,90\n"),
    ("shipped-targets", "targets", "F.csv", (EXAMPLES_DIR / "ur5-targets.csv").read_text()),
    ("user-configurations", "configurations", "F.csv", "q1,q2,q3,q4,q5,q6\n0,-90,90,0,90,0\n30,-60,60,10,80,0\n"),
    ("design-poses-as-configurations", "configurations", "F.csv", lambda base: (base / "plan.csv").read_text()),
    ("user-joint-log", "joint-log", "F.csv", HAND_MADE["joints.csv"]),
    ("user-points", "points", "F.txt", HAND_MADE["points.txt"]),
    ("user-placements", "placements", "F.csv", PLACEMENTS),
    ("user-placements-unnamed", "placements", "F.csv", "x,y,z,rx,ry,rz\n1500,0,300,0,0,0\n1400,300,250,0,0,30\n"),
    ("user-targets-with-hints", "targets", "F.csv", unlabelled("targets.csv")),
    ("user-campaign", "campaign", "F.csv", measured_campaign),
    ("iso-plan-measured", "campaign", "F.csv", lambda base: (examples() / "campaign.csv").read_text()),
    ("model", "model", "F.json", lambda base: (base / "ur5_model.json").read_text()),
    ("truth", "truth", "F.json", lambda base: (base / "ur5_truth.json").read_text()),
    ("validation", "validation", "F.json", lambda base: (examples() / "val.json").read_text()),
    ("exported-robot-toml", "robot", "F.toml", lambda base: (base / "ur5_cal.toml").read_text()),
    ("exported-urdf", "robot", "F.urdf", lambda base: (base / "ur5_cal.urdf").read_text()),
    ("shipped-fixture", "fixture", "F.toml", (EXAMPLES_DIR / "plate-fixture.toml").read_text()),
]


@pytest.mark.parametrize("reader, name, content", [row[1:] for row in GOOD], ids=[row[0] for row in GOOD])
def test_each_reader_still_reads_its_own_kind_and_users_files(tmp_path, reader, name, content):
    prepare(tmp_path, {**HAND_MADE, name: content})
    outcome = invoke(tmp_path, [name if arg == "F" else arg for arg in READS[reader]])
    assert outcome.code == 0, outcome.output
