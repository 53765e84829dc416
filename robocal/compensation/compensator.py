"""Turn desired TCP targets into commands that make the real robot reach them.

A :class:`Compensator` holds the kinematic model used for IK (the nominal robot, registered
or calibrated) and optionally an error model: the predicted difference between where the
robot really goes and where the model says.

* A Cartesian error model ê(c) of the commanded position c (Kriging): the robot commanded to
  c lands at c + e(c); to land on P, command c = P − ê(P) (one step), or solve c = P − ê(c)
  to a fixed point.
* A joint-space error model Δp(q) of the joint command q (the GA-trained network): IK gives
  q for the target, and the command moves against the predicted error through the
  Jacobian, q′ = q − J⁺Δp(q) (:func:`~robocal.compensation.joint_space.correct_joints`).
* No error model (a parametric calibration): IK of the calibrated model itself.

Either way the result is a joint command, and beside it the Cartesian target to send to a
controller that keeps its nominal model: the controller's own forward kinematics of that
joint command, in the controller's base frame with its own tool (the robot file's), so that
the controller's IK gives back the compensated joints.  Targets come in the measurement
frame; a registered base and tool are part of the calibrated model that solves them.
"""
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import InputError
from ..kinematics.ik import solve_ik
from ..kinematics.ik.point import PointSolver
from ..kinematics.program import PointProgram
from .joint_space import correct_joints


@dataclass(frozen=True)
class CommandResult:
    """Joint commands for N targets.

    q: (N, n) joint commands (rad, mm), NaN where unreachable; success: (N,) bool;
    corrected: (N, 4, 4) the Cartesian target for a controller that keeps its nominal model
    (its FK of ``q``, in the controller's base frame with its own tool; NaN where
    unreachable); predicted_error: (N, 3) mm, where the robot would land without
    compensation minus the target, as the model predicts it (NaN where unknown).
    """

    q: np.ndarray
    success: np.ndarray
    corrected: np.ndarray
    predicted_error: np.ndarray


ERROR_INPUTS = ("position", "joints")
# Gauss–Newton steps of the joint-space correction with --iterate (one step otherwise).
JOINT_ITERATIONS = 5


@dataclass(frozen=True)
class Compensator:
    """Kinematic model + optional error model (anything with ``predict``) of the commanded
    TCP position (``error_input='position'``) or of the joint command (``'joints'``).

    chain: the model whose IK solves the targets (measurement frame); nominal: the robot
    whose closed-form IK seeds the solver; controller: the robot as its controller knows it
    (default ``nominal``, else ``chain``): the corrected Cartesian targets are its FK;
    reference: the nominal geometry in the measurement frame (default ``chain``): what the
    robot would do uncompensated, for the predicted error of a model without error model.
    """

    chain: object
    error_model: object = None
    nominal: object = None
    error_input: str = "position"
    controller: object = None
    reference: object = None

    def __post_init__(self):
        if self.error_input not in ERROR_INPUTS:
            raise InputError(f"error_input must be one of {', '.join(ERROR_INPUTS)}, got {self.error_input!r}")

    def predicted_error(self, positions):
        """ê at commanded positions (N, 3) mm; zeros without a Cartesian error model."""
        positions = np.asarray(positions, dtype=float)
        if self.error_model is None or self.error_input == "joints":
            return np.zeros_like(positions)
        return np.asarray(self.error_model.predict(positions), dtype=float).reshape(positions.shape)

    def predict_positions(self, joints):
        """Where the real robot's TCP goes for joints (N, n) rad: model FK + predicted error."""
        commanded = self.chain.fk_positions(joints)
        if self.error_model is not None and self.error_input == "joints":
            return commanded + np.asarray(self.error_model.predict(joints), dtype=float).reshape(commanded.shape)
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
        """Joint commands (through IK of the model) for (N, 4, 4) targets in the measurement
        frame; see :class:`CommandResult`."""
        targets = np.asarray(targets, dtype=float)
        if self.error_model is not None and self.error_input == "joints":
            q, ok, error = self._joint_space_commands(targets, hint, iterate)
        else:
            moved, error = self.corrected_targets(targets, iterate=iterate)
            q, ok = self._ik(moved, hint)
            if self.error_model is None:
                error = self._uncompensated_error(targets, hint)
        corrected = np.full_like(targets, np.nan)
        controller = self.controller if self.controller is not None else (self.nominal or self.chain)
        if ok.any():
            corrected[ok] = controller.fk(q[ok])
        return CommandResult(q, ok, corrected, error)

    def command(self, target, hint=None, *, iterate=False):
        """:meth:`commands` of one target (4, 4) in the measurement frame, with an optional
        posture hint (n,) rad: the same joint command and corrected target (a
        :class:`CommandResult` of one row), without the batch machinery.

        Built for a controller that asks point by point: the IK solver, the controller's
        forward kinematics and the checks of the model are prepared once per compensator
        (:class:`~robocal.kinematics.ik.point.PointSolver`).  ``predicted_error`` is the
        error model's prediction at the target; without an error model it is NaN (the batch
        computes it with a second IK, of the nominal geometry, that the command does not need).
        """
        target = np.asarray(target, dtype=float)
        if target.shape != (4, 4):
            raise InputError(f"a target must be one (4, 4) pose, got shape {target.shape}")
        point = self._point
        if point.mode == "position":
            corrected, error = self.corrected_targets(target[None], iterate=iterate)
            moved = corrected[0]
        else:
            moved, error = target, None
        q, ok = point.solver.solve(moved, hint)
        if ok and point.compliant:
            q = self.chain.commands_for(q[None])[0]
        if ok and point.mode == "joints":
            # As _joint_space_commands: IK, then the correction against the predicted error.
            error = np.asarray(self.error_model.predict(q[None]), dtype=float).reshape(1, 3)
            q = correct_joints(self.chain, self.error_model, q[None],
                               iterations=JOINT_ITERATIONS if iterate else 1)[0]
            ok = bool(self.chain.within_limits(q[None])[0])
            if not ok:
                q = q + np.nan
        if error is None:
            error = _NAN_ROW.copy()
        corrected = point.controller_fk(q) if ok else _NAN_POSE.copy()
        return CommandResult(q[None], np.array([ok]), corrected, error)

    @cached_property
    def _point(self):
        """What :meth:`command` prepares once: the IK of the rigid chain and the
        controller's forward kinematics of one configuration."""
        return _PointPath(self)

    def _ik(self, targets, hint):
        # A compliant model is solved on its rigid geometry, then the commands are moved so
        # that the joints, once gravity has bent them, stand where the rigid solution is.
        rigid = self.chain.rigid
        result = solve_ik(rigid, targets, hint=hint, nominal=self.nominal)
        q = result.q if rigid is self.chain else self.chain.commands_for(result.q)
        return q, result.success

    def _uncompensated_error(self, targets, hint):
        """Where the model says the robot lands when commanded as its nominal geometry (in the
        measurement frame) would be, minus the target; NaN where that geometry cannot reach."""
        reference = self.reference if self.reference is not None else self.chain
        result = solve_ik(reference.rigid, targets, hint=hint, nominal=self.nominal)
        error = np.full((len(targets), 3), np.nan)
        ok = result.success
        if ok.any():
            error[ok] = self.predict_positions(result.q[ok]) - targets[ok, :3, 3]
        return error

    def _joint_space_commands(self, targets, hint, iterate):
        """IK of the targets, then the joint-space correction; a corrected command outside
        the joint limits counts as unreachable.  Returns (q, success, predicted error)."""
        q, ok = self._ik(targets, hint)
        q, ok = q.copy(), ok.copy()
        error = np.full((len(targets), 3), np.nan)
        if ok.any():
            error[ok] = self.error_model.predict(q[ok])
            q[ok] = correct_joints(self.chain, self.error_model, q[ok],
                                   iterations=JOINT_ITERATIONS if iterate else 1)
            ok[ok] = self.chain.within_limits(q[ok])
        q[~ok] = np.nan
        return q, ok, error


# What command returns where nothing is known (copied: results are the caller's to keep).
_NAN_ROW = np.full((1, 3), np.nan)
_NAN_POSE = np.full((1, 4, 4), np.nan)


class _PointPath:
    """A compensator's one-target machinery (see :meth:`Compensator.command`): ``mode`` is
    'position' (a Cartesian error model moves the target), 'joints' (a joint-space error
    model corrects the IK solution) or 'none' (IK alone)."""

    def __init__(self, compensator):
        rigid = compensator.chain.rigid
        self.compliant = rigid is not compensator.chain
        self.mode = "none" if compensator.error_model is None else compensator.error_input
        self.solver = PointSolver(rigid, compensator.nominal)
        controller = compensator.controller if compensator.controller is not None else (
            compensator.nominal or compensator.chain)
        if getattr(controller, "rigid", None) is controller:
            self._pose = PointProgram.of(controller).pose
            self._controller = None
        else:
            self._pose, self._controller = None, controller

    def controller_fk(self, q):
        """The controller's FK (1, 4, 4) of one command (n,)."""
        if self._pose is None:
            return self._controller.fk(q[None])
        xx, xy, xz, yx, yy, yz, zx, zy, zz, tx, ty, tz = self._pose(q.tolist())
        return np.array([xx, yx, zx, tx, xy, yy, zy, ty, xz, yz, zz, tz, 0.0, 0.0, 0.0, 1.0]).reshape(1, 4, 4)
