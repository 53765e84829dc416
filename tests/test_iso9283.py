"""ISO 9283 pose and distance characteristics (robocal.acceptance.iso9283) against an
independent computation of the standard's formulas, on simulated campaigns with a known bias
and noise, visits matched by name or by a jittered command, and angles across ±180 deg."""
import csv

import numpy as np
import pytest

from robocal.acceptance.iso9283 import (
    CYCLES, characteristics, cube_poses, group_visits, plan_campaign, pose_characteristics)
from robocal.errors import InputError
from robocal.io.iso_campaign import read_iso_campaign
from robocal.io.library import builtin

RNG = np.random.default_rng(7)


def _by_hand(commanded, attained):
    """The standard's formulas, written out one visit at a time."""
    n = len(attained)
    xc, yc, zc = (sum(c[k] for c in commanded) / n for k in range(3))
    xb, yb, zb = (sum(a[k] for a in attained) / n for k in range(3))
    ap = ((xb - xc) ** 2 + (yb - yc) ** 2 + (zb - zc) ** 2) ** 0.5
    lengths = [((a[0] - xb) ** 2 + (a[1] - yb) ** 2 + (a[2] - zb) ** 2) ** 0.5 for a in attained]
    mean = sum(lengths) / n
    s = (sum((length - mean) ** 2 for length in lengths) / (n - 1)) ** 0.5
    return ap, xb - xc, yb - yc, zb - zc, mean + 3 * s


def _campaign(path, plan, bias, noise, jitter=0.0, angles=False, names=True):
    rows = []
    for cycle in range(CYCLES):
        for name, point in zip(plan.names, plan.positions):
            command = point + RNG.normal(0, jitter, 3)
            attained = command + bias[name] + RNG.normal(0, noise, 3)
            row = {"pose": name, "cycle": cycle + 1, "x_cmd": command[0], "y_cmd": command[1], "z_cmd": command[2],
                   "x": attained[0], "y": attained[1], "z": attained[2]}
            if angles:
                row.update({"rx_cmd": 179.99, "ry_cmd": 0.0, "rz_cmd": -90.0,
                            "rx": 179.99 + 0.02 + RNG.normal(0, 0.01), "ry": RNG.normal(0, 0.01),
                            "rz": -90.0 + RNG.normal(0, 0.01)})
            if not names:
                row.pop("pose")
            rows.append(row)
    with open(path, "w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({k: repr(float(v)) if k not in ("pose",) else v for k, v in r.items()} for r in rows)
    return rows


@pytest.fixture(scope="module")
def plan():
    return plan_campaign(builtin("ur5"))


@pytest.mark.parametrize("names, jitter", [(True, 0.0), (False, 0.3)])
def test_pose_figures_equal_the_standards_formulas_to_1e9(plan, tmp_path, names, jitter):
    bias = {name: RNG.normal(0, 0.5, 3) for name in plan.names}
    rows = _campaign(tmp_path / "iso.csv", plan, bias, noise=0.02, jitter=jitter, names=names)
    result = characteristics(read_iso_campaign(tmp_path / "iso.csv"))
    assert [p.pose for p in result.poses] == list(plan.names)
    for k, pose in enumerate(result.poses):
        visits = rows[k::len(plan.names)]
        commanded = [[r["x_cmd"], r["y_cmd"], r["z_cmd"]] for r in visits]
        attained = [[r["x"], r["y"], r["z"]] for r in visits]
        expected = _by_hand(commanded, attained)
        got = (pose.AP, pose.APx, pose.APy, pose.APz, pose.RP)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
        assert pose.n == CYCLES
        assert abs(pose.AP - np.linalg.norm(bias[pose.pose])) < 0.02  # the bias it was given
        assert (pose.command_spread_mm > 1e-9) == (jitter > 0)


def test_distance_figures_equal_the_standards_formulas(plan, tmp_path):
    bias = {name: RNG.normal(0, 0.5, 3) for name in plan.names}
    rows = _campaign(tmp_path / "iso.csv", plan, bias, noise=0.05)
    result = characteristics(read_iso_campaign(tmp_path / "iso.csv"))
    p2 = [np.array([r["x"], r["y"], r["z"]]) for r in rows if r["pose"] == "P2"]
    p4 = [np.array([r["x"], r["y"], r["z"]]) for r in rows if r["pose"] == "P4"]
    commanded = np.linalg.norm(plan.positions[1] - plan.positions[3])
    d = [np.linalg.norm(a - b) for a, b in zip(p2, p4)]
    mean = sum(d) / len(d)
    s = (sum((x - mean) ** 2 for x in d) / (len(d) - 1)) ** 0.5
    assert result.distance.between == ("P2", "P4") and result.distance.n == CYCLES
    np.testing.assert_allclose([result.distance.AD, result.distance.RD], [mean - commanded, 3 * s], rtol=0, atol=1e-9)


def test_orientation_figures_difference_angles_on_the_circle(plan, tmp_path):
    bias = {name: np.zeros(3) for name in plan.names}
    rows = _campaign(tmp_path / "iso.csv", plan, bias, noise=0.02, angles=True)
    result = characteristics(read_iso_campaign(tmp_path / "iso.csv"))
    visits = rows[0::len(plan.names)]
    a = np.array([r["rx"] for r in visits])
    wrapped = (a - 179.99 + 180) % 360 - 180  # about the command, on the circle
    for pose in result.poses[:1]:
        np.testing.assert_allclose(pose.APa, wrapped.mean(), atol=1e-9)
        np.testing.assert_allclose(pose.RPa, 3 * wrapped.std(ddof=1), atol=1e-9)
        assert abs(pose.APa - 0.02) < 0.01 and pose.RPa < 0.1  # not 360 deg from rows either side of ±180


def test_visits_are_matched_by_command_within_the_tolerance_and_ambiguity_is_refused():
    commanded = np.array([[0, 0, 0], [100, 0, 0], [0.5, 0, 0], [100.4, 0, 0]], dtype=float)
    labels, names = group_visits(commanded, tolerance_mm=2.0)
    assert labels.tolist() == [0, 1, 0, 1] and names == ["P1", "P2"]
    with pytest.raises(InputError, match="give a pose column, or a smaller --match-mm"):
        group_visits(np.array([[0, 0, 0], [3, 0, 0], [1.5, 0, 0]], dtype=float), tolerance_mm=2.0)


def test_a_pose_visited_once_has_no_repeatability():
    with pytest.raises(InputError, match="needs at least two cycles"):
        pose_characteristics("P1", [[0, 0, 0]], [[0, 0, 0]])


def test_the_plan_puts_p2_to_p5_on_the_cubes_diagonal_plane_a_tenth_of_its_diagonal_in():
    points = cube_poses([0, 0, 0], 100.0)
    corner = np.array([-50.0, -50.0, -50.0])
    assert np.allclose(points[0], 0)
    plane = np.cross(points[2] - points[1], points[4] - points[1])
    assert all(abs(np.dot(p - points[1], plane)) < 1e-9 for p in points)  # all five on one plane
    diagonal = np.linalg.norm(np.array([50.0, 50.0, 50.0]) - corner)
    assert np.isclose(np.linalg.norm(points[1] - corner), 0.1 * diagonal)


def test_the_plan_is_reachable_on_one_branch_above_the_mounting_plane(plan):
    chain = builtin("ur5")
    assert np.allclose(chain.replace(base=np.eye(4)).fk_positions(plan.joints), plan.positions, atol=1e-6)
    assert plan.positions[:, 2].min() > 0 and plan.edge_mm > 100


def test_poses_visited_once_are_left_out_and_listed(tmp_path):
    rows = [("P1", 0.0, 0.01), ("P1", 0.0, 0.02), ("P1", 0.0, 0.0), ("Q", 100.0, 0.1)]
    with open(tmp_path / "iso.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["pose", "x_cmd", "y_cmd", "z_cmd", "x", "y", "z"])
        writer.writerows([name, x, 0, 0, x + dx, 0, 0] for name, x, dx in rows)
    result = characteristics(read_iso_campaign(tmp_path / "iso.csv"))
    assert [p.pose for p in result.poses] == ["P1"] and result.visited_once == ("Q",)
    assert result.to_dict()["visited_once"] == ["Q"]
    with open(tmp_path / "once.csv", "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["x_cmd", "y_cmd", "z_cmd", "x", "y", "z"])
        writer.writerows([[0, 0, 0, 0, 0, 0], [100, 0, 0, 100, 0, 0]])
    with pytest.raises(InputError, match="every commanded pose is visited once"):
        characteristics(read_iso_campaign(tmp_path / "once.csv"))
