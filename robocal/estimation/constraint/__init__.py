"""Calibration from position and distance constraints: a ball on the flange seated in the
sockets of a fixture, joint angles only.

``data`` groups the configurations by (placement, socket) and pairs them; ``metrics`` scores
any chain against the fixture; ``estimator`` identifies the POE model
(:class:`ConstraintCalibration`).
"""
from .data import PAIRINGS, ConstraintPairs, SocketData, constraint_pairs, socket_data
from .estimator import (SCALE, ConstraintCalibration, ConstraintResult, candidate_parameters, constraint_rows,
                        poe_deviations)
from .metrics import socket_deviations, socket_errors

__all__ = ["PAIRINGS", "SCALE", "ConstraintCalibration", "ConstraintPairs", "ConstraintResult", "SocketData",
           "candidate_parameters", "constraint_pairs", "constraint_rows", "poe_deviations", "socket_data",
           "socket_deviations", "socket_errors"]
