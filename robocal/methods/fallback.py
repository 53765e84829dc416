"""Outside its training domain, a model answers with another: the domain fallback of
``calibrate --method auto``, and of an error model predicted to do worse there than the
registered nominal robot (:func:`robocal.methods.expectation.fall_back_outside_if_worse`).

Cross-validation can only judge a model where the training data are. Beyond them — another
arm branch, a joint beyond its measured range — two kinds of model are known to fail:

* an error model (Kriging, the hybrid's residual, the network) has nothing to say there:
  measured on the region splits of UR5 Tsinghua and UR10 series A, the Kriging residual's
  predicted variance at the held-out configurations was the process variance itself
  (0.96 to 1.03 of it), i.e. it predicted its trend, a constant, and whether that helped was a
  coin toss (UR5 +3 %, UR10 A −6 %);
* joint gains scale the joint value, so an error in a gain grows with the distance from the
  measured range: on the other shoulder side of the UR10 A, ``full+gains`` missed by 4.8 mm
  where ``full`` missed by 1.9 and ``full+compliance`` by 0.82.

So :class:`DomainFallback` holds two compensators: the chosen model's for configurations
inside its :class:`~robocal.methods.domain.Domain`, and a parametric calibration's without
gains (the rule is in :func:`robocal.methods.selection.outside_choice`) for those outside.
Every verb sees one compensator (:class:`~robocal.compensation.CompensatorProtocol`):
``predict_positions``, ``commands`` and ``command`` pick per configuration; the chain, the
error model and the frames are the chosen model's, each declared below.
"""
from dataclasses import dataclass

import numpy as np

from ..compensation import Compensator
from ..compensation.compensator import CommandResult
from ..errors import FileFormatError
from .domain import Domain


@dataclass(frozen=True)
class DomainFallback:
    """The chosen model's compensator inside ``domain``, ``outside``'s beyond it.

    inside, outside : Compensator
        The chosen model's; a parametric calibration's (no error model).
    domain : Domain
        The training domain that decides, per configuration.
    label : str
        What answers outside, as ``robocal compare`` names it ("kinematic full+compliance").
    """

    inside: Compensator
    outside: Compensator
    domain: Domain
    label: str

    # The rest of the compensator protocol is the chosen model's: its chain solves and
    # reports, its error model is the one the report and the bound describe, its frames are
    # the ones the model file records.
    @property
    def chain(self):
        """The chosen model's kinematic model (measurement frame)."""
        return self.inside.chain

    @property
    def error_model(self):
        """The chosen model's error model (None for a parametric calibration)."""
        return self.inside.error_model

    @property
    def error_input(self):
        """What the chosen model's error model is over: 'position' or 'joints'."""
        return self.inside.error_input

    @property
    def nominal(self):
        """The robot whose closed form seeds the chosen model's IK."""
        return self.inside.nominal

    @property
    def controller(self):
        """The robot as its controller knows it (shared by both models)."""
        return self.inside.controller

    @property
    def reference(self):
        """The chosen model's nominal geometry in the measurement frame."""
        return self.inside.reference

    def _inside(self, joints):
        """(N,) bool: configurations inside the domain; a NaN row (unreachable) counts as
        inside, where the chosen model's NaN stands."""
        return self.domain.check(joints).inside

    def predict_positions(self, joints):
        """Where the real robot's TCP goes for joints (N, n) rad: (N, 3) mm, from the chosen
        model inside the domain and the fallback outside."""
        joints = np.asarray(joints, dtype=float)
        out = np.asarray(self.inside.predict_positions(joints), dtype=float).copy()
        outside = ~self._inside(joints)
        if outside.any():
            out[outside] = self.outside.predict_positions(joints[outside])
        return out

    def commands(self, targets, hint=None, *, iterate=False):
        """Joint commands for (N, 4, 4) targets: the fallback's IK decides where each target
        lies (it is parametric, so its configuration does not depend on an error model), and
        the targets inside the domain take the chosen model's commands."""
        return self._pick(self.inside.commands(targets, hint, iterate=iterate),
                          self.outside.commands(targets, hint, iterate=iterate))

    def command(self, target, hint=None, *, iterate=False):
        """:meth:`commands` of one target (4, 4), each model through its
        :meth:`Compensator.command` (without the forwarding below, the chosen model's would
        answer alone)."""
        return self._pick(self.inside.command(target, hint, iterate=iterate),
                          self.outside.command(target, hint, iterate=iterate))

    def _pick(self, mine, other):
        """The chosen model's commands inside the domain, the fallback's outside."""
        q = np.where(other.success[:, None], other.q, mine.q)
        use_other = ~self._inside(q) & other.success
        pick = use_other[:, None]
        return CommandResult(np.where(pick, other.q, mine.q), np.where(use_other, other.success, mine.success),
                             np.where(pick[:, :, None], other.corrected, mine.corrected),
                             np.where(pick, other.predicted_error, mine.predicted_error))

    def outside_mask(self, joints):
        """(N,) bool: the configurations the fallback answers for."""
        return ~self._inside(np.asarray(joints, dtype=float))


def wrap(fitted, fallback, label):
    """``fitted`` (a fitted method) answering with ``fallback`` (a fitted parametric method)
    outside its domain; returns ``fitted``, changed in place."""
    fitted.compensator_ = DomainFallback(fitted.compensator_, fallback.compensator_, fitted.domain_, label)
    return fitted


def from_fallback_document(compensator, outside, domain, path):
    """The :class:`DomainFallback` a model file describes: ``compensator`` (the chosen
    model's), ``outside`` ((label, kinematics chain, reference chain) read by
    :func:`robocal.io.model_file.load_model`) and the file's ``domain``."""
    if domain is None:
        raise FileFormatError(f"{path}: the model answers with another outside its domain of validity, but the file "
                              "records no domain; regenerate it with 'robocal calibrate'")
    label, chain, reference = outside
    fallback = Compensator(chain, None, nominal=chain.rigid, controller=compensator.controller, reference=reference)
    return DomainFallback(compensator, fallback, domain, label)
