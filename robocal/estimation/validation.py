"""Held-out validation of any positioning model: k-fold cross-validation and learning curves.

A calibration is only as good as its predictions on poses it never saw: the residual on the
training poses shrinks with every parameter added, whether or not the model is right.  The
functions here score a model on poses withheld from its fit, and they are generic over a
*fitter*: a callable ``fit(train_index) -> predict`` where ``predict(test_index)`` returns
the (len(test_index), 3) TCP positions (mm) the model fitted on ``train_index`` expects at
the poses ``test_index``.  Any method fits this shape (kinematic calibration, Kriging,
hybrid); :func:`robocal.methods.validation.method_fitter` builds one for any registered
method.

Errors are measured − predicted, summarised by :func:`~robocal.estimation.metrics.error_stats`.
Everything stays in memory: the fitter closes over its data and receives only indices.
"""
import numbers

import numpy as np

from ..errors import InputError
from .metrics import error_stats


def k_fold(n_poses, fit, measured, k=5, seed=0):
    """k-fold cross-validation: every pose is predicted exactly once, by a model fitted on
    the other folds.

    n_poses: number of poses; fit: a fitter (see the module docstring); measured: (n_poses, 3)
    measured positions (mm); k: number of folds, 2 <= k <= n_poses; seed: the random
    assignment of poses to folds (folds differ in size by at most one pose).

    Returns a dict:
      ``k``; ``folds``: per fold ``{"fold", "n_train", "held_out": error_stats}``;
      ``pooled``: error_stats over all held-out predictions (each pose once);
      ``fold_of``: (n_poses,) the fold each pose was held out in;
      ``predicted``: (n_poses, 3) its held-out prediction; ``errors``: measured − predicted.
    """
    n_poses = _count(n_poses, "n_poses", minimum=2)
    measured = _positions(measured, n_poses)
    k = _count(k, "k", minimum=2)
    if k > n_poses:
        raise InputError(f"k = {k} folds need at least {k} poses, got {n_poses}: use k <= {n_poses}")
    fold_of = fold_assignment(n_poses, k, seed)
    predicted = np.empty((n_poses, 3))
    folds = []
    for fold in range(k):
        test = np.flatnonzero(fold_of == fold)
        train = np.flatnonzero(fold_of != fold)
        predicted[test] = _predict(fit(train), test)
        folds.append({"fold": fold, "n_train": int(train.size),
                      "held_out": error_stats(measured[test] - predicted[test]).to_dict()})
    errors = measured - predicted
    return {"k": k, "folds": folds, "pooled": error_stats(errors).to_dict(), "fold_of": fold_of,
            "predicted": predicted, "errors": errors}


def fold_assignment(n_poses, k, seed=0):
    """(n_poses,) int: the fold of each pose in :func:`k_fold` (random, sizes differing by one
    at most)."""
    order = np.random.default_rng(seed).permutation(n_poses)
    fold_of = np.empty(n_poses, dtype=int)
    for fold, members in enumerate(np.array_split(order, k)):
        fold_of[members] = fold
    return fold_of


def learning_curve(n_poses, fit, measured, sizes, test_fraction=0.3, repeats=3, seed=0):
    """Held-out error against the number of training poses.

    One held-out set (``test_fraction`` of the poses, drawn with ``seed``) scores every
    model, so the sizes are compared on the same poses; each model is fitted on a random
    subset of the given size drawn from the remaining poses, ``repeats`` times with
    different subsets (once when the size is the whole pool: every subset would be the same).

    Returns a list, one entry per size in the given order:
      ``{"n_train": m, "n_test": t, "repeats": r, "held_out": error_stats of the t·r held-out
      errors together, "per_repeat": [error_stats, ...]}``.
    """
    n_poses = _count(n_poses, "n_poses", minimum=2)
    measured = _positions(measured, n_poses)
    repeats = _count(repeats, "repeats", minimum=1)
    if not (isinstance(test_fraction, numbers.Real) and 0.0 < test_fraction < 1.0):
        raise InputError(f"test_fraction must be a number between 0 and 1 (exclusive), got {test_fraction!r}")
    n_test = int(round(test_fraction * n_poses))
    if not 1 <= n_test < n_poses:
        raise InputError(
            f"test_fraction {test_fraction} of {n_poses} poses leaves {n_test} to test and "
            f"{n_poses - n_test} to train: both need at least one pose"
        )
    sizes = np.atleast_1d(np.asarray(sizes))
    if sizes.size == 0:
        raise InputError("sizes must list at least one training-set size")
    sizes = [_count(size, "a training-set size", minimum=1) for size in sizes.tolist()]
    rng = np.random.default_rng(seed)
    order = rng.permutation(n_poses)
    test, pool = np.sort(order[:n_test]), order[n_test:]
    too_large = [m for m in sizes if m > pool.size]
    if too_large:
        raise InputError(
            f"training-set size {max(too_large)} exceeds the {pool.size} poses left after holding "
            f"out {n_test} ({test_fraction:.0%}) for testing: use sizes <= {pool.size}"
        )
    curve = []
    for m in sizes:
        runs = 1 if m == pool.size else repeats
        per_repeat, errors = [], []
        for _ in range(runs):
            train = np.sort(rng.choice(pool, size=m, replace=False))
            error = measured[test] - _predict(fit(train), test)
            per_repeat.append(error_stats(error).to_dict())
            errors.append(error)
        curve.append({"n_train": m, "n_test": n_test, "repeats": runs,
                      "held_out": error_stats(np.concatenate(errors)).to_dict(), "per_repeat": per_repeat})
    return curve


# ----------------------------------------------------------------------------- checks
def _count(value, name, minimum):
    """A whole number >= minimum (numpy integers and integral floats accepted), or InputError."""
    if (isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value)
            or value != int(value)):
        raise InputError(f"{name} must be a whole number, got {value!r}")
    if int(value) < minimum:
        raise InputError(f"{name} must be at least {minimum}, got {value!r}")
    return int(value)


def _positions(measured, n_poses):
    measured = np.asarray(measured, dtype=float)
    if measured.shape != (n_poses, 3):
        raise InputError(f"measured positions must be ({n_poses}, 3) for {n_poses} poses, got {measured.shape}")
    if not np.all(np.isfinite(measured)):
        raise InputError("measured positions contain NaN or infinite values: remove or fix those poses")
    return measured


def _predict(predict, test):
    """Call a fitted model's ``predict`` on ``test`` and check what comes back."""
    predicted = np.asarray(predict(test), dtype=float)
    if predicted.shape != (test.size, 3):
        raise InputError(f"the fitter's predict returned shape {predicted.shape} for {test.size} poses, "
                         f"expected ({test.size}, 3)")
    return predicted
