"""The one unit-evidence test (robocal.io.units): the robot itself says which units a file is
in.  Real tracker data written in radians, metres or both are refused with the units named;
the same data in degrees and mm pass; posture hints in radians are refused before they put
every target on another arm branch."""
import csv

import numpy as np
import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.errors import InputError
from robocal.io import datasets, units
from robocal.io.library import builtin
from robocal.io.observations import read_target_poses

REAL = {"ur5": datasets.ur5_tsinghua, "ur10 B": lambda: datasets.ipa_ur10("B")}


@pytest.fixture(scope="module", params=sorted(REAL))
def real(request):
    """The robot and its data in file units (deg, mm): the units a file is judged in."""
    dataset = REAL[request.param]()
    return dataset.chain, dataset.measurements


@pytest.mark.parametrize("angles, scale, says", [
    ("radians", 1.0, "the joint values look like radians: "),
    ("radians", 1e-3, "look like radians and x, y, z look like metres"),
    ("degrees", 1e-3, "they look like metres"),
    ("degrees", 1 / 25.4, "they look like inches"),
])
def test_real_data_in_other_units_are_refused_naming_them(real, angles, scale, says):
    chain, measured = real
    joints = np.radians(measured.joints) if angles == "radians" else measured.joints
    with pytest.raises(InputError, match=says):
        units.check_measurement_units(chain, joints, measured.positions * scale, "real.csv")


def test_real_data_in_degrees_and_mm_fit_the_nominal_robot_to_a_small_share_of_their_spread(real):
    chain, measured = real
    misfits = units.evidence(chain, measured.joints, measured.positions)
    assert misfits[(), "mm"] < 0.01
    assert min(v for k, v in misfits.items() if k != ((), "mm")) > 0.5
    units.check_measurement_units(chain, measured.joints, measured.positions, "real.csv")


def test_small_degree_readings_are_not_taken_for_radians():
    chain = builtin("ur5")
    q = np.random.default_rng(0).uniform(-3.0, 3.0, size=(50, 6))  # degrees, all within one radian turn
    positions = chain.fk_positions(np.radians(q))
    units.check_measurement_units(chain, q, positions, "small.csv")


def _targets(path, chain, hints_deg, radians):
    positions = chain.fk_positions(np.radians(hints_deg))
    hints = np.radians(hints_deg) if radians else hints_deg
    with open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["x", "y", "z", "rx", "ry", "rz"] + [f"q{k}" for k in range(1, 7)])
        for p, h in zip(positions, hints):
            writer.writerow([*p, 180, 0, 0, *h])


@pytest.fixture(scope="module")
def hinted(tmp_path_factory):
    root = tmp_path_factory.mktemp("units")
    chain = builtin("ur5")
    hints = chain.joints_to_file(chain.random_configurations(8, np.random.default_rng(2)))
    _targets(root / "hints_deg.csv", chain, hints, radians=False)
    _targets(root / "hints_rad.csv", chain, hints, radians=True)
    run_ok("simulate", "ur5", "--n", "40", "--out", root / "meas.csv")
    run_ok("calibrate", "ur5", root / "meas.csv", "--out", root / "model.json")
    rows = list(csv.reader(open(root / "meas.csv", newline="")))
    q = [rows[0].index(f"q{k}") for k in range(1, 7)]
    for row in rows[1:]:
        for k in q:
            row[k] = repr(float(np.radians(float(row[k]))))
    with open(root / "meas_rad.csv", "w", newline="") as stream:
        csv.writer(stream).writerows(rows)
    return root


def test_posture_hints_in_radians_are_refused_and_in_degrees_read(hinted):
    chain = builtin("ur5")
    assert read_target_poses(hinted / "hints_deg.csv", chain).hints.shape == (8, 6)
    with pytest.raises(InputError, match="posture hints q1..q6 look like radians"):
        read_target_poses(hinted / "hints_rad.csv", chain)


@pytest.mark.parametrize("args, says", [
    ("compensate model.json hints_rad.csv --out c.csv", "posture hints q1..q6 look like radians"),
    ("calibrate ur5 meas_rad.csv --out m.json", "the joint values look like radians"),
    ("evaluate model.json meas_rad.csv", "the joint values look like radians"),
])
def test_the_command_line_refuses_other_units_in_one_line(args, says, hinted, tmp_path, monkeypatch):
    before = copy_inputs(hinted, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)


def _tagged_copy(source, target, joints="rad", lengths="m"):
    rows = list(csv.reader(open(source, newline="")))
    header = rows[0]
    to_joint = {"rad": np.radians, "deg": lambda v: v}[joints]
    to_length = {"m": 1e-3, "mm": 1.0, "in": 1 / 25.4}[lengths]
    with open(target, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow([f"{c}[{joints}]" if c.startswith("q") else f"{c}[{lengths}]" if c in ("x", "y", "z") else c
                         for c in header])
        for row in rows[1:]:
            writer.writerow([repr(float(to_joint(float(v)))) if c.startswith("q") else
                             repr(float(v) * to_length) if c in ("x", "y", "z") else v for c, v in zip(header, row)])


@pytest.mark.parametrize("joints, lengths", [("rad", "m"), ("deg", "in"), ("rad", "mm")])
def test_a_file_whose_header_tags_its_units_calibrates_to_the_same_model(hinted, tmp_path, joints, lengths):
    _tagged_copy(hinted / "meas.csv", tmp_path / "tagged.csv", joints, lengths)
    plain = run_ok("calibrate", "ur5", hinted / "meas.csv", "--out", tmp_path / "a.json", "--json").output
    tagged = run_ok("calibrate", "ur5", tmp_path / "tagged.csv", "--out", tmp_path / "b.json", "--json").output
    import json
    a, b = json.loads(plain), json.loads(tagged)
    assert abs(a["residual_after_training"]["mean_mm"] - b["residual_after_training"]["mean_mm"]) < 1e-9
    assert a["calibration"]["parameters"].keys() == b["calibration"]["parameters"].keys()


@pytest.mark.parametrize("header, says", [
    ("q1[furlong],q2,q3,q4,q5,q6,x,y,z", "unit 'furlong', which robocal does not know"),
    ("q1,q2,q3,q4,q5,q6,x[deg],y,z", "x is a length, not in deg"),
    ("q1,q2,q3,q4,q5,q6,x,y,z,rx[m],ry,rz", "rx is an angle, not in m"),
])
def test_unit_tags_robocal_cannot_apply_are_refused(header, says, tmp_path):
    from robocal.errors import FileFormatError
    from robocal.io.tables import read_measurements

    width = len(header.split(","))
    (tmp_path / "t.csv").write_text(header + "\n" + ",".join(["1"] * width) + "\n")
    with pytest.raises(FileFormatError, match=says):
        read_measurements(tmp_path / "t.csv")
