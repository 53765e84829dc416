"""The method protocol: every calibration / error-compensation method is one class.

A method is an estimator over a robot and its observations, in scikit-learn's manner:

* its settings are the constructor's keyword arguments, stored unchanged; a keyword the
  method does not take is refused at once (``--payload`` means nothing to Kriging), and the
  values are validated at the start of :meth:`Method.fit`, each against the constraint its
  :class:`~robocal.settings.Setting` declares (the same constraint parses the command line's
  options and a fleet file's);
* ``fit(chain, observations)`` returns the method fitted, with the attributes
  ``compensator_`` (the :class:`~robocal.compensation.Compensator` that turns targets into
  commands), ``reference_`` (the nominal geometry in the measurement frame: the honest
  "before") and ``record_`` (a :class:`FitRecord`: what was done);
* ``predict(joints)`` is where the real robot's TCP goes, (N, 3) mm in the measurement frame;
* ``to_model_file`` / ``from_model_file`` write it to a model file and read it back, and
  ``report_figures`` names the diagnostics its report section shows.

The registry (:mod:`robocal.methods`) maps names to these classes; nothing else in robocal
asks which method it holds.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..compensation import Compensator
from ..errors import FileFormatError, InputError
from ..estimation.calibration import LOSSES, PARAMETER_SETS, check_payload, parameter_terms
from ..io.model_file import ModelFile
from ..settings import Choice, Number, Setting, check_settings
from .domain import Domain
from .fallback import DomainFallback, from_fallback_document
from .records import FitRecord
from .reregistration import ReframedErrorModel, is_reframed, reframed_document, reframed_from_document

REGISTER_CHOICES = ("auto", "yes", "no")
# What an error model of the position error takes as input: the TCP position (Cartesian, as
# Liu et al. 2022), the joint vector, or the sines and cosines of the joints.
ERROR_MODEL_INPUTS = ("position", "joints", "sincos")

# Settings several methods share, each declared once with its constraint.  A help is a phrase
# the command line prefixes with the methods that take it and follows with the default.
REGISTER = Setting("register", "auto", "--register",
                   "register base and tool first: auto (when the data are not in the robot base frame), yes or no",
                   Choice(REGISTER_CHOICES))
PARAMETERS = Setting("parameters", "full", "--parameters",
                     "the parameter set: offsets, full, full+gains (plus a scale error of each joint reading), "
                     "full+compliance (plus the stiffness of every joint gravity loads) or full+compliance+gains "
                     "(ann: for --base-model kinematic)", Choice(PARAMETER_SETS))
LOSS = Setting("loss", "linear", "--loss", "the loss: linear, or huber or soft_l1 (robust to outliers)", Choice(LOSSES))
PAYLOAD = Setting("payload", None, "--payload",
                  "with a compliance parameter set, the mass at the TCP in kg (default: 0 if the robot file gives "
                  "link masses, else the rated payload of a robot of that size)", Number(at_least=0))
RANDOM_STATE = Setting("random_state", 0, "--seed", "seed of the random search (Kriging's multi-start search, the "
                       "network's training)", Number(whole=True, at_least=0), optional=True)
PRIOR = Setting("prior", "tolerances", "--prior",
                "tolerances (each parameter weighed against its manufacturing tolerance: maximum a posteriori; one the "
                "poses cannot pin stays near nominal) or none (plain least squares)", Choice(("tolerances", "none")))
TOLERANCE_SCALE = Setting("tolerance_scale", 1.0, "--tolerance-scale",
                          "multiply every tolerance (the robot file's [tolerances] or the defaults) by this, for a "
                          "robot known to lie further from its drawing", Number(between=(0, 1e6)))


class Method:
    """Base of every method; see the module docstring for the protocol.

    Subclasses set ``name``, ``description``, ``settings`` and ``data_kind`` (``"position"``:
    measured TCP positions; ``"sockets"``: ball-in-socket joint readings) and implement
    ``fit``; those with an error model also ``error_model_document`` and
    ``error_model_from_document``.
    """

    name: ClassVar[str]
    description: ClassVar[str]
    data_kind: ClassVar[str] = "position"
    settings: ClassVar[tuple[Setting, ...]] = ()
    # What the command line's progress bar counts while this method fits.
    progress_label: ClassVar[str] = "fitting"
    # Whether a fit has independent pieces that an active robocal.parallel executor runs on
    # its workers (calibrate --jobs): Kriging's likelihood search of each error component.
    spreads_work: ClassVar[bool] = False
    # Whether the fit itself judges that the data are this robot's (a calibration under the
    # tolerances does); if not, fit runs robocal.estimation.plausibility.check_robot_data first.
    checks_its_data: ClassVar[bool] = False

    def __init__(self, **settings):
        known = {s.name for s in self.settings}
        for key in settings:
            if key not in known:
                raise InputError(f"{option_of(key)} does not apply to the {self.name} method; it takes "
                                 f"{', '.join(s.option for s in self.settings) or 'no settings'}")
        for setting in self.settings:
            setattr(self, setting.name, settings.get(setting.name, setting.default))

    def get_settings(self):
        """The settings as given (JSON-ready: tuples as lists)."""
        return {s.name: list(v) if isinstance(v := getattr(self, s.name), tuple) else v for s in self.settings}

    def progress_total(self):
        """How many steps ``fit`` reports through its ``progress`` callback (None: unknown)."""
        return None

    def clone(self):
        """A new unfitted method with the same settings."""
        return type(self)(**{s.name: getattr(self, s.name) for s in self.settings})

    @classmethod
    def candidates(cls, chain, observations, training, forced=None):
        """(list of :class:`~robocal.methods.candidacy.Candidate`, notes): how this method is
        compared on ``observations`` of ``chain`` whose comparison fits see ``training`` poses
        (``forced``: {method name: True/False} to force one in or out).  Not a candidate here."""
        return [], []

    # ------------------------------------------------------------------ fitting
    def fit(self, chain, observations, progress=None):
        """Fit to ``observations`` (:class:`~robocal.io.observations.Observations`) of ``chain``;
        returns self with ``compensator_``, ``reference_``, ``record_`` and ``domain_`` (the
        training data's :class:`~robocal.methods.domain.Domain`).  ``progress(**info)`` is
        called as the fit reports its steps (see :meth:`progress_total`).  Data that cannot be
        this robot's are refused first (:mod:`robocal.estimation.plausibility`), and before them
        a setting its constraint refuses (:meth:`robocal.settings.Setting.check`)."""
        check_settings(self.settings, {s.name: getattr(self, s.name) for s in self.settings})
        from ..estimation.plausibility import check_measured, check_positions_follow_the_robot, check_robot_data

        # Positions stuck while the robot moves, named before they are judged another robot's.
        check_positions_follow_the_robot(chain, observations)
        if not self.checks_its_data:
            self.data_check_ = check_robot_data(chain, observations, getattr(self, "prior", "tolerances"),
                                                getattr(self, "tolerance_scale", 1.0))
        self._fit(chain, observations, progress)
        # After the fit, whose own checks (too few poses, a bad weight) name the finer fault.
        check_measured(chain, observations)
        self.domain_ = Domain.of(chain, observations)
        return self

    def _fit(self, chain, observations, progress):
        """What the method does to fit: set ``compensator_``, ``reference_`` and ``record_``."""
        raise NotImplementedError

    def predict(self, joints):
        """Where the real robot's TCP goes at ``joints`` (N, n) rad: (N, 3) mm in the
        measurement frame (for ball-in-socket data, the ball centre in the robot's frame)."""
        self._check_fitted()
        return self.compensator_.predict_positions(self.compensator_.chain.joint_batch(joints))

    def uncertainty(self, joints):
        """The standard deviation (N,) mm of :meth:`predict` at ``joints`` (N, n) rad, as the
        error model predicts it; None for a method without such an estimate."""
        self._check_fitted()
        return None

    def _check_fitted(self):
        if not hasattr(self, "compensator_"):
            raise InputError(f"this {self.name} method is not fitted: call fit(chain, observations) first")

    # ------------------------------------------------------------- model files
    def error_model_document(self):
        """The error model as the model file's ``error_model`` entry (None: none)."""
        return None

    @classmethod
    def error_model_from_document(cls, document, path):
        """(error model, its input: 'position' or 'joints') from a model file's entry."""
        if document is not None:
            raise FileFormatError(f"{path}: a {cls.name} model has no error model, but the file has one; "
                                  "regenerate it with 'robocal calibrate'")
        return None, "position"

    def to_model_file(self, nominal, training=None):
        """The fitted method as a :class:`ModelFile` of robot ``nominal``; ``training`` adds
        entries about the data (file, number of poses) to the record."""
        self._check_fitted()
        compensator = self.compensator_
        outside = alternative = None
        if isinstance(compensator, DomainFallback):
            outside = (compensator.label, compensator.outside.chain, compensator.outside.reference)
            compensator = compensator.inside
            other = getattr(self, "outside_alternative_", None)
            if other is not None:
                alternative = (other[0], other[1].chain, other[1].reference)
        # A re-registered error model is written as the method writes its own, wrapped with
        # the frame it was moved by (robocal.methods.reregistration).
        document = (reframed_document(self) if isinstance(compensator.error_model, ReframedErrorModel)
                    else self.error_model_document())
        return ModelFile(method=self.name, nominal=nominal, kinematics=compensator.chain, outside=outside,
                         outside_alternative=alternative,
                         reference=self.reference_, error_model=document,
                         training={**(training or {}), **self.record_.to_dict()}, options=self.get_settings(),
                         domain=None if getattr(self, "domain_", None) is None else self.domain_.to_dict())

    @classmethod
    def from_model_file(cls, model, path):
        """The fitted method a :class:`ModelFile` holds (``path`` names it in messages)."""
        names = {s.name for s in cls.settings}
        method = cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in model.options.items() if k in names})
        try:
            if is_reframed(model.error_model):
                error_model, error_input = reframed_from_document(
                    model.error_model, lambda document: cls.error_model_from_document(document, path))
            else:
                error_model, error_input = cls.error_model_from_document(model.error_model, path)
        except FileFormatError:
            raise
        except (InputError, KeyError, TypeError, ValueError) as exc:
            raise FileFormatError(f"{path}: the error model is damaged ({exc}); "
                                  "regenerate the file with 'robocal calibrate'") from None
        method.compensator_ = Compensator(model.kinematics, error_model, nominal=model.kinematics.rigid,
                                          error_input=error_input, controller=model.nominal, reference=model.reference)
        method.reference_ = model.reference
        method.record_ = FitRecord.from_dict(model.training)
        # Files written before the domain was recorded have none: the verbs say so.
        method.domain_ = None if model.domain is None else Domain.from_dict(model.domain, model.nominal, path)
        if model.outside is not None:
            method.compensator_ = from_fallback_document(method.compensator_, model.outside, method.domain_, path)
            if model.outside_alternative is not None:
                label, chain, reference = model.outside_alternative
                method.outside_alternative_ = (label, Compensator(chain, None, nominal=chain.rigid,
                                                                  controller=model.nominal, reference=reference))
        return method

    # ------------------------------------------------------------------ report
    def report_figures(self, joints):
        """The diagnostics of this method for the report, at ``joints`` (N, n) rad."""
        return []


def option_of(name):
    """The command-line option of a setting keyword."""
    return RANDOM_STATE.option if name == RANDOM_STATE.name else "--" + name.replace("_", "-")


def check_parameters(parameters, payload):
    """The parameter set's extras ({'compliance', 'gains'} or fewer); a payload without
    compliance is refused, since nothing would use it."""
    terms = parameter_terms(parameters)
    check_payload(payload)
    if payload is not None and "compliance" not in terms:
        raise InputError(f"--payload applies to the compliance parameter sets "
                         f"(full+compliance, full+compliance+gains), not to {parameters!r}")
    return terms


def require_positions(observations, name):
    """``observations`` if they carry measured positions; otherwise a clear refusal."""
    if observations.positions is None:
        raise InputError(f"{observations.path or 'the data'} has no x, y, z columns: the {name} method needs "
                         "measured positions")
    return observations


# A model of the error over the workspace learns nothing from fewer distinct poses than this
# (one pose repeated 50 times would otherwise become a constant correction everywhere).
MIN_DISTINCT_POSES = 5


def require_distinct(observations, name, minimum=MIN_DISTINCT_POSES):
    """``observations`` if at least ``minimum`` of their joint configurations differ."""
    distinct = len(np.unique(np.round(observations.joints, 9), axis=0))
    if distinct < minimum:
        raise InputError(f"{observations.path or 'the data'} holds {distinct} distinct pose(s) "
                         f"in {observations.n_poses} "
                         f"rows: the {name} method models the error over the workspace and needs at least {minimum} "
                         "different poses spread over it; measure more poses")
    return observations
