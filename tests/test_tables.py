"""Measurement, target, command and fixture files: round trips and every kind of bad input."""

import csv
import os
import warnings

import numpy as np
import pytest

from robocal.errors import FileFormatError, InputError, RobocalWarning
from robocal.io.atomic import write_bytes_atomic, write_text_atomic
from robocal.io.fixtures import Fixture, read_fixture, write_fixture
from robocal.io.tables import (
    Measurements,
    read_measurements,
    read_targets,
    write_commands,
    write_measurements,
)

RNG = np.random.default_rng(20240611)


def write(tmp_path, text, name="meas.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def degrees(rows, joints=6):
    """Joint angles spread over a realistic range in degrees."""
    return RNG.uniform(-170.0, 170.0, size=(rows, joints))


def read_quietly(path, **options):
    """Read, turning any RobocalWarning into an error so that unexpected warnings fail tests."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RobocalWarning)
        return read_measurements(path, **options)


def assert_error(error_info, *fragments):
    message = str(error_info.value)
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} not in {message!r}"


# --------------------------------------------------------------------------- round trips


def test_position_measurements_round_trip_exactly(tmp_path):
    count = 40
    original = Measurements(
        path="",
        joints=degrees(count),
        positions=RNG.uniform(-2500.0, 2500.0, size=(count, 3)) + 1e-7,
        extra={"temperature": np.array([f"{20 + i / 10:.1f}" for i in range(count)])},
    )
    path = write_measurements(tmp_path / "meas.csv", original)
    loaded = read_quietly(path, n_joints=6)
    np.testing.assert_array_equal(loaded.joints, original.joints)
    np.testing.assert_array_equal(loaded.positions, original.positions)
    np.testing.assert_array_equal(loaded.extra["temperature"], original.extra["temperature"])
    np.testing.assert_array_equal(loaded.rows, np.arange(2, count + 2))
    assert loaded.orientations is None and loaded.sigmas is None and loaded.fixture is None
    assert (loaded.kind, loaded.n_poses, loaded.n_joints, loaded.path) == ("position", count, 6, str(path))


def test_pose_measurements_with_sigmas_round_trip(tmp_path):
    count = 12
    original = Measurements(
        path="",
        joints=degrees(count, joints=7),
        positions=RNG.normal(0.0, 1000.0, size=(count, 3)),
        orientations=RNG.uniform(-180.0, 180.0, size=(count, 3)),
        sigmas=RNG.uniform(0.001, 0.05, size=(count, 3)),
    )
    loaded = read_quietly(write_measurements(tmp_path / "pose.csv", original))
    assert loaded.kind == "pose"
    for name in ("joints", "positions", "orientations", "sigmas"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(original, name))


def test_constraint_measurements_round_trip(tmp_path):
    original = Measurements(
        path="",
        joints=degrees(6),
        fixture=np.array(["1", "1", "1", "2", "2", "2"]),
        socket=np.array(["A", "B", "C", "A", "B", "socket, left"]),
    )
    loaded = read_quietly(write_measurements(tmp_path / "sockets.csv", original))
    assert loaded.kind == "constraint" and loaded.positions is None
    np.testing.assert_array_equal(loaded.fixture, original.fixture)
    np.testing.assert_array_equal(loaded.socket, original.socket)


def test_rows_are_file_line_numbers_and_survive_subset(tmp_path):
    text = "q1,q2,x,y,z\n10,20,1,2,3\n\n11,21,4,5,6\n12,22,7,8,9\n"
    measurements = read_quietly(write(tmp_path, text))
    np.testing.assert_array_equal(measurements.rows, [2, 4, 5])
    selected = measurements.subset(np.array([False, True, True]))
    np.testing.assert_array_equal(selected.rows, [4, 5])
    np.testing.assert_array_equal(selected.positions, [[4, 5, 6], [7, 8, 9]])
    np.testing.assert_array_equal(measurements.subset(np.array([2, 0])).joints, [[12, 22], [10, 20]])
    assert measurements.subset([]).n_poses == 0


def test_subset_refuses_a_mask_of_the_wrong_length(tmp_path):
    measurements = read_quietly(write(tmp_path, "q1,x,y,z\n1,1,2,3\n2,4,5,6\n"))
    with pytest.raises(InputError, match="2 entries"):
        measurements.subset(np.array([True]))


def test_commands_keep_every_digit_and_are_refused_as_targets(tmp_path):
    joints = degrees(20)
    positions = RNG.uniform(-2000.0, 2000.0, size=(20, 3)) + 1.23456789012e-5
    orientations = RNG.uniform(-180.0, 180.0, size=(20, 3))
    path = write_commands(tmp_path / "commands.csv", joints, positions, orientations)
    with open(path, newline="") as stream:
        rows = list(csv.reader(stream))
    values = np.array([[float(cell) for cell in row[:12]] for row in rows[1:]])
    assert np.max(np.abs(values[:, 6:9] - positions)) < 1e-9
    np.testing.assert_array_equal(values[:, 9:12], orientations)
    np.testing.assert_array_equal(values[:, :6], joints)
    # Given back as targets, they would be corrected a second time.
    with pytest.raises(FileFormatError, match="written by 'robocal compensate', not a targets file"):
        read_targets(path, n_joints=6)


def test_unreachable_commands_have_empty_joint_cells(tmp_path):
    joints = np.array([[1.5, 2.0], [np.nan, np.nan], [3.0, 4.0]])
    positions = np.array([[1.0, 2.0, 3.0], [np.nan, np.nan, np.nan], [4.0, 5.0, 6.0]])
    orientations = np.zeros((3, 3))
    path = write_commands(tmp_path / "c.csv", joints, positions, orientations, joint_ok=[True, False, True])
    with open(path, newline="") as stream:
        rows = list(csv.reader(stream))
    assert rows[0] == ["q1", "q2", "x", "y", "z", "rx", "ry", "rz", "reachable", "robocal_file"]
    assert rows[1] == ["1.5", "2.0", "1.0", "2.0", "3.0", "0.0", "0.0", "0.0", "1", "commands"]
    assert rows[2] == ["", "", "", "", "", "0.0", "0.0", "0.0", "0", "commands"]
    assert rows[3][-2] == "1"


def test_unreachable_row_never_carries_a_joint_vector(tmp_path):
    joints = np.array([[10.0, 20.0], [30.0, 40.0]])
    path = write_commands(tmp_path / "c.csv", joints, np.ones((2, 3)), np.zeros((2, 3)), joint_ok=[False, True])
    with open(path, newline="") as stream:
        rows = list(csv.reader(stream))
    assert rows[1][:2] == ["", ""] and rows[2][:2] == ["30.0", "40.0"]


def test_commands_refuse_non_finite_joints_of_a_reachable_row(tmp_path):
    joints = np.array([[1.0, np.nan]])
    with pytest.raises(InputError, match="q2"):
        write_commands(tmp_path / "c.csv", joints, np.zeros((1, 3)), np.zeros((1, 3)))
    assert not (tmp_path / "c.csv").exists()


def test_fixture_round_trip(tmp_path):
    fixture = Fixture("plate \"B\"",
                      {"A": [0, 0, 0], "B": [150.0, 0, 0], "C": [0, 120.0, 1e-7], "left side": [1, 2, 3]})
    loaded = read_fixture(write_fixture(tmp_path / "fixture.toml", fixture))
    assert loaded.name == 'plate "B"'
    assert loaded.ids == ("A", "B", "C", "left side")
    for socket_id in fixture.ids:
        np.testing.assert_array_equal(loaded.sockets[socket_id], fixture.sockets[socket_id])
    assert loaded.distance("A", "B") == pytest.approx(150.0)
    distances = loaded.distances()
    assert len(distances) == 6
    assert distances[("B", "C")] == pytest.approx(np.hypot(150.0, 120.0))


def test_fixture_from_design_example(tmp_path):
    path = write(tmp_path, 'name = "plate"\n[sockets]\nA = [0.0, 0.0, 0.0]\nB = [150, 0, 0]\nC = [0.0, 120.0, 0.0]\n',
                 "f.toml")
    fixture = read_fixture(path)
    assert fixture.name == "plate" and fixture.distance("B", "A") == 150.0
    with pytest.raises(InputError, match="no socket 'D'"):
        fixture.distance("A", "D")


# --------------------------------------------------------------------------- atomic writes


def test_atomic_write_to_missing_directory_is_an_input_error(tmp_path):
    missing = tmp_path / "nowhere"
    with pytest.raises(InputError, match=f"directory {missing} does not exist"):
        write_text_atomic(missing / "out.csv", "x")


def test_failed_atomic_write_leaves_the_target_and_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "model.json"
    target.write_text("old")

    def fail(*_):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(InputError, match="cannot write .*model.json: disk full; it is left as it was"):
        write_bytes_atomic(target, b"new")
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["model.json"]


def test_atomic_write_replaces_content_and_keeps_permissions(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    target.chmod(0o640)
    write_text_atomic(target, "new\n")
    assert target.read_bytes() == b"new\n"
    assert target.stat().st_mode & 0o777 == 0o640


# --------------------------------------------------------------------------- file-level errors


def test_missing_file(tmp_path):
    with pytest.raises(FileFormatError) as error:
        read_measurements(tmp_path / "absent.csv")
    assert_error(error, "absent.csv", "does not exist")


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "is empty"),
        ("\n\n", "is empty"),
        (",,\n1,2,3\n", "no header"),
        ("1,2,3,4\n5,6,7,8\n", "not column names"),
        ("q1,x,y,z\n", "no data rows"),
        ("q1;x;y;z\n1;2;3;4\n", "not comma-separated"),
    ],
)
def test_unusable_file_structure(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), expected)


def test_row_with_a_wrong_number_of_cells_is_named(tmp_path):
    path = write(tmp_path, "q1,x,y,z\n1,2,3,4\n1,2,3\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "row 3", "3 cells", "4 columns")


def test_unquoted_decimal_comma_breaks_the_row(tmp_path):
    path = write(tmp_path, "q1,x,y,z\n1,2,3,4\n1,2,3,4,5\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, "row 3", "decimal comma")


def test_duplicate_header_column(tmp_path):
    path = write(tmp_path, "q1,x,y,z,x\n1,2,3,4,5\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "'x' appears twice", "columns 2 and 5")


def test_trailing_commas_of_spreadsheets_are_tolerated_but_unnamed_data_are_not(tmp_path):
    measurements = read_quietly(write(tmp_path, "q1,x,y,z,\n1,2,3,4,\n"))
    assert measurements.extra == {}
    path = write(tmp_path, "q1,x,y,z,\n1,2,3,4,\n1,2,3,4,7\n", "named.csv")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "row 3", "column 5", "no name")


# --------------------------------------------------------------------------- column errors


def test_gap_in_joint_columns_names_the_missing_one(tmp_path):
    path = write(tmp_path, "q1,q2,q4,x,y,z\n1,2,3,4,5,6\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "no q3")


def test_joint_count_must_match_the_robot(tmp_path):
    path = write(tmp_path, "q1,q2,q3,q4,q5,x,y,z\n1,2,3,4,5,6,7,8\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path, n_joints=6)
    assert_error(error, str(path), "has 5 joint columns (q1..q5) but the robot has 6 joints")


def test_zero_based_joint_columns(tmp_path):
    path = write(tmp_path, "q0,q1,x,y,z\n1,2,3,4,5\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "numbered from q1")


def test_no_joint_columns(tmp_path):
    path = write(tmp_path, "x,y,z\n1,2,3\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "no joint columns")


@pytest.mark.parametrize(
    ("header", "written", "meant"),
    [
        ("q1,X,y,z", "X", "x"),
        ("q_1,q2,x,y,z", "q_1", "q1"),
        ("q1,xx,y,z", "xx", "x"),
        ("q1,x,y,z,Rx,ry,rz", "Rx", "rx"),
        ("q1,fixtures,socket", "fixtures", "fixture"),
    ],
)
def test_misspelt_column_gets_a_suggestion(tmp_path, header, written, meant):
    cells = ",".join(["1"] * len(header.split(",")))
    path = write(tmp_path, f"{header}\n{cells}\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), f"column '{written}' is not known: did you mean '{meant}'?")


def test_unrelated_and_derived_columns_are_kept_as_extra(tmp_path):
    path = write(tmp_path, "q1,x,y,z,temperature,dx,operator\n1,2,3,4,21.5,0.1,Anna\n")
    measurements = read_quietly(path)
    assert sorted(measurements.extra) == ["dx", "operator", "temperature"]
    assert measurements.extra["operator"][0] == "Anna"


@pytest.mark.parametrize(
    ("header", "missing"),
    [
        ("q1,x,y", "not z"),
        ("q1,x,y,z,rx,ry", "not rz"),
        ("q1,x,y,z,sx", "not sy, sz"),
        ("q1,fixture", "not socket"),
    ],
)
def test_partial_column_group_names_the_missing_column(tmp_path, header, missing):
    cells = ",".join(["1"] * len(header.split(",")))
    path = write(tmp_path, f"{header}\n{cells}\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), missing)


def test_neither_positions_nor_constraints(tmp_path):
    path = write(tmp_path, "q1,q2\n1,2\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "x, y, z", "fixture, socket")


def test_orientation_without_position(tmp_path):
    path = write(tmp_path, "q1,rx,ry,rz,fixture,socket\n1,2,3,4,1,A\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "rx, ry, rz but no x, y, z")


# --------------------------------------------------------------------------- cell errors


@pytest.mark.parametrize(
    ("cell", "expected"),
    [
        ("abc", "'abc' is not a number"),
        ("", "is empty"),
        ("nan", "'nan' is not a finite number"),
        ("-inf", "'-inf' is not a finite number"),
        ('"1,5"', "'.' as the decimal point"),
    ],
)
def test_bad_cell_names_row_and_column(tmp_path, cell, expected):
    path = write(tmp_path, f"q1,q2,x,y,z\n1,2,3,4,5\n1,2,{cell},4,5\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "row 3, column 'x'", expected)


def test_empty_socket_id(tmp_path):
    path = write(tmp_path, "q1,fixture,socket\n1,1,A\n2,1, \n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "row 3, column 'socket'", "empty")


@pytest.mark.parametrize("sigma", ["0", "-0.01"])
def test_sigmas_must_be_positive(tmp_path, sigma):
    path = write(tmp_path, f"q1,x,y,z,sx,sy,sz\n1,2,3,4,0.01,0.01,0.01\n1,2,3,5,0.01,{sigma},0.01\n")
    with pytest.raises(FileFormatError) as error:
        read_measurements(path)
    assert_error(error, str(path), "row 3, column 'sy'", "> 0", sigma)


# --------------------------------------------------------------------------- warnings


def _csv(joints, positions):
    header = ",".join([f"q{i + 1}" for i in range(joints.shape[1])] + ["x", "y", "z"])
    lines = [",".join(repr(v) for v in row) for row in np.hstack([joints, positions]).tolist()]
    return header + "\n" + "\n".join(lines) + "\n"


def test_joint_values_in_radians_give_a_warning(tmp_path):
    path = write(tmp_path, _csv(np.radians(degrees(20)), RNG.normal(size=(20, 3))))
    with pytest.warns(RobocalWarning, match="look like radians") as record:
        measurements = read_measurements(path)
    assert str(path) in str(record[0].message)
    assert measurements.n_poses == 20


@pytest.mark.parametrize(
    "joints",
    [
        degrees(20),  # ordinary degrees
        np.radians(degrees(4)),  # too few rows to judge
        np.full((20, 6), 1.0) + RNG.uniform(0.0, 0.01, size=(20, 6)),  # small moves near one pose
    ],
)
def test_no_radian_warning_without_evidence(tmp_path, joints):
    read_quietly(write(tmp_path, _csv(joints, RNG.normal(size=(len(joints), 3)))))


def test_identical_rows_give_a_warning_naming_both_lines(tmp_path):
    joints, positions = degrees(50), RNG.normal(size=(50, 3))
    joints[38], positions[38] = joints[10], positions[10]  # lines 12 and 40
    path = write(tmp_path, _csv(joints, positions))
    with pytest.warns(RobocalWarning, match="rows 12 and 40 are identical: a repeated export") as record:
        measurements = read_measurements(path)
    assert str(path) in str(record[0].message)
    assert measurements.n_poses == 50


def test_same_joints_in_different_sockets_are_not_duplicates(tmp_path):
    read_quietly(write(tmp_path, "q1,q2,fixture,socket\n10,20,1,A\n10,20,1,B\n"))


# --------------------------------------------------------------------------- targets


def test_targets_without_hints(tmp_path):
    path = write(tmp_path, "x,y,z,rx,ry,rz,comment\n1,2,3,0,90,180,first\n4,5,6,0,0,0,second\n", "t.csv")
    targets = read_targets(path)
    assert targets.hints is None and targets.n_targets == 2
    np.testing.assert_array_equal(targets.orientations[0], [0, 90, 180])
    np.testing.assert_array_equal(targets.rows, [2, 3])


def test_targets_need_all_six_pose_columns(tmp_path):
    path = write(tmp_path, "q1,x,y,z,rx,ry\n1,2,3,4,5,6\n", "t.csv")
    with pytest.raises(FileFormatError) as error:
        read_targets(path)
    assert_error(error, str(path), "lacks column rz")


def test_targets_bad_cell_and_joint_count(tmp_path):
    path = write(tmp_path, "q1,q2,x,y,z,rx,ry,rz\n1,2,3,4,5,6,7,8\n1,2,3,4,5,6,seven,8\n", "t.csv")
    with pytest.raises(FileFormatError) as error:
        read_targets(path)
    assert_error(error, str(path), "row 3, column 'ry'", "'seven' is not a number")
    with pytest.raises(FileFormatError) as error:
        read_targets(path, n_joints=6)
    assert_error(error, "has 2 joint columns (q1..q2) but the robot has 6 joints")


# --------------------------------------------------------------------------- fixture errors


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('name = "p"\n[socket]\nA = [0, 0, 0]\n', "no [sockets] table (is [socket] meant to be [sockets]?)"),
        ("[sockets]\nA = [0, 0]\nB = [1, 0, 0]\n", "socket A = [0, 0] is not three finite numbers"),
        ('[sockets]\nA = [0, 0, "z"]\nB = [1, 0, 0]\n', "socket A"),
        ("[sockets]\nA = [0, 0, nan]\nB = [1, 0, 0]\n", "not three finite numbers"),
        ("[sockets]\nA = [0, 0, true]\nB = [1, 0, 0]\n", "not three finite numbers"),
        ("[sockets]\nA = [0, 0, 0]\n", "has 1 socket: the calibration uses distances between sockets"),
        ("[sockets]\nA = [0, 0, 0]\nB = [1, 0, 0]\nC = [0.0, 0.0, 0.0]\n", "sockets A and C are both at"),
        ("[sockets\nA = 1\n", "is not valid TOML"),
    ],
)
def test_bad_fixture_file(tmp_path, text, expected):
    path = write(tmp_path, text, "fixture.toml")
    with pytest.raises(FileFormatError) as error:
        read_fixture(path)
    assert_error(error, str(path), expected)


def test_missing_fixture_file(tmp_path):
    with pytest.raises(FileFormatError, match="absent.toml does not exist"):
        read_fixture(tmp_path / "absent.toml")


# --------------------------------------------------------------------------- speed


def test_twelve_thousand_rows_read_quickly(tmp_path):
    import time

    count = 12_000
    original = Measurements(
        path="",
        joints=degrees(count),
        positions=RNG.normal(0.0, 1000.0, size=(count, 3)),
        sigmas=np.full((count, 3), 0.01),
    )
    path = write_measurements(tmp_path / "big.csv", original)
    start = time.process_time()  # the reader's work, not what else the machine runs meanwhile
    loaded = read_quietly(path)
    elapsed = time.process_time() - start
    np.testing.assert_array_equal(loaded.positions, original.positions)
    assert elapsed < 1.0


def test_written_numbers_carry_no_rounding_noise(tmp_path):
    joints = np.array([[2.598e-16, -0.0, 90.0]])
    path = write_commands(tmp_path / "c.csv", joints, np.array([[-1e-14, 1.5, 0.0]]), np.array([[0.0, -0.0, 180.0]]))
    with open(path, newline="") as stream:
        rows = list(csv.reader(stream))
    assert rows[1] == ["0.0", "0.0", "90.0", "0.0", "1.5", "0.0", "0.0", "0.0", "180.0", "commands"]


def test_a_row_repeated_many_times_is_named_by_a_few_of_its_rows(tmp_path):
    path = tmp_path / "repeated.csv"
    path.write_text("q1,q2,q3,q4,q5,q6,x,y,z\n" + "10,20,30,40,50,60,400,100,300\n" * 40)
    with pytest.warns(RobocalWarning, match=r"rows 2, 3, 4, 5, 6 and 35 more are identical") as record:
        read_measurements(path)
    assert ", 7," not in str(record[0].message)  # the other 35 rows are counted, not listed
