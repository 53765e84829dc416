"""The 95 % bound of a re-registered model (``calibrate MODEL.json NEW.csv --method frames``).

A model carried to a new set-up keeps everything it identified, so its bound
(:mod:`robocal.methods.bound`) keeps its form, calibrated on the original training data: the
inside factor q, the residual scale r, the growth outside the domain.  Two things change:

* **the frames are new**, identified from a few poses: their posterior
  (:func:`robocal.methods.reregistration._frames_posterior`) replaces the old base and tool
  in the model's own σ(x), so that a target where the few poses pin the frames loosely gets
  a wider bound;
* **the new set-up may hold what the old one did not**: another payload bends the arm
  differently, a re-mastered joint moved, or the targets lie where the old data never were.
  The new poses are the only data of the new set-up, so they calibrate the bound there: each
  is left out of the re-registration in turn (five folds above LEAVE_ONE_OUT_BELOW poses),
  its error under the frames fitted without it is divided by the old bound at its
  configuration, and the bound is multiplied by the split-conformal quantile of those
  ratios.  It covers new poses like the ones measured with probability 0.95 (with fewer
  than 19 poses the largest ratio, scaled by (m + 1)/m, stands for the quantile).  Targets
  unlike them keep the old bound's shape: its growth away from the original training data.

On the ipa UR10 (series B calibrated, re-registered on 25 random poses of series A, tested
on the rest of A; ``bench/small_campaigns.py``, with its bound option) every test pose
lies outside B's domain, where the old bound grows with the distance from B's poses; the
new poses bring it down to what A's errors are.
"""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from ..errors import InputError, RobocalWarning
from .bound import FOLDS, LEAVE_ONE_OUT_BELOW, conformal_quantile


def _with_frames(posterior, frames):
    """The posterior (names, (P, P) covariance) with the base and tool parameters of
    ``frames`` (names, covariance, own) put in place of the old ones.

    The rest keep their covariance *given* the old frames (the Schur complement): in the
    original fit the links and the frames were correlated, the frames taking up much of what
    the links could not be told apart from; re-identified on the new poses they take it up
    again, so what is left of the links' uncertainty is what the frames could not absorb.
    The new frames' own covariance joins it, uncorrelated (identified apart from it)."""
    names, covariance, _ = frames
    names = list(names)
    if posterior is None:
        return names, np.asarray(covariance, dtype=float)
    old_names, old_cov = list(posterior[0]), np.asarray(posterior[1], dtype=float)
    framed = [i for i, name in enumerate(old_names) if name in set(names)]
    kept = [i for i, name in enumerate(old_names) if name not in set(names)]
    rest = old_cov[np.ix_(kept, kept)]
    if framed:
        cross = old_cov[np.ix_(kept, framed)]
        rest = rest - cross @ np.linalg.pinv(old_cov[np.ix_(framed, framed)]) @ cross.T
        rest = (rest + rest.T) / 2.0
    size = len(kept) + len(names)
    out = np.zeros((size, size))
    out[:len(kept), :len(kept)] = rest
    out[len(kept):, len(kept):] = covariance
    return [old_names[i] for i in kept] + names, out


def _held_out_errors(fitted, observations, parameters, robot, seed):
    """(indices, error norms (mm)) of the new poses each left out of the re-registration
    (one at a time below LEAVE_ONE_OUT_BELOW poses, else FOLDS random folds); poses whose
    fold cannot be re-registered (too few poses left for the frames) are skipped."""
    from .reregistration import reregister

    n = observations.n_poses
    order = np.random.default_rng(seed).permutation(n)
    tests = [order[[k]] for k in range(n)] if n < LEAVE_ONE_OUT_BELOW else np.array_split(order, FOLDS)
    indices, errors = [], []
    for test in tests:
        train = np.setdiff1d(np.arange(n), test)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobocalWarning)
            try:
                moved = reregister(fitted, observations.subset(train), parameters, robot=robot)
            except (InputError, np.linalg.LinAlgError):
                continue
        held = observations.subset(test)
        indices.append(test)
        errors.append(np.linalg.norm(held.positions - moved.predict(held.joints), axis=1))
    if not indices:
        return np.zeros(0, dtype=int), np.zeros(0)
    return np.concatenate(indices), np.concatenate(errors)


def reregistered_bound(bound, fitted, moved, observations, parameters="frames", *, robot=None, seed=0):
    """The 95 % bound of ``moved``, the re-registration of ``fitted`` on ``observations``.

    Parameters
    ----------
    bound : PositionBound
        ``fitted``'s bound (fitted by ``calibrate`` or read from its model file).
    fitted, moved : Method
        The model before and after :func:`~robocal.methods.reregistration.reregister`.
    observations : Observations
        The new set-up's poses: joints (N, n) rad, positions (N, 3) mm.
    parameters : str
        What the re-registration identified ('frames' or 'frames+offsets'), to refit it the
        same way on the folds.

    Returns
    -------
    PositionBound
        The bound on ``moved``: σ(x) with the new frames' posterior, multiplied by the set-up
        factor the new poses calibrate; its ``calibration['new_set_up']`` records the poses
        scored, the share the old bound covered, and the factor.
    """
    from .bound import _FallbackView

    frames = moved.frames_posterior_
    fallback, alternative = bound.fallback, bound.alternative
    label = getattr(moved.compensator_, "label", None)
    if alternative is not None and alternative.calibration.get("label") == label:
        # The new poses preferred the alternative (reregister): its bound answers outside now.
        fallback, alternative = alternative, fallback
    other = getattr(moved, "outside_alternative_", None)
    if fallback is not None:
        fallback = replace(fallback, method=_FallbackView(moved), posterior=_with_frames(fallback.posterior, frames))
    if alternative is not None and other is not None:
        alternative = replace(alternative, method=_FallbackView(moved, other[1]),
                              posterior=_with_frames(alternative.posterior, frames))
    out = replace(bound, method=moved, posterior=_with_frames(bound.posterior, frames), fallback=fallback,
                  alternative=alternative if other is not None else None, set_up_factor=1.0)
    index, error = _held_out_errors(fitted, observations, parameters, robot, seed)
    record = dict(out.calibration)
    if not len(index):
        record["new_set_up"] = {"poses": 0, "covered": None, "factor": 1.0}
        return replace(out, calibration=record)
    ratio = error / out.predict(observations.joints[index])
    factor = conformal_quantile(ratio)
    record["new_set_up"] = {"poses": int(len(index)), "covered": float(np.mean(ratio <= 1.0)), "factor": factor}
    return replace(out, set_up_factor=factor, calibration=record)
