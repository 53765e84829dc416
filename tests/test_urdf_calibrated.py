"""`robocal export --format urdf --urdf ORIGINAL.urdf`: the calibrated robot written into its
own URDF (robocal.io.urdf_update) keeps the original's joint and link names, meshes, limits
and other branches, changes only joint origins, re-imports to the calibrated forward
kinematics and so to the same error, and an independent URDF parser (yourdfpy) reads it with
the original joint names and the same forward kinematics; refusals in one line."""
import csv
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.io.model_file import load_model
from robocal.io.urdf import read_urdf

PANDA = Path(__file__).resolve().parents[1] / "robocal" / "io" / "data" / "mukca" / "panda.urdf"


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A Panda read from its URDF (tip panda_link8), calibrated on 80 simulated poses, and
    exported into its own URDF."""
    root = tmp_path_factory.mktemp("urdf_calibrated")
    run_ok("simulate", PANDA, "--tip", "panda_link8", "--n", "80", "--seed", "2", "--out", root / "meas.csv")
    run_ok("calibrate", PANDA, root / "meas.csv", "--tip", "panda_link8", "--out", root / "model.json")
    report = json.loads(run_ok("export", root / "model.json", "--format", "urdf", "--urdf", PANDA, "--out",
                               root / "cal.urdf", "--json").stdout)
    return root, report


def _elements(path):
    robot = ET.parse(path).getroot()
    return ({e.get("name"): e for e in robot.findall("link")}, {e.get("name"): e for e in robot.findall("joint")})


def test_only_joint_origins_change_and_names_meshes_limits_stay(exported):
    root, report = exported
    links, joints = _elements(PANDA)
    new_links, new_joints = _elements(root / "cal.urdf")
    assert report["root"] == "panda_link0" and report["tip"] == "panda_link8"
    assert set(new_links) == set(links) | set(report["added_links"])
    assert set(new_joints) == set(joints) | {f"{name}_joint" for name in report["added_links"]}
    for name, link in links.items():  # meshes, inertias, collisions: the same elements
        assert ET.tostring(new_links[name]).replace(b" />", b"/>") == ET.tostring(link).replace(b" />", b"/>")
    for name, joint in joints.items():
        new = new_joints[name]
        for child in joint:
            if child.tag != "origin":
                assert child.attrib == new.find(child.tag).attrib, (name, child.tag)
        origin_changed = joint.find("origin").attrib != new.find("origin").attrib
        assert origin_changed == (name in report["changed_joints"])
    assert {f"panda_joint{k}" for k in range(1, 8)} <= set(report["changed_joints"])
    assert not {"panda_finger_joint1", "panda_finger_joint2", "panda_hand_joint"} & set(report["changed_joints"])


def test_the_exported_urdf_reimports_to_the_calibrated_kinematics_and_the_same_error(exported):
    root, report = exported
    calibrated = load_model(root / "model.json").kinematics.rigid
    chain = read_urdf(root / "cal.urdf", tip=report["added_links"][-1])
    assert chain.joint_names == tuple(f"panda_joint{k}" for k in range(1, 8))
    q = calibrated.random_configurations(300, rng=3)
    np.testing.assert_allclose(chain.fk(q), calibrated.fk(q), rtol=0, atol=1e-8)
    rows = list(csv.DictReader(open(root / "meas.csv", newline="")))
    joints = np.radians([[float(r[f"q{k}"]) for k in range(1, 8)] for r in rows])
    measured = np.array([[float(r[a]) for a in "xyz"] for r in rows])
    evaluated = json.loads(run_ok("evaluate", root / "model.json", root / "meas.csv", "--json").stdout)
    stats = evaluated.get("residual_after", evaluated)
    errors = np.linalg.norm(chain.fk_positions(joints) - measured, axis=1)
    assert abs(errors.mean() - stats["mean_mm"]) < 1e-6 and abs(errors.max() - stats["max_mm"]) < 1e-6


def test_yourdfpy_reads_the_original_joint_names_and_the_calibrated_kinematics(exported):
    yourdfpy = pytest.importorskip("yourdfpy", reason="yourdfpy (the test extra) is not installed")
    root, report = exported
    calibrated = load_model(root / "model.json").kinematics.rigid
    robot = yourdfpy.URDF.load(str(root / "cal.urdf"), load_meshes=False, build_collision_scene_graph=False,
                               load_collision_meshes=False)
    assert robot.actuated_joint_names[:7] == [f"panda_joint{k}" for k in range(1, 8)]
    worst = 0.0
    for q in calibrated.random_configurations(20, rng=4):
        values = dict(zip(calibrated.joint_names, q))
        robot.update_cfg(np.array([values.get(name, 0.0) for name in robot.actuated_joint_names]))
        pose = robot.get_transform(frame_to=report["added_links"][-1], frame_from=report["added_links"][0])
        expected = calibrated.fk(q[None])[0]
        worst = max(worst, np.abs(pose[:3, 3] * 1000.0 - expected[:3, 3]).max())
        np.testing.assert_allclose(pose[:3, :3], expected[:3, :3], rtol=0, atol=1e-9)
    assert worst < 1e-6  # mm


@pytest.fixture(scope="module")
def refusal_folder(exported, tmp_path_factory):
    root, _ = exported
    folder = tmp_path_factory.mktemp("urdf_refusals")
    for name in ("model.json", "meas.csv"):
        (folder / name).write_bytes((root / name).read_bytes())
    (folder / "panda.urdf").write_bytes(PANDA.read_bytes())
    # The same robot with joint 3's link 1 mm longer: not the one calibrated from.
    (folder / "other.urdf").write_text(PANDA.read_text().replace('xyz="0 -0.316 0"', 'xyz="0 -0.317 0"'))
    run_ok("calibrate", PANDA, folder / "meas.csv", "--tip", "panda_link8", "--parameters", "full+gains", "--out",
           folder / "gains.json")
    return folder


@pytest.mark.parametrize("args, says", [
    ("export model.json --format urdf --urdf other.urdf --out c.urdf", "holds no chain of links whose forward"),
    ("export model.json --format toml --urdf panda.urdf --out c.toml", "give --format urdf"),
    ("export model.json --format urdf --urdf panda.urdf --convention dh --out c.urdf", "and no --convention"),
    ("export gains.json --format urdf --urdf panda.urdf --out c.urdf", "scales or couples joints"),
    ("export model.json --format urdf --urdf meas.csv --out c.urdf", "meas.csv is a measurement file"),
])
def test_export_into_the_original_urdf_refuses_in_one_line(args, says, refusal_folder, tmp_path, monkeypatch):
    before = copy_inputs(refusal_folder, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)
