"""Layer 4: simulated robots with known errors, and sampling plans.

A :class:`TrueRobot` is the hidden reality (geometric deviations, joint compliance under
gravity, gear backlash, measurement noise) that calibration is scored against;
:func:`make_true_robot` builds one from a preset (``none``, ``typical``, ``liu2022``).
The sampling plans choose the configurations to measure.
"""
from ..kinematics.gravity import GRAVITY
from .joint_effects import Compliance, backlash_offsets
from .presets import PRESETS, make_true_robot
from .sampling import grid, latin_hypercube_box, liu2022_plan, uniform_joints
from .true_robot import TrueRobot, read_truth, write_truth

__all__ = [
    "GRAVITY", "PRESETS", "Compliance", "TrueRobot", "backlash_offsets", "grid",
    "latin_hypercube_box", "liu2022_plan", "make_true_robot", "read_truth",
    "uniform_joints", "write_truth",
]
