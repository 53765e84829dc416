"""The metrology verbs from the command line: `robocal import` gives the measurement file a
hand-made join gives (and so the same model), `robocal iso9283` plans a campaign and prints
the figures the Python API computes; their refusals are one line."""
import csv
import json

import numpy as np
import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.acceptance.iso9283 import characteristics
from robocal.io.iso_campaign import read_iso_campaign


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("metrology")
    run_ok("simulate", "ur5", "--n", "60", "--seed", "4", "--out", root / "meas.csv")
    rows = list(csv.DictReader(open(root / "meas.csv", newline="")))
    with open(root / "joints.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["point"] + [f"q{k}" for k in range(1, 7)])
        for k, row in enumerate(rows):
            writer.writerow([f"P{k}"] + [row[f"q{j}"] for j in range(1, 7)])
    lines = ["// exported by the tracker", "// Units: mm", "Point;X;Y;Z"]
    lines += [f"P{k};" + ";".join(row[a].replace(".", ",") for a in "xyz") for k, row in enumerate(rows)][::-1]
    (root / "points.txt").write_text("\n".join(lines) + "\n")
    with open(root / "hand.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow([f"q{k}" for k in range(1, 7)] + ["x", "y", "z"])
        for row in rows:
            writer.writerow([row[f"q{k}"] for k in range(1, 7)] + [row[a] for a in "xyz"])
    run_ok("simulate", "ur5", "--n", "40", "--seed", "9", "--out", root / "test.csv")
    return root


def test_an_imported_campaign_calibrates_to_the_hand_made_files_model(folder, tmp_path):
    report = json.loads(run_ok("import", "--points", folder / "points.txt", "--joints", folder / "joints.csv",
                               "--out", tmp_path / "meas.csv", "--json").output)
    assert report["matched"] == 60 and not report["joint_rows_without_point"]
    held_out = []
    for name in (tmp_path / "meas.csv", folder / "hand.csv"):
        model = tmp_path / f"{name.stem}_model.json"
        run_ok("calibrate", "ur5", name, "--out", model)
        held_out.append(json.loads(run_ok("evaluate", model, folder / "test.csv", "--json").output))
    a, b = (h["residual_after"]["mean_mm"] if "residual_after" in h else h["mean_mm"] for h in held_out)
    assert abs(a - b) < 1e-6


def test_iso9283_plans_a_campaign_and_prints_the_figures_the_api_computes(tmp_path):
    run_ok("iso9283", "plan", "ur5", "--out", tmp_path / "plan.csv", "--cycles", "10")
    rows = list(csv.DictReader(open(tmp_path / "plan.csv", newline="")))
    assert len(rows) == 50 and [r["pose"] for r in rows[:5]] == ["P1", "P2", "P3", "P4", "P5"]
    rng = np.random.default_rng(0)
    with open(tmp_path / "measured.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(list(rows[0]) + ["x", "y", "z"])
        for row in rows:
            writer.writerow(list(row.values()) + [float(row[c]) + 0.05 + rng.normal(0, 0.01)
                                                  for c in ("x_cmd", "y_cmd", "z_cmd")])
    printed = json.loads(run_ok("iso9283", tmp_path / "measured.csv", "--json").output)
    assert printed == json.loads(json.dumps(characteristics(read_iso_campaign(tmp_path / "measured.csv")).to_dict()))
    assert all(abs(p["AP_mm"] - 0.05 * 3 ** 0.5) < 0.01 for p in printed["poses"])


@pytest.mark.parametrize("args, says", [
    ("iso9283 plan --out p.csv", "needs the robot and --out"),
    ("iso9283 meas.csv --out p.csv", "give 'plan' first"),
    ("iso9283 meas.csv", "lacks columns x_cmd, y_cmd, z_cmd"),
    ("import --points points.txt --joints meas.csv --out m.csv", "no name column"),
    ("import --points points.txt --joints joints.csv --out m.csv --units m", "contradicts"),
])
def test_metrology_verbs_refuse_in_one_line(args, says, folder, tmp_path, monkeypatch):
    before = copy_inputs(folder, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)


def _more_joint_rows(folder):
    """40 joint rows no point was measured for (P60..P99, on lines 62..101 of the log)."""
    rows = (folder / "joints.csv").read_text().splitlines()
    return "\n".join(rows + [f"P{60 + k}," + row.split(",", 1)[1] for k, row in enumerate(rows[1:41])]) + "\n"


def _more_points(folder):
    """Points P60..P89 with no joint row (lines 64..93 of the points file)."""
    lines = (folder / "points.txt").read_text().splitlines()
    return "\n".join(lines + [f"P{60 + k};1;2;3" for k in range(30)]) + "\n"


def _points_twice(folder):
    """Every point measured twice, 0.02 mm apart in x the second time."""
    lines = (folder / "points.txt").read_text().splitlines()
    again = []
    for line in lines[3:]:
        name, x, y, z = line.split(";")
        again.append(";".join([name, repr(float(x.replace(",", ".")) + 0.02).replace(".", ","), y, z]))
    return "\n".join(lines + again) + "\n"


# Many rows left out (or averaged) are reported in one line, not one line each: their count,
# every line as ranges, some of their names; --json lists each.
UNMATCHED = [
    ("joint-rows-without-point", "joints.csv", _more_joint_rows, 60,
     "warning: 40 joint rows have no point, left out: lines 62-101 (P60, P61"),
    ("points-without-joint-row", "points.txt", _more_points, 60,
     "warning: 30 points have no joint row, left out: lines 64-93 (P60, P61"),
    ("points-measured-twice", "points.txt", _points_twice, 60,
     "note: 60 points measured more than once, averaged (P0, P1, P10"),
]


@pytest.mark.parametrize("name, make, matched, says", [u[1:] for u in UNMATCHED], ids=[u[0] for u in UNMATCHED])
def test_rows_left_out_of_an_import_are_reported_in_one_line(name, make, matched, says, folder, tmp_path,
                                                            monkeypatch):
    copy_inputs(folder, tmp_path, monkeypatch)
    (tmp_path / name).write_text(make(folder))
    result = run_ok("import", "--points", "points.txt", "--joints", "joints.csv", "--out", "m.csv")
    notes = [line for line in result.output.splitlines() if line.startswith(("warning:", "note:"))]
    assert len(notes) == 1 and notes[0].startswith(says), notes
    assert len(notes[0]) < 160 and f"{matched} poses joined" in result.output
    listed = json.loads(run_ok("import", "--points", "points.txt", "--joints", "joints.csv", "--out", "m.csv",
                               "--json").output)
    assert sum(map(len, (listed["joint_rows_without_point"], listed["points_without_joint_row"],
                         listed["averaged"]))) == int(says.split()[1])
