"""Kriging of the position error e = measured − FK(q), over the nominal TCP position (Liu et
al. 2022: the robot is moved against the predicted error at the target) or over the joint
configuration (``inputs``: the joints, or their sines and cosines; compensated in joint
space, as the network is)."""
import numpy as np

from ..compensation import Compensator
from ..errors import FileFormatError
from ..estimation.joint_kriging import JointKriging
from ..estimation.kriging import APPROXIMATIONS, AUTO_VECCHIA_ABOVE, Kriging
from ..estimation.metrics import error_stats
from ..kinematics.ik import solve_ik
from ..estimation.kriging import CORRELATIONS, REGRESSIONS
from ..settings import Choice, Either, Flag, Number, Setting
from .base import (ERROR_MODEL_INPUTS, PRIOR, RANDOM_STATE, REGISTER, TOLERANCE_SCALE, Method, require_distinct,
                   require_positions)
from .candidacy import RESIDUAL_INPUTS, Candidate, kriging_minimum, kriging_too_many
from .records import FitRecord, ReportFigure
from .frames import measurement_frame

TREND = Setting("trend", "constant", "--trend", "the Kriging's trend: constant, linear or quadratic",
                Choice(REGRESSIONS))
CORRELATION = Setting("correlation", "gaussian", "--correlation", "the Kriging's correlation function: gaussian or "
                      "matern52", Choice(CORRELATIONS))
NUGGET = Setting("nugget", "estimate", "--nugget", "the Kriging's nugget: 'estimate' or a number >= 0",
                 Either(Choice(("estimate",)), Number(at_least=0)))
SHARED_THETA = Setting("shared_theta", False, "--shared-theta", "one theta for the three outputs", Flag())
INPUTS = Setting("inputs", "position", "--inputs",
                 "what the error is modelled over: position (the TCP position), joints, or sincos "
                 "(sines and cosines of the revolute joints)", Choice(ERROR_MODEL_INPUTS))
KRIGING = Setting("kriging", "auto", "--kriging",
                  f"exact Kriging, or its vecchia approximation (nearest-neighbour conditioning, for large data); "
                  f"auto: exact up to {AUTO_VECCHIA_ABOVE:,} training poses", Choice(APPROXIMATIONS))
KRIGING_SETTINGS = (INPUTS, TREND, CORRELATION, NUGGET, SHARED_THETA, KRIGING, RANDOM_STATE)
DOCUMENT_TYPE = "kriging"


def kriging_of(method):
    """The unfitted :class:`Kriging` of a method's Kriging settings (checked in its ``fit``)."""
    return Kriging(regression=method.trend, correlation=method.correlation, nugget=method.nugget,
                   shared_theta=method.shared_theta, random_state=method.random_state, approximation=method.kriging)


def fit_error_model(method, chain, joints, errors, like=None):
    """The method's Kriging fitted to the position ``errors`` (N, 3) mm of ``chain`` at
    ``joints`` (N, n) rad: (model, the Compensator's error input, its fit of ``errors``).
    ``like``: a fitted error model of the same settings whose hyperparameters are kept
    (conditioned on these data without a likelihood search; see :meth:`KrigingResidual.refit`)."""
    if method.inputs == "position":
        positions = chain.fk_positions(joints)
        model = kriging_of(method).fit(positions, errors) if like is None else like.conditioned_on(positions, errors)
        return model, "position", model.predict(positions)
    model = (JointKriging(method.inputs, kriging_of(method)).fit(chain, joints, errors) if like is None
             else like.conditioned_on(chain, joints, errors))
    return model, "joints", model.predict(joints)


def kriging_document(model, inputs):
    """The model file's ``error_model`` entry; ``input`` says what the model is over."""
    return {"type": DOCUMENT_TYPE, "input": inputs, "parameters": model.to_dict()}


def kriging_from_document(document):
    """(model, the Compensator's error input, the method's ``inputs``) of a model file's
    entry; a file written before joint inputs existed has no ``input`` and is over the position.
    ValueError or FileFormatError if the entry is damaged."""
    if not isinstance(document, dict) or document.get("type") != DOCUMENT_TYPE:
        raise ValueError(f"expected a {DOCUMENT_TYPE} error model")
    inputs = document.get("input", "position")
    if inputs not in ERROR_MODEL_INPUTS:
        raise ValueError(f"'input' must be one of {', '.join(ERROR_MODEL_INPUTS)}, got {inputs!r}")
    if inputs == "position":
        model = Kriging.from_dict(document["parameters"])
        if model.n_features_in_ != 3:
            raise ValueError(f"a Kriging over the position has 3 inputs, this one {model.n_features_in_}")
        return model, "position", inputs
    model = JointKriging.from_dict(document["parameters"])
    if model.kind != inputs:
        raise ValueError(f"the document says 'input' {inputs!r} but its model is over {model.kind!r}")
    return model, "joints", inputs


class _ReachedBy:
    """A joint-input error model seen from Cartesian points, for the report's plane of
    uncertainty: each point is reached (IK of the compensator's model) with the orientation
    and the posture of the nearest of the given poses; a point it cannot reach is NaN."""

    def __init__(self, compensator, joints):
        self.compensator = compensator
        self.joints = np.asarray(joints, dtype=float)
        self.poses = compensator.chain.fk(self.joints)

    def predict(self, points, return_mse=False):
        chain = self.compensator.chain
        points = np.asarray(points, dtype=float)
        squared = (np.einsum("ij,ij->i", points, points)[:, None] - 2.0 * points @ self.poses[:, :3, 3].T
                   + np.einsum("ij,ij->i", self.poses[:, :3, 3], self.poses[:, :3, 3])[None, :])
        nearest = np.argmin(squared, axis=1)
        targets = self.poses[nearest].copy()
        targets[:, :3, 3] = points
        result = solve_ik(chain.rigid, targets, hint=self.joints[nearest], nominal=self.compensator.nominal)
        mean = np.full((len(points), 3), np.nan)
        mse = np.full_like(mean, np.nan)
        ok = result.success
        if ok.any():
            q = result.q[ok] if chain.rigid is chain else chain.commands_for(result.q[ok])
            mean[ok], mse[ok] = self.compensator.error_model.predict(q, return_mse=True)
        return (mean, mse) if return_mse else mean


def uncertainty_figure(method, joints):
    """The Kriging standard deviation over the poses, for the report."""
    compensator = method.compensator_
    points = compensator.chain.fk_positions(joints)
    if compensator.error_input == "position":
        model, where = compensator.error_model, ""
    else:
        model = _ReachedBy(compensator, joints)
        where = (" The model is over the joints: each point of the plane is reached with the orientation "
                 "and arm branch of the nearest pose; blank where that cannot be reached.")
    return ReportFigure("kriging_uncertainty", "Kriging uncertainty", "Predicted standard deviation of the "
                        "error model: small where training poses are, growing away from them." + where,
                        {"model": model, "points": points})


class KrigingResidual:
    """What the methods whose error model is a Kriging of the position error share: the
    ``inputs`` it is over, its model-file entry, its uncertainty and its report figure."""

    spreads_work = True  # each error component's likelihood search (Kriging._search)

    def _check_inputs(self):
        # fit checks every setting; a refit (robocal.methods.selection) starts here.
        INPUTS.check(self.inputs)
        KRIGING.check(self.kriging)

    def error_model_document(self):
        return kriging_document(self.compensator_.error_model, self.inputs)

    @classmethod
    def error_model_from_document(cls, document, path):
        model, error_input, _ = kriging_from_document(document)
        return model, error_input

    @classmethod
    def from_model_file(cls, model, path):
        fitted = super().from_model_file(model, path)
        # The settings and the error model are separate entries: a file edited in one only
        # would compensate with another model than its options say.
        inputs = model.error_model.get("input", "position")
        if fitted.inputs != inputs:
            raise FileFormatError(f"{path}: the options say inputs {fitted.inputs!r} but the error model is over "
                                  f"{inputs!r}; regenerate the file with 'robocal calibrate'")
        return fitted

    def uncertainty(self, joints):
        """The predicted standard deviation (N,) mm of the position error at ``joints`` (N, n)
        rad: the root of the summed x, y, z variances of the Kriging (for position inputs,
        at the model's FK of the joints)."""
        self._check_fitted()
        compensator = self.compensator_
        joints = compensator.chain.joint_batch(joints)
        inputs = joints if compensator.error_input == "joints" else compensator.chain.fk_positions(joints)
        _, mse = compensator.error_model.predict(inputs, return_mse=True)
        return np.sqrt(np.asarray(mse).sum(axis=1))

    def report_figures(self, joints):
        return [uncertainty_figure(self, joints)]

    def refit(self, chain, observations, base=None):
        """A new method of these settings fitted to other ``observations``, keeping this fit's
        Kriging hyperparameters (θ, nugget) instead of searching for them again: what
        cross-validation of many folds needs to stay fast (robocal.methods.selection).  The
        hyperparameters have then seen this fit's data; the fold's predictions have not.
        ``base``: for the hybrid, its kinematic calibration already fitted to ``observations``."""
        self._check_fitted()
        return self.clone()._fit_error_model_on(chain, observations, like=self.compensator_.error_model, base=base)


class KrigingMethod(KrigingResidual, Method):
    """Kriging of the position error of the nominal robot (registered in the measurement
    frame when needed) over its TCP position, or over the joints (``inputs``).  Settings:
    register, inputs, trend, correlation, nugget, shared_theta, kriging (exact, vecchia or
    auto), random_state (see
    :class:`~robocal.estimation.kriging.Kriging` and
    :class:`~robocal.estimation.joint_kriging.JointKriging`)."""

    name = "kriging"
    description = "Kriging of the position error over the TCP position (or the joints), targets moved against it"
    settings = (REGISTER,) + KRIGING_SETTINGS + (PRIOR, TOLERANCE_SCALE)

    @classmethod
    def candidates(cls, chain, observations, training, forced=None):
        """Position data: over the TCP position and over the joints' sines and cosines, each
        needing ten training poses per input dimension, up to KRIGING_MAX_POSES."""
        too_many = kriging_too_many(training)
        if observations.positions is None or too_many:
            return [], [too_many] if observations.positions is not None else []
        return [Candidate(f"kriging ({inputs})", cls.name, {"inputs": inputs},
                          minimum_poses=kriging_minimum(chain, inputs)) for inputs in ("position", RESIDUAL_INPUTS)], []

    def _fit(self, chain, observations, progress):
        return self._fit_error_model_on(chain, observations)

    def _fit_error_model_on(self, chain, observations, like=None, base=None):
        self._check_inputs()
        obs = require_distinct(require_positions(observations, self.name), self.name)
        frame, record = measurement_frame(chain, obs.joints, obs.positions, self.register)
        errors = obs.positions - frame.fk_positions(obs.joints)
        model, error_input, fitted = fit_error_model(self, frame, obs.joints, errors, like)
        self.compensator_ = Compensator(frame, model, nominal=frame, error_input=error_input, controller=chain,
                                        reference=frame)
        self.reference_ = frame
        self.record_ = FitRecord(**record, residual_before=error_stats(errors).to_dict(),
                                 residual_after_training=error_stats(errors - fitted).to_dict(),
                                 diagnostics=list(model.diagnostics_))
        return self
