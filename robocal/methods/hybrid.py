"""The hybrid: the parametric calibration, then Kriging of what the calibrated model still
misses (compliance, backlash, other non-geometric errors) over the calibrated TCP position."""
from ..compensation import Compensator
from ..estimation.metrics import error_stats
from .base import Method
from .kinematic import KinematicMethod
from .kriging import KRIGING_SETTINGS, KrigingResidual, kriging_of


class HybridMethod(KrigingResidual, Method):
    """:class:`KinematicMethod`, then Kriging of its residual; the settings of both."""

    name = "hybrid"
    description = "parametric calibration, then Kriging of the residual error"
    settings = KinematicMethod.settings + KRIGING_SETTINGS

    def _fit(self, chain, observations, progress):
        kinematic_settings = {s.name: getattr(self, s.name) for s in KinematicMethod.settings}
        base = KinematicMethod(**kinematic_settings).fit(chain, observations)
        calibrated = base.compensator_.chain
        model_positions = calibrated.fk_positions(observations.joints)
        residual = observations.positions - model_positions
        model = kriging_of(self).fit(model_positions, residual)
        self.compensator_ = Compensator(calibrated, model, nominal=chain, controller=chain, reference=base.reference_)
        self.reference_ = base.reference_
        self.record_ = base.record_.replace(
            residual_after_training=error_stats(residual - model.predict(model_positions)),
            diagnostics=list(model.diagnostics_))
        return self
