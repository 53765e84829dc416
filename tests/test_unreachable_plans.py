# ruff: noqa: E501  (one input per table row)
"""Plans the robot cannot execute. design, simulate and iso9283 plan options
that put every pose below the floor, beyond the reach or outside the walls are refused in one
line saying what to change, and nothing is written."""
import csv
import json

import pytest

from user_files import invoke, nominal_fk, prepare, refuse

D = ["design", "ur5", "--n", "12", "--pool", "200"]
# A UR5 with its upper arm pointing straight down: through the table it stands on.
ARM_DOWN = "0,90,0,0,0,0"


def plan_with(base, row):
    """The designed plan's joint columns (poses the robot can take) with ``row`` added last."""
    rows = list(csv.DictReader(open(base / "plan.csv")))
    lines = [",".join(r[f"q{k}"] for k in range(1, 7)) for r in rows]
    return "q1,q2,q3,q4,q5,q6\n" + "\n".join(lines + [row]) + "\n"
REFUSED = [
    ("design-floor-above-the-robot", [*D, "--floor", "2000", "--out", "p.csv"], None, "keeps the arm in the working volume"),
    ("design-box-below-the-floor", [*D, "--box", "-400,400,-400,400,-900,-600", "--out", "p.csv"], None, "only 0 of 200 points of the box"),
    ("design-box-out-of-reach", [*D, "--box", "3000,3500,-200,200,0,400", "--out", "p.csv"], None, "only 0 of 200 points of the box"),
    ("design-walls-around-the-base", [*D, "--walls", "-10,10,-10,10", "--out", "p.csv"], None, "within x -10..10, y -10..10 mm (--walls)"),
    ("design-walls-inverted", [*D, "--walls", "500,-500,-500,500", "--out", "p.csv"], None, "with each min below its max"),
    ("design-kr150-box-below-the-floor", ["design", "kr150-2", "--n", "12", "--pool", "200", "--box", "1000,1800,-400,400,-1500,-1000", "--out", "p.csv"], None, "z >= 0 mm"),
    ("design-fixture-below-the-floor", ["design", "kr150-2", "--n", "72", "--fixture", "plate.toml", "--region", "1000,1500,-300,300,-2000,-1800", "--out", "p.csv"], None, "below the robot's mounting plane"),
    ("design-fixture-out-of-reach", ["design", "kr150-2", "--n", "72", "--fixture", "plate.toml", "--region", "9000,9500,-300,300,0,200", "--out", "p.csv"], None, "at none of the placements"),
    ("design-targets-out-of-reach", [*D, "--targets", "tf.csv", "--out", "p.csv"], {"tf.csv": "x,y,z,rx,ry,rz\n5000,0,0,180,0,0\n5100,0,0,180,0,0\n"}, "none of the targets of tf.csv can be reached"),
    ("design-candidates-beyond-limits", ["design", "ur5", "--n", "12", "--candidates", "c.csv", "--out", "p.csv"], {"c.csv": "q1,q2,q3,q4,q5,q6\n" + "".join(f"{400 + i},0,0,0,0,0\n" for i in range(30))}, "lies beyond joint 1's limits"),
    ("design-too-few-poses", ["design", "ur5", "--n", "5", "--pool", "200", "--out", "p.csv"], None, "ask for at least 9 poses"),
    # --n that no whole number per socket gives over every placement: the two that do (24 was refused suggesting 24)
    ("design-fixture-n-not-per-socket", ["design", "kr150-2", "--fixture", "plate.toml", "--placements", "pl.csv", "--n", "24", "--out", "p.csv"], {"pl.csv": "x,y,z,rx,ry,rz\n1500,-300,400,0,0,0\n1600,300,400,0,0,90\n1400,0,700,0,0,45\n"}, "--n 24 over 3 reachable placements x 3 sockets is not a whole number per socket: ask for 18 or 27 (2 or 3 per socket)"),
    ("design-fixture-n-not-placements", ["design", "kr150-2", "--fixture", "plate.toml", "--placements", "pl.csv", "--per-socket", "2", "--n", "25", "--out", "p.csv"], {"pl.csv": "x,y,z,rx,ry,rz\n1500,-300,400,0,0,0\n1600,300,400,0,0,90\n1400,0,700,0,0,45\n"}, "--n 25 is not a whole number of placements x 3 sockets x 2 per socket: ask for 24 or 30"),
    ("design-fixture-too-few-poses", ["design", "kr150-2", "--n", "6", "--fixture", "plate.toml", "--region", "1000,1500,-300,300,0,200", "--out", "p.csv"], None, "leave fewer than 2 per socket"),
    ("design-placements-in-cm", ["design", "kr150-2", "--fixture", "plate.toml", "--placements", "pl.csv", "--n", "12", "--out", "p.csv"], {"pl.csv": "x,y,z,rx,ry,rz\n150,-30,40,0,0,0\n160,30,40,0,0,0\n140,0,60,0,0,0\n"}, "at none of the placements"),
    ("design-placements-below-the-floor", ["design", "kr150-2", "--fixture", "plate.toml", "--placements", "pl.csv", "--n", "12", "--out", "p.csv"], {"pl.csv": "x,y,z,rx,ry,rz\n1500,0,-600,0,0,0\n1400,300,-700,0,0,0\n"}, "puts every socket below the robot's mounting plane"),
    ("design-fixture-region-inside-the-base", ["design", "kr150-2", "--fixture", "plate.toml", "--region", "-50,50,-50,50,0,50", "--n", "12", "--out", "p.csv"], None, "at none of the placements"),
    ("design-walls-leave-out-the-base", [*D, "--walls", "200,900,-400,400", "--out", "p.csv"], None, "within x 200..900, y -400..400 mm (--walls)"),
    ("iso-one-cycle", ["iso9283", "plan", "ur5", "--cycles", "1", "--out", "i.csv"], None, "--cycles must be a whole number >= 2, got '1'"),
    ("iso-centre-below-the-floor", ["iso9283", "plan", "ur5", "--centre", "400,0,-800", "--out", "i.csv"], None, "about 400, 0, -800 mm is reachable"),
    ("iso-centre-out-of-reach", ["iso9283", "plan", "ur5", "--centre", "3000,0,300", "--out", "i.csv"], None, "about 3000, 0, 300 mm is reachable"),
    ("iso-edge-beyond-reach", ["iso9283", "plan", "ur5", "--edge", "5000", "--out", "i.csv"], None, "no ISO 9283 cube of edge 5000 mm"),
    ("iso-cube-at-the-base", ["iso9283", "plan", "ur5", "--centre", "0,0,0", "--edge", "200", "--out", "i.csv"], None, "no ISO 9283 cube of edge 200 mm"),
    ("iso-kr150-cube-through-the-floor", ["iso9283", "plan", "kr150-2", "--centre", "1500,0,100", "--edge", "1000", "--out", "i.csv"], None, "no ISO 9283 cube of edge 1000 mm"),
    ("iso-zero-cycles", ["iso9283", "plan", "ur5", "--cycles", "0", "--out", "i.csv"], None, "--cycles must be a whole number >= 2"),
    ("iso-negative-cycles", ["iso9283", "plan", "ur5", "--cycles", "-3", "--out", "i.csv"], None, "--cycles must be a whole number >= 2"),
    ("iso-zero-edge", ["iso9283", "plan", "ur5", "--edge", "0", "--out", "i.csv"], None, "--edge must be a number >= 1, got '0'"),
    ("simulate-box-below-the-floor", ["simulate", "ur5", "--sampling", "lhs", "--n", "10", "--box", "-400,400,-400,400,-900,-600", "--out", "s.csv"], None, "cannot be reached by robot"),
    ("simulate-box-out-of-reach", ["simulate", "ur5", "--sampling", "lhs", "--n", "10", "--box", "3000,3500,-200,200,0,400", "--out", "s.csv"], None, "10 of 10 points in the box"),
    ("simulate-grid-below-the-floor", ["simulate", "ur5", "--sampling", "grid", "--n", "8", "--box", "-400,400,-400,400,-900,-600", "--out", "s.csv"], None, "cannot be reached by robot"),
    ("compensate-targets-out-of-reach", ["compensate", "ur5_model.json", "tf.csv", "--out", "o.csv"], {"tf.csv": "x,y,z,rx,ry,rz\n5000,0,0,180,0,0\n"}, "nothing was written"),
    # the working volume binds the poses a user gives as it binds those robocal draws
    ("design-candidates-drawn-through-the-table", ["design", "ur5", "--n", "12", "--candidates", "ur5.csv", "--out", "p.csv"], None, "of the candidates put the arm outside the working volume (above the mounting plane, z >= 0 mm"),
    ("design-candidates-one-arm-down", ["design", "ur5", "--n", "12", "--candidates", "c.csv", "--out", "p.csv"], {"c.csv": lambda base: plan_with(base, ARM_DOWN)}, "row 14: 1 of the candidates put the arm outside the working volume"),
    ("design-candidates-outside-the-walls", ["design", "ur5", "--n", "12", "--candidates", "plan.csv", "--walls", "-50,50,-50,50", "--out", "p.csv"], None, "within x -50..50, y -50..50 mm (--walls)"),
    ("design-candidates-above-a-raised-floor", ["design", "ur5", "--n", "12", "--candidates", "plan.csv", "--floor", "1000", "--out", "p.csv"], None, "above z = 1000 mm (--floor)"),
    ("design-targets-below-the-table", [*D, "--targets", "tf.csv", "--out", "p.csv"], {"tf.csv": "x,y,z,rx,ry,rz\n400,0,-300,180,0,0\n400,100,300,180,0,0\n"}, "row 2: 1 of the targets put the arm outside the working volume"),
    ("design-joint-targets-arm-down", [*D, "--targets", "tq.csv", "--out", "p.csv"], {"tq.csv": "q1,q2,q3,q4,q5,q6\n" + ARM_DOWN + "\n"}, "of the targets put the arm outside the working volume"),
    # measured poses given to a design meet the data check a calibration meets
    ("design-existing-of-another-robot", [*D, "--existing", "kr.csv", "--out", "p.csv"], None, "explains 0% of the error"),
    ("design-existing-nominal-fk", [*D, "--existing", "fk.csv", "--out", "p.csv"], {"fk.csv": lambda base: nominal_fk(base)}, "the nominal robot's own forward kinematics"),
]


@pytest.mark.parametrize("args, files, says", [row[1:] for row in REFUSED], ids=[row[0] for row in REFUSED])
def test_plan_the_robot_cannot_execute_is_refused(tmp_path, args, files, says):
    refuse(tmp_path, args, files, says)


def test_designed_tool_far_from_the_flange_keeps_the_tcp_above_the_floor(tmp_path):
    prepare(tmp_path)
    outcome = invoke(tmp_path, [*D, "--tool", "0,0,900", "--out", "p.csv"])
    assert outcome.code == 0, outcome.output
    rows = list(csv.DictReader(open(tmp_path / "p.csv")))
    assert len(rows) == 12 and min(float(r["z_nominal"]) for r in rows) >= 0


def test_one_unreachable_target_among_reachable_ones_is_flagged_not_answered(tmp_path):
    prepare(tmp_path, {"tf.csv": "x,y,z,rx,ry,rz\n5000,0,0,180,0,0\n-506.815,-242.645,-38.323,78.439,-9.785,-81.802\n"})
    outcome = invoke(tmp_path, ["compensate", "ur5_model.json", "tf.csv", "--out", "o.csv"])
    assert outcome.code == 0, outcome.output
    rows = list(csv.DictReader(open(tmp_path / "o.csv")))
    assert [r["reachable"] for r in rows] == ["0", "1"]
    assert rows[0]["q1"] in ("", "nan")


@pytest.mark.parametrize("args", [
    ["design", "ur5", "--n", "12", "--candidates", "plan.csv", "--out", "p.csv"],
    ["design", "ur5", "--n", "12", "--candidates", "c.csv", "--floor", "none", "--out", "p.csv"],
    [*D, "--targets", "tf.csv", "--out", "p.csv"],
    [*D, "--existing", "ur5.csv", "--out", "p.csv"],
], ids=["own-candidates-above-the-table", "arm-down-on-a-wall-mount", "targets-above-the-table", "existing-of-this-robot"])
def test_a_plan_the_robot_can_execute_from_given_poses_is_designed(tmp_path, args):
    prepare(tmp_path, {"c.csv": lambda base: plan_with(base, ARM_DOWN),
                       "tf.csv": "x,y,z,rx,ry,rz\n400,0,300,180,0,0\n400,100,300,180,0,0\n"})
    outcome = invoke(tmp_path, args)
    assert outcome.code == 0, outcome.output
    assert len(list(csv.DictReader(open(tmp_path / "p.csv")))) == 12


# iso9283 plan's refusals print the numbers they compare or repeat so that a user can tell
# them apart: a centre typed to the tenth is not shown rounded, and a length just below the
# least the check allows is not shown equal to it (robocal.io.units.apart).
ISO_NUMBERS = [
    ("centre-tenths", "400.4,0,0.6", "about 400.4, 0, 0.6 mm is reachable"),
    ("centre-just-too-near", "5,0,0", "distance from the origin 5, where a length about robot 'Universal Robots UR5' (reach 1001 mm) needs at least 5.003 mm"),
    ("centre-3-4-0-is-5-away", "3,4,0", "distance from the origin 5, "),
    ("centre-4.996", "4.996,0,0", "distance from the origin 4.996, "),
]


@pytest.mark.parametrize("centre, says", [row[1:] for row in ISO_NUMBERS], ids=[row[0] for row in ISO_NUMBERS])
def test_iso_plan_refusal_prints_the_numbers_it_compares_apart(tmp_path, centre, says):
    refuse(tmp_path, ["iso9283", "plan", "ur5", "--centre", centre, "--out", "i.csv"], None, says)


def test_apart_prints_close_numbers_differently_and_equal_ones_alike():
    from robocal.io.units import apart

    assert apart(0.648, 5.00345) == ["0.648", "5"]
    assert apart(4.996, 5.00345) == ["4.996", "5.003"]
    assert apart(5.0, 5.00345) == ["5", "5.003"]
    assert apart(2.0, 2.0) == ["2", "2"]


def test_iso_plan_at_a_reachable_centre_typed_to_the_tenth_is_planned(tmp_path):
    prepare(tmp_path)
    outcome = invoke(tmp_path, ["iso9283", "plan", "ur5", "--centre", "400.4,-100.6,400.2", "--edge", "150.5",
                                "--out", "i.csv", "--json"])
    assert outcome.code == 0, outcome.output
    planned = json.loads(outcome.result.stdout)
    assert planned["cube_centre_mm"] == [400.4, -100.6, 400.2] and planned["cube_edge_mm"] == 150.5
