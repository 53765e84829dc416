"""Measurement planning: which poses to measure for a calibration (``robocal design``).

Beside the estimators (it imports kinematics and estimation, never methods or interfaces):
candidates (:mod:`.candidates`), the information one pose gives the parametric calibration
(:mod:`.information`), design criteria with rank-3 updates (:mod:`.criteria`), greedy
selection and exchange (:mod:`.exchange`), the measuring order (:mod:`.tour`), the design
and its predicted result (:mod:`.design`), and ball-in-socket campaigns: fixture placements
and configurations per socket for the constraint calibration (:mod:`.sockets`).
"""
from .candidates import box_candidates, joint_candidates, usable
from .criteria import CRITERIA, DEFAULT_CRITERION
from .design import Design, design_poses
from .information import information_model
from .sockets import design_sockets, socket_candidates
from .tour import tour

__all__ = ["CRITERIA", "DEFAULT_CRITERION", "Design", "box_candidates", "design_poses", "design_sockets",
           "information_model", "joint_candidates", "socket_candidates", "tour", "usable"]
