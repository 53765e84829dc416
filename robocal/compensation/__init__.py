"""Layer 6: compensation — a kinematic model plus an optional error model, turned into joint
commands or corrected Cartesian targets."""
from .compensator import CommandResult, Compensator
from .joint_space import correct_joints
from .protocol import CompensatorProtocol, ErrorModel

__all__ = ["CommandResult", "Compensator", "CompensatorProtocol", "ErrorModel", "correct_joints"]
