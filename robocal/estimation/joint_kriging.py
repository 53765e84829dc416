"""Kriging of the position error over the joint configuration instead of the TCP position.

The same TCP position is reached with other joints on another arm branch (elbow up or down,
wrist flipped, shoulder turned through 180°), and the errors a kinematic model misses —
joint compliance, backlash, link deflection, errors of the axes themselves — follow the
joints, not the Cartesian point.  A model over the joints tells the branches apart; one over
the position cannot.

Two input kinds (:data:`JOINT_INPUTS`):

* ``joints``: the joint values themselves, rad (revolute) and mm (prismatic).  The Kriging
  standardises every input column to unit variance and estimates one θ per column, so
  radians and millimetres need no common scale.
* ``sincos``: sin q and cos q of each revolute joint (prismatic joints as their value in mm).
  They are periodic: q = 179° and q = −179° are neighbours, as the robot's geometry says,
  where in ``joints`` they are 358° apart.

Only joints that move the TCP position enter (:func:`moving_joints`): the last joint of a
six-axis arm turns a tool on its axis about itself, and a column that changes nothing in
the error would only cost a dimension of the likelihood search.
"""
import numpy as np

from ..errors import InputError
from .arrays import as_matrix, check_choice, damaged, not_fitted
from .kriging import Kriging

JOINT_INPUTS = ("joints", "sincos")
# The constructor keywords of Kriging, copied onto the model that is fitted.
KRIGING_SETTINGS = ("regression", "correlation", "theta0", "theta_bounds", "nugget", "n_starts", "shared_theta",
                    "random_state", "approximation", "neighbours")
# Likelihood searches of a Kriging over the joints whose n_starts is left to the default:
# JOINT_STARTS up to JOINT_STARTS_UP_TO training poses, one above.  In 6 to 12 dimensions a
# search costs several times one over the 3-D position, and on large designs more starts
# found the same optimum.  Measured on UR5 Tsinghua (random halves of the 1,000 poses, one
# core): n = 800, sincos: 2 starts (Kriging's default) 28 s, one start 7 s, the same held-out
# error (0.071 mm); joints 8.8 s against 3.7 s, again the same (0.075 mm).  At n = 200 one
# start was worse (joints 0.129 mm against 0.088 with 4 starts), so small designs keep them.
JOINT_STARTS = 4
JOINT_STARTS_UP_TO = 400
# A joint whose motion over the training data moves the model's TCP by less than this (mm)
# does not move the TCP position: below what any position instrument resolves, and zero for
# a tool on the last joint's axis.
MIN_TCP_MOTION_MM = 0.01


def moving_joints(chain, q):
    """Indices of the joints of ``chain`` that move its TCP position over the configurations
    ``q`` (N, n) rad/mm: those whose largest position-Jacobian column (mm/rad, mm/mm) times
    their range in ``q`` reaches MIN_TCP_MOTION_MM.  A joint held still in ``q`` is left out
    too: no model can learn how the error depends on it.  A compliant chain is judged on its
    rigid geometry (gravity moves the TCP by fractions of a mm, not the lever of a joint)."""
    _, jacobian = chain.rigid.fk_jacobian(q)
    lever = np.linalg.norm(jacobian[:, :3, :], axis=1).max(axis=0)  # (n,) mm per unit of q
    motion = lever * np.ptp(q, axis=0)
    return np.flatnonzero(motion >= MIN_TCP_MOTION_MM)


class JointFeatures:
    """The input columns of an error model over the joints.

    kind: ``"joints"`` or ``"sincos"`` (see the module docstring); joints: indices of the
    joints used, ascending; revolute: (n,) bool, which joints of the robot are revolute.
    """

    def __init__(self, kind, joints, revolute):
        if kind not in JOINT_INPUTS:
            raise InputError(f"joint inputs must be one of {', '.join(JOINT_INPUTS)}, got {kind!r}")
        self.kind = kind
        self.revolute = np.asarray(revolute, dtype=bool).reshape(-1)
        self.joints = np.asarray(joints, dtype=int).reshape(-1)
        if (not len(self.joints) or np.any(np.diff(self.joints) <= 0) or self.joints[0] < 0
                or self.joints[-1] >= len(self.revolute)):
            raise InputError(f"joint indices must ascend within 0..{len(self.revolute) - 1}, got "
                             f"{self.joints.tolist()}")

    @property
    def n_joints(self):
        return len(self.revolute)

    @property
    def n_features(self):
        periodic = self.revolute[self.joints] if self.kind == "sincos" else np.zeros(len(self.joints), bool)
        return len(self.joints) + int(periodic.sum())

    def transform(self, q):
        """The input columns (N, n_features) at joints ``q`` (N, n): the used joints' values,
        then (for ``sincos``) the revolute ones replaced by their sines, with the cosines
        appended."""
        q = as_matrix(q, "joints")
        if q.shape[1] != self.n_joints:
            raise InputError(f"the error model is over {self.n_joints} joints; got joint values of "
                             f"shape {q.shape}")
        used = q[:, self.joints]
        if self.kind == "joints":
            return used
        periodic = self.revolute[self.joints]
        columns = np.where(periodic, np.sin(used), used)
        return np.hstack([columns, np.cos(used[:, periodic])])

    def to_dict(self):
        return {"kind": self.kind, "joints": self.joints.tolist(), "revolute": self.revolute.tolist()}

    @classmethod
    def from_dict(cls, document):
        """The features a :meth:`to_dict` document describes; FileFormatError if damaged."""
        try:
            revolute = document["revolute"]
            joints = document["joints"]
            if not all(isinstance(r, bool) for r in revolute) or not all(
                    isinstance(j, int) and not isinstance(j, bool) for j in joints):
                raise InputError("'revolute' must hold true/false and 'joints' whole numbers")
            return cls(document["kind"], joints, revolute)
        except (KeyError, TypeError, ValueError) as error:  # InputError is a ValueError
            raise damaged("joint-input Kriging model", error) from None


class JointKriging:
    """A :class:`Kriging` of the position error over :class:`JointFeatures` of the joints:
    ``predict(q)`` takes joint vectors (N, n) rad/mm, as the joint-space compensation
    (:func:`~robocal.compensation.joint_space.correct_joints`) asks of an error model.

    kind: ``"joints"`` or ``"sincos"``; kriging: the unfitted :class:`Kriging` (its settings).

    Attributes (set by ``fit`` or ``from_dict``): ``features_`` (:class:`JointFeatures`),
    ``kriging_`` (the fitted :class:`Kriging` over them), ``diagnostics_``.
    """

    def __init__(self, kind="joints", kriging=None):
        self.kind = kind
        self.kriging = kriging

    def fit(self, chain, q, errors):
        """Fit to the position errors ``errors`` (N, 3) mm of ``chain`` (the model whose
        error this is) at joints ``q`` (N, n) rad/mm; returns self."""
        check_choice("kind", self.kind, JOINT_INPUTS)
        q = as_matrix(q, "joints")
        if q.shape[1] != chain.n_joints:
            raise InputError(f"robot {chain.name!r} has {chain.n_joints} joints; got joint values of shape {q.shape}")
        joints = moving_joints(chain, q)
        if not len(joints):
            raise InputError("no joint moves the TCP over these poses: an error model over the joints "
                             "needs poses that differ in the joints")
        features = JointFeatures(self.kind, joints, chain.revolute)
        # A copy of the settings' Kriging is fitted, so that fitting leaves the settings as given.
        given = self.kriging if self.kriging is not None else Kriging()
        settings = {k: getattr(given, k) for k in KRIGING_SETTINGS}
        if settings["n_starts"] is None:
            settings["n_starts"] = JOINT_STARTS if len(q) <= JOINT_STARTS_UP_TO else 1
        model = Kriging(**settings)
        model.fit(features.transform(q), errors)
        self.features_, self.kriging_ = features, model
        self.diagnostics_ = model.diagnostics_ + self._dropped_note()
        return self

    def conditioned_on(self, chain, q, errors):
        """A new JointKriging over the same features with this model's Kriging hyperparameters,
        conditioned on other data (see :meth:`Kriging.conditioned_on`)."""
        if not hasattr(self, "kriging_"):
            raise InputError("this JointKriging is not fitted: fit it before conditioning it on other data")
        q = as_matrix(q, "joints")
        model = JointKriging(self.kind, self.kriging)
        model.features_ = self.features_
        model.kriging_ = self.kriging_.conditioned_on(self.features_.transform(q), errors)
        model.diagnostics_ = model.kriging_.diagnostics_ + model._dropped_note()
        return model

    def _dropped_note(self):
        left = sorted(set(range(self.features_.n_joints)) - set(self.features_.joints.tolist()))
        if not left:
            return []
        return [f"joints {', '.join(f'q{j + 1}' for j in left)} left out: they do not move the TCP position "
                f"over the training poses (by less than {MIN_TCP_MOTION_MM} mm)"]

    def predict(self, q, return_mse=False):
        """The position error (N, 3) mm at joints ``q`` (N, n) rad/mm, and with ``return_mse``
        its mean squared error (N, 3) mm²."""
        if not hasattr(self, "kriging_"):
            raise not_fitted("joint-input Kriging model", "fit(chain, q, errors)")
        return self.kriging_.predict(self.features_.transform(q), return_mse=return_mse)

    def to_dict(self):
        if not hasattr(self, "kriging_"):
            raise not_fitted("joint-input Kriging model", "fit(chain, q, errors)")
        return {"features": self.features_.to_dict(), "kriging": self.kriging_.to_dict()}

    @classmethod
    def from_dict(cls, document):
        """The fitted model of a :meth:`to_dict` document; FileFormatError if damaged."""
        if not isinstance(document, dict) or "features" not in document or "kriging" not in document:
            raise damaged("joint-input Kriging model", "expected 'features' and 'kriging' entries")
        features = JointFeatures.from_dict(document["features"])
        kriging = Kriging.from_dict(document["kriging"])
        if kriging.n_features_in_ != features.n_features:
            raise damaged("joint-input Kriging model", f"the Kriging has {kriging.n_features_in_} inputs but "
                          f"the {features.kind} of joints {features.joints.tolist()} make {features.n_features}")
        model = cls(features.kind, kriging)
        model.features_, model.kriging_ = features, kriging
        model.diagnostics_ = kriging.diagnostics_ + model._dropped_note()
        return model
