"""Layer 1: batched rigid-body math (rotations, homogeneous transforms, SO(3)/SE(3) maps).

Conventions: lengths in mm, angles in radians, 6-vectors ordered [linear; angular]
(a twist is [v; w], a Jacobian row block is [dp; dw]).  Every function accepts a single
element or a leading batch axis.
"""
from .rotations import matrix_to_rpy, rot_x, rot_y, rot_z, rpy_to_matrix
from .transforms import (
    chained,
    compose_pose,
    invert,
    make_transform,
    pose_to_xyz_rpy,
    transform_points,
    translation,
)
from .lie import adjoint, hat, se3_exp, se3_log, so3_exp, so3_log, vee

__all__ = [
    "adjoint", "chained", "compose_pose", "hat", "invert", "make_transform", "matrix_to_rpy",
    "pose_to_xyz_rpy", "rot_x", "rot_y", "rot_z", "rpy_to_matrix", "se3_exp", "se3_log",
    "so3_exp", "so3_log", "transform_points", "translation", "vee",
]
