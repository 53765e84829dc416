"""The hybrid: the parametric calibration, then Kriging of what the calibrated model still
misses (compliance, backlash, other non-geometric errors) over the calibrated TCP position
or over the joints (``inputs``)."""
from ..compensation import Compensator
from ..estimation.metrics import error_stats
from .base import Method
from .candidacy import (PARAMETER_SETS, RESIDUAL_INPUTS, Candidate, kinematic_candidates, kriging_minimum,
                        kriging_too_many)
from .kinematic import KinematicMethod
from .kriging import KRIGING_SETTINGS, KrigingResidual, fit_error_model


class HybridMethod(KrigingResidual, Method):
    """:class:`KinematicMethod`, then Kriging of its residual; the settings of both."""

    checks_its_data = True
    name = "hybrid"
    description = "parametric calibration, then Kriging of the residual error (over the TCP position or the joints)"
    settings = KinematicMethod.settings + KRIGING_SETTINGS

    @classmethod
    def candidates(cls, chain, observations, training, forced=None):
        """Position data, up to KRIGING_MAX_POSES training poses: on each 'full' parameter set,
        its residual over the joints' sines and cosines, to beat its own kinematic calibration."""
        if observations.positions is None or kriging_too_many(training):
            return [], []
        need = kriging_minimum(chain, RESIDUAL_INPUTS)
        return [Candidate(f"{cls.name} {c.settings['parameters']}", cls.name,
                          {**c.settings, "inputs": RESIDUAL_INPUTS}, base=c.label,
                          minimum_poses=max(need, c.minimum_poses))
                for c in kinematic_candidates("kinematic", chain, observations,
                                              PARAMETER_SETS[:1] + PARAMETER_SETS[2:])], []

    def kinematic(self):
        """The unfitted :class:`KinematicMethod` of these settings (the hybrid's base)."""
        return KinematicMethod(**{s.name: getattr(self, s.name) for s in KinematicMethod.settings})

    def _fit(self, chain, observations, progress):
        return self._fit_error_model_on(chain, observations)

    def _fit_error_model_on(self, chain, observations, like=None, base=None):
        """The residual's Kriging on ``base`` (the kinematic calibration of these settings,
        fitted here when not given), searching its hyperparameters or keeping ``like``'s."""
        self._check_inputs()
        base = self.kinematic().fit(chain, observations) if base is None else base
        calibrated = base.compensator_.chain
        residual = observations.positions - calibrated.fk_positions(observations.joints)
        model, error_input, fitted = fit_error_model(self, calibrated, observations.joints, residual, like)
        self.compensator_ = Compensator(calibrated, model, nominal=chain, error_input=error_input, controller=chain,
                                        reference=base.reference_)
        self.reference_ = base.reference_
        self.record_ = base.record_.replace(residual_after_training=error_stats(residual - fitted).to_dict(),
                                            diagnostics=list(model.diagnostics_))
        return self
