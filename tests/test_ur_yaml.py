"""`robocal export --format ur-yaml` (robocal.io.ur_yaml): UR's ROS 2 kinematics file, rebuilt
here as ur_description builds the arm from it, reproduces the calibrated forward kinematics up
to wrist_3_link; the nominal arm's file is UR's published default; refusals in one line."""
import json

import numpy as np
import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.io.library import builtin
from robocal.io.model_file import load_model
from robocal.io.ur_yaml import SEGMENTS, ur_kinematics


def _rpy(roll, pitch, yaw):
    """A URDF origin's rotation, written out: Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _driver_fk(kinematics, q):
    """base_link_inertia -> wrist_3_link (4x4, mm) as ur_description chains the six origins, each
    followed by the joint's turn about its z axis."""
    pose = np.eye(4)
    for name, angle in zip(SEGMENTS, q):
        entry = kinematics[name]
        origin = np.eye(4)
        origin[:3, :3] = _rpy(entry["roll"], entry["pitch"], entry["yaw"])
        origin[:3, 3] = [1000.0 * entry[axis] for axis in "xyz"]
        turn = np.eye(4)
        turn[:2, :2] = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
        pose = pose @ origin @ turn
    return pose


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    root = tmp_path_factory.mktemp("ur_yaml")
    run_ok("simulate", "ur10", "--n", "100", "--seed", "3", "--out", root / "meas.csv")
    run_ok("calibrate", "ur10", root / "meas.csv", "--out", root / "model.json")
    run_ok("calibrate", "ur10", root / "meas.csv", "--parameters", "full+gains", "--out", root / "gains.json")
    run_ok("simulate", "irb120", "--n", "40", "--seed", "3", "--out", root / "abb.csv")
    run_ok("calibrate", "irb120", root / "abb.csv", "--out", root / "abb.json")
    return root


def test_the_drivers_chain_from_the_yaml_is_the_calibrated_robot(folder, tmp_path):
    yaml = pytest.importorskip("yaml", reason="PyYAML (installed with dask, the test extra) reads the file")
    report = json.loads(run_ok("export", folder / "model.json", "--format", "ur-yaml", "--out", tmp_path / "k.yaml",
                               "--json").stdout)
    document = yaml.safe_load((tmp_path / "k.yaml").read_text())
    kinematics = document["kinematics"]
    assert set(kinematics) == set(SEGMENTS) | {"hash"} and str(kinematics["hash"]).startswith("robocal_")
    calibrated = load_model(folder / "model.json").kinematics.rigid
    bare = calibrated.replace(base=np.eye(4), tool=np.eye(4))
    q = calibrated.random_configurations(50, rng=5)
    worst = max(np.abs(_driver_fk(kinematics, row) - bare.fk(row[None])[0]).max() for row in q)
    assert worst < 1e-9
    # The calibration moved the arm: the file is not the nominal one.
    nominal = builtin("ur10")
    assert max(np.abs(_driver_fk(kinematics, row) - nominal.fk(row[None])[0]).max() for row in q) > 0.05
    assert any("the tool" in line for line in report["left_out"])


def test_the_nominal_ur10s_segments_are_urs_published_default_kinematics():
    ur10 = builtin("ur10")
    segments, left_out = ur_kinematics(ur10, ur10)
    published = {"shoulder": (0, 0, 0.1273, 0, 0, 0), "upper_arm": (0, 0, 0, np.pi / 2, 0, 0),
                 "forearm": (-0.612, 0, 0, 0, 0, 0), "wrist_1": (-0.5723, 0, 0.163941, 0, 0, 0),
                 "wrist_2": (0, -0.1157, 0, np.pi / 2, 0, 0), "wrist_3": (0, 0.0922, 0, np.pi / 2, np.pi, np.pi)}
    for name, (x, y, z, roll, pitch, yaw) in published.items():
        np.testing.assert_allclose(segments[name][:3, 3], [1000 * x, 1000 * y, 1000 * z], atol=1e-9)
        np.testing.assert_allclose(segments[name][:3, :3], _rpy(roll, pitch, yaw), atol=1e-12)
    assert left_out == []


@pytest.mark.parametrize("args, says", [
    ("export abb.json --format ur-yaml --out k.yaml", "is not a UR arm"),
    ("export gains.json --format ur-yaml --out k.yaml", "holds no joint gains"),
    ("export model.json --format ur-yaml --out k.toml", "writes a UR kinematics YAML file"),
])
def test_ur_yaml_export_refuses_in_one_line(args, says, folder, tmp_path, monkeypatch):
    before = copy_inputs(folder, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)
