"""The parametric calibration: link parameters, base and tool (with joint compliance and
joint gains on request) identified by Levenberg–Marquardt; compensated through the
calibrated model's IK, or directly by exporting the calibrated parameters."""
import warnings

from ..compensation import Compensator
from ..estimation.calibration import KinematicCalibration, OutlierError, OutlierWarning
from ..estimation.metrics import error_stats
from ..settings import ANGLE_SIGMA, LENGTH_SIGMA, Number, Setting
from .base import LOSS, PARAMETERS, PAYLOAD, PRIOR, REGISTER, TOLERANCE_SCALE, Method, check_parameters, \
    require_positions
from .candidacy import kinematic_candidates
from .records import CalibrationRecord, FitRecord
from .frames import registered_nominal


# How the rows of 6-D data are weighed against each other: one standard deviation of a
# measured coordinate (mm) and of a measured orientation angle (deg).  The defaults are a
# laser tracker's (0.02 mm) and its 6-D probe's (0.01 deg).  The setting keeps the name users
# write (--orientation-sigma, a fleet file's orientation_sigma, a model file's options); the
# estimator it reaches takes it as orientation_sigma_deg, the unit in the name.
POSITION_SIGMA = Setting("position_sigma", 0.02, "--position-sigma",
                         "one standard deviation of a measured x, y or z in mm, weighing positions against "
                         "orientations (default 0.02; a file's sx, sy, sz take precedence)",
                         Number(between=(0, 1e3), plausible=LENGTH_SIGMA))
ORIENTATION_SIGMA = Setting("orientation_sigma", 0.01, "--orientation-sigma",
                            "one standard deviation of a measured orientation angle in deg, for 6-D data (rx, ry, "
                            "rz; default 0.01)", Number(between=(0, 90), plausible=ANGLE_SIGMA))


class KinematicMethod(Method):
    """Parametric calibration (see :class:`~robocal.estimation.calibration.KinematicCalibration`).

    Settings: register ('auto', 'yes', 'no'), parameters (a parameter set), loss ('linear',
    'huber', 'soft_l1'), payload (kg at the TCP, compliance sets only), prior ('tolerances':
    maximum a posteriori, or 'none'), tolerance_scale, and the weights of 6-D rows,
    position_sigma (mm) and orientation_sigma (deg).
    """

    checks_its_data = True
    name = "kinematic"
    description = "parametric calibration of links, base and tool (optionally joint compliance and gains)"
    settings = (REGISTER, PARAMETERS, LOSS, PAYLOAD, PRIOR, TOLERANCE_SCALE, POSITION_SIGMA, ORIENTATION_SIGMA)

    @classmethod
    def candidates(cls, chain, observations, training, forced=None):
        """Position data: one candidate per parameter set, the default ``full`` first (scored
        by deletion on small campaigns: a linearised fit)."""
        if observations.positions is None:
            return [], []
        return kinematic_candidates(cls.name, chain, observations, linear=True), []

    def calibration(self):
        """The unfitted :class:`KinematicCalibration` these settings ask for (the settings
        checked: :meth:`Method.fit` does it first)."""
        check_parameters(self.parameters, self.payload)
        return KinematicCalibration(parameters=self.parameters, loss=self.loss, register=self.register != "no",
                                    payload=self.payload, prior=self.prior, tolerance_scale=self.tolerance_scale,
                                    position_sigma=self.position_sigma,
                                    orientation_sigma_deg=self.orientation_sigma)

    def _fit(self, chain, observations, progress):
        obs = require_positions(observations, self.name)
        # The outlying poses a refusal or a warning names, as the lines of the user's file.
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                calibration = self.calibration().fit(chain, obs.joints, obs.positions, orientations=obs.rotations,
                                                     sigmas=obs.sigmas)
        except OutlierError as error:
            raise error.naming(obs.rows, obs.path) from None
        finally:
            for warning in caught:
                message = warning.message
                if isinstance(message, OutlierWarning):
                    message = message.naming(obs.rows, obs.path)
                warnings.warn_explicit(message, warning.category, warning.filename, warning.lineno)
        result = calibration.result_
        record = CalibrationRecord.from_dict(
            {**result.to_dict(calibration.chain_), "outlier_rows": [int(obs.rows[i]) for i in result.outliers]})
        self.calibration_ = calibration
        # The calibration starts from the registered nominal; without registration the
        # baseline is still the nominal registered to the data (the honest "before").
        reference = (calibration.start_chain_.rigid if self.register != "no"
                     else registered_nominal(chain, obs.joints, obs.positions))
        self.compensator_ = Compensator(calibration.chain_, None, nominal=chain, controller=chain, reference=reference)
        self.reference_ = reference
        self.record_ = FitRecord(
            registered=self.register != "no", calibration=record,
            residual_before=error_stats(obs.positions - reference.fk_positions(obs.joints)).to_dict(),
            residual_after_training=error_stats(
                obs.positions - calibration.chain_.fk_positions(obs.joints)).to_dict())
        return self
