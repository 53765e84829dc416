"""The point of robocal filter: on simulated robots with geometric errors, a filtered program
run by the unchanged controller (the nominal inverse kinematics, the posture the program
names) puts the true robot's TCP on the original targets, where the original program misses
by about a millimetre."""
import numpy as np
import pytest
from filter_support import PROGRAMS, angle_deg, model_of, true_robot

from robocal.interfaces.filter import filter_job, prepare, read_programs
from robocal.io.model_file import load_model

CASES = [("kr150-2", PROGRAMS / "krl" / "pallet_cell.src"),
         ("irb120", PROGRAMS / "rapid" / "PickPlace.mod"),
         ("ur5", PROGRAMS / "urscript" / "feeder_to_tray.script")]


def landing(robot, model, program):
    """(where the true TCP lands (N, 4, 4), where the program means it to be (N, 4, 4)) for
    every target of ``program`` executed by the nominal controller."""
    prepared = prepare(read_programs([program]), model)
    assert np.isfinite(prepared.hints).all()
    t0 = model.nominal.tool
    landed = np.array([pose @ np.linalg.inv(t0) @ tool
                       for pose, (_, tool) in zip(robot.pose(prepared.hints), prepared.frames)])
    meant = np.array([base @ t.pose for t, (base, _) in zip(prepared.targets, prepared.frames)])
    return landed, meant


@pytest.mark.parametrize("name, program", CASES, ids=[c[0] for c in CASES])
def test_the_filtered_program_lands_the_true_robot_on_its_targets(name, program, tmp_path):
    robot = true_robot(name)
    model_path = model_of(robot, tmp_path)
    model = load_model(model_path)
    (tmp_path / "out").mkdir()
    filter_job(model_path, [program], tmp_path / "out", allow_unfiltered=True)
    landed, meant = landing(robot, model, program)
    unfiltered = np.linalg.norm(landed[:, :3, 3] - meant[:, :3, 3], axis=1)
    assert 0.5 < unfiltered.mean() < 2.5, unfiltered  # about 1 mm
    filtered_landed, _ = landing(robot, model, tmp_path / "out" / program.name)
    # The filtered targets, executed, land on the original ones.
    miss = np.linalg.norm(filtered_landed[:, :3, 3] - meant[:, :3, 3], axis=1)
    assert miss.max() <= 0.01, miss
    assert angle_deg(filtered_landed, meant).max() <= 0.001
