"""One configuration on floats (robocal.kinematics.program.PointProgram): the frames at the
program's marks, and the joint frames built from them, equal to the batch to rounding."""
import numpy as np
import pytest

from robocal.io.library import load_robot
from robocal.kinematics import program, to_poe


def _chains():
    ur5, kr150 = load_robot("ur5"), load_robot("kr150-2")
    names = kr150.parameter_names(("links", "base", "tool"))
    moved = kr150.perturbed(names, np.random.default_rng(1).normal(0.0, 1e-2, len(names)))
    return {"ur5": ur5, "kr150-2 moved": moved, "panda poe": to_poe(load_robot("panda"))}


@pytest.mark.parametrize("name", list(_chains()))
def test_the_frames_at_marks_are_the_batch_snapshots(name):
    chain = _chains()[name]
    ops = chain._compiled[0]
    marks = [op.name for op in ops if op.kind == "mark"][::2]
    point = program.PointProgram(ops, chain.joint_map, chain.revolute, marks=marks)
    q = chain.random_configurations(20, np.random.default_rng(2))
    frame, snapshots = program.run(ops, chain.model_joints(q), marks=marks)
    for k, row in enumerate(q):
        pose, frames = point.pose_marks(row.tolist())
        np.testing.assert_allclose(pose, np.concatenate([frame.x[:, k], frame.y[:, k], frame.z[:, k], frame.t[:, k]]),
                                   rtol=0, atol=1e-9)
        for mark, got in zip(marks, frames):
            s = snapshots[mark]
            np.testing.assert_allclose(got, np.concatenate([s.x[:, k], s.y[:, k], s.z[:, k], s.t[:, k]]),
                                       rtol=0, atol=1e-9)
    # The point program without marks is unchanged: no pose_marks.
    assert program.PointProgram.of(chain).pose_marks is None


def test_a_mark_the_program_lacks_is_refused():
    chain = load_robot("ur5")
    with pytest.raises(ValueError, match="no mark 'J9'"):
        program.PointProgram(chain._compiled[0], chain.joint_map, chain.revolute, marks=["J9"])


@pytest.mark.parametrize("name", list(_chains()))
def test_joint_frames_of_one_configuration_are_the_batch_row(name):
    chain = _chains()[name]
    q = chain.random_configurations(20, np.random.default_rng(3))
    batch = chain.joint_frames(q)
    for k, row in enumerate(q):
        one = chain.joint_frames(row[None])
        for got, expected in zip(one, batch):
            assert got.shape == (1,) + expected.shape[1:]
            np.testing.assert_allclose(got[0], expected[k], rtol=0, atol=1e-9)
