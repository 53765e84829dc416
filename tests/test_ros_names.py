"""ROS habits: joint columns named by the URDF's joints and tagged with ROS units calibrate to
the model of the q1..qN file in degrees; the names survive the robot file."""
import csv
import json
from pathlib import Path

import numpy as np
import pytest

from refusals import run_ok
from robocal.errors import FileFormatError
from robocal.io.library import load_robot
from robocal.io.robot_file import read_robot, write_robot
from robocal.io.tables import read_measurements

URDF = Path(__file__).resolve().parents[2] / "shared" / "data" / "mukca" / "panda.urdf"
pytestmark = pytest.mark.skipif(not URDF.exists(), reason="the shared Panda URDF is not beside the project")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("ros")
    run_ok("simulate", URDF, "--tip", "ball_link", "--n", "60", "--out", root / "meas.csv")
    names = load_robot(str(URDF), tip="ball_link").joint_names
    rows = list(csv.reader(open(root / "meas.csv", newline="")))
    header = rows[0]
    with open(root / "ros.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow([f"{names[int(c[1:]) - 1]}[rad]" if c.startswith("q") else f"{c}[m]" if c in "xyz" else c
                         for c in header])
        for row in rows[1:]:
            writer.writerow([repr(float(np.radians(float(v)))) if c.startswith("q") else
                             repr(float(v) / 1000) if c in "xyz" else v for c, v in zip(header, row)])
    return root, names


def test_the_urdf_joint_names_are_the_chains(files):
    _, names = files
    assert names == tuple(f"panda_joint{k}" for k in range(1, 8))


def test_a_urdf_named_file_in_radians_and_metres_calibrates_to_the_same_model(files, tmp_path):
    root, _ = files
    plain = json.loads(run_ok("calibrate", URDF, root / "meas.csv", "--tip", "ball_link", "--out", tmp_path / "a.json",
                              "--json").output)
    ros = json.loads(run_ok("calibrate", URDF, root / "ros.csv", "--tip", "ball_link", "--out", tmp_path / "b.json",
                            "--json").output)
    assert abs(plain["residual_after_training"]["mean_mm"] - ros["residual_after_training"]["mean_mm"]) < 1e-9


def test_both_kinds_of_joint_column_in_one_file_are_refused(files, tmp_path):
    root, names = files
    (tmp_path / "both.csv").write_text(f"q1,{names[1]},x,y,z\n1,2,3,4,5\n")
    with pytest.raises(FileFormatError, match="both by the robot's joint names"):
        read_measurements(tmp_path / "both.csv", joint_names=names)


def test_joint_names_survive_a_robot_file(files, tmp_path):
    _, names = files
    write_robot(load_robot(str(URDF), tip="ball_link"), tmp_path / "panda.toml")
    assert read_robot(tmp_path / "panda.toml").joint_names == names


def test_the_exported_urdf_keeps_the_joint_names_and_re_imports_to_the_same_robot(files, tmp_path):
    from robocal.io.urdf import read_urdf, write_urdf

    chain = load_robot(str(URDF), tip="ball_link")
    write_urdf(chain, tmp_path / "out.urdf")
    again = read_urdf(tmp_path / "out.urdf", tip="tcp")
    assert again.joint_names == chain.joint_names
    q = chain.random_configurations(50, np.random.default_rng(1))
    np.testing.assert_allclose(again.fk_positions(q), chain.fk_positions(q), atol=1e-9)


def test_show_lists_the_joint_names():
    shown = run_ok("show", URDF, "--tip", "ball_link").output
    for k in range(1, 8):
        assert f"{k} panda_joint{k}" in shown
