"""What a compensator is, and what an error model is, to the code that uses them.

A fitted method's ``compensator_`` is a :class:`~robocal.compensation.Compensator`, or
something built around one: the domain fallback of ``calibrate --method auto``
(:class:`robocal.methods.fallback.DomainFallback`), which answers with two.  The verbs, the
server, the bound and re-registration use only what :class:`CompensatorProtocol` declares,
so a wrapper implements exactly that, each member on purpose, instead of forwarding
whatever is asked for to the model it wraps.

An error model is anything with :meth:`ErrorModel.predict` (Kriging, the network, the
Kriging over joints, an error model moved to another measurement frame:
:class:`robocal.estimation.reregistration.ReframedErrorModel`).
"""
from typing import Protocol, runtime_checkable


@runtime_checkable
class ErrorModel(Protocol):
    """The predicted position error: measured minus model, (N, 3) mm."""

    def predict(self, X, return_mse=False):
        """The error (N, 3) mm at X: commanded TCP positions (N, 3) mm, or joint vectors
        (N, n) rad (mm for prismatic joints) for a joint-space model; with ``return_mse``
        also its mean squared error (N, 3) mm² where the model has one."""


@runtime_checkable
class CompensatorProtocol(Protocol):
    """Targets in, joint commands out; configurations in, real TCP positions out.

    Attributes
    ----------
    chain : Chain
        The kinematic model whose IK solves the targets (measurement frame).
    error_model : ErrorModel or None
        What the kinematic model misses; None for a parametric calibration.
    error_input : str
        What the error model is over: 'position' (commanded TCP position) or 'joints'.
    nominal : Chain or None
        The robot whose closed-form IK seeds the solver.
    controller : Chain or None
        The robot as its controller knows it: the corrected Cartesian targets are its FK.
    reference : Chain or None
        The nominal geometry in the measurement frame (what the robot does uncompensated).
    """

    chain: object
    error_model: object
    error_input: str
    nominal: object
    controller: object
    reference: object

    def predict_positions(self, joints):
        """Where the real robot's TCP goes for joints (N, n) rad: (N, 3) mm."""

    def commands(self, targets, hint=None, *, iterate=False):
        """Joint commands for (N, 4, 4) targets in the measurement frame, with an optional
        posture hint (N, n) or (n,) rad: a :class:`~robocal.compensation.CommandResult`."""

    def command(self, target, hint=None, *, iterate=False):
        """:meth:`commands` of one (4, 4) target and an optional (n,) hint: a
        :class:`~robocal.compensation.CommandResult` of one row, equal to the batch's."""
