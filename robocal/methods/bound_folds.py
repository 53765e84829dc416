"""The held-out poses the 95 % bound (:mod:`robocal.methods.bound`) is calibrated on: random
folds for inside the training domain, regions left out (joint-space clusters, an arm
branch's sides) for outside it, each fold's model fitted on the rest."""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import InputError, RobocalWarning
from .domain import Domain
from .model_sigma import base_calibration, calibration_posterior, chain_of, model_sigma
from .omitted import omitted_of

# Random folds of the inside calibration.  Below LEAVE_ONE_OUT_BELOW poses each pose is
# left out alone (for the methods that refit cheaply), so that a campaign of a dozen poses
# still gives a dozen held-out scores.
FOLDS = 5
LEAVE_ONE_OUT_BELOW = 40
# The network trains from scratch on every fold: five random folds, as for the other methods
# (with two, each fold network saw half the poses and missed far more than the final one:
# UR10 B random half, trained 20 generations, 0.997 covered at 4.95 times the median error;
# with five 0.989 at 2.95; bench/bound_coverage.py --methods ann), and its genetic algorithm
# stops after at most this many generations on a fold (its default is 300): a network trained
# less misses more, so the bound errs on the safe side, and calibrate costs a few full fits.
NETWORK_FOLDS = 5
NETWORK_FOLD_GENERATIONS = 60
# A region left out must keep this many training poses to be fitted (the parametric
# calibration under its priors fits from fewer, but its posterior then says little).
MIN_REGION_TRAINING = 8


def fold_fit(method, chain, part):
    """``method``'s configuration fitted to ``part``: by ``refit`` (hyperparameters kept)
    where the method has one, else from scratch: (fitted, its parametric calibration's
    posterior, that calibration), or Nones when the fit is refused (a fold too small for the
    method)."""
    with warnings.catch_warnings():
        # The fit's own warnings were shown once; its folds' would repeat them.
        warnings.simplefilter("ignore", RobocalWarning)
        try:
            refit = getattr(method, "refit", None)
            if refit is not None:
                base = None
                if method.name == "hybrid":
                    base = method.kinematic()
                    base._fit(chain, part, None)
                fitted = refit(chain, part, base=base)
                calibration = None if base is None else base.calibration_
            else:
                fitted = method.clone()
                if method.name == "ann":
                    fitted.generations = min(fitted.generations, NETWORK_FOLD_GENERATIONS)
                fitted._fit(chain, part, None)
                calibration = base_calibration(fitted, chain, part)
        except (InputError, np.linalg.LinAlgError):
            return None, None, None
    posterior = None if calibration is None else calibration_posterior(calibration, part.joints, part.positions)
    return fitted, posterior, calibration


def _deleted_errors(method, observations, tests):
    """[(1, 3) mm] leave-one-out errors of a kinematic calibration from the hat matrix of its
    one fit (:func:`robocal.methods.scoring.deleted_errors`), when ``tests`` leave one pose
    out each; else None (the folds are refitted)."""
    if method.name != "kinematic" or any(len(test) != 1 for test in tests):
        return None
    from .scoring import deleted_errors

    return deleted_errors(method, observations, tests)


def held_out(method, chain, observations, tests, full_posterior=None, full_omitted=None):
    """The held-out poses of the folds ``tests`` (held-out index arrays), concatenated:
    (indices, error norms (mm), the fold model's own σ there (mm), inside the fold's domain
    (bool), the fold model's omitted-parameter σ_o there (mm; 0 inside the fold's domain,
    where it is not used: :mod:`robocal.methods.omitted`), folds fitted); folds whose fit is
    refused are left out; None when none could be fitted.  A kinematic calibration left one
    pose out at a time is not refitted (:func:`_deleted_errors`; its σ and σ_o from
    ``full_posterior`` and ``full_omitted``, those of the fit on every pose): a campaign of a
    dozen poses gets a bound too."""
    n = observations.n_poses
    deleted = _deleted_errors(method, observations, tests)
    parts = []
    for k, test in enumerate(tests):
        train = np.setdiff1d(np.arange(n), test)
        part, held = observations.subset(train), observations.subset(test)
        if deleted is not None:
            # Leave-one-out of a linearised fit: the full fit with the pose deleted through
            # its hat matrix, and the full fit's posterior (one pose fewer barely moves it).
            fitted, posterior, omitted = method, full_posterior, full_omitted
            error = np.linalg.norm(deleted[k], axis=1)
        else:
            fitted, posterior, calibration = fold_fit(method, chain, part)
            if fitted is None:
                continue
            omitted = omitted_of(fitted, chain_of(fitted), part, calibration, posterior)
            with warnings.catch_warnings():
                # A fold model predicting its held-out poses warns of what the user never
                # gave (its own training box): the fit's own warnings were shown once.
                warnings.simplefilter("ignore", RobocalWarning)
                error = np.linalg.norm(held.positions - fitted.predict(held.joints), axis=1)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobocalWarning)
            sigma = model_sigma(fitted, held.joints, posterior)
        inside = Domain.of(chain, part).check(held.joints, held.positions).inside
        spread = np.zeros(len(test))
        if omitted is not None and not inside.all():
            spread[~inside] = omitted.sigma(chain_of(fitted), held.joints[~inside])
        parts.append((test, error, sigma, inside, spread))
    if not parts:
        return None
    return tuple(np.concatenate([p[k] for p in parts]) for k in range(5)) + (len(parts),)


def random_tests(n, method, seed):
    """Held-out index arrays of the random folds."""
    cheap = hasattr(method, "refit") or method.name == "kinematic"
    folds = NETWORK_FOLDS if method.name == "ann" else n if (cheap and n < LEAVE_ONE_OUT_BELOW) else FOLDS
    order = np.random.default_rng(seed).permutation(n)
    return [np.sort(part) for part in np.array_split(order, folds)]


def region_tests(chain, observations, seed):
    """Held-out index arrays of whole regions: joint-space clusters, and each side of an arm
    branch when the data hold both; regions that leave fewer than MIN_REGION_TRAINING poses
    to train on are left out."""
    from .splits import branch_split, cluster_split

    n = observations.n_poses
    tests = []
    folds = max(2, min(FOLDS, n // MIN_REGION_TRAINING))
    try:
        tests += list(cluster_split(chain, observations.joints, folds, seed).tests)
    except InputError:
        pass
    branch = branch_split(chain, observations.joints)
    if branch is not None:
        tests += list(branch.tests)
    return [t for t in tests if n - len(t) >= MIN_REGION_TRAINING and len(t)]


