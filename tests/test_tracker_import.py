"""Tracker points joined to a joint log (robocal.io.tracker_points, robocal.io.point_join):
SpatialAnalyzer-style exports in every dialect give the measurement file a hand-made join
gives; unmatched rows are reported, never guessed; repeated points are averaged."""
import csv

import numpy as np
import pytest

from robocal.errors import FileFormatError, InputError
from robocal.io.csv_writing import write_measurements
from robocal.io.point_join import join
from robocal.io.tables import Measurements, read_measurements
from robocal.io.tracker_points import read_points
from robocal.io.library import builtin
from robocal.simulation import make_true_robot

RNG = np.random.default_rng(11)


@pytest.fixture(scope="module")
def campaign():
    chain = builtin("ur5")
    q = chain.random_configurations(30, np.random.default_rng(4))
    positions = make_true_robot(chain, "typical", seed=2).measure(q, np.random.default_rng(5))
    return chain.joints_to_file(q), positions


def _points_file(path, names, positions, dialect):
    """Write the points as tracker software would, in one of several dialects."""
    if dialect == "sa":  # semicolons, decimal commas, metres stated in a comment, a header
        lines = ["// SpatialAnalyzer export", "// Units: Meters", "Collection;Group;Point;X;Y;Z"]
        lines += [f"A;robot;{n};" + ";".join(f"{v / 1000:.9f}".replace(".", ",") for v in p)
                  for n, p in zip(names, positions)]
    elif dialect == "tabs":  # tabs, header with units in brackets, a comment with #
        lines = ["# tracker run 3", "Name\tX [mm]\tY [mm]\tZ [mm]\tUncertainty [mm]"]
        lines += ["\t".join([n] + [repr(float(v)) for v in p] + ["0.01"]) for n, p in zip(names, positions)]
    else:  # spaces, no header
        lines = [" ".join([n] + [repr(float(v)) for v in p]) for n, p in zip(names, positions)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _joint_log(path, names, joints, times=None):
    with open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["point"] * (names is not None) + ["time"] * (times is not None)
                        + [f"q{k}" for k in range(1, joints.shape[1] + 1)])
        for k, row in enumerate(joints):
            writer.writerow(([names[k]] if names is not None else []) + ([times[k]] if times is not None else [])
                            + [repr(float(v)) for v in row])


@pytest.mark.parametrize("dialect", ["sa", "tabs", "spaces"])
def test_every_dialect_joins_to_the_hand_made_measurement_file(campaign, dialect, tmp_path):
    joints, positions = campaign
    names = [f"P{k:03d}" for k in range(len(joints))]
    order = RNG.permutation(len(joints))  # the tracker measured them in another order
    _points_file(tmp_path / "points.txt", [names[k] for k in order], positions[order], dialect)
    _joint_log(tmp_path / "joints.csv", names, joints)
    data, report = join(read_points(tmp_path / "points.txt"), tmp_path / "joints.csv")
    assert report.matched == len(joints) and not report.joints_without_point and not report.points_without_joints
    np.testing.assert_allclose(data.joints, joints, atol=1e-12)
    np.testing.assert_allclose(data.positions, positions, atol=1e-6)  # nine decimals of a metre
    write_measurements(tmp_path / "meas.csv", data)
    hand = Measurements(path="", joints=joints, positions=positions)
    write_measurements(tmp_path / "hand.csv", hand)
    a, b = read_measurements(tmp_path / "meas.csv"), read_measurements(tmp_path / "hand.csv")
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-6)


def test_unmatched_rows_are_reported_and_repeats_averaged(campaign, tmp_path):
    joints, positions = campaign
    names = [f"P{k}" for k in range(len(joints))]
    measured = list(zip(names[:-2], positions[:-2])) + [("P0", positions[0] + [0.02, 0, 0]), ("STRAY", positions[5])]
    _points_file(tmp_path / "points.txt", [n for n, _ in measured], np.array([p for _, p in measured]), "spaces")
    _joint_log(tmp_path / "joints.csv", names, joints)
    data, report = join(read_points(tmp_path / "points.txt"), tmp_path / "joints.csv")
    assert report.matched == len(joints) - 2
    assert [k for _, k in report.joints_without_point] == names[-2:]
    assert [k for _, k in report.points_without_joints] == ["STRAY"]
    (name, count, spread), = report.duplicates
    assert (name, count) == ("P0", 2) and abs(spread - 0.01) < 1e-9
    np.testing.assert_allclose(data.positions[0], positions[0] + [0.01, 0, 0], atol=1e-9)


def test_join_by_nearest_timestamp_uses_each_point_once(campaign, tmp_path):
    joints, positions = campaign
    times = np.arange(len(joints)) * 5.0
    lines = ["name time x y z"] + [f"T{k} {times[k] + 0.1:.3f} " + " ".join(repr(float(v)) for v in p)
                                   for k, p in enumerate(positions)]
    (tmp_path / "points.txt").write_text("\n".join(lines) + "\n")
    _joint_log(tmp_path / "joints.csv", None, joints, times=[f"{t:.3f}" for t in times])
    data, report = join(read_points(tmp_path / "points.txt"), tmp_path / "joints.csv", by="time", max_dt=0.5)
    assert report.matched == len(joints)
    np.testing.assert_allclose(data.positions, positions)
    with pytest.raises(InputError, match="no joint row"):  # 0.1 s apart, beyond max_dt
        join(read_points(tmp_path / "points.txt"), tmp_path / "joints.csv", by="time", max_dt=0.05)


@pytest.mark.parametrize("text, says", [
    ("// Units: furlongs\nP1 1 2 3\n", "unit 'furlongs'"),
    ("P1;1;2\nP2;1;2;3;4\n", "do not split into the same number of fields"),
    ("name x y\nP1 1 2\n", "names no z column"),
    ("// units: m\nName X[mm] Y[mm] Z[mm]\nP1 1 2 3\n", "states two units"),
])
def test_point_files_robocal_cannot_read_are_refused_in_one_line(text, says, tmp_path):
    (tmp_path / "p.txt").write_text(text)
    with pytest.raises(FileFormatError, match=says):
        read_points(tmp_path / "p.txt")


def test_a_name_logged_twice_with_other_joints_is_refused(campaign, tmp_path):
    joints, positions = campaign
    _points_file(tmp_path / "points.txt", ["A", "B"], positions[:2], "spaces")
    _joint_log(tmp_path / "joints.csv", ["A", "A"], joints[:2])
    with pytest.raises(FileFormatError, match="point A is logged twice with different joints"):
        join(read_points(tmp_path / "points.txt"), tmp_path / "joints.csv")


def test_units_given_must_not_contradict_the_file(tmp_path):
    (tmp_path / "p.txt").write_text("// Units: m\nP1 1 2 3\n")
    with pytest.raises(InputError, match="contradicts"):
        read_points(tmp_path / "p.txt", units="mm")
    assert read_points(tmp_path / "p.txt", units="m").positions.tolist() == [[1000.0, 2000.0, 3000.0]]
