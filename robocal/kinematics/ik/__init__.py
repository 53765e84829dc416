"""Inverse kinematics: closed forms for spherical-wrist and UR-type arms, a batched numerical
solver for any chain, and :func:`solve_ik`, which combines them."""
from .closed_form import ClosedForm
from .numeric import IKResult, solve_numeric
from .opw import SphericalWrist
from .point import PointSolver
from .solve import closed_form, ik_all, solve_ik
from .ur import OffsetWrist

__all__ = [
    "ClosedForm", "IKResult", "OffsetWrist", "PointSolver", "SphericalWrist", "closed_form",
    "ik_all", "solve_ik", "solve_numeric",
]
