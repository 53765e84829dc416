"""Turn desired TCP targets into commands that make the real robot reach them.

A :class:`Compensator` holds the kinematic model used for IK (the nominal robot, registered
or calibrated) and optionally a Cartesian error model ê(c): the predicted difference between
where the robot really goes and where the model says, as a function of the commanded
position c.  The robot commanded to c lands at c + e(c); to land on P, command c = P − ê(P)
(one step), or solve c = P − ê(c) to a fixed point.
"""
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..kinematics.ik import solve_ik


@dataclass(frozen=True)
class CommandResult:
    """Joint commands for N targets.

    q: (N, n) joints (rad, mm), NaN where unreachable; success: (N,) bool;
    corrected: (N, 4, 4) the Cartesian targets actually sent through IK (the input targets
    moved by the predicted error); predicted_error: (N, 3) mm.
    """

    q: np.ndarray
    success: np.ndarray
    corrected: np.ndarray
    predicted_error: np.ndarray


@dataclass(frozen=True)
class Compensator:
    """Kinematic model + optional Cartesian error model (anything with ``predict(X)``)."""

    chain: object
    error_model: object = None
    nominal: object = None  # the robot whose closed-form IK seeds the solver

    def predicted_error(self, positions):
        """ê at commanded positions (N, 3) mm; zeros without an error model."""
        positions = np.asarray(positions, dtype=float)
        if self.error_model is None:
            return np.zeros_like(positions)
        return np.asarray(self.error_model.predict(positions), dtype=float).reshape(positions.shape)

    def predict_positions(self, joints):
        """Where the real robot's TCP goes for joints (N, n) rad: model FK + ê."""
        commanded = self.chain.fk_positions(joints)
        return commanded + self.predicted_error(commanded)

    def corrected_targets(self, targets, *, iterate=False, tolerance=1e-7, max_iterations=50):
        """Cartesian targets to command so the robot lands on ``targets`` (N, 4, 4).

        Returns (corrected (N, 4, 4), predicted error at the corrected positions (N, 3)).
        """
        targets = np.asarray(targets, dtype=float)
        if targets.ndim != 3 or targets.shape[1:] != (4, 4):
            raise InputError(f"targets must be (N, 4, 4) poses, got shape {targets.shape}")
        goal = targets[:, :3, 3]
        error = self.predicted_error(goal)
        command = goal - error
        if iterate and self.error_model is not None:
            for _ in range(max_iterations):
                error = self.predicted_error(command)
                new_command = goal - error
                change = np.max(np.abs(new_command - command))
                command = new_command
                if change < tolerance:
                    break
        corrected = targets.copy()
        corrected[:, :3, 3] = command
        return corrected, error

    def commands(self, targets, hint=None, *, iterate=False):
        """Joint commands (through IK of the model) for (N, 4, 4) targets."""
        corrected, error = self.corrected_targets(targets, iterate=iterate)
        # A compliant model is solved on its rigid geometry, then the commands are moved so
        # that the joints, once gravity has bent them, stand where the rigid solution is.
        rigid = getattr(self.chain, "rigid", self.chain)
        result = solve_ik(rigid, corrected, hint=hint, nominal=self.nominal)
        q = result.q if rigid is self.chain else self.chain.commands_for(result.q)
        return CommandResult(q, result.success, corrected, error)
