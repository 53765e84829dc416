"""A 95 % bound on the position error of a fitted method, per pose and per target.

What a model states about its own uncertainty is too small on real data: the Kriging variance
says what the process it assumed would do, not what the robot does (held out on 2,000
simulated KR 150-2 poses it was 15 times too small), and a calibration's posterior says
nothing of what no parameter models.  The bound here starts from the model's own
uncertainty and corrects it by what cross-validation shows the model misses:

* **the model's own standard deviation** σ(x) (mm): for a parametric calibration its
  posterior covariance Σ propagated through the identification Jacobian,
  σ² = trace(J Σ Jᵀ) over the position rows (issue 23's posterior,
  :mod:`robocal.estimation.prediction`); for a Kriging error model its predicted variance
  (:meth:`~robocal.methods.kriging.KrigingResidual.uncertainty`); both for the hybrid; none
  for the network, whose cross-validated spread is the residual scale below;
* **the cross-validated residual scale** r (mm): the root mean square of the held-out error
  norms over random folds of the training data;
* their combination s(x) = sqrt(σ(x)² + r²) is the scale of a normalised score |e| / s(x).

**Inside the training domain** (:meth:`~robocal.methods.domain.Domain.check`), the bound is
q · s(x), q the split-conformal quantile of the scores of the random folds' held-out poses
(those inside their fold's domain): with m scores, the ⌈(m + 1)·0.95⌉-th smallest, which
covers a new pose like them with probability at least 0.95.

**Outside it** no held-out pose of the training data can check the model; the bound rests on
what the model did not model (:mod:`robocal.methods.omitted`): the spread σ_o(x) (mm) of the
error that the parameters it left out (joint compliances and gains; for a model over the
nominal robot, the links too), drawn from their tolerances, cause at x once the fitted
parameters absorbed what they did on the training poses.  The bound there is
max(q · s(x), q_o · sqrt(a² s(x)² + κ² σ_o(x)²)), a and κ fitted by maximum likelihood to
the held-out poses that lay outside their fold's domain when whole regions were left out
(joint-space clusters, :func:`~robocal.methods.splits.cluster_split`, and an arm branch's
other side when the data hold both), κ kept only where those poses support it, and q_o the
conformal quantile of their normalised errors.  It no longer grows with the joint-space
distance from the training configurations: calibrated on regions left out of one side, that
growth extrapolated to another arm branch made the bound 5.2 times the median error on UR10
series B's other elbow side, where the error merely doubled (bench/bound_coverage.py).  A
ball-in-socket bound (:mod:`robocal.methods.socket_bound`) and a model file written before
keep the distance growth (``growth_per_rad``, ``sigma_growth_per_rad``:
:func:`outside_bound`).

A model that answers with another outside its domain (``calibrate --method auto``,
:mod:`robocal.methods.fallback`) has the bound of the chosen model inside and the bound of its
fallback outside.

The fold fits are cheap where the method offers ``refit`` (Kriging, hybrid: the
hyperparameters kept); the bound is computed by ``calibrate`` only, never by the fold fits of
``compare``.  Use from Python::

    bound = fit_bound(method, chain, observations)   # method: fitted
    bound.predict(joints)                            # (N,) mm, 95 % bound per configuration
    method.bound_ = bound; bound95(method, joints)   # the same, as the verbs ask a model

A model file stores the bound (:meth:`PositionBound.to_dict`); a file written before robocal
computed bounds has none, and the verbs say so instead of giving one.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from ..errors import FileFormatError, InputError, RobocalWarning
from ..io.observations import Observations
from .bound_folds import (FOLDS, LEAVE_ONE_OUT_BELOW, MIN_REGION_TRAINING, NETWORK_FOLD_GENERATIONS,  # noqa: F401
                          NETWORK_FOLDS, held_out, random_tests, region_tests)
from .model_sigma import (base_calibration, calibration_posterior, chain_of, joint_distance,  # noqa: F401
                          model_sigma, posterior_sigma)
from .omitted import OutsideScale, fit_outside, omitted_of

# The share of poses the bound is to cover.
COVERAGE = 0.95
# What evaluate, compensate and serve say of a model file without a bound.
NO_BOUND = ("this model file holds no 95 % bound (written before robocal computed one, or from too few poses to "
            "calibrate one): regenerate it with 'robocal calibrate' to get bound95_mm")


def conformal_quantile(scores, coverage=COVERAGE):
    """The split-conformal quantile of ``scores`` (m,): the ⌈(m + 1)·coverage⌉-th smallest,
    which a new exchangeable score stays below with probability at least ``coverage``.
    With fewer than 1/(1 − coverage) − 1 scores that rank does not exist: the largest score,
    scaled by (m + 1)/m, stands for it (the guarantee is then approximate).  NaN if empty."""
    scores = np.sort(np.asarray(scores, dtype=float))
    scores = scores[~np.isnan(scores)]
    m = len(scores)
    if m == 0:
        return float("nan")
    rank = math.ceil((m + 1) * coverage)
    if rank > m:
        return float(scores[-1] * (m + 1) / m)
    return float(scores[rank - 1])


# ------------------------------------------------------------------ the bound
@dataclass(frozen=True)
class PositionBound:
    """A fitted 95 % bound on a method's position error (see the module docstring).

    Attributes
    ----------
    method : Method or None
        The fitted method it bounds (not part of the document: :meth:`from_dict` takes it).
    coverage : float
        The share of poses it is calibrated to cover (0.95).
    residual_mm : float
        r, the root mean square of the held-out error norms over random folds (mm).
    inside_factor : float
        q, the conformal quantile of |e| / s(x) inside the domain (dimensionless).
    growth_per_rad : float or None
        γ, how fast the bound grows outside the domain per rad of joint-space distance from
        the nearest training configuration; None when no region could be left out (then
        the bound outside is unknown: NaN).
    sigma_growth_per_rad : float or None
        κ, how fast the model's own σ grows outside the domain per rad (None: the model has
        no σ, or it cannot cover what the regions left out showed; the γ form alone then).
    posterior : (names, (P, P) covariance) or None
        The parametric posterior propagated into σ(x) (mm and rad), or None.
    training_joints : (M, n) array
        The training configurations the distance is measured from (rad; mm prismatic).
    fallback : PositionBound or None
        The bound of what answers outside the domain (``calibrate --method auto``).
    calibration : dict
        How it was calibrated: held-out poses and folds of each part, and the share each
        part covered (on its own calibration scores, ≥ 0.95 by construction).
    """

    method: object = field(repr=False, compare=False)
    coverage: float
    residual_mm: float
    inside_factor: float
    growth_per_rad: float | None
    sigma_growth_per_rad: float | None
    posterior: tuple | None
    training_joints: np.ndarray = field(repr=False)
    fallback: PositionBound | None = None
    calibration: dict = field(default_factory=dict)
    # The bound of the fallback's alternative (an auto model's other parametric candidate,
    # which a re-registration may make the fallback: robocal.methods.moved_bound), or None.
    alternative: PositionBound | None = None
    # A re-registered model's bound (reregistered_bound): the factor the new set-up's
    # held-out poses calibrate the original's by (1 for a model fitted where it answers).
    set_up_factor: float = 1.0
    # The bound outside the domain (robocal.methods.omitted), or None: then the growth with
    # the joint-space distance (growth_per_rad, sigma_growth_per_rad) of a ball-in-socket
    # bound or of a model file written before, or NaN when neither was calibrated.
    outside: OutsideScale | None = None

    # ------------------------------------------------------------------ predicting
    def scale(self, joints):
        """(N,) mm: s(x) = sqrt(σ(x)² + r²) at ``joints`` (N, n) rad."""
        return np.sqrt(self.sigma(joints) ** 2 + self.residual_mm ** 2)

    def sigma(self, joints):
        """(N,) mm: the model's own standard deviation σ(x) at ``joints`` (N, n) rad."""
        return model_sigma(self.method, joints, self.posterior)

    def inside_mask(self, joints):
        """(N,) bool: the configurations inside the method's training domain (all of them
        when the method records no domain)."""
        domain = getattr(self.method, "domain_", None)
        joints = np.atleast_2d(np.asarray(joints, dtype=float))
        return np.ones(len(joints), dtype=bool) if domain is None else domain.check(joints).inside

    def predict(self, joints, inside=None):
        """The 95 % bound (N,) mm on the position error at ``joints`` (N, n) rad (mm for
        prismatic joints); NaN for a NaN row.  ``inside`` (N,) bool: which lie inside the
        training domain, when the caller has checked already."""
        joints = np.atleast_2d(np.asarray(joints, dtype=float))
        inside = self.inside_mask(joints) if inside is None else np.asarray(inside, dtype=bool)
        known = np.all(np.isfinite(joints), axis=1)
        out = np.full(len(joints), np.nan)
        chosen = known & inside
        if chosen.any():
            out[chosen] = self._own(joints[chosen], inside=True)
        beyond = known & ~inside
        if beyond.any():
            out[beyond] = (self.fallback or self)._own(joints[beyond], inside=False)
        return out * self.set_up_factor

    def predict_one(self, joints, inside):
        """:meth:`predict` of one configuration ``joints`` (n,) rad (mm for prismatic
        joints) that lies inside the training domain or not (``inside``, a bool): the bound in
        mm as a float, NaN for a NaN configuration.  Prepared once per bound, without the
        batch machinery (some 230 us for a batch of one): for ``robocal serve``."""
        joints = np.asarray(joints, dtype=float).reshape(-1)
        if not np.all(np.isfinite(joints)):
            return math.nan
        own = self if inside else (self.fallback or self)
        return own._point.bound(joints, bool(inside)) * self.set_up_factor

    @cached_property
    def _point(self):
        """The one-configuration form of this bound's formula (:class:`.point_bound.PointBound`),
        prepared at its first use."""
        from .point_bound import PointBound

        return PointBound(self)

    def omitted_sigma(self, joints):
        """(N,) mm: σ_o at ``joints`` (N, n) rad, what the model did not model
        (:class:`~robocal.methods.omitted.Omitted`); zeros when it omits nothing."""
        omitted = None if self.outside is None else self.outside.omitted
        if omitted is None:
            return np.zeros(len(np.atleast_2d(joints)))
        return omitted.sigma(chain_of(self.method), joints)

    def _own(self, joints, inside):
        """This bound's formula at ``joints`` (all inside, or all outside)."""
        sigma = self.sigma(joints)
        if not inside and self.outside is not None:
            return self.outside.bound(np.sqrt(sigma ** 2 + self.residual_mm ** 2), self.omitted_sigma(joints),
                                      self.inside_factor)
        return outside_bound(self.inside_factor, self.residual_mm, sigma, None if inside else joint_distance(
            joints, self.training_joints, chain_of(self.method).revolute), self.growth_per_rad,
            self.sigma_growth_per_rad)

    # ------------------------------------------------------------------ documents
    def to_dict(self):
        """The model file's ``bound`` entry (mm, rad, dimensionless; the training
        configurations in rad as the distances are measured)."""
        return {"coverage": self.coverage, "residual_mm": self.residual_mm, "inside_factor": self.inside_factor,
                "growth_per_rad": self.growth_per_rad, "sigma_growth_per_rad": self.sigma_growth_per_rad,
                "posterior": None if self.posterior is None else {
                    "names": list(self.posterior[0]), "covariance_mm_rad": np.asarray(self.posterior[1]).tolist()},
                "training_joints_rad": np.asarray(self.training_joints).tolist(),
                "fallback": None if self.fallback is None else self.fallback.to_dict(),
                "alternative": None if self.alternative is None else self.alternative.to_dict(),
                "calibration": self.calibration, "set_up_factor": self.set_up_factor,
                "outside": None if self.outside is None else self.outside.to_dict()}

    @classmethod
    def from_dict(cls, document, method, path="<bound>", fallback_method=None, alternative_method=None):
        """The bound of ``method`` (fitted) that :meth:`to_dict` wrote; FileFormatError when the
        entry is damaged.  ``fallback_method``: what answers outside the domain, if anything;
        ``alternative_method``: the fallback's alternative."""
        try:
            posterior = document["posterior"]
            if posterior is not None:
                names = [str(n) for n in posterior["names"]]
                covariance = np.asarray(posterior["covariance_mm_rad"], dtype=float)
                if covariance.shape != (len(names), len(names)) or not np.all(np.isfinite(covariance)):
                    raise ValueError("the posterior covariance must be square and finite")
                posterior = (names, covariance)
            training = np.asarray(document["training_joints_rad"], dtype=float)
            if training.ndim != 2 or not len(training) or not np.all(np.isfinite(training)):
                raise ValueError("training_joints_rad must be rows of finite numbers")
            growth = document["growth_per_rad"]
            sigma_growth = document["sigma_growth_per_rad"]
            numbers = [float(document[k]) for k in ("coverage", "residual_mm", "inside_factor")]
            if not all(np.isfinite(numbers)) or min(numbers) < 0:
                raise ValueError("coverage, residual_mm and inside_factor must be finite and >= 0")
            # Files written before re-registered models had bounds carry no set-up factor.
            set_up_factor = float(document.get("set_up_factor", 1.0))
            if not np.isfinite(set_up_factor) or set_up_factor <= 0.0:
                raise ValueError("set_up_factor must be a finite number > 0")
            fallback = document.get("fallback")
            outside = document.get("outside")
            bound = cls(method=method, coverage=numbers[0], residual_mm=numbers[1], inside_factor=numbers[2],
                        growth_per_rad=None if growth is None else float(growth),
                        sigma_growth_per_rad=None if sigma_growth is None else float(sigma_growth), posterior=posterior,
                        training_joints=training, calibration=dict(document.get("calibration") or {}),
                        set_up_factor=set_up_factor,
                        outside=None if outside is None else OutsideScale.from_dict(outside))
            if fallback is not None:
                bound = replace(bound, fallback=cls.from_dict(fallback, fallback_method or method, path))
            alternative = document.get("alternative")
            if alternative is not None and alternative_method is not None:
                bound = replace(bound, alternative=cls.from_dict(alternative, alternative_method, path))
            return bound
        except (KeyError, TypeError, ValueError) as exc:
            raise FileFormatError(f"{path}: the 95 % bound is damaged ({exc}); regenerate the file with "
                                  "'robocal calibrate'") from None


def outside_bound(factor, residual, sigma, distance, growth, sigma_growth):
    """(N,) mm: the bound at configurations whose model σ is ``sigma`` (N,) mm, ``distance``
    (N,) rad from the training configurations (None: inside the domain), with the inside
    factor q, the residual scale r (mm) and the growths γ and κ (1/rad; None: not used;
    both None outside: NaN, unknown)."""
    scale = np.sqrt(np.asarray(sigma) ** 2 + residual ** 2)
    if distance is None:
        return factor * scale
    if growth is None and sigma_growth is None:
        return np.full(len(scale), np.nan)
    bound = np.zeros(len(scale))
    if growth is not None:
        bound = factor * scale * (1.0 + growth * distance)
    if sigma_growth is not None:
        bound = np.maximum(bound, factor * np.sqrt(scale ** 2 + (sigma_growth * sigma * distance) ** 2))
    return bound


def _growths(factor, residual, error, sigma, distance):
    """(γ, κ) of the module docstring from held-out poses outside their fold's domain:
    error, sigma (N,) mm, distance (N,) rad.  κ is None when the model has no σ there or
    more than 1 − COVERAGE of the poses need more than σ can give (σ · d = 0)."""
    scale = np.sqrt(sigma ** 2 + residual ** 2)
    growth = conformal_quantile(np.maximum(error / (factor * scale) - 1.0, 0.0) / distance)
    missing = np.sqrt(np.maximum((error / factor) ** 2 - scale ** 2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        needed = np.where(missing > 0, missing / (sigma * distance), 0.0)
    sigma_growth = conformal_quantile(needed) if np.any(sigma > 0) else float("inf")
    return growth, (sigma_growth if np.isfinite(sigma_growth) else None)


# ------------------------------------------------------------------ calibrating it
def _calibrate(method, chain, observations, posterior, seed, regions=True, calibration=None):
    """A :class:`PositionBound` of ``method`` (fitted to ``observations``, its parametric
    ``calibration`` and that calibration's ``posterior`` given); the region folds, and so a
    bound outside the domain, only with ``regions``."""
    n = observations.n_poses
    omitted = omitted_of(method, chain_of(method), observations, calibration, posterior) if regions else None
    random_part = held_out(method, chain, observations, random_tests(n, method, seed), posterior, omitted)
    if random_part is None:
        return None
    _, error, sigma, inside, spread, folds = random_part
    residual = float(np.sqrt(np.mean(error ** 2)))
    scale = np.sqrt(sigma ** 2 + residual ** 2)
    # Poses held out at random that still fell outside their fold's domain (few) are judged
    # with the regions; the rest calibrate the bound inside.
    scores = (error / scale)[inside] if inside.sum() >= 1 else error / scale
    factor = conformal_quantile(scores)
    record = {"inside": {"poses": len(scores), "folds": int(folds),
                         "covered": float(np.mean(scores <= factor)) if len(scores) else None}}
    outside = None
    if regions:
        parts = [(error[~inside], scale[~inside], spread[~inside])]
        region_part = held_out(method, chain, observations, region_tests(chain, observations, seed))
        if region_part is not None:
            _, r_error, r_sigma, r_inside, r_spread, _ = region_part
            parts.append((r_error[~r_inside], np.sqrt(r_sigma ** 2 + residual ** 2)[~r_inside], r_spread[~r_inside]))
        e, s, o = (np.concatenate(x) for x in zip(*parts))
        outside = fit_outside(e, s, o, omitted, conformal_quantile)
        if outside is not None:
            record["outside"] = {"poses": len(e), "folds": int(region_part[-1]) if region_part else 0,
                                 "covered": float(np.mean(e <= outside.bound(s, o, factor)))}
    return PositionBound(method=method, coverage=COVERAGE, residual_mm=residual, inside_factor=factor,
                         growth_per_rad=None, sigma_growth_per_rad=None, posterior=posterior,
                         training_joints=_kept(observations.joints, seed), calibration=record, outside=outside)


def _kept(joints, seed):
    """The training configurations the distance is measured from: all distinct ones, or a
    random NEIGHBOUR_KEEP of them (the model file stays small, as the domain's does; a
    distance to a subset is never shorter, so the bound errs on the safe side)."""
    from .domain import NEIGHBOUR_KEEP

    kept = np.unique(np.asarray(joints, dtype=float), axis=0)
    if len(kept) > NEIGHBOUR_KEEP:
        kept = kept[np.sort(np.random.default_rng(seed).choice(len(kept), NEIGHBOUR_KEEP, replace=False))]
    return kept


def _fallback_method(method, chain, observations, label=None):
    """The fitted parametric calibration a domain fallback answers with outside (``wrap``
    labels it "kinematic <parameter set>"; ``label``: another of that form, its
    alternative), refitted on ``observations``; None otherwise."""
    from .fallback import DomainFallback
    from .kinematic import KinematicMethod

    compensator = method.compensator_
    if not isinstance(compensator, DomainFallback):
        return None
    label = label or compensator.label
    if not label.startswith("kinematic "):
        raise InputError(f"the 95 % bound knows no fallback {label!r}")
    fallback = KinematicMethod(parameters=label.split(" ", 1)[1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobocalWarning)
        fallback.fit(chain, observations)
    return fallback


def fit_bound(method, chain, observations, *, seed=0):
    """The 95 % bound of a fitted ``method`` on its training ``observations`` of ``chain``
    (see the module docstring).

    Parameters
    ----------
    method : Method
        Fitted on ``observations`` (any registered method on position data).
    chain : Chain
        The nominal robot it was fitted for.
    observations : Observations
        Its training data: joints (N, n) rad, positions (N, 3) mm.
    seed : int
        Seeds the random folds and the region clusters.

    Returns
    -------
    PositionBound or None
        ``predict(joints)`` gives the bound (N,) mm.  None, with a RobocalWarning, when the
        method cannot be fitted on the folds (too few poses), and for ball-in-socket data
        (no position error to bound).
    """
    method._check_fitted()
    if observations.positions is None:
        return None
    if not isinstance(observations, Observations):
        raise InputError("fit_bound takes robocal Observations (robocal.io.observations.Observations.of)")
    fallback = _fallback_method(method, chain, observations)
    calibration = base_calibration(method, chain, observations)
    posterior = None if calibration is None else calibration_posterior(calibration, observations.joints,
                                                                       observations.positions)
    inner = method
    if fallback is not None:
        # The chosen model's folds are of the chosen model alone: its fallback answers outside.
        inner = method.clone()
        inner.compensator_ = method.compensator_.inside
        for name in ("reference_", "record_", "domain_"):
            setattr(inner, name, getattr(method, name))
    bound = _calibrate(inner, chain, observations, posterior, seed, regions=fallback is None, calibration=calibration)
    if bound is None:
        warnings.warn(RobocalWarning(
            f"no 95 % bound: the {method.name} method could not be fitted on any fold of these {observations.n_poses} "
            "poses (each leaves poses out); the model is saved without one. Measure more poses to get bound95_mm"),
            stacklevel=2)
        return None
    bound = replace(bound, method=method)
    if fallback is not None:
        outside = _calibrate(fallback, chain, observations,
                             calibration_posterior(fallback.calibration_, observations.joints, observations.positions),
                             seed, calibration=fallback.calibration_)
        # No fallback bound (its folds could not be fitted): outside, the bound is unknown (NaN).
        bound = replace(bound, fallback=None if outside is None else _labelled(outside, method, None),
                        growth_per_rad=None, sigma_growth_per_rad=None)
        other = getattr(method, "outside_alternative_", None)
        if other is not None:
            refitted = _fallback_method(method, chain, observations, other[0])
            alternative = _calibrate(refitted, chain, observations, calibration_posterior(
                refitted.calibration_, observations.joints, observations.positions), seed,
                calibration=refitted.calibration_)
            if alternative is not None:
                bound = replace(bound, alternative=_labelled(alternative, method, other))
    return bound


def _labelled(bound, method, alternative):
    """A fallback's bound (``alternative``: (label, Compensator) of the fallback's
    alternative, or None for the fallback itself), seen through :class:`_FallbackView` and
    labelled with what it bounds."""
    label = method.compensator_.label if alternative is None else alternative[0]
    view = _FallbackView(method, None if alternative is None else alternative[1])
    return replace(bound, method=view, calibration={**bound.calibration, "label": label})


class _FallbackView:
    """What answers outside an auto model's domain, as its bound sees it: the fallback's
    chain and no error model; its domain is the chosen model's."""

    def __init__(self, method, compensator=None):
        self.compensator_ = method.compensator_.outside if compensator is None else compensator
        self.domain_ = method.domain_
        self.name = "kinematic"

    def uncertainty(self, joints):
        return None


def bound_of_model(model, method, path):
    """The :class:`PositionBound` a :class:`~robocal.io.model_file.ModelFile` ``model``
    stores for its fitted ``method``, or None when the file has none."""
    if model.bound is None:
        return None
    fallback_method = alternative_method = None
    from .fallback import DomainFallback

    if isinstance(method.compensator_, DomainFallback):
        fallback_method = _FallbackView(method)
        other = getattr(method, "outside_alternative_", None)
        if other is not None:
            alternative_method = _FallbackView(method, other[1])
    return PositionBound.from_dict(model.bound, method, path, fallback_method=fallback_method,
                                   alternative_method=alternative_method)


def bound95(method, joints):
    """The 95 % bound (N,) mm at ``joints`` (N, n) rad of a method whose bound was fitted
    (:func:`fit_bound`, or read from its model file); InputError when it has none."""
    bound = getattr(method, "bound_", None)
    if bound is None:
        raise InputError(NO_BOUND)
    return bound.predict(joints)
