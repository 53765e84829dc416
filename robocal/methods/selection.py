"""Choosing a model by what it does where it was not trained: ``robocal compare`` and
``calibrate --method auto``.

Every applicable method and parameter set (:func:`candidates`) is scored by two kinds of
held-out split of the data it is given (:func:`splits`):

* **random**: k-fold cross-validation, poses assigned to folds at random; what a random
  train/test split of one measurement series says;
* **region**: a part of configuration space left out as a whole: clusters of the joint
  configurations (always), one side of an arm branch (when both sides were measured), one
  fixture placement (ball-in-socket data), the last poses in time (when the file has a
  timestamp column).  This is what users meet: a program that sends the robot where the
  calibration poses were not.

The recommendation (:func:`recommend`) answers inside the training domain, where targets lie
among the training poses as the random folds hold them out, so it is judged on those, with
the regions as a guard: the simplest model stays chosen unless a richer one is better on the
random folds by more than the spread of that gain from fold to fold, and not worse on the
regions by more than the spread there; of the richer models that pass, the one with the
lowest random-fold error is taken, or, among those the random folds cannot tell from it, the
one that models most (a residual above its kinematic model, then the parameter set).  A residual model (hybrid, network) that does not beat its
own base model on the region split is dropped, with a line that says so.  (Judging by the
regions first, as this module first did, kept the rigid calibration on UR10 series A where the
hybrid was three times better on a random half: ``bench/model_choice.py``.)

Beyond the training data no split can judge a model; there ``calibrate --method auto``
answers with the kinematic calibration without joint gains (:func:`outside_choice`,
:mod:`robocal.methods.fallback`), target by target.

Scores are of the position error |measured - predicted| (mm) on held-out poses; on
ball-in-socket data, the socket consistency on the placement left out.  The registered
nominal robot, scored the same way, is the baseline of every table.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .. import parallel
from ..errors import InputError, RobocalWarning
from ..estimation.constraint import socket_deviations
from ..estimation.metrics import error_stats
from ..kinematics.chain import Chain
from ..io.observations import Observations
from . import make_method
from .frames import registered_nominal
from .domain import Domain, arm_branches
from .fallback import wrap

# The parameter sets compared, simplest first (the order in which the rule considers them).
PARAMETER_SETS = ("full", "full+gains", "full+compliance", "full+compliance+gains")
# Error models of a residual are compared over the joints' sines and cosines (what holds on
# another arm branch) and, for Kriging alone, over the TCP position (the paper's form).
RESIDUAL_INPUTS = "sincos"
# Folds of each split.  Five clusters of a 6-axis arm's configurations leave out regions of
# about a fifth of the workspace each: far enough to be another region, near enough that the
# training part still surrounds part of it.
FOLDS = 5
# The network's 16-16 hidden layers have 435 weights; with fewer training poses than this
# (each gives three equations) it fits noise rather than the robot's error.
NETWORK_MIN_POSES = 500
# The network's genetic algorithm runs this many generations in a comparison (its default is
# 300): held out on the UR5's 1,000 poses, 5 random folds, two seeds, 150 generations gave
# 0.0957 / 0.0932 mm against 0.0963 / 0.0974 with 300, in 10 s of CPU instead of 17.  What
# compare scores is what auto fits: the candidate's settings.
NETWORK_GENERATIONS = 150
# Kriging keeps per input dimension an n x n matrix of squared differences while it searches
# its hyperparameters (216 MB at 1,500 poses over the 12 sines and cosines of a 6-axis arm):
# beyond this many training poses the Kriging-based models are left out of a comparison.
KRIGING_MAX_POSES = 1500
# A region split whose smallest training part is below this many poses cannot fit the full
# parameter set with any margin; the split is left out (and said so).
MIN_TRAINING_POSES = 30
# The share of the poses, last in time, that the time-tail split holds out.
TIME_TAIL = 0.2
# A side of an arm branch must hold this share of the poses to be left out as a region.
BRANCH_MIN_SHARE = 0.15
# Differences of held-out mean error below this (mm) are ties whatever their spread: no
# tracker resolves them, and two models that differ only where a parameter was left out (a
# compliance not told from zero) otherwise differ by 1e-4 mm with a spread of 0.
RESOLUTION = 1e-3


@dataclass(frozen=True)
class Candidate:
    """One model compared: its ``label`` in tables, the registered ``method`` and its
    ``settings``, and the ``base`` label a residual model must beat (None for the others)."""

    label: str
    method: str
    settings: dict
    base: str | None = None

    def unfitted(self):
        """The unfitted method."""
        return make_method(self.method, **self.settings)



def candidates(observations, *, network=None, folds=FOLDS):
    """(models, notes): the models :func:`compare` scores on ``observations``, simplest
    first, and lines saying which were left out and why.

    Position data: the kinematic calibration with each parameter set; the hybrid on each
    (its residual over the joints' sines and cosines); Kriging over the TCP position and over
    the joints' sines and cosines (while the training folds hold at most KRIGING_MAX_POSES);
    the network when they hold NETWORK_MIN_POSES or more (``network`` True/False forces it in
    or out).  Ball-in-socket data: the constraint calibration with each parameter set.
    """
    if observations.positions is None:
        return [Candidate(f"constraint {p}", "constraint", {"parameters": p}) for p in PARAMETER_SETS], []
    training = observations.n_poses * (folds - 1) // folds
    notes = []
    out = [Candidate(f"kinematic {p}", "kinematic", {"parameters": p}) for p in PARAMETER_SETS]
    if training <= KRIGING_MAX_POSES:
        out += [Candidate(f"hybrid {p}", "hybrid", {"parameters": p, "inputs": RESIDUAL_INPUTS},
                          base=f"kinematic {p}") for p in PARAMETER_SETS]
        out += [Candidate("kriging (position)", "kriging", {"inputs": "position"}),
                Candidate(f"kriging ({RESIDUAL_INPUTS})", "kriging", {"inputs": RESIDUAL_INPUTS})]
    else:
        notes.append(f"hybrid and kriging left out: the training folds hold {training} poses, more than the "
                     f"{KRIGING_MAX_POSES} Kriging is fitted on here (compare a random subset of the file to see them)")
    if network if network is not None else training >= NETWORK_MIN_POSES:
        out.append(Candidate("ann", "ann", {"generations": NETWORK_GENERATIONS}))
    elif network is None:
        notes.append(f"ann left out: the training folds hold {training} poses, fewer than the {NETWORK_MIN_POSES} its "
                     "435 weights need (--network includes it)")
    return out, notes


# ---------------------------------------------------------------------------- splits
@dataclass(frozen=True)
class Split:
    """A way of holding poses out: ``name``, ``kind`` ('random' or 'region'), the held-out
    index arrays ``tests`` (one per fold; every fit sees the poses of the others) and what
    the folds are (``fold_names``)."""

    name: str
    kind: str
    tests: tuple
    fold_names: tuple


def random_split(n, folds=FOLDS, seed=0, groups=None):
    """k-fold: the poses in ``folds`` random folds (sizes differing by one at most).  With
    ``groups`` ((n,) labels), each group's poses are dealt out over the folds in turn, so that
    every held-out pose keeps poses of its group in the training part (ball-in-socket data:
    they say where its socket is)."""
    rng = np.random.default_rng(seed)
    order = rng.permutation(n)
    if groups is None:
        tests = tuple(np.sort(part) for part in np.array_split(order, folds))
    else:
        labels = np.unique(np.asarray(groups)[order], return_inverse=True)[1]
        by_group = np.argsort(labels, kind="stable")
        rank = np.empty(n, dtype=int)
        rank[by_group] = np.arange(n) - np.searchsorted(labels[by_group], labels[by_group])
        # Each group starts at a random fold, so that the folds' sizes stay even.
        fold = (rank + rng.integers(folds, size=labels.max() + 1)[labels]) % folds
        tests = tuple(np.sort(order[fold == k]) for k in range(folds))
    return Split(f"random {folds}-fold", "random", tests, tuple(f"fold {k + 1}" for k in range(folds)))


def joint_features(chain, joints):
    """Joint configurations as points where distance means "another region": sines and cosines
    of the revolute joints (±180 deg is one place), prismatic joints scaled by their range."""
    q = np.asarray(joints, dtype=float)
    revolute = np.asarray(chain.revolute, dtype=bool)
    parts = [np.sin(q[:, revolute]), np.cos(q[:, revolute])]
    if (~revolute).any():
        span = np.maximum(np.ptp(q[:, ~revolute], axis=0), 1e-9)
        parts.append((q[:, ~revolute] - q[:, ~revolute].min(axis=0)) / span)
    return np.hstack(parts)


def cluster_split(chain, joints, folds=FOLDS, seed=0):
    """Leave one cluster of joint configurations out at a time (k-means in
    :func:`joint_features`, seeded k-means++ starts, best of several)."""
    from scipy.cluster.vq import kmeans2

    features = joint_features(chain, joints)
    rng = np.random.default_rng(seed)
    best, best_inertia = None, np.inf
    for _ in range(5):
        centres, labels = kmeans2(features, folds, minit="++", seed=rng, missing="raise")
        inertia = float(np.sum((features - centres[labels]) ** 2))
        if inertia < best_inertia and len(np.unique(labels)) == folds:
            best, best_inertia = labels, inertia
    if best is None:
        raise InputError(f"the joint configurations do not form {folds} regions: measure poses spread over the "
                         "workspace, or compare with fewer folds")
    # Clusters in order of their first pose, so that the fold names are reproducible.
    order = np.argsort([np.flatnonzero(best == c)[0] for c in range(folds)])
    tests = tuple(np.flatnonzero(best == c) for c in order)
    return Split("joint-space regions", "region", tests, tuple(f"region {k + 1}" for k in range(folds)))


def branch_split(chain, joints):
    """Leave one side of an arm branch (shoulder, elbow or wrist) out, then the other: the
    most balanced choice whose both sides hold BRANCH_MIN_SHARE of the poses; None if none
    does (or the robot has no closed form that defines branches)."""
    found = arm_branches(chain, joints)
    if found is None:
        return None
    _, sides = found
    n = len(joints)
    best = None
    for name, side in sides.items():
        shares = [np.mean(side == s) for s in (0, 1)]
        if min(shares) >= BRANCH_MIN_SHARE and (best is None or min(shares) > best[0]):
            best = (min(shares), name, side)
    if best is None:
        return None
    _, name, side = best
    tests = tuple(np.flatnonzero(side == s) for s in (0, 1))
    # Poses too near the singularity to tell their side are trained on in both folds.
    return Split(f"{name} branch", "region", tests, (f"{name} side 0 ({len(tests[0])} of {n})",
                                                     f"{name} side 1 ({len(tests[1])} of {n})"))


def time_split(times):
    """Hold out the last TIME_TAIL of the poses in time order (one fold)."""
    order = np.argsort(np.asarray(times, dtype=float), kind="stable")
    tail = order[int(round(len(order) * (1.0 - TIME_TAIL))):]
    return Split(f"last {TIME_TAIL:.0%} in time", "region", (np.sort(tail),), ("time tail",))


def placement_split(placements):
    """Ball-in-socket data: leave one fixture placement out at a time."""
    names = sorted(set(placements.tolist()))
    return Split("fixture placements", "region", tuple(np.flatnonzero(placements == p) for p in names),
                 tuple(f"placement {p}" for p in names))


def splits(chain, observations, *, folds=FOLDS, seed=0):
    """(splits, notes): every split that applies to ``observations`` (the random one first);
    notes say what was left out."""
    n, notes = observations.n_poses, []
    if observations.positions is None:
        if observations.placement is None or len(set(observations.placement.tolist())) < 2:
            raise InputError(f"{observations.path or 'the data'} has one fixture placement: comparing models on "
                             "ball-in-socket data leaves a placement out and needs two or more")
        sockets = np.char.add(np.char.add(observations.placement.astype(str), "/"), observations.socket.astype(str))
        return [random_split(n, folds, seed, groups=sockets), placement_split(observations.placement)], notes
    if n < 2 * folds or n - n // folds < MIN_TRAINING_POSES:
        raise InputError(f"{observations.path or 'the data'} holds {n} poses: comparing models with {folds} folds "
                         f"needs at least {max(2 * folds, MIN_TRAINING_POSES + MIN_TRAINING_POSES // (folds - 1))}; "
                         "measure more poses")
    out = [random_split(n, folds, seed), cluster_split(chain, observations.joints, folds, seed)]
    branch = branch_split(chain, observations.joints)
    if branch is not None:
        out.append(branch)
    else:
        notes.append("no arm-branch split: the poses lie on one side of every arm branch (or the robot has no "
                     "closed form that defines them)")
    if observations.times is not None:
        out.append(time_split(observations.times))
    for split in list(out):
        smallest = min(n - len(test) for test in split.tests)
        if smallest < MIN_TRAINING_POSES:
            out.remove(split)
            notes.append(f"{split.name} left out: a fold would train on {smallest} poses")
    return out, notes


# ---------------------------------------------------------------------------- scoring
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


def _held_out_errors(fitted, observations, train, test):
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
        fitted = candidate.unfitted().fit(self.chain, observations)
        self.template.setdefault(candidate.label, fitted)
        if candidate.method == "kinematic":
            self.kinematic[(candidate.settings["parameters"],) + where] = fitted
        return _Fitted(fitted)


def score(candidate, observations, split, refits, *, on_fit=None):
    """:class:`Score` of ``candidate`` fitted on each fold's training poses of ``split`` and
    scored on its held-out poses (fits made by ``refits``, a :class:`_Refits`)."""
    n = observations.n_poses
    errors, fold_means, seconds, insides = [], [], 0.0, []
    for fold, test in enumerate(split.tests):
        train = np.setdiff1d(np.arange(n), test)
        # Warnings of a fold's fit or prediction (Kriging extrapolating into the region left
        # out, an outlier) are what the held-out error measures; the final fit still gives them.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobocalWarning)
            start = time.perf_counter()
            fitted = refits.fit(candidate, observations.subset(train), (split.name, fold))
            seconds += time.perf_counter() - start
            error = _held_out_errors(fitted, observations, train, test)
        if on_fit is not None:
            on_fit()
        errors.append(error)
        fold_means.append(float(np.linalg.norm(error, axis=1).mean()))
        insides.append(refits.inside(observations, train, test, (split.name, fold)))
    lengths = [np.linalg.norm(e, axis=1) for e in errors]
    inside_means = [float(d[i].mean()) if i.any() else float("nan") for d, i in zip(lengths, insides)]
    inside = np.concatenate([d[i] for d, i in zip(lengths, insides)])
    return Score(fold_means, error_stats(np.concatenate(errors)), seconds / len(split.tests), inside_means,
                 float(inside.mean()) if inside.size else float("nan"))


# ---------------------------------------------------------------------------- the choice
@dataclass
class Comparison:
    """What :func:`compare` measured and recommends.

    Attributes: ``poses``, ``file``; ``splits`` (names and kinds); ``scores``:
    {label: {split name: Score}} with the registered nominal under "nominal (registered)";
    ``candidates`` (the :class:`Candidate` list); ``recommended`` (a Candidate); ``reasons``:
    lines that say why; ``dropped``: lines naming the residual models that did not beat their
    base; ``notes``: splits left out; ``seconds``: {label: total s}.
    """

    poses: int
    file: str
    splits: list
    scores: dict
    candidates: list
    recommended: Candidate
    reasons: list
    dropped: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)
    # What answers outside the training domain (a Candidate, :func:`outside_choice`), or None.
    outside: Candidate | None = None

    def _method_of(self, label):
        """The method and settings of a compared model ({} for the registered nominal)."""
        for candidate in self.candidates:
            if candidate.label == label:
                return {"method": candidate.method, "settings": candidate.settings}
        return {}

    def to_dict(self):
        return {"file": self.file, "poses": self.poses,
                "splits": [{"name": s.name, "kind": s.kind, "folds": list(s.fold_names)} for s in self.splits],
                "models": [{"label": label, **self._method_of(label),
                            "scores": {name: score.to_dict() for name, score in by_split.items()},
                            "seconds": self.seconds.get(label)}
                           for label, by_split in self.scores.items()],
                "recommended": {"label": self.recommended.label, "method": self.recommended.method,
                                "settings": self.recommended.settings},
                "outside_domain": None if self.outside is None else {
                    "label": self.outside.label, "method": self.outside.method, "settings": self.outside.settings},
                "reasons": self.reasons, "dropped": self.dropped, "notes": self.notes}


NOMINAL = "nominal (registered)"


def _behind(scores, label, best, splits_):
    """(how far ``label`` is behind ``best`` per fold, its spread), mm."""
    gain, spread = _gain(scores, label, best, splits_)
    return -gain, spread


def _beyond(gain, spread):
    """Whether a mean ``gain`` (mm) exceeds its fold-to-fold ``spread`` and RESOLUTION."""
    return gain > max(spread, RESOLUTION)


def _gain(scores, better, worse, splits_):
    """Mean and fold-to-fold standard deviation of the per-fold gain (mm) of ``better`` over
    ``worse`` over the folds of ``splits_`` (paired by fold; :meth:`Score.judged` means, folds
    with no held-out pose inside their training domain left out)."""
    gain = np.concatenate([scores[worse][s.name].judged()[0] - scores[better][s.name].judged()[0] for s in splits_])
    gain = gain[np.isfinite(gain)]
    if not gain.size:
        return 0.0, 0.0
    spread = float(gain.std(ddof=1)) if gain.size > 1 else 0.0
    return float(gain.mean()), spread


def recommend(comparison_scores, candidate_list, split_list):
    """(chosen Candidate, reasons, dropped): the rule of the module docstring.

    The chosen model answers inside its training domain (outside, :func:`outside_choice`'s
    does), where targets lie among the training poses as random folds hold them out: it is
    judged there, with the held-out regions as a guard (their folds pooled; on each, the
    held-out poses inside the fold's training domain, :meth:`Score.judged`).  Residual
    models that do not beat their own base model on the regions are dropped.  The contenders
    are the richer models whose gain over the simplest on the random folds is larger on
    average than its fold-to-fold standard deviation, and that are not worse than the
    simplest on the regions by more than the fold-to-fold deviation of that difference.  The
    contender with the lowest random-fold error is the best; of the models not guarded out whose
    random-fold error is within the fold-to-fold spread of the best's, the one that models most
    (:func:`_richness`) is chosen.  With no contender, the simplest."""
    regions = [s for s in split_list if s.kind == "region"]
    random = next((s for s in split_list if s.kind == "random"), regions[0])
    # A region split whose held-out poses all lie outside their training domain (the other
    # arm branch) is the fallback's to answer, not the chosen model's: it is left out here
    # unless every region split is like that.
    some_inside = [s for s in regions if all(np.isfinite(comparison_scores[c.label][s.name].inside_mean)
                                             for c in candidate_list)]
    regions = some_inside or regions
    where = "the held-out regions" if len(regions) > 1 else regions[0].name
    by_label = {c.label: c for c in candidate_list}

    def region(label):
        return float(np.mean([comparison_scores[label][s.name].judged()[1] for s in regions]))

    def at_random(label):
        return comparison_scores[label][random.name].judged()[1]

    dropped, eligible = [], []
    for candidate in candidate_list:
        base = candidate.base
        if base is not None and base in comparison_scores and region(candidate.label) >= region(base):
            dropped.append(f"{candidate.label} dropped: on {where} it does not beat its base model {base} "
                           f"({region(candidate.label):.4f} mm against {region(base):.4f} mm)")
            continue
        eligible.append(candidate)
    simplest = eligible[0]
    contenders, guarded, unguarded = [], [], [simplest]
    for candidate in eligible[1:]:
        gain, spread = _gain(comparison_scores, candidate.label, simplest.label, [random])
        region_gain, region_spread = _gain(comparison_scores, candidate.label, simplest.label, regions)
        if _beyond(-region_gain, region_spread):
            if _beyond(gain, spread):
                guarded.append(f"{candidate.label} not taken: {gain:.4f} mm better on {random.name}, but worse on "
                               f"{where} by {-region_gain:.4f} mm, more than the fold-to-fold spread "
                               f"({region_spread:.4f} mm)")
            continue
        unguarded.append(candidate)
        if _beyond(gain, spread):
            contenders.append((at_random(candidate.label), candidate, gain, spread))
    reasons = [f"the simplest model, {simplest.label}: {at_random(simplest.label):.4f} mm held out on {random.name}, "
               f"{region(simplest.label):.4f} mm on {where} (judged on the held-out poses inside each fold's "
               "training domain, where the chosen model answers)"] + guarded
    if not contenders:
        reasons.append(f"no richer model beats it on {random.name} by more than the fold-to-fold spread of its gain "
                       f"without losing on {where}: keep it")
        return simplest, reasons, dropped
    _, best, gain, spread = min(contenders, key=lambda item: item[0])
    others = len(contenders) - 1
    reasons.append(f"{best.label} beats it by {gain:.4f} mm per fold on {random.name}, more than the fold-to-fold "
                   f"spread of that gain ({spread:.4f} mm), is not worse on {where} ({region(best.label):.4f} mm), "
                   f"and has the lowest held-out error on {random.name} ({at_random(best.label):.4f} mm)"
                   + (f" of the {others + 1} models that pass so" if others else ""))
    # Models the random folds cannot tell from the best: the one that models most of the robot
    # (UR5 and UR10 A: the hybrids differ by 1 % in cross-validation; the richest was the best
    # held out by 3-5 %).
    ties = [c for c in unguarded if not _beyond(*_behind(comparison_scores, c.label, best.label, [random]))]
    chosen = max(ties, key=_richness)
    if _richness(chosen) > _richness(best):
        behind, spread = _gain(comparison_scores, best.label, chosen.label, [random])
        within = (f"within the fold-to-fold spread ({spread:.4f} mm)" if spread >= RESOLUTION
                  else f"less than the {RESOLUTION * 1e3:.0f} µm a tracker resolves")
        reasons.append(f"{chosen.label} is {behind:.4f} mm behind it on {random.name}, {within}, and models more of "
                       "the robot: take it")
        return by_label[chosen.label], reasons, dropped
    reasons[-1] += ": take it"
    return by_label[best.label], reasons, dropped


def _richness(candidate):
    """What a candidate models, for ranking those the held-out errors cannot tell apart: a
    residual on a kinematic model above the kinematic model, then the parameter set."""
    parameters = candidate.settings.get("parameters")
    return (candidate.base is not None, PARAMETER_SETS.index(parameters) if parameters in PARAMETER_SETS else -1)


def outside_choice(comparison_scores, candidate_list, split_list, recommended):
    """(Candidate or None, reason): what answers for configurations outside the training
    domain (see :mod:`robocal.methods.fallback` for why): the kinematic calibration without
    joint gains — with joint compliance, which models gravity wherever the arm goes, unless
    the held-out regions show it worse than the rigid one by more than the fold-to-fold
    spread of the difference.  None when there is no kinematic candidate (ball-in-socket
    data) or when it is the recommended model itself."""
    kinematic = {c.settings.get("parameters"): c for c in candidate_list if c.method == "kinematic"}
    rigid, compliant = kinematic.get("full"), kinematic.get("full+compliance")
    if rigid is None and compliant is None:
        return None, None
    regions = [s for s in split_list if s.kind == "region"]
    chosen, why = rigid or compliant, "the rigid kinematic calibration"
    if rigid is not None and compliant is not None:
        gain, spread = _gain(comparison_scores, compliant.label, rigid.label, regions)
        if _beyond(-gain, spread):
            why = (f"{compliant.label} is worse than {rigid.label} on the held-out regions by {-gain:.4f} mm, more "
                   f"than the fold-to-fold spread ({spread:.4f} mm)")
        else:
            chosen, why = compliant, "joint compliance models gravity on every branch"
    if chosen.label == recommended.label:
        return None, None
    return chosen, (f"outside the training domain (another arm branch, a joint beyond its measured range) it "
                    f"answers with {chosen.label}: error models know nothing there and joint gains extrapolate; "
                    f"{why}")


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
    """A piece of :func:`compare` run by a worker of :mod:`robocal.parallel`: ``task`` and
    the result are plain data (the robot and the observations as their ``to_plain`` gives
    them, splits and candidates as dicts; the scores as the fields of :class:`Score`)."""
    chain = Chain.from_plain(task["robot"])
    observations = Observations.from_plain(task["observations"])
    split_list = [Split(s["name"], s["kind"], tuple(s["tests"]), tuple(s["fold_names"])) for s in task["splits"]]
    scores, seconds = _score_group(chain, observations, [Candidate(**c) for c in task["candidates"]], split_list)
    return {"scores": {label: {name: vars(one) for name, one in by_split.items()} for label, by_split in scores.items()},
            "seconds": seconds}


def _score_all(chain, observations, candidate_list, split_list, on_fit):
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
              "splits": [{"name": s.name, "kind": s.kind, "tests": list(s.tests), "fold_names": list(s.fold_names)}
                         for s in splits_]} for group, splits_ in groups]

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


def compare(chain, observations, *, folds=FOLDS, seed=0, network=None, on_fit=None, only=None):
    """Score every :func:`candidates` model (``only``: a list of labels to keep) on every
    :func:`splits` split of ``observations`` of ``chain``, beside the registered nominal, and
    recommend one (:func:`recommend`).  ``on_fit(steps=1)`` is called as fits finish.  The
    fits run on the active :func:`robocal.parallel.executor` when there is one.  Returns a
    :class:`Comparison`."""
    if folds < 2:
        raise InputError(f"--folds must be at least 2, got {folds}")
    split_list, notes = splits(chain, observations, folds=folds, seed=seed)
    candidate_list, left_out = candidates(observations, network=network, folds=folds)
    notes = notes + left_out
    if only is not None:
        unknown = sorted(set(only) - {c.label for c in candidate_list})
        if unknown:
            raise InputError(f"no candidate model is called {', '.join(unknown)}; the candidates are "
                             f"{', '.join(c.label for c in candidate_list)}")
        candidate_list = [c for c in candidate_list if c.label in only]
    scores, seconds = _score_all(chain, observations, candidate_list, split_list, on_fit)
    chosen, reasons, dropped = recommend(scores, candidate_list, split_list)
    outside, why = outside_choice(scores, candidate_list, split_list, chosen)
    if why:
        reasons.append(why)
    return Comparison(observations.n_poses, observations.path, split_list, scores, candidate_list, chosen, reasons,
                      dropped, notes, seconds, outside)


def choose(chain, observations, *, folds=FOLDS, seed=0, network=None, on_fit=None, progress=None):
    """``calibrate --method auto``: :func:`compare`, then the recommended method fitted on all
    of ``observations``, answering with the :func:`outside_choice` model (fitted on all of
    them too) outside its training domain (:mod:`robocal.methods.fallback`).  Returns (fitted method, :class:`Comparison`)."""
    comparison = compare(chain, observations, folds=folds, seed=seed, network=network, on_fit=on_fit)
    fitted = comparison.recommended.unfitted().fit(chain, observations, progress=progress)
    if comparison.outside is not None:
        fallback = comparison.outside.unfitted().fit(chain, observations)
        wrap(fitted, fallback, comparison.outside.label)
    return fitted, comparison
