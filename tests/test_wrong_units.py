# ruff: noqa: E501  (one input per table row)
"""Wrong units on the numbers a user types or a file carries: metres, cm,
inches or micrometres for mm, radians for degrees, in CSV columns, options (--box, --tool,
--rpy, --hint, --tracker, --walls, --region), fixture spacings and robot files. Untagged, each
is refused in one line naming the unit it looks like; tagged in the header (x[m], q1[rad]),
it gives the same answer as the file in mm and degrees."""
import atexit
import csv
import functools
import io
import json
import math
import shutil
import tempfile
from pathlib import Path

import pytest

from user_files import EXAMPLES, campaign, invoke, prepare, refuse, text

Q = [f"q{i}" for i in range(1, 7)]
XYZ = ["x", "y", "z"]
RPY = ["rx", "ry", "rz"]
SXYZ = ["sx", "sy", "sz"]


def scaled(name, columns, factor, unit=None, keep=None):
    """The base file ``name`` (or an example, ``examples/NAME``; ``six-d``: a simulated UR5's
    measurements with orientations) with ``columns`` multiplied by ``factor`` (and tagged
    [unit]); ``keep``: only these columns (and robocal_file)."""
    def make(base):
        if name == "six-d":
            source = six_d_text()
        else:
            source = (EXAMPLES / name[len("examples/"):] if name.startswith("examples/") else base / name).read_text()
        rows = list(csv.reader(io.StringIO(source)))
        if keep is not None:
            chosen = [i for i, c in enumerate(rows[0]) if c in keep or c == "robocal_file"]
            rows = [[row[i] for i in chosen] for row in rows]
        header = rows[0]
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow([f"{c}[{unit}]" if unit and c in columns else c for c in header])
        for row in rows[1:]:
            writer.writerow([repr(float(v) * factor) if header[i] in columns else v for i, v in enumerate(row)])
        return out.getvalue()
    return make


@functools.cache
def six_d_text():
    """A simulated UR5's measurements with rx, ry, rz (deg), made once per run."""
    folder = Path(tempfile.mkdtemp(prefix="robocal-six-d-"))
    atexit.register(shutil.rmtree, folder, True)
    outcome = invoke(folder, ["simulate", "ur5", "--n", "60", "--orientation", "--seed", "4", "--out", "six.csv"])
    assert outcome.code == 0, outcome.output
    return (folder / "six.csv").read_text()


FIX_M = 'name = "plate m"\n[sockets]\nA = [0.0, 0.0, 0.0]\nB = [0.15, 0.0, 0.0]\nC = [0.0, 0.12, 0.0]\n'


def robot_in_metres(base):
    import re
    return re.sub(r"(\n[ad] = )(-?[0-9.]+)", lambda m: m.group(1) + str(float(m.group(2)) / 1000),
                  (base / "ur5_cal.toml").read_text())


def robot_limits_in_radians(base):
    return (base / "ur5_cal.toml").read_text().replace("min = -360.0", "min = -6.283").replace("max = 360.0", "max = 6.283")


BOX = ["--box", "-400,400,-400,-100,100,500"]
REFUSED = [
    ("measurements-metres", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 1e-3)}, "they look like metres"),
    ("measurements-cm", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 0.1)}, "they look like cm"),
    ("measurements-inches", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 1 / 25.4)}, "they look like inches"),
    ("measurements-micrometres", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 1000)}, "they look like micrometres"),
    ("measurements-mm-tagged-metres", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 1, "m")}, "they look like micrometres"),
    ("joints-degrees-tagged-radians", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", Q, 1, "rad")}, "lies beyond joint 1's limits"),
    ("unknown-unit-tag", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 1, "furlong")}, "has the unit 'furlong', which robocal does not know"),
    ("evaluate-metres", ["evaluate", "ur5_model.json", "m.csv"], {"m.csv": scaled("ur5.csv", XYZ, 1e-3)}, "they look like metres"),
    ("report-metres", ["report", "ur5_model.json", "m.csv", "--out", "r.html"], {"m.csv": scaled("ur5.csv", XYZ, 1e-3)}, "they look like metres"),
    ("validate-metres", ["validate", "ur5", "m.csv", "--folds", "3"], {"m.csv": scaled("ur5.csv", XYZ, 1e-3)}, "they look like metres"),
    ("targets-metres", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", XYZ, 1e-3)}, "they look like metres"),
    ("targets-metres-no-hints", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", XYZ, 1e-3, keep=XYZ + RPY)}, "they look like metres"),
    ("targets-inches-with-hints", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", XYZ, 1 / 25.4)}, "they look like inches"),
    ("kr-targets-metres", ["compensate", "kr_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("examples/kr150-targets.csv", XYZ, 1e-3)}, "they look like metres"),
    ("design-targets-metres", ["design", "ur5", "--n", "5", "--pool", "300", "--targets", "t.csv", "--out", "p.csv"], {"t.csv": scaled("targets.csv", XYZ, 1e-3, keep=XYZ + RPY)}, "they look like metres"),
    ("measurements-wrist-radians", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", Q[3:], math.pi / 180)}, "the joint values q4..q6 look like radians"),
    ("measurements-shoulder-elbow-radians", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", Q[1:3], math.pi / 180)}, "the joint values q2, q3 look like radians"),
    ("evaluate-wrist-radians", ["evaluate", "ur5_model.json", "m.csv"], {"m.csv": scaled("ur5.csv", Q[3:], math.pi / 180)}, "the joint values q4..q6 look like radians"),
    ("targets-hint-wrist-radians", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", Q[3:], math.pi / 180)}, "the posture hints q4..q6 look like radians"),
    ("targets-hint-one-joint-radians", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", ["q5"], math.pi / 180)}, "the posture hints q5 look like radians"),
    ("kr-targets-seed-hint-radians", ["compensate", "kr_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("examples/kr150-targets.csv", Q, math.pi / 180)}, "the posture hints q1..q6 look like radians"),
    ("kr-targets-seed-hint-radians-iterate", ["compensate", "kr_model.json", "t.csv", "--out", "o.csv", "--iterate"], {"t.csv": scaled("examples/kr150-targets.csv", Q, math.pi / 180)}, "the posture hints q1..q6 look like radians"),
    ("measurements-orientation-radians", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("six-d", RPY, math.pi / 180)}, "the measured rx, ry, rz of m.csv look like radians"),
    ("validate-orientation-radians", ["validate", "ur5", "m.csv", "--folds", "3"], {"m.csv": scaled("six-d", RPY, math.pi / 180)}, "the measured rx, ry, rz of m.csv look like radians"),
    ("evaluate-orientation-radians", ["evaluate", "ur5_model.json", "m.csv"], {"m.csv": scaled("six-d", RPY, math.pi / 180)}, "the measured rx, ry, rz of m.csv look like radians"),
    ("compare-orientation-radians", ["compare", "ur5", "m.csv", "--folds", "3"], {"m.csv": scaled("six-d", RPY, math.pi / 180)}, "the measured rx, ry, rz of m.csv look like radians"),
    ("targets-orientation-radians", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", RPY, math.pi / 180)}, "look like radians"),
    ("targets-hint-radians", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", Q, math.pi / 180)}, "the posture hints q1..q6 look like radians"),
    ("simulate-box-metres", ["simulate", "ur5", "--sampling", "lhs", "--n", "10", "--box", "-0.4,0.4,-0.4,0.4,0.1,0.5", "--out", "s.csv"], None, "they look like metres"),
    ("simulate-rpy-radians", ["simulate", "ur5", "--sampling", "lhs", "--n", "10", *BOX, "--rpy", "3.1416,0,0", "--out", "s.csv"], None, "the angles of --rpy look like radians"),
    ("simulate-hint-radians", ["simulate", "ur5", "--sampling", "lhs", "--n", "10", *BOX, "--hint", "0,-1.57,1.57,-1.57,-1.57,0", "--out", "s.csv"], None, "--hint look like radians"),
    ("simulate-box-min-above-max", ["simulate", "ur5", "--sampling", "lhs", "--n", "10", "--box", "400,-400,-400,-100,100,500", "--out", "s.csv"], None, "must not exceed high"),
    ("design-box-metres", ["design", "ur5", "--n", "12", "--pool", "200", "--box", "-0.4,0.4,-0.4,0.4,0.1,0.5", "--out", "p.csv"], None, "they look like metres"),
    ("design-tool-metres", ["design", "ur5", "--n", "12", "--pool", "200", "--tool", "0,0,0.1", "--out", "p.csv"], None, "--tool: distance from the origin 0.1"),
    ("design-tracker-metres", ["design", "ur5", "--n", "12", "--pool", "200", "--tracker", "2,0,0.5", "--out", "p.csv"], None, "--tracker: distance from the origin 2.06"),
    ("design-rpy-radians", ["design", "ur5", "--n", "12", "--pool", "200", *BOX, "--rpy", "3.1416,0,0", "--out", "p.csv"], None, "the angles of --rpy look like radians"),
    ("design-hint-radians", ["design", "ur5", "--n", "12", "--pool", "200", *BOX, "--hint", "0,-1.57,1.57,-1.57,-1.57,0", "--out", "p.csv"], None, "--hint look like radians"),
    ("design-walls-metres", ["design", "ur5", "--n", "12", "--pool", "200", "--walls", "-0.8,0.8,-0.8,0.8", "--out", "p.csv"], None, "--walls: largest 0.8"),
    ("design-joint-noise-too-big", ["design", "ur5", "--n", "12", "--pool", "200", "--joint-noise", "5", "--out", "p.csv"], None, "--joint-noise must be a number >= 0 and <= 1"),
    ("design-sag-too-big", ["design", "ur5", "--n", "12", "--pool", "200", "--sag", "30", "--out", "p.csv"], None, "--sag must be a number >= 0 and <= 1"),
    ("design-margin-huge", ["design", "ur5", "--n", "12", "--pool", "200", "--margin", "400", "--out", "p.csv"], None, "--margin must be a number >= 0 and <= 45"),
    ("design-region-metres", ["design", "kr150-2", "--n", "6", "--fixture", "plate.toml", "--region", "1,1.5,-0.3,0.3,0,0.2", "--out", "p.csv"], None, "--region: largest 1.5"),
    ("calibrate-negative-tolerance-scale", ["calibrate", "ur5", "ur5.csv", "--tolerance-scale", "-1", "--out", "o.json"], None, "--tolerance-scale must be a number between 0"),
    ("iso-edge-metres", ["iso9283", "plan", "ur5", "--edge", "0.3", "--out", "i.csv"], None, "--edge must be a number >= 1"),
    ("fixture-metres-calibrate", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "fm.toml", "--out", "o.json"], {"fm.toml": FIX_M}, "they look like metres"),
    ("fixture-metres-simulate", ["simulate", "kr150-2", "--sampling", "sockets", "--fixture", "fm.toml", "--placements", "3", "--per-socket", "5", "--out", "s.csv"], {"fm.toml": FIX_M}, "they look like metres"),
    ("fixture-metres-evaluate", ["evaluate", "sock_model.json", "sockets.csv", "--fixture", "fm.toml"], {"fm.toml": FIX_M}, "they look like metres"),
    ("fixture-metres-with-unit-key", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "fm.toml", "--out", "o.json"], {"fm.toml": FIX_M.replace("[sockets]", 'unit = "m"\n[sockets]')}, "they look like metres"),
    ("fixture-inches", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "fi.toml", "--out", "o.json"], {"fi.toml": lambda b: (b / "plate.toml").read_text().replace("150.0", "5.9").replace("120.0", "4.72")}, "they look like inches"),
    ("robot-file-metres", ["calibrate", "r.toml", "ur5.csv", "--out", "o.json"], {"r.toml": robot_in_metres}, "its robot file looks like metres"),
    ("design-targets-orientation-radians", ["design", "ur5", "--n", "8", "--pool", "300", "--targets", "t.csv", "--out", "p.csv"], {"t.csv": scaled("targets.csv", RPY, math.pi / 180, keep=XYZ + RPY)}, "the rx, ry, rz of t.csv look like radians"),
    ("frames-measurements-metres", ["calibrate", "ur5_model.json", "m.csv", "--method", "frames", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 1e-3)}, "they look like metres; give x, y, z in mm"),
    ("robot-file-limits-radians", ["calibrate", "r.toml", "ur5.csv", "--out", "o.json"], {"r.toml": robot_limits_in_radians}, "the min and max of the revolute [[joints]] look like radians"),
    # hostile pass 5: the same units in other verbs, methods, robots and options
    ("compare-metres", ["compare", "ur5", "m.csv", "--folds", "3", "--no-network"], {"m.csv": scaled("ur5.csv", XYZ + SXYZ, 1e-3)}, "spread 0.545 over these poses where the model of 'Universal Robots UR5' spreads 544 mm: they look like metres"),
    ("validate-kriging-micrometres", ["validate", "ur5", "m.csv", "--folds", "3", "--method", "kriging"], {"m.csv": scaled("ur5.csv", XYZ + SXYZ, 1e3)}, "they look like micrometres"),
    ("hybrid-cm", ["calibrate", "ur5", "m.csv", "--method", "hybrid", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ + SXYZ, 0.1)}, "they look like cm"),
    ("ann-inches", ["calibrate", "ur5", "m.csv", "--method", "ann", "--generations", "20", "--out", "o.json"], {"m.csv": scaled("ur5.csv", XYZ, 1 / 25.4)}, "they look like inches"),
    ("auto-joints-radians", ["calibrate", "ur5", "m.csv", "--method", "auto", "--out", "o.json"], {"m.csv": scaled("ur5.csv", Q, math.pi / 180)}, "the joint values look like radians: read so, the nominal 'Universal Robots UR5' misses them by 0.1%"),
    ("design-existing-metres", ["design", "ur5", "--existing", "m.csv", "--n", "5", "--pool", "300", "--out", "p.csv"], {"m.csv": scaled("ur5.csv", XYZ + SXYZ, 1e-3)}, "they look like metres"),
    ("design-candidates-radians", ["design", "ur5", "--candidates", "c.csv", "--n", "6", "--out", "p.csv"], {"c.csv": scaled("ur5.csv", Q, math.pi / 180, keep=Q)}, "all joint values of c.csv lie within ±6.3: they look like radians"),
    ("fixture-cm", ["calibrate", "kr150-2", "sockets.csv", "--method", "constraint", "--fixture", "fc.toml", "--out", "o.json"], {"fc.toml": lambda b: (b / "plate.toml").read_text().replace("150.0", "15.0").replace("120.0", "12.0")}, "its socket distances are 0.1 of what the robot's poses put between the sockets: they look like cm"),
    ("kr150-design-box-metres", ["design", "kr150-2", "--box", "1.2,1.8,-0.4,0.4,0.6,1.2", "--n", "8", "--pool", "400", "--out", "p.csv"], None, "--box: largest 1.8, where a length about robot 'KUKA KR 150-2' (reach 3346 mm)"),
    ("kr150-design-tool-metres", ["design", "kr150-2", "--tool", "0,0,0.35", "--n", "8", "--pool", "400", "--out", "p.csv"], None, "--tool: distance from the origin 0.35"),
    ("kr150-design-walls-cm", ["design", "kr150-2", "--walls", "-250,250,-250,250", "--n", "8", "--pool", "400", "--out", "p.csv"], None, "hardly any configuration of robot 'KUKA KR 150-2' keeps the arm in the working volume"),
    ("kr150-iso-centre-cm", ["iso9283", "plan", "kr150-2", "--centre", "150,0,90", "--out", "i.csv"], None, "about 150, 0, 90 mm is reachable by 'KUKA KR 150-2'"),
    ("simulate-grid-hint-radians", ["simulate", "ur5", "--sampling", "grid", "--box", "200,450,-250,250,150,450", "--hint", "0,-1.5708,1.5708,-1.5708,-1.5708,0", "--n", "8", "--out", "s.csv"], None, "the joint values of --hint look like radians"),
    ("design-payload-grams", ["design", "ur5", "--parameters", "full+compliance", "--payload", "3000", "--n", "12", "--pool", "400", "--out", "p.csv"], None, "give the payload in kg (grams divided by 1000)"),
    ("validate-payload-grams", ["validate", "ur5", "ur5.csv", "--parameters", "full+compliance", "--payload", "4500", "--folds", "3"], None, "--payload 4500 kg is more than 5 times the arm's own 17.0 kg"),
]


@pytest.mark.parametrize("args, files, says", [row[1:] for row in REFUSED], ids=[row[0] for row in REFUSED])
def test_wrong_unit_is_refused(tmp_path, args, files, says):
    refuse(tmp_path, args, files, says)


def tracker_points(factor=1.0, unit_line=""):
    """A tracker's point export (name x y z) of the base measurements' first 20 poses, times
    ``factor``, with the joint log beside it (name, q1..q6)."""
    def points(base):
        rows = list(csv.DictReader(io.StringIO((base / "ur5.csv").read_text())))[:20]
        return unit_line + "".join(f"P{n} " + " ".join(f"{float(r[a]) * factor:.6f}" for a in XYZ) + "\n"
                                   for n, r in enumerate(rows, 1))

    def joints(base):
        rows = list(csv.DictReader(io.StringIO((base / "ur5.csv").read_text())))[:20]
        return "name," + ",".join(Q) + "\n" + "".join(f"P{n}," + ",".join(r[q] for q in Q) + "\n"
                                                       for n, r in enumerate(rows, 1))
    return {"pts.txt": points, "j.csv": joints}


IMPORT = ["import", "--points", "pts.txt", "--joints", "j.csv", "--out", "m.csv"]
# Positions and angles read without a robot to judge them (an ISO campaign, a tracker's points).
REFUSED_WITHOUT_ROBOT = [
    ("iso-campaign-metres", ["iso9283", "f.csv"], {"f.csv": campaign(1e-3, 1e-3)}, "they look like metres"),
    ("iso-campaign-measured-metres", ["iso9283", "f.csv"], {"f.csv": campaign(1.0, 1e-3)}, "the measured x, y, z of f.csv: largest"),
    ("iso-campaign-measured-inches", ["iso9283", "f.csv"], {"f.csv": campaign(1.0, 1 / 25.4)}, "they look like inches"),
    ("iso-campaign-measured-cm", ["iso9283", "f.csv"], {"f.csv": campaign(1.0, 0.1)}, "they look like cm"),
    ("iso-campaign-measured-angles-radians", ["iso9283", "f.csv"], {"f.csv": campaign(angles=math.pi / 180)}, "the measured rx, ry, rz of f.csv look like radians"),
    ("iso-campaign-small-measured-angles-radians", ["iso9283", "f.csv"], {"f.csv": campaign(angles=math.pi / 180, rpy=(30, 20, 10))}, "the measured rx, ry, rz of f.csv look like radians: read so, they lie 0.0"),
    ("iso-campaign-angles-radians", ["iso9283", "f.csv"], {"f.csv": campaign(angles=math.pi / 180, angles_cmd=math.pi / 180)}, "the commanded rx_cmd, ry_cmd, rz_cmd of f.csv look like radians"),
    ("report-iso-campaign-metres", ["report", "ur5_model.json", "ur5.csv", "--iso", "f.csv", "--out", "r.html"], {"f.csv": campaign(1e-3, 1e-3)}, "the commanded x_cmd, y_cmd, z_cmd of f.csv: largest"),
    ("import-points-metres-unstated", IMPORT, tracker_points(1e-3), "no unit stated, read as mm"),
    ("import-points-metres-unstated-names-fix", IMPORT, tracker_points(1e-3), "they look like metres; state the unit (--units m"),
    ("iso-campaign-commanded-metres-measured-mm", ["iso9283", "f.csv"], {"f.csv": campaign(1e-3, 1.0)}, "the commanded x_cmd, y_cmd, z_cmd of f.csv: largest 0.643"),
]


@pytest.mark.parametrize("args, files, says", [row[1:] for row in REFUSED_WITHOUT_ROBOT],
                         ids=[row[0] for row in REFUSED_WITHOUT_ROBOT])
def test_positions_without_a_robot_in_another_unit_are_refused(tmp_path, args, files, says):
    refuse(tmp_path, args, files, says)


# The same shapes in mm and degrees: read and used.
ACCEPTED = [
    ("measurements", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("ur5.csv", Q, 1.0)}, "o.json"),
    ("targets-with-hints", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", XYZ, 1.0)}, "o.csv"),
    ("targets-no-hints", ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("targets.csv", XYZ, 1.0, keep=XYZ + RPY)}, "o.csv"),
    ("kr-targets-seed-hint", ["compensate", "kr_model.json", "t.csv", "--out", "o.csv"], {"t.csv": scaled("examples/kr150-targets.csv", XYZ, 1.0)}, "o.csv"),
    ("iso-campaign", ["iso9283", "f.csv", "--json"], {"f.csv": campaign()}, None),
    ("iso-campaign-angles", ["iso9283", "f.csv", "--json"], {"f.csv": campaign(angles=1.0)}, None),
    ("iso-campaign-small-angles", ["iso9283", "f.csv", "--json"], {"f.csv": campaign(angles=1.0, rpy=(0.5, 0.3, 0.2))}, None),
    ("iso-campaign-angles-away-from-commands", ["iso9283", "f.csv", "--json"], {"f.csv": campaign(angles=1.0, rpy=(30, 20, 10), angles_cmd=0.5)}, None),
    ("measurements-orientation", ["calibrate", "ur5", "m.csv", "--out", "o.json"], {"m.csv": scaled("six-d", Q, 1.0)}, "o.json"),
    ("evaluate-orientation", ["evaluate", "ur5_model.json", "m.csv"], {"m.csv": scaled("six-d", Q, 1.0)}, None),
    ("import-points-mm-unstated", IMPORT, tracker_points(), "m.csv"),
    ("import-points-metres-stated", IMPORT, tracker_points(1e-3, "// Units: m\n"), "m.csv"),
    ("import-points-metres-option", IMPORT + ["--units", "m"], tracker_points(1e-3), "m.csv"),
    ("kr-targets-seed-hint-iterate", ["compensate", "kr_model.json", "t.csv", "--out", "o.csv", "--iterate"], {"t.csv": scaled("examples/kr150-targets.csv", XYZ, 1.0)}, "o.csv"),
]


@pytest.mark.parametrize("args, files, output", [row[1:] for row in ACCEPTED], ids=[row[0] for row in ACCEPTED])
def test_the_same_shapes_in_mm_and_degrees_are_accepted(tmp_path, args, files, output):
    prepare(tmp_path, files)
    outcome = invoke(tmp_path, args)
    assert outcome.code == 0, outcome.output
    assert output is None or (tmp_path / output).stat().st_size > 0


def test_orientations_tagged_radians_calibrate_to_the_same_model(tmp_path):
    prepare(tmp_path, {"deg.csv": scaled("six-d", Q, 1.0), "rad.csv": scaled("six-d", RPY, math.pi / 180, "rad")})
    for data, out in (("deg.csv", "a.json"), ("rad.csv", "b.json")):
        outcome = invoke(tmp_path, ["calibrate", "ur5", data, "--out", out])
        assert outcome.code == 0, outcome.output
    assert _mean(tmp_path, "a.json", "deg.csv") == pytest.approx(_mean(tmp_path, "b.json", "deg.csv"), rel=1e-6)


def test_iso_campaign_angles_give_the_small_offset_they_were_given(tmp_path):
    prepare(tmp_path, {"f.csv": campaign(angles=1.0)})
    outcome = invoke(tmp_path, ["iso9283", "f.csv", "--json"])
    assert outcome.code == 0, outcome.output
    poses = json.loads(outcome.result.stdout)["poses"]
    assert all(abs(pose[f"AP{c}_deg"]) < 0.1 for pose in poses for c in "abc")


def _mean(folder, model, data):
    outcome = invoke(folder, ["evaluate", model, data, "--json"])
    assert outcome.code == 0, outcome.output
    return json.loads(outcome.result.stdout)["mean_mm"]


@pytest.mark.parametrize("columns, factor, unit", [
    (XYZ, 1e-3, "m"), (XYZ, 1 / 25.4, "in"), (Q, math.pi / 180, "rad"),
], ids=["metres", "inches", "radians"])
def test_tagged_units_calibrate_to_the_same_model(tmp_path, columns, factor, unit):
    prepare(tmp_path, {"m.csv": scaled("ur5.csv", columns, factor, unit)})
    outcome = invoke(tmp_path, ["calibrate", "ur5", "m.csv", "--out", "o.json"])
    assert outcome.code == 0, outcome.output
    assert _mean(tmp_path, "o.json", "ur5.csv") == pytest.approx(_mean(tmp_path, "ur5_model.json", "ur5.csv"), rel=1e-6)


@pytest.mark.parametrize("columns, factor, unit", [
    (XYZ, 1e-3, "m"), (XYZ, 10, "um"), (Q, math.pi / 180, "rad"),
], ids=["metres", "micrometres", "radians"])
def test_tagged_units_evaluate_the_same(tmp_path, columns, factor, unit):
    prepare(tmp_path, {"m.csv": scaled("ur5.csv", columns, factor if unit != "um" else 1000, unit)})
    assert _mean(tmp_path, "ur5_model.json", "m.csv") == pytest.approx(_mean(tmp_path, "ur5_model.json", "ur5.csv"), rel=1e-6)


@pytest.mark.parametrize("columns, factor, unit", [
    (XYZ, 1e-3, "m"), (RPY, math.pi / 180, "rad"), (Q, math.pi / 180, "rad"),
], ids=["position-metres", "orientation-radians", "hint-radians"])
def test_tagged_targets_give_the_same_commands(tmp_path, columns, factor, unit):
    prepare(tmp_path, {"t.csv": scaled("targets.csv", columns, factor, unit)})
    outcome = invoke(tmp_path, ["compensate", "ur5_model.json", "t.csv", "--out", "o.csv"])
    assert outcome.code == 0, outcome.output
    got = list(csv.reader(open(tmp_path / "o.csv")))
    want = list(csv.reader(io.StringIO(text("cmds.csv"))))
    assert got[0] == want[0]
    for a, b in zip(got[1:], want[1:]):
        assert [float(v) for v in a[:12]] == pytest.approx([float(v) for v in b[:12]], abs=1e-6)


# design's candidates, targets and measured poses are read as measurement files are: a column
# tagged with its unit (q1[rad]) plans what the file in degrees plans (candidates tagged q1[rad]
# were refused: "lacks columns q1 ... q6").
DESIGN = ["design", "ur5", "--n", "10", "--out", "p.csv"]
TAGGED_DESIGN = [
    ("candidates-radians", ["--candidates", "f.csv"], "plan.csv", Q, math.pi / 180, "rad", Q),
    ("targets-radians", ["--pool", "200", "--targets", "f.csv"], "plan.csv", Q, math.pi / 180, "rad", Q),
    ("existing-radians", ["--pool", "200", "--existing", "f.csv"], "ur5.csv", Q, math.pi / 180, "rad", None),
    ("existing-metres", ["--pool", "200", "--existing", "f.csv"], "ur5.csv", XYZ, 1e-3, "m", None),
]


@pytest.mark.parametrize("args, name, columns, factor, unit, keep", [row[1:] for row in TAGGED_DESIGN],
                         ids=[row[0] for row in TAGGED_DESIGN])
def test_tagged_design_inputs_plan_what_degrees_and_mm_plan(tmp_path, args, name, columns, factor, unit, keep):
    plans, results = [], []
    for folder, tagged in ((tmp_path / "plain", (1.0, None)), (tmp_path / "tagged", (factor, unit))):
        folder.mkdir()
        prepare(folder, {"f.csv": scaled(name, columns, *tagged, keep=keep)})
        outcome = invoke(folder, DESIGN + args + ["--json"])
        assert outcome.code == 0, outcome.output
        plans.append(list(csv.DictReader(open(folder / "p.csv"))))
        results.append(json.loads(outcome.result.stdout))
    # The noise a calibration of the measured poses leaves (--existing): found in both.
    assert results[0]["noise_from"] == results[1]["noise_from"]
    assert results[0]["noise_mm"] == pytest.approx(results[1]["noise_mm"], rel=1e-6)
    assert [row["pose"] for row in plans[0]] == [row["pose"] for row in plans[1]]
    for a, b in zip(*plans):
        assert [float(a[q]) for q in Q] == pytest.approx([float(b[q]) for q in Q], abs=1e-6)


# iso9283 plan's typed numbers meet the same units check as design's and simulate's.
ISO_PLAN_UNITS = [
    ("--rpy", "3.1416,0,0", "look like radians"),
    ("--centre", "0.3,-0.3,0.4", "look like metres"),
]


@pytest.mark.parametrize("option, value, says", ISO_PLAN_UNITS)
def test_iso9283_plan_refuses_typed_numbers_in_other_units(option, value, says, tmp_path):
    from typer.testing import CliRunner

    from robocal.interfaces.cli import app

    out = tmp_path / "plan.csv"
    result = CliRunner().invoke(app, ["iso9283", "plan", "ur5", option, value, "--out", str(out)])
    assert result.exit_code != 0 and says in result.output
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1
    assert not out.exists()


def truth_with(change):
    """The base truth file (simulate --truth) with ``change(document)`` applied."""
    def make(base):
        document = json.loads((base / "ur5_truth.json").read_text())
        change(document)
        return json.dumps(document)
    return make


def _units(**units):
    return lambda document: document.__setitem__("units", {**document["units"], **units})


# A truth file's numbers are read in mm and degrees: an entry saying otherwise is refused
# (robocal.io.schema.stated_units), as is an entry robocal would not read at all.
TRUTH_REFUSED = [
    ("lengths-metres", _units(lengths="m"), "units says lengths are in 'm', but this file's lengths are read in mm"),
    ("angles-radians", _units(angles="rad"), "units says angles are in 'rad', but this file's angles are read in deg"),
    ("masses-grams", _units(masses="g"), "units says masses are in 'g'"),
    ("unit-not-text", _units(lengths=1000), "units says lengths are in 1000"),
    ("unknown-quantity", _units(time="s"), "units has unknown key 'time'"),
    ("units-not-a-table", lambda d: d.__setitem__("units", "m"), "units must be a table of units"),
    ("misspelt-units-key", lambda d: d.__setitem__("unit", {"lengths": "m"}), "unknown key 'unit': did you mean 'units'?"),
]


@pytest.mark.parametrize("change, says", [row[1:] for row in TRUTH_REFUSED], ids=[row[0] for row in TRUTH_REFUSED])
def test_truth_file_units_other_than_mm_and_degrees_are_refused(tmp_path, change, says):
    refuse(tmp_path, ["simulate", "ur5", "--n", "10", "--errors", "t.json", "--out", "s.csv"],
           {"t.json": truth_with(change)}, says)


@pytest.mark.parametrize("change", [
    _units(lengths="millimetres", angles="degrees"), _units(lengths="MM", angles="Deg", masses="kg"),
    lambda d: d.pop("units"),
], ids=["spelt-out", "other-case", "no-units-entry"])
def test_truth_file_stating_mm_and_degrees_simulates_what_the_written_one_does(tmp_path, change):
    prepare(tmp_path, {"t.json": truth_with(change)})
    for truth, out in (("t.json", "a.csv"), ("ur5_truth.json", "b.csv")):
        outcome = invoke(tmp_path, ["simulate", "ur5", "--n", "10", "--seed", "3", "--errors", truth, "--out", out])
        assert outcome.code == 0, outcome.output
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def positions(change):
    """ur5.csv with its x, y, z replaced by ``change(k, xyz)`` on data row k."""
    def make(base):
        rows = list(csv.reader(io.StringIO((base / "ur5.csv").read_text())))
        columns = [rows[0].index(c) for c in XYZ]
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(rows[0])
        first = [float(rows[1][c]) for c in columns]
        for k, row in enumerate(rows[1:]):
            new = change(k, first)
            writer.writerow([repr(new[columns.index(i)]) if i in columns else v for i, v in enumerate(row)])
        return out.getvalue()
    return make


# Positions that do not move while the robot does are no unit's: the message says they do not
# vary, not that they are "not in mm" (robocal.io.units, the one check of every verb).
STILL = {
    "same-xyz": positions(lambda k, p: p),
    "same-xyz-jitter-5um": positions(lambda k, p: [v + 0.005 * math.sin(7 * k + i) for i, v in enumerate(p)]),
    "same-xyz-metres": positions(lambda k, p: [v / 1000 for v in p]),
}
STILL_VERBS = {
    "calibrate": ["calibrate", "ur5", "m.csv", "--out", "o.json"],
    "evaluate": ["evaluate", "ur5_model.json", "m.csv"],
    "report": ["report", "ur5_model.json", "m.csv", "--out", "r.html"],
    "validate": ["validate", "ur5", "m.csv", "--folds", "3"],
    "design-existing": ["design", "ur5", "--n", "6", "--pool", "100", "--existing", "m.csv", "--out", "p.csv"],
}


@pytest.mark.parametrize("content", list(STILL.values()), ids=list(STILL))
@pytest.mark.parametrize("args", list(STILL_VERBS.values()), ids=list(STILL_VERBS))
def test_positions_that_do_not_vary_are_named_so(tmp_path, args, content):
    outcome = refuse(tmp_path, args, {"m.csv": content}, "do not move with the robot")
    assert "not in mm" not in outcome.lines[0] and "look like" not in outcome.lines[0]


def test_positions_that_move_little_with_a_robot_that_moves_little_are_read(tmp_path):
    # A small box (40 mm): the positions vary little because the TCP does, in mm.
    prepare(tmp_path)
    outcome = invoke(tmp_path, ["simulate", "ur5", "--sampling", "lhs", "--n", "30", "--seed", "5", "--box",
                                "-420,-380,-120,-80,380,420", "--out", "small.csv"])
    assert outcome.code == 0, outcome.output
    outcome = invoke(tmp_path, ["evaluate", "ur5_model.json", "small.csv"])
    assert outcome.code == 0, outcome.output


def filled_down(start, count=None):
    """ur5.csv with rows ``start`` .. ``start + count`` given the x, y, z of the row before
    (a column filled down in a spreadsheet, an instrument that lost its target)."""
    def make(base):
        rows = list(csv.reader(io.StringIO((base / "ur5.csv").read_text())))
        columns = [rows[0].index(c) for c in XYZ]
        end = len(rows) if count is None else start + 1 + count
        held = [rows[start][c] for c in columns]
        for row in rows[start + 1:end]:
            for c, v in zip(columns, held):
                row[c] = v
        out = io.StringIO()
        csv.writer(out, lineterminator="\n").writerows(rows)
        return out.getvalue()
    return make


# Some rows' positions stuck at an earlier row's while the robot moves: named by row, as not
# following the robot (robocal.methods.plausibility.check_measured), not as another robot's.
FILLED = {"half-filled-down": filled_down(20), "three-filled-down": filled_down(30, 3)}


@pytest.mark.parametrize("content", list(FILLED.values()), ids=list(FILLED))
@pytest.mark.parametrize("args", list(STILL_VERBS.values()), ids=list(STILL_VERBS))
def test_positions_stuck_while_the_robot_moves_are_named_by_row(tmp_path, args, content):
    outcome = refuse(tmp_path, args, {"m.csv": content}, "the positions do not follow the robot")
    assert "the same measured x, y, z as an earlier row" in outcome.lines[0]


def test_a_pose_visited_again_with_the_same_reading_is_calibrated(tmp_path):
    # The same point read again at joints a thousandth of a degree apart: a repeat visit.
    def again(base):
        header, *rows = (base / "ur5.csv").read_text().splitlines()
        repeats = [",".join([repr(float(r.split(",")[0]) + 0.001)] + r.split(",")[1:]) for r in rows[:3]]
        return "\n".join([header, *rows, *repeats]) + "\n"
    prepare(tmp_path, {"m.csv": again})
    outcome = invoke(tmp_path, ["calibrate", "ur5", "m.csv", "--out", "o.json"])
    assert outcome.code == 0, outcome.output


# A --region of a ball-in-socket design typed below the robot's mounting plane (z < 0, as a
# height measured down from the base, or the sign flipped): refused naming the plane, not
# "place the fixture nearer"; the same region above it designs.
def test_a_region_below_the_mounting_plane_is_refused_naming_it(tmp_path):
    refuse(tmp_path, ["design", "kr150-2", "--fixture", "plate.toml", "--region", "1200,2000,-500,500,-900,-600",
                      "--n", "12", "--out", "p.csv"], None, "below the robot's mounting plane")


def test_a_region_above_the_mounting_plane_designs(tmp_path):
    prepare(tmp_path)
    outcome = invoke(tmp_path, ["design", "kr150-2", "--fixture", "plate.toml", "--region",
                                "1200,2000,-500,500,600,900", "--n", "18", "--per-socket", "3", "--out", "p.csv"])
    assert outcome.code == 0, outcome.output
    assert (tmp_path / "p.csv").stat().st_size > 0
