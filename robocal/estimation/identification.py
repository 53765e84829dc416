"""The identification core the kinematic and the constraint calibrations share.

Each calibration brings what is its own: how to analyse the identifiability of its
residual at a chain, how to fit a set of parameters, and the weighted rows its covariance
comes from.  This module runs the rest the same way for both:

* the analyse → fit → re-analyse loop: identifiability is local (nominal geometry can make
  parameters look dependent, say a TCP exactly on the last axis, that the real robot
  separates), so the set is analysed again at the fit until it settles;
* the refit without the joint gains the data pin down too loosely, and without the joint
  compliances they cannot tell from zero or that would bend a joint further than any arm
  bends under its own weight;
* the covariance, standard errors and strongly correlated pairs of the identified set;
* the record every calibration result shares (:class:`IdentifiedResult`), and the document
  a fitted calibration serialises to.

Names of the base frame and tool position parameters are defined here, once.
"""
from dataclasses import dataclass, field, replace
from functools import cache
from collections.abc import Callable

import numpy as np

from ..errors import FileFormatError, InputError
from ..io.robot_file import chain_from_dict, chain_to_dict
from ..kinematics.compliant import UNITS_NOTE, CompliantChain, file_units
from ..kinematics.parameters import COMPLIANCE
from ..kinematics.tolerances import prior_sigmas, tolerances_of
from .identifiability import STRONG_CORRELATION, IdentifiabilityReport
from .least_squares import Fit, Prior


BASE = ("base_x", "base_y", "base_z", "base_rx", "base_ry", "base_rz")
TOOL_POSITION = ("tool_x", "tool_y", "tool_z")
# How many times the identified set is analysed before the loop stops: on every data set
# and test so far it settles by the second analysis.
MAX_ANALYSES = 3
# A joint gain the data determine no better than this (0.1 %) is left at its starting value:
# real transmission errors are smaller, and a free one takes up noise (on the UR5 tracker
# data the wrist's gain came out at -47 % +- 158 % while the others had 64-335 ppm errors).
GAIN_STD_LIMIT = 1e-3
# A joint compliance is kept only if it is this many standard errors from zero, and if the
# deflection it gives under the largest gravity torque of the poses stays within
# MAX_GRAVITY_DEFLECTION_DEG; otherwise the joint is taken as rigid.  A compliance that fails
# either is not the joint giving way: it takes up an error that varies with the arm's posture
# as gravity's torque does, and it goes wrong where the posture changes.  Trained on one
# elbow side of the UR10 series B data, compliances of -1.4 +- 1.2 and 94 +- 259 urad/(N*m)
# (joints 2 and 4) made the calibration worse on the other side (1.025 mm against 0.937
# rigid), and from the other side a compliance bending joint 3 by 0.37 deg made it 2.28 mm
# against 1.035; the compliances that generalise are well determined and small (UR10 series
# A, joints 2 and 3: 4.9 +- 1.0 and 14 +- 3 urad/(N*m), 0.03 deg, 0.82 mm on the other shoulder
# side against 1.87 rigid; the UR5's joint 2: 31 +- 2.6, 0.08 deg, the largest seen on a real
# arm).  Held out on random halves the rule changes the UR10 B figure by 0.0002 mm.
COMPLIANCE_SIGNIFICANCE = 2.0
MAX_GRAVITY_DEFLECTION_DEG = 0.25
# A fit whose distance from nominal (sum of squared deviations over tolerances) would occur
# with less than this probability under the tolerances is not this robot's (implausible_fit).
PLAUSIBLE_PROBABILITY = 1e-6
# ... and that moves some parameter by more than this many tolerances: real arms have a few
# well-determined deviations far beyond the tolerance of their kind (the MUKCa Pandas' wrist
# axes, 24), another robot's geometry hundreds.
GROSS_TOLERANCES = 50.0
# ... unless the nominal residual is already within this many times the instrument's noise.
NOISE_FLOOR = 3.0
# A parameter whose prior variance the data reduce by less than half is "held by its prior":
# the fit keeps it near nominal, within its tolerance, and says so.
HELD_BY_PRIOR = 0.5


# ------------------------------------------------------------------- settings
def check_payload(payload):
    """None, or a validated payload mass in kg."""
    if payload is None:
        return None
    try:
        value = float(payload)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value) or value < 0:
        raise InputError(f"payload must be a mass in kg >= 0, got {payload}")
    return value


def check_iterations(value, setting="max_iterations"):
    """A whole number of iterations >= 1, or InputError (0 would return the start unfitted)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputError(f"{setting} must be a whole number >= 1, got {value!r}")
    return int(value)


def check_prior(prior, scale):
    """InputError unless ``prior`` is 'tolerances' or 'none' and ``scale`` a number > 0."""
    one_of(prior, ("tolerances", "none"), "prior")
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not np.isfinite(scale) or scale <= 0:
        raise InputError(f"tolerance_scale must be a number > 0, got {scale!r}")


def tolerance_prior(start, names, joints, prior, scale, deviation):
    """The :class:`~robocal.estimation.least_squares.Prior` of a calibration from ``start``
    over ``names`` at the configurations ``joints`` (N, n) rad: the robot's tolerances
    (:mod:`robocal.kinematics.tolerances`) times ``scale``, centred on ``start`` by
    ``deviation(chain, names)``; None when ``prior`` is 'none'."""
    if prior == "none":
        return None
    sigmas = prior_sigmas(start, list(names), tolerances_of(start, scale), joints)
    return Prior({n: float(s) for n, s in zip(names, sigmas) if np.isfinite(s)}, deviation)


@cache
def _plausible_distance(dof):
    """The chi-square quantile of ``dof`` degrees of freedom at PLAUSIBLE_PROBABILITY (scipy's
    quantile costs a fit more than its check)."""
    from scipy.stats import chi2

    return float(chi2.isf(PLAUSIBLE_PROBABILITY, dof))


def implausible_fit(names, values, prior_std, before_rms, after_rms, noise_rms, tolerance_rms, space, *, override,
                    distances=None):
    """The one-line reason a maximum a posteriori fit is not this robot's data, or None.

    Two kinds of evidence, both in the data's own statistics rather than fixed millimetres:

    * distance from nominal: sum over the parameters with a prior of (deviation /
      tolerance)², against the chi-square quantile of as many degrees of freedom at
      PLAUSIBLE_PROBABILITY, with at least one deviation beyond GROSS_TOLERANCES (real arms
      on tracker data: 4.5 to 16.5 for 16 to 18 parameters; the Pandas' ball-in-socket data
      990 for 30, a wrist axis 10 mm, 24 tolerances, from the nominal POE model, well
      determined; a UR10's data fitted as a UR5's move a2 and a3 by 180 mm, over 500
      tolerances);
    * what calibration leaves: a calibration within the tolerances that still misses by more
      than the whole error the tolerances predict for the nominal robot (``tolerance_rms``,
      times the chi-square margin of as many parameters at PLAUSIBLE_PROBABILITY) and than
      NOISE_FLOOR times the instrument's noise is not of this robot's data (real arms leave
      a tenth of it or less; another robot's data or another unit leave tens to hundreds of
      mm, the prior holding a model that cannot fit them).  A robot already calibrated,
      whose small residual is mostly what no geometry explains, passes.

    names, values, prior_std: (P,) the fitted deviations and their tolerances (internal
    units, inf for none); before_rms, after_rms: mm RMS of the registered nominal and the
    calibrated model; noise_rms: mm RMS the instrument's noise alone gives; tolerance_rms: mm
    RMS of the nominal robot's error that the tolerances predict at these poses (or a callable
    that computes it, called only when needed); space: the chain's
    parameter space (for units); override: the option that widens the tolerances.
    distances: for ball-in-socket data, (before_rms, after_rms, tolerance_rms) mm of the
    socket distances' errors, judged as what calibration leaves is (the position residual
    says nothing of a fixture whose distances are wrong: the fit bends the robot toward them
    and keeps its sockets consistent).
    """
    values = np.asarray(values, dtype=float)
    prior = np.asarray(prior_std, dtype=float)
    held = np.isfinite(prior)
    z = np.where(held, values / np.where(held, prior, 1.0), 0.0)
    distance = float(np.sum(z ** 2))
    limit = _plausible_distance(max(int(held.sum()), 1))
    if distance > limit and np.max(np.abs(z)) > GROSS_TOLERANCES:
        worst = np.argsort(-np.abs(z))[:3]
        said = ", ".join(f"{names[k]} by {_shown(space, names[k], values[k])} ({abs(z[k]):.0f} tolerances)"
                         for k in worst if held[k] and abs(z[k]) > 1)
        return (f"the calibration moves {said} from the registered nominal robot: {distance:.0f} squared "
                f"tolerances in all where a robot of this type stays within {limit:.0f}, so these data are not this "
                f"robot's, or not in mm and degrees: check the robot file and the data, or widen the tolerances "
                f"({override})")
    explained = 1.0 - (after_rms / before_rms) ** 2 if before_rms > 0 else 1.0
    # A robot within its tolerances, calibrated, leaves less than the whole error they predict
    # for its nominal model, give or take the chi-square spread of as many parameters at
    # PLAUSIBLE_PROBABILITY.
    margin = float(np.sqrt(limit / max(int(held.sum()), 1)))
    if after_rms > NOISE_FLOOR * noise_rms and callable(tolerance_rms):
        tolerance_rms = tolerance_rms()  # a Jacobian over poses: only when it can decide
    if distances is not None:
        d_before, d_after, d_tolerance = distances
        if d_after > margin * d_tolerance:
            return (f"the registered nominal robot misses the fixture's socket distances by {d_before:.3g} mm RMS and "
                    f"its calibration within the tolerances still by {d_after:.3g} mm, where a robot within its "
                    f"tolerances misses them by {d_tolerance:.2g} mm RMS: these ball-in-socket data are not this "
                    f"robot's with this fixture, or not in mm: check the robot, the fixture file and the data; if "
                    f"they are right, widen the tolerances ({override})")
    if after_rms > max(NOISE_FLOOR * noise_rms, margin * (0.0 if callable(tolerance_rms) else tolerance_rms)):
        return (f"the registered nominal robot misses these data by {before_rms:.3g} mm RMS and its calibration "
                f"within the tolerances still by {after_rms:.3g} mm (it explains {max(explained, 0.0):.0%} of the "
                f"error), where a robot within its tolerances misses by {tolerance_rms:.2g} mm RMS before any "
                f"calibration: these data are not this robot's, or the robot file or the data are not in mm and "
                f"degrees; if they are, widen the tolerances ({override})")
    return None


def tolerance_rms(chain, joints, names, prior_std, rows=3, most=50):
    """mm RMS of the TCP error the tolerances predict for the nominal robot at ``joints``
    (N, n) rad: sqrt(mean trace(J Σp Jᵀ)) over the position rows of the identification
    Jacobian of ``names`` with prior standard deviations ``prior_std`` (at most ``most``
    poses, evenly spread)."""
    prior = np.asarray(prior_std, dtype=float)
    held = np.isfinite(prior)
    if not np.any(held):
        return 0.0
    q = np.asarray(joints, dtype=float)
    q = q[np.linspace(0, len(q) - 1, min(len(q), most)).astype(int)]
    held_names = [n for n, h in zip(names, held) if h]
    jac = chain.identification_jacobian(q, held_names)[:, :rows, :] * prior[held]
    return float(np.sqrt(np.sum(jac ** 2) / len(q)))


def _shown(space, name, value):
    """A deviation in file units with its unit: '12.7 deg', '283.3 mm', '1200 ppm'."""
    record = space.get(name)
    if record is None:
        return f"{value:.3g}"
    return f"{value * record.file_factor:.3g} {record.file_unit}"


def one_of(value, choices, setting):
    """InputError naming ``setting`` unless ``value`` is one of ``choices``."""
    if value not in choices:
        raise InputError(f"{setting} must be one of {', '.join(choices)}, got {value!r}")
    return value


# --------------------------------------------------------------------- steps
@dataclass(frozen=True)
class Analysis:
    """An identifiability analysis at one chain.

    identified: the names the data determine there, in the order of preference;
    explain: () -> IdentifiabilityReport with the reasons (made only when asked for).
    """

    identified: tuple
    explain: Callable


@dataclass(frozen=True)
class Identification:
    """What the identification loop found.

    chain: the fitted chain; names: the identified parameters (tuple of str); report: the
    IdentifiabilityReport (joint gains left out for a loose fit among its fixed ones);
    iterations: fit steps over all fits; converged: of the last fit; fit: the last
    :class:`Fit`; std_errors: (P,) posterior standard errors of the identified deviations
    (rad, mm, ...); correlated_pairs: ((name, name, correlation), ...) beyond
    STRONG_CORRELATION; covariance: (P, P) their posterior covariance; prior_std: (P,) their
    prior standard deviations (inf: no prior).
    """

    chain: object
    names: tuple
    report: IdentifiabilityReport
    iterations: int
    converged: bool
    fit: Fit
    std_errors: np.ndarray
    correlated_pairs: tuple
    covariance: np.ndarray = None
    prior_std: np.ndarray = None
    prior_scale: float = 1.0


# ---------------------------------------------------------------------- core
def covariance(residual, jacobian, names, prior_std=None):
    """Posterior covariance, standard errors and strongly correlated pairs of a weighted
    least-squares fit.

    residual: (m,) weighted residual at the fit; jacobian: (m, P) its weighted Jacobian
    columns for ``names`` (or an R factor (P, P) with RᵀR = JᵀJ);
    prior_std: (P,) prior standard deviations (inf or None: no prior).  The residual
    variance is estimated from the fit (m - P degrees of freedom); the posterior precision is
    JᵀJ over it plus the prior's; columns are scaled to unit norm before the
    (pseudo-)inverse.  Returns ((P, P) covariance, (P,) standard errors,
    ((name, name, correlation), ...)).
    """
    dof = max(len(residual) - len(names), 1)
    sigma2 = float(residual @ residual) / dof
    scale = np.linalg.norm(jacobian, axis=0)
    scale[scale == 0] = 1.0
    scaled = jacobian / scale
    precision = scaled.T @ scaled
    if prior_std is not None and sigma2 > 0:
        precision = precision + np.diag(sigma2 / (np.asarray(prior_std, dtype=float) * scale) ** 2)
    cov = sigma2 * np.linalg.pinv(precision, hermitian=True) / np.outer(scale, scale)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(std, std)
    upper = np.argwhere(np.triu(np.abs(corr) > STRONG_CORRELATION, 1))
    return cov, std, tuple((names[a], names[b], float(corr[a, b])) for a, b in upper)


def data_share(std_errors, prior_std):
    """(P,) how much of each parameter's prior variance the data removed: 1 - posterior
    variance / prior variance (1 where there is no prior: the data alone determine it)."""
    prior = np.asarray(prior_std, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = 1.0 - (np.asarray(std_errors, dtype=float) / prior) ** 2
    return np.where(np.isfinite(prior), np.clip(share, 0.0, 1.0), 1.0)


def loose_gains(chain, names, std_errors):
    """{name: reason} for the joint gains among ``names`` whose standard error (a fraction)
    exceeds GAIN_STD_LIMIT: refit without them."""
    space = chain.parameters
    return {name: (f"{name} is determined to ±{s * 1e6:.0f} ppm only (more than "
                   f"{GAIN_STD_LIMIT * 1e6:.0f}): left at its starting value")
            for name, s in zip(names, std_errors) if space[name].group == "gains" and s > GAIN_STD_LIMIT}


def loose_compliances(fitted, names, std_errors, joints):
    """{name: reason} for the joint compliances among ``names``, identified in the compliant
    chain ``fitted`` from the configurations ``joints`` (N, n) rad, that are within
    COMPLIANCE_SIGNIFICANCE standard errors of zero, or that bend a revolute joint by more
    than MAX_GRAVITY_DEFLECTION_DEG under the largest gravity torque of ``joints``: refit
    without them (the joint rigid)."""
    space = fitted.parameters
    picked = [(k, space[n]) for k, n in enumerate(names) if space[n].group == COMPLIANCE]
    if not picked or joints is None:
        return {}
    torque = np.abs(fitted.gravity_torque(np.asarray(joints, dtype=float))).max(axis=0)
    out = {}
    for k, record in picked:
        name, value, std = names[k], float(fitted.compliance[record.joint - 1]), float(std_errors[k])
        shown = f"{name} came out at {value * 1e6:.3g} ± {std * 1e6:.3g} µrad/(N·m)"
        bend = np.degrees(abs(value) * torque[record.joint - 1])
        if abs(value) < COMPLIANCE_SIGNIFICANCE * std:
            out[name] = f"{shown}, not told from zero by these poses: the joint is taken as rigid"
        elif fitted.revolute[record.joint - 1] and bend > MAX_GRAVITY_DEFLECTION_DEG:
            out[name] = (f"{shown}, which would bend the joint by {bend:.2f} deg under its gravity torque, more than "
                         f"{MAX_GRAVITY_DEFLECTION_DEG} deg: not a compliance (an error that varies with the posture); "
                         "the joint is taken as rigid")
    return out


def _settle(start, candidates, analyse, fit, linearise, prior=None):
    """Analyse, fit, analyse again at the fit until the identified set settles (at most
    MAX_ANALYSES analyses).  The report is that of the analysis whose set was fitted last."""
    fitted, identified, iterations, analysis = Fit(start, 0, False), None, 0, None
    for _ in range(MAX_ANALYSES):
        analysis = analyse(fitted.chain, candidates)
        if analysis.identified == identified:
            break
        identified = analysis.identified
        fitted = fit(fitted.chain, identified)
        iterations += fitted.iterations
    prior_std = None if prior is None else prior.sigmas(list(identified)) * fitted.prior_scale
    residual, jacobian = linearise(fitted, list(identified))[:2]
    cov, std, pairs = covariance(residual, jacobian, list(identified), prior_std)
    return Identification(chain=fitted.chain, names=tuple(identified), report=analysis.explain(),
                          iterations=iterations, converged=fitted.converged, fit=fitted,
                          std_errors=std, correlated_pairs=pairs, covariance=cov, prior_scale=fitted.prior_scale,
                          prior_std=np.full(len(identified), np.inf) if prior_std is None else prior_std)


def identify(start, candidates, *, analyse, fit, linearise, joints=None, prior=None):
    """Identify what the data determine among ``candidates``, from the chain ``start``.

    analyse(chain, candidates) -> :class:`Analysis`; fit(chain, names) ->
    :class:`~robocal.estimation.least_squares.Fit`;
    linearise(fit, names) -> (weighted residual (m,), weighted Jacobian (m, P)) at a fit, for
    the covariance; ``joints``: (N, n) rad, the configurations fitted (for the gravity
    torques that judge a compliance).  When some joint gains come out looser than
    GAIN_STD_LIMIT, or some compliances fail :func:`loose_compliances`, the whole
    identification runs again from ``start`` without them, and the report says why they
    were left out.  ``prior``: the :class:`~robocal.estimation.least_squares.Prior` that
    ``fit`` uses, for the posterior covariance (None: plain least squares).  Returns an
    :class:`Identification`.
    """
    found = _settle(start, list(candidates), analyse, fit, linearise, prior)
    loose = {**loose_gains(start, found.names, found.std_errors),
             **loose_compliances(found.chain, found.names, found.std_errors, joints)}
    if not loose:
        return found
    again = _settle(start, [n for n in candidates if n not in loose], analyse, fit, linearise, prior)
    return replace(again, iterations=found.iterations + again.iterations,
                   report=replace(again.report, fixed={**again.report.fixed, **loose}))


# -------------------------------------------------------------------- results
def identified_parameters(chain, result):
    """The part of a calibration record every method shares: each identified parameter's
    deviation and standard error in file units (with a prior, its tolerance, ``null`` for
    none, and the share of its prior variance the data removed), correlated pairs and the
    identifiability."""
    unit = file_units(chain, result.names)
    entries = {n: {"deviation": float(v), "std_error": float(s)}
               for n, v, s in zip(result.names, result.values * unit, result.std_errors * unit)}
    if result.prior_std is not None:
        for n, p, share in zip(result.names, result.prior_std * unit, result.data_share):
            entries[n].update(prior_std=float(p) if np.isfinite(p) else None, data_share=float(share))
    return {
        "parameters": entries,
        "units": UNITS_NOTE,
        "correlated_pairs": [list(p) for p in result.correlated_pairs],
        "identifiability": result.identifiability.to_dict(),
    }


@dataclass(frozen=True)
class IdentifiedResult:
    """The fields every calibration result has.

    names: identified parameters; values: (P,) their deviations from the starting model
    (rad, mm, rad/(N·m), gain); std_errors: (P,) standard errors of those; correlated_pairs:
    ((name, name, correlation), ...); identifiability: IdentifiabilityReport;
    residual_before / residual_after: error statistics of the starting and the calibrated
    model on the training data (mm); iterations; converged; prior_std: (P,) the prior
    standard deviations (the tolerances; inf: no prior), and data_share: (P,) how much of
    each prior variance the data removed (:func:`data_share`), or None for a plain fit.
    """

    names: tuple
    values: np.ndarray
    std_errors: np.ndarray
    correlated_pairs: tuple
    identifiability: IdentifiabilityReport
    residual_before: dict
    residual_after: dict
    iterations: int
    converged: bool
    prior_std: np.ndarray | None = field(default=None, kw_only=True)
    # The common scale of the tolerances the data supported (1: as the tolerances say).
    tolerance_scale: float = field(default=1.0, kw_only=True)

    @property
    def data_share(self):
        """(P,) 1 - posterior / prior variance per parameter (1 without a prior), or None."""
        return None if self.prior_std is None else data_share(self.std_errors, self.prior_std)

    @property
    def held_by_prior(self):
        """The parameters whose uncertainty the data reduced by less than half
        (HELD_BY_PRIOR): they stay near nominal within their tolerance."""
        share = self.data_share
        return () if share is None else tuple(n for n, s in zip(self.names, share) if s < HELD_BY_PRIOR)

    def _details(self):
        """The result's own entries of :meth:`to_dict`, in their order."""
        raise NotImplementedError

    def to_dict(self, chain):
        """Deviations and standard errors in file units (deg for angles, mm for lengths),
        then the result's own entries: JSON-ready."""
        return {**identified_parameters(chain, self), **self._details()}

    @staticmethod
    def _shared_fields(doc, chain):
        """The shared fields back from :meth:`to_dict`'s ``doc`` (KeyError, TypeError or
        ValueError if it is damaged)."""
        names = tuple(doc["parameters"])
        unit = file_units(chain, names)
        ident = dict(doc["identifiability"])
        with_prior = all("prior_std" in doc["parameters"][n] for n in names) and bool(names)
        prior = (np.array([np.inf if doc["parameters"][n]["prior_std"] is None else doc["parameters"][n]["prior_std"]
                           for n in names], dtype=float) / unit) if with_prior else None
        return dict(
            prior_std=prior,
            names=names,
            values=np.array([doc["parameters"][n]["deviation"] for n in names], dtype=float) / unit,
            std_errors=np.array([doc["parameters"][n]["std_error"] for n in names], dtype=float) / unit,
            correlated_pairs=tuple((str(a), str(b), float(c)) for a, b, c in doc["correlated_pairs"]),
            identifiability=IdentifiabilityReport(**{**ident, "identified": tuple(ident["identified"])}),
            residual_before=dict(doc["residual_before"]), residual_after=dict(doc["residual_after"]),
            iterations=int(doc["iterations"]), converged=bool(doc["converged"]))


# --------------------------------------------------------- fitted documents
def chain_document(chain):
    """A chain (rigid or compliant) as {"robot": robot-file structure (mm, deg), and
    "joint_compliance" when it has one}, JSON-ready."""
    doc = {"robot": chain_to_dict(chain)}
    if isinstance(chain, CompliantChain):
        doc["joint_compliance"] = chain.compliance_document()
    return doc


def chain_from_document(doc, where):
    """The chain of a :func:`chain_document`; FileFormatError if it is damaged."""
    if not isinstance(doc, dict) or not isinstance(doc.get("robot"), dict):
        raise FileFormatError(f"{where}: no robot document; regenerate it")
    chain = chain_from_dict(doc["robot"], where)
    if "joint_compliance" in doc:
        chain = CompliantChain.from_document(chain, doc["joint_compliance"], where)
    return chain


class FittedCalibration:
    """What a fitted calibration offers beyond its fit: the positions of the calibrated model
    and its document.

    A subclass sets KIND (the document's "estimator" entry) and RESULT (its result class,
    with ``from_dict(doc, chain)``), defines ``get_settings()`` and ``_validate()``, and its
    ``fit`` sets ``chain_``, ``start_chain_``, ``names_`` and ``result_``.
    """

    KIND = ""
    RESULT = None

    def _require_fitted(self):
        if not hasattr(self, "result_"):
            raise InputError(f"this {type(self).__name__} is not fitted: call fit first")

    def predict(self, joints):
        """(N, 3) mm: positions of the calibrated model at joints (N, n) rad (mm for
        prismatic joints), as commanded; InputError if not fitted."""
        self._require_fitted()
        return self.chain_.fk_positions(np.asarray(joints, dtype=float))

    def to_dict(self):
        """The fitted calibration as a JSON-ready dict: "estimator", "settings" (as given),
        "chain" and "start_chain" (each {"robot": robot-file structure in mm and deg, and
        "joint_compliance" when it has one}), "names" and "result" (the result's
        ``to_dict(chain_)``).  InputError if not fitted."""
        self._require_fitted()
        return {"estimator": self.KIND, "settings": self.get_settings(),
                "chain": chain_document(self.chain_), "start_chain": chain_document(self.start_chain_),
                "names": list(self.names_), "result": self.result_.to_dict(self.chain_)}

    @classmethod
    def from_dict(cls, doc):
        """A fitted calibration back from :meth:`to_dict`; FileFormatError, in one line, if
        ``doc`` is not such a document or is damaged."""
        where = f"{cls.KIND} calibration document"
        if not isinstance(doc, dict) or doc.get("estimator") != cls.KIND:
            raise FileFormatError(f"not a {where} (no \"estimator\": \"{cls.KIND}\")")
        try:
            out = cls(**doc["settings"])
            out._validate()
            out.chain_ = chain_from_document(doc["chain"], f"{where} (chain)")
            out.start_chain_ = chain_from_document(doc["start_chain"], f"{where} (start_chain)")
            out.names_ = tuple(str(n) for n in doc["names"])
            out.result_ = cls.RESULT.from_dict(doc["result"], out.chain_)
        except (KeyError, TypeError, ValueError, AttributeError, InputError) as exc:
            raise FileFormatError(f"{where} is damaged ({type(exc).__name__}: {exc}); regenerate it") from None
        return out
