"""Kriging of the Cartesian position error e = measured − FK(q) over the nominal TCP
position, compensated by moving the target against the predicted error (Liu et al. 2022)."""
from ..compensation import Compensator
from ..estimation.kriging import Kriging
from ..estimation.metrics import error_stats
from .base import RANDOM_STATE, REGISTER, Method, Setting, require_distinct, require_positions
from .records import FitRecord, ReportFigure
from .frames import measurement_frame

TREND = Setting("trend", "constant", "--trend", "Kriging trend: constant, linear or quadratic")
CORRELATION = Setting("correlation", "gaussian", "--correlation", "Kriging correlation: gaussian or matern52")
NUGGET = Setting("nugget", "estimate", "--nugget", "Kriging nugget: 'estimate' or a number")
SHARED_THETA = Setting("shared_theta", False, "--shared-theta", "one theta for the three outputs")
KRIGING_SETTINGS = (TREND, CORRELATION, NUGGET, SHARED_THETA, RANDOM_STATE)
DOCUMENT_TYPE = "kriging"


def kriging_of(method):
    """The unfitted :class:`Kriging` of a method's Kriging settings (checked in its ``fit``)."""
    return Kriging(regression=method.trend, correlation=method.correlation, nugget=method.nugget,
                   shared_theta=method.shared_theta, random_state=method.random_state)


def kriging_document(model):
    return {"type": DOCUMENT_TYPE, "parameters": model.to_dict()}


def kriging_from_document(document):
    if not isinstance(document, dict) or document.get("type") != DOCUMENT_TYPE:
        raise ValueError(f"expected a {DOCUMENT_TYPE} error model")
    return Kriging.from_dict(document["parameters"]), "position"


def uncertainty_figure(method, joints):
    """The Kriging standard deviation over the poses, for the report."""
    points = method.compensator_.chain.fk_positions(joints)
    return ReportFigure("kriging_uncertainty", "Kriging uncertainty", "Predicted standard deviation of the "
                        "error model: small where training poses are, growing away from them.",
                        {"model": method.compensator_.error_model, "points": points})


class KrigingResidual:
    """What the methods whose error model is a Kriging of the position error share: its
    model-file entry and its uncertainty figure."""

    def error_model_document(self):
        return kriging_document(self.compensator_.error_model)

    @classmethod
    def error_model_from_document(cls, document, path):
        return kriging_from_document(document)

    def report_figures(self, joints):
        return [uncertainty_figure(self, joints)]


class KrigingMethod(KrigingResidual, Method):
    """Kriging of the position error over the nominal position (registered in the
    measurement frame when needed).  Settings: register, trend, correlation, nugget,
    shared_theta, random_state (see :class:`~robocal.estimation.kriging.Kriging`)."""

    name = "kriging"
    description = "Kriging of the position error over the TCP position, targets moved against it"
    settings = (REGISTER,) + KRIGING_SETTINGS

    def _fit(self, chain, observations, progress):
        obs = require_distinct(require_positions(observations, self.name), self.name)
        frame, record = measurement_frame(chain, obs.joints, obs.positions, self.register)
        nominal_positions = frame.fk_positions(obs.joints)
        errors = obs.positions - nominal_positions
        model = kriging_of(self).fit(nominal_positions, errors)
        self.compensator_ = Compensator(frame, model, nominal=frame, controller=chain, reference=frame)
        self.reference_ = frame
        self.record_ = FitRecord(**record, residual_before=error_stats(errors),
                                 residual_after_training=error_stats(errors - model.predict(nominal_positions)),
                                 diagnostics=list(model.diagnostics_))
        return self
