"""Calibration from ball-in-socket data (position and distance constraints, no measuring
instrument) of the product-of-exponentials model; compensated through the calibrated
model's IK, or directly by exporting it."""
from ..compensation import Compensator
from ..errors import InputError
from ..estimation.constraint import PAIRINGS, ConstraintCalibration
from ..io.fixtures import fixture_to_dict
from ..settings import Choice, Setting
from .base import PARAMETERS, PAYLOAD, PRIOR, TOLERANCE_SCALE, Method, check_parameters
from .candidacy import PARAMETER_SETS, Candidate
from .records import CalibrationRecord, FitRecord

PAIRS = Setting("pairs", "all", "--pairs", "all pairs of configurations, or spanning (fewer, faster)",
                Choice(PAIRINGS))


def require_sockets(observations):
    """``observations`` if they are ball-in-socket data with their fixture; else a refusal."""
    where = observations.path or "the data"
    if observations.placement is None:
        raise InputError(f"{where} has no fixture and socket columns: the constraint method needs ball-in-socket "
                         "data (q1..qN, fixture, socket)")
    if observations.positions is not None:
        raise InputError(f"{where} has x, y, z columns: that is instrument data; use --method kinematic, or "
                         "give only fixture and socket columns for the constraint method")
    if observations.fixture is None:
        raise InputError("the constraint method needs the fixture: --fixture FIX.toml (socket centres in mm)")
    return observations


class ConstraintMethod(Method):
    """:class:`~robocal.estimation.constraint.ConstraintCalibration` of the full POE model.

    Settings: pairs ('all' or 'spanning'), parameters (the 'full' sets: full, full+gains,
    full+compliance, full+compliance+gains) and payload (kg, compliance sets only).
    ``predict`` gives ball centres in the starting model's base frame.
    """

    checks_its_data = True
    name = "constraint"
    description = "ball-in-socket calibration of the POE model from position and distance constraints"
    data_kind = "sockets"
    settings = (PAIRS, PARAMETERS, PAYLOAD, PRIOR, TOLERANCE_SCALE)

    @classmethod
    def candidates(cls, chain, observations, training, forced=None):
        """Ball-in-socket data: one candidate per 'full' parameter set."""
        if observations.positions is not None or observations.placement is None:
            return [], []
        return [Candidate(f"{cls.name} {p}", cls.name, {"parameters": p}) for p in PARAMETER_SETS
                if p.startswith("full")], []

    def calibration(self):
        """The unfitted :class:`ConstraintCalibration` these settings ask for."""
        terms = check_parameters(self.parameters, self.payload)
        if not self.parameters.startswith("full"):
            raise InputError("the constraint method identifies the full POE model: --parameters full, full+gains, "
                             f"full+compliance or full+compliance+gains, got {self.parameters!r}")
        return ConstraintCalibration(pairs=self.pairs, compliance="compliance" in terms, gains="gains" in terms,
                                     payload=self.payload, prior=self.prior, tolerance_scale=self.tolerance_scale)

    def _fit(self, chain, observations, progress):
        obs = require_sockets(observations)
        calibration = self.calibration().fit(chain, obs.joints, obs.placement, obs.socket, obs.fixture)
        result = calibration.result_
        self.calibration_ = calibration
        self.compensator_ = Compensator(calibration.chain_, None, nominal=chain, controller=chain, reference=chain)
        self.reference_ = chain
        self.record_ = FitRecord(calibration=CalibrationRecord.from_dict(result.to_dict(calibration.chain_)),
                                 fixture=fixture_to_dict(obs.fixture), residual_before=result.residual_before,
                                 residual_after_training=result.residual_after)
        return self
