"""Scoring a candidate model on a split (:mod:`robocal.methods.splits`): fitted on each
fold's training poses, scored on its held-out ones, for ``robocal compare`` and ``calibrate
--method auto`` (:mod:`robocal.methods.selection`).

Scores are of the position error |measured - predicted| (mm) on held-out poses; on
ball-in-socket data, the socket consistency on the poses held out.  The registered nominal
robot (:data:`NOMINAL`), scored the same way, is the baseline of every table.

On a small campaign's split (``Split.deletion``), a linearised least-squares fit (the
kinematic calibration, a MAP fit under the tolerances) is fitted once on every pose and each
fold's held-out residuals come from its hat matrix: for the weighted rows r_T of the poses T
left out, the fit without them leaves (I - H_TT)⁻¹ r_T there, with H = J (JᵀJ + Λ)⁻¹ Jᵀ, J the
weighted Jacobian at the fit and Λ the prior's precision (the noise the data leave over the
squared tolerances, as the fit weighs them).  Exact for the linearised fit, and one Jacobian
instead of one fit per fold.  Against refitting without each pose, on 12 poses of UR10
series B (tests/test_small_campaigns.py): its mean within 1 % for ``full``, 9.5 % below for
``full+compliance+gains``, whose 37 parameters leave leverages up to 0.99, where a refit
moves beyond the linearisation (one pose 1.58 mm refitted, 0.92 deleted).  That optimism
favours the richest set on the smallest campaigns; bench/small_campaigns.py measures what it
costs on the data left out (nothing on average over its draws).
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np

from .. import parallel
from ..errors import InputError, RobocalWarning
from ..estimation.constraint import socket_deviations
from ..estimation.least_squares import noise_variance
from ..estimation.least_squares import residual as residual_of
from ..estimation.metrics import error_stats
from ..io.observations import Observations
from ..kinematics.chain import Chain
from . import make_method
from .candidacy import Candidate
from .domain import Domain
from .frames import registered_nominal
from .splits import Split

# The label of the registered nominal robot in every comparison.
NOMINAL = "nominal (registered)"


def unfitted(candidate):
    """The unfitted method of ``candidate`` (a :class:`~robocal.methods.candidacy.Candidate`)."""
    return make_method(candidate.method, **candidate.settings)


@dataclass
class Score:
    """A model on a split: the per-fold mean errors (mm), the pooled statistics of every
    held-out pose (:func:`error_stats`), and the mean fit time (s); ``inside_fold_means`` and
    ``inside_mean``: the same means over the held-out poses inside the fold's training domain
    only (NaN for a fold with none), which is where an auto model answers with this model
    (outside, its fallback does: :mod:`robocal.methods.fallback`)."""

    fold_means: list
    pooled: dict
    fit_seconds: float
    inside_fold_means: list | None = None
    inside_mean: float = float("nan")

    def to_dict(self):
        return {"fold_means_mm": self.fold_means, "pooled": self.pooled, "fit_seconds": self.fit_seconds,
                "inside_fold_means_mm": [None if not np.isfinite(m) else m for m in self.inside_fold_means or []],
                "inside_mean_mm": None if not np.isfinite(self.inside_mean) else self.inside_mean}

    def judged(self):
        """(per-fold means, overall mean) the rule judges: over the poses inside each fold's
        training domain where the split has any, else over all held-out poses."""
        if self.inside_fold_means is not None and np.isfinite(self.inside_mean):
            return np.asarray(self.inside_fold_means, dtype=float), self.inside_mean
        return np.asarray(self.fold_means, dtype=float), self.pooled["mean_mm"]


def held_out_errors(fitted, observations, train, test):
    """(len(test), 3) held-out errors in mm: the position error; on ball-in-socket data, each
    ball centre's deviation from where the training poses of its socket put the ball (random
    folds), or, for a socket with no training pose (a placement left out), from the mean of
    its held-out poses."""
    held = observations.subset(test)
    if observations.positions is None:
        chain = fitted.kinematics()
        deviations, centres = socket_deviations(chain, held.joints, held.placement, held.socket, held.fixture)
        seen = observations.subset(train)
        keys = np.char.add(np.char.add(seen.placement.astype(str), "/"), seen.socket.astype(str))
        held_keys = np.char.add(np.char.add(held.placement.astype(str), "/"), held.socket.astype(str))
        names, group = np.unique(keys, return_inverse=True)
        balls = chain.fk_positions(seen.joints)
        means = np.stack([np.bincount(group, weights=balls[:, c], minlength=len(names)) for c in range(3)], axis=1)
        means /= np.bincount(group, minlength=len(names))[:, None]
        where = np.searchsorted(names, held_keys).clip(max=len(names) - 1)
        known = names[where] == held_keys
        deviations[known] = centres[known] - means[where[known]]
        return deviations
    return held.positions - fitted.predict(held.joints)


def constraining(observations, train):
    """The poses of ``train`` a fit can use: all of them, but on ball-in-socket data only those
    whose socket keeps two or more in the training part (a lone seating constrains nothing;
    it still says where its socket is when a held-out seating of that socket is scored)."""
    if observations.positions is not None:
        return train
    keys = np.char.add(np.char.add(observations.placement[train].astype(str), "/"),
                       observations.socket[train].astype(str))
    _, group, counts = np.unique(keys, return_inverse=True, return_counts=True)
    return train[counts[group.reshape(-1)] > 1]


def deleted_errors(fitted, observations, tests):
    """[(len(test), 3) mm]: the held-out position errors of a kinematic calibration fitted on
    every pose of ``observations``, each test block deleted through the hat matrix of the
    linearised fit (see the module notes); None if the fit is not one this applies to (a
    robust loss that down-weighted poses)."""
    calibration = getattr(fitted, "calibration_", None)
    result = getattr(calibration, "result_", None)
    if result is None or getattr(result, "outliers", ()) or getattr(calibration, "loss", "linear") != "linear":
        return None
    chain, names = calibration.chain_, list(calibration.names_)
    q = observations.joints
    rotations = observations.rotations if result.orientation_rms_deg is not None else None
    rows = 3 if rotations is None else 6
    sigmas = observations.sigmas if observations.sigmas is not None else np.full((len(q), 3),
                                                                                 calibration.position_sigma)
    weights = 1.0 / np.asarray(sigmas, dtype=float)
    if rotations is not None:
        weights = np.hstack([weights, np.full((len(q), 3), 1.0 / np.radians(calibration.orientation_sigma_deg))])
    r = residual_of(chain, q, observations.positions, rotations) * weights
    jac = chain.identification_jacobian(q, names)[:, :rows, :] * weights[:, :, None]
    flat = jac.reshape(-1, len(names))
    scale = np.linalg.norm(flat, axis=0)
    scale[scale == 0] = 1.0
    normal = (flat / scale).T @ (flat / scale)
    if result.prior_std is not None:
        # The prior's weight as the fit gave it: the noise of the rows a plain least-squares
        # step leaves (robocal.estimation.least_squares.damped_least_squares).
        rows_r = r.reshape(-1)
        plain = (flat / scale) @ (np.linalg.pinv(normal, hermitian=True) @ ((flat / scale).T @ rows_r))
        noise = noise_variance(rows_r - plain, len(names))
        normal = normal + np.diag(noise / (np.asarray(result.prior_std, dtype=float) * scale) ** 2)
    inverse = np.linalg.pinv(normal, hermitian=True)
    out = []
    for test in tests:
        block = (jac[test] / scale).reshape(-1, len(names))
        hat = block @ inverse @ block.T
        deleted = np.linalg.solve(np.eye(len(hat)) - hat, r[test].reshape(-1)).reshape(len(test), rows)
        out.append(deleted[:, :3] / weights[test, :3])
    return out


class _Nominal:
    """The simplest model: the nominal robot registered on the training poses (the nominal
    itself on ball-in-socket data, whose consistency does not depend on the frame)."""

    def __init__(self, chain):
        self.chain = chain

    def fit(self, chain, observations):
        if observations.positions is not None:
            self.chain = registered_nominal(chain, observations.joints, observations.positions)
        return self

    def predict(self, joints):
        return self.chain.fk_positions(joints)

    def kinematics(self):
        return self.chain


class _Fitted:
    """A fitted method as :func:`score` uses it: its predictions and its kinematics."""

    def __init__(self, method):
        self.method = method

    def fit(self, chain, observations):
        self.method.fit(chain, observations)
        return self

    def predict(self, joints):
        return self.method.predict(joints)

    def kinematics(self):
        return self.method.compensator_.chain


class _Refits:
    """The fits of one comparison, made fast without changing what is scored:

    * a hybrid's kinematic calibration on a fold is the kinematic candidate's fit of the same
      parameter set on the same fold (fitted once);
    * a Kriging-based model searches its hyperparameters (θ, nugget) on its first fold only
      and keeps them on the others (:meth:`~robocal.methods.kriging.KrigingResidual.refit`):
      a Cholesky factorisation instead of dozens of likelihood evaluations per fold.  Those
      hyperparameters have seen the first fold's training poses, which overlap the other
      folds' held-out ones; the predictions scored never have.
    """

    def __init__(self, chain):
        self.chain = chain
        self.kinematic = {}  # (parameter set, split, fold) -> fitted KinematicMethod
        self.template = {}  # candidate label -> its first fit
        self.insides = {}  # (split, fold) -> (len(test),) bool
        self.whole = {}  # candidate label -> its fit on every pose (deletion)

    def inside(self, observations, train, test, where):
        """(len(test),) bool: the held-out poses ``test`` inside the domain of the training
        poses ``train`` (computed once per fold, for every candidate)."""
        if where not in self.insides:
            held = observations.subset(test)
            domain = Domain.of(self.chain, observations.subset(train))
            self.insides[where] = domain.check(held.joints, held.positions).inside
        return self.insides[where]

    def fit(self, candidate, observations, where):
        if candidate.method == "nominal":
            return _Nominal(self.chain).fit(self.chain, observations)
        template = self.template.get(candidate.label)
        if template is not None and hasattr(template, "refit"):
            base = self.kinematic.get((candidate.settings.get("parameters"),) + where)
            return _Fitted(template.refit(self.chain, observations, base=base))
        fitted = unfitted(candidate).fit(self.chain, observations)
        self.template.setdefault(candidate.label, fitted)
        if candidate.method == "kinematic":
            self.kinematic[(candidate.settings["parameters"],) + where] = fitted
        return _Fitted(fitted)

    def deleted(self, candidate, observations, split):
        """The held-out errors of ``candidate`` on every fold of a deletion ``split``, from
        its one fit on every pose, or None when it is not a linearised fit."""
        if not (split.deletion and candidate.linear and observations.positions is not None):
            return None
        if candidate.label not in self.whole:
            self.whole[candidate.label] = unfitted(candidate).fit(self.chain, observations)
        return deleted_errors(self.whole[candidate.label], observations, split.tests)


def score(candidate, observations, split, refits, *, on_fit=None):
    """:class:`Score` of ``candidate`` fitted on each fold's training poses of ``split`` and
    scored on its held-out poses (fits made by ``refits``, a :class:`_Refits`; on a small
    campaign's split a linearised fit's by deletion)."""
    n = observations.n_poses
    errors, seconds, insides = [], 0.0, []
    with warnings.catch_warnings():
        # Warnings of a fold's fit or prediction (Kriging extrapolating into the region left
        # out, an outlier) are what the held-out error measures; the final fit still gives them.
        warnings.simplefilter("ignore", RobocalWarning)
        start = time.perf_counter()
        deleted = refits.deleted(candidate, observations, split)
        seconds += time.perf_counter() - start
    for fold, test in enumerate(split.tests):
        train = np.setdiff1d(np.arange(n), test)
        if deleted is not None:
            error = deleted[fold]
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RobocalWarning)
                start = time.perf_counter()
                fitted = refits.fit(candidate, observations.subset(constraining(observations, train)),
                                    (split.name, fold))
                seconds += time.perf_counter() - start
                error = held_out_errors(fitted, observations, train, test)
        if on_fit is not None:
            on_fit()
        errors.append(error)
        insides.append(refits.inside(observations, train, test, (split.name, fold)))
    lengths = [np.linalg.norm(e, axis=1) for e in errors]
    if split.groups is not None:
        # Each pose held out once (leave-one-out): its errors pooled into the split's groups.
        by_pose, inside_pose = np.empty(n), np.zeros(n, dtype=bool)
        for test, d, i in zip(split.tests, lengths, insides):
            by_pose[test], inside_pose[test] = d, i
        lengths = [by_pose[g] for g in split.groups]
        insides = [inside_pose[g] for g in split.groups]
    fold_means = [float(d.mean()) for d in lengths]
    inside_means = [float(d[i].mean()) if i.any() else float("nan") for d, i in zip(lengths, insides)]
    inside = np.concatenate([d[i] for d, i in zip(lengths, insides)])
    return Score(fold_means, error_stats(np.concatenate(errors)).to_dict(), seconds / len(split.tests), inside_means,
                 float(inside.mean()) if inside.size else float("nan"))


def _groups(candidate_list, split_list):
    """The comparison's independent pieces of work, longest first (a cluster starts them in
    this order): [(candidates, splits)].  A hybrid goes with the kinematic candidate of its
    parameter set, whose fold fits it reuses (:class:`_Refits`); a Kriging-based model is one
    piece, since it keeps the hyperparameters of its first fold; the network, which fits every
    fold from scratch, one piece per split; the registered nominal one piece."""
    pieces = []
    for candidate in candidate_list:
        if candidate.method == "ann":
            pieces += [([candidate], [split]) for split in split_list]
            continue
        base = next((piece for piece in pieces if piece[0][0].label == candidate.base), None)
        if base is not None:
            base[0].append(candidate)
        else:
            pieces.append(([candidate], split_list))

    def length(piece):  # the network, then anything with a Kriging fit, then the rest
        methods = {c.method for c in piece[0]}
        return 0 if "ann" in methods else 1 if methods & {"kriging", "hybrid"} else 2

    return sorted(pieces, key=length)


def _score_group(chain, observations, candidates_, split_list, on_fit=None):
    """({label: {split name: Score}}, {label: s}) of ``candidates_`` on ``split_list``, fitted
    one after the other with one :class:`_Refits`."""
    refits, scores, seconds = _Refits(chain), {}, {}
    for candidate in candidates_:
        start = time.perf_counter()
        scores[candidate.label] = {split.name: score(candidate, observations, split, refits, on_fit=on_fit)
                                   for split in split_list}
        seconds[candidate.label] = time.perf_counter() - start
    return scores, seconds


def score_task(task):
    """A piece of :func:`score_all` run by a worker of :mod:`robocal.parallel`: ``task`` and
    the result are plain data (the robot and the observations as their ``to_plain`` gives
    them, splits and candidates as dicts; the scores as the fields of :class:`Score`)."""
    chain = Chain.from_plain(task["robot"])
    observations = Observations.from_plain(task["observations"])
    split_list = [Split.from_plain(s) for s in task["splits"]]
    scores, seconds = _score_group(chain, observations, [Candidate(**c) for c in task["candidates"]], split_list)
    return {"scores": {label: {name: vars(one) for name, one in by_split.items()}
                       for label, by_split in scores.items()},
            "seconds": seconds}


def score_all(chain, observations, candidate_list, split_list, on_fit):
    """({label: {split name: Score}}, {label: s}) of every candidate (the registered nominal
    first): here, one fit after the other, or on the active executor of
    :mod:`robocal.parallel` (``robocal compare --jobs N``), one :func:`_groups` piece a task."""
    everything = [Candidate(NOMINAL, "nominal", {})] + candidate_list
    runner = parallel.current()
    if runner.client is None:
        return _score_group(chain, observations, everything, split_list, on_fit)
    groups = _groups(everything, split_list)
    robot, plain = chain.to_plain(), observations.to_plain()
    tasks = [{"robot": robot, "observations": plain, "candidates": [vars(c) for c in group],
              "splits": [s.to_plain() for s in splits_]} for group, splits_ in groups]

    def done(index, result):
        if on_fit is not None:
            on_fit(len(groups[index][0]) * sum(len(s.tests) for s in groups[index][1]))

    results = runner.map(score_task, tasks, on_done=done)
    scores, seconds = {c.label: {} for c in everything}, dict.fromkeys((c.label for c in everything), 0.0)
    for result in results:
        for label, by_split in result["scores"].items():
            scores[label].update({name: Score(**fields) for name, fields in by_split.items()})
            seconds[label] += result["seconds"][label]
    # In the order of the splits, as the serial path gives them.
    return {label: {s.name: scores[label][s.name] for s in split_list} for label in scores}, seconds


def fold_errors(method, chain, observations, split):
    """(N,) mm: each pose's held-out error under ``method`` (fitted, or unfitted) fitted
    without it, over the folds of ``split`` (each pose held out once): its ``refit`` when it
    has one (the hyperparameters kept), else a :meth:`~robocal.methods.base.Method.clone`
    fitted on the fold's training poses (without the data check its full fit made)."""
    n = observations.n_poses
    refit = getattr(method, "refit", None)
    errors = np.full(n, np.nan)
    for test in split.tests:
        train = np.setdiff1d(np.arange(n), test)
        part = observations.subset(train)
        with warnings.catch_warnings():
            # The fit's own warnings were shown once; its folds' would repeat them.
            warnings.simplefilter("ignore", RobocalWarning)
            if refit is not None:
                fitted = refit(chain, part)
            else:
                fitted = method.clone()
                fitted._fit(chain, part, None)
            # Nor do its predictions of the held-out poses warn (of its own training box).
            errors[test] = np.linalg.norm(held_out_errors(fitted, observations, train, test), axis=1)
    if np.isnan(errors).any():
        raise InputError("a split that leaves some poses never held out cannot give every pose's held-out error")
    return errors
