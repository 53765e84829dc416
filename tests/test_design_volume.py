"""A design the robot can execute (robocal.planning.workspace): drawn candidates keep the arm
above its mounting plane unless told otherwise, within walls when given, and the design says
what it assumed."""
import csv
import json

import numpy as np
import pytest

from refusals import assert_refused, copy_inputs, run_ok
from robocal.io.library import builtin
from robocal.planning.candidates import joint_candidates
from robocal.planning.workspace import WorkingVolume


def _planned_points(path, chain):
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    q = chain.joints_from_file([[float(r[f"q{k}"]) for k in range(1, chain.n_joints + 1)] for r in rows])
    return WorkingVolume().points(chain, q)


# (robot, options, the floor, the walls): the README's line first, then hostile pass 5's robots,
# criteria, samplings, parameter sets, a raised floor and walls.
DESIGNS = [
    ("ur5", "--n 30 --pool 2000", 0.0, None),
    ("ur10", "--n 30 --pool 800", 0.0, None),
    ("irb120", "--n 20 --pool 800", 0.0, None),
    ("fanuc-r2000ic-165f", "--n 20 --pool 800", 0.0, None),
    ("iiwa14", "--n 25 --pool 800", 0.0, None),
    ("panda", "--n 25 --pool 800", 0.0, None),
    ("kr150-2", "--n 20 --pool 800 --criterion d-optimal", 0.0, None),
    ("ur5", "--n 12 --pool 800 --criterion space-filling", 0.0, None),
    ("ur5", "--n 12 --pool 800 --sampling lhs --order random", 0.0, None),
    ("ur10", "--n 15 --pool 800 --floor 300", 300.0, None),
    ("ur5", "--n 12 --pool 800 --parameters offsets", 0.0, None),
    ("kr150-2", "--n 15 --pool 800 --walls 0,2500,-1500,1500", 0.0, (0.0, 2500.0, -1500.0, 1500.0)),
]


@pytest.mark.parametrize("robot, options, floor, walls", DESIGNS, ids=[f"{r[0]} {r[1]}" for r in DESIGNS])
def test_a_design_keeps_every_joint_and_the_tcp_above_the_mounting_plane(tmp_path, robot, options, floor, walls):
    result = json.loads(run_ok("design", robot, *options.split(), "--out", tmp_path / "p.csv", "--json").output)
    points = _planned_points(tmp_path / "p.csv", builtin(robot))
    assert points[:, :, 2].min() >= floor
    assert ("above the mounting plane" if floor == 0.0 else f"above z = {floor:g} mm") in result["working_volume"]
    if walls is not None:
        assert walls[0] <= points[:, :, 0].min() and points[:, :, 0].max() <= walls[1]
        assert walls[2] <= points[:, :, 1].min() and points[:, :, 1].max() <= walls[3]


def test_without_a_floor_the_same_design_goes_below_the_base(tmp_path):
    run_ok("design", "ur5", "--n", "30", "--pool", "2000", "--floor", "none", "--out", tmp_path / "p.csv")
    assert _planned_points(tmp_path / "p.csv", builtin("ur5"))[:, :, 2].min() < 0.0


def test_walls_and_a_raised_floor_hold_for_every_candidate():
    chain = builtin("kr150-2")
    volume = WorkingVolume(300.0, (-500.0, 2500.0, -1500.0, 1500.0))
    q = joint_candidates(chain, 500, seed=1, volume=volume)
    points = volume.points(chain, q)
    assert len(q) == 500 and points[:, :, 2].min() >= 300.0
    assert points[:, :, 0].min() >= -500.0 and points[:, :, 0].max() <= 2500.0
    assert np.abs(points[:, :, 1]).max() <= 1500.0


def test_the_volume_is_checked_in_the_robot_base_frame_not_the_measurement_frame():
    chain = builtin("ur5")
    moved = chain.replace(base=np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -5000.0], [0, 0, 0, 1]]))
    q = chain.random_configurations(200, np.random.default_rng(0))
    np.testing.assert_array_equal(WorkingVolume().inside(chain, q), WorkingVolume().inside(moved, q))


@pytest.mark.parametrize("args, says", [
    ("design ur5 --n 12 --floor abc --out p.csv", "--floor must be 'none' or a number"),
    ("design ur5 --n 12 --walls 0,-1,0,1 --out p.csv", "each min below its max"),
    ("design ur5 --n 12 --floor 5000 --out p.csv", "keeps the arm in the working volume"),
])
def test_a_volume_no_pose_fits_is_refused_in_one_line(args, says, tmp_path, monkeypatch):
    before = copy_inputs(tmp_path, tmp_path, monkeypatch)
    assert_refused(args.split(), says, tmp_path, before)
