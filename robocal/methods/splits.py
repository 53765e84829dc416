"""Ways of holding poses out, for ``robocal compare``, ``calibrate --method auto`` and the
held-out estimates of ``calibrate``: each split is a list of held-out index arrays, every fit
seeing the poses of the others (scikit-learn's splitters, in robocal's terms).

* **random**: k-fold, poses dealt to folds at random; on a small campaign, where a fold's
  training part would hold fewer than MIN_TRAINING_POSES, leave-one-out (or, with an
  explicit ``--folds K``, K-fold repeated REPEATS times with other seeds);
* **region**: a part of configuration space left out whole: clusters of the joint
  configurations, one side of an arm branch, the last poses in time, one fixture placement.
  A region split whose smallest training part holds fewer than MIN_TRAINING_POSES is left
  out with a note (a region that leaves a dozen poses to train on says nothing about
  another region).

A small-campaign split is marked ``deletion``: a linearised least-squares fit (the kinematic
calibration) then scores it from its one fit on every pose, through its hat matrix, and
needs no refit (:mod:`robocal.methods.scoring`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .domain import arm_branches

# Folds of each split.  Five clusters of a 6-axis arm's configurations leave out regions of
# about a fifth of the workspace each: far enough to be another region, near enough that the
# training part still surrounds part of it.
FOLDS = 5
# A k-fold training part below this many poses cannot fit the full parameter set with any
# margin: the random split becomes leave-one-out, and a region split is left out (and said so).
MIN_TRAINING_POSES = 30
# An explicit --folds K on a small campaign: K-fold repeated with this many seeds, so that
# every pose is held out this many times and one unlucky deal does not decide.
REPEATS = 5
# The share of the poses, last in time, that the time-tail split holds out.
TIME_TAIL = 0.2
# A side of an arm branch must hold this share of the poses to be left out as a region.
BRANCH_MIN_SHARE = 0.15


@dataclass(frozen=True)
class Split:
    """A way of holding poses out: ``name``, ``kind`` ('random' or 'region'), the held-out
    index arrays ``tests`` (one per fold; every fit sees the poses of the others) and what
    the folds are (``fold_names``).

    ``groups``: None, or index arrays of poses whose held-out errors are averaged together
    as one fold's mean (leave-one-out: its single poses pooled into FOLDS random groups, so
    that the fold-to-fold spread the choice weighs is of the same kind as on a k-fold split);
    ``deletion``: True where a linearised fit may score the split by deletion from its fit
    on every pose (small campaigns)."""

    name: str
    kind: str
    tests: tuple
    fold_names: tuple
    groups: tuple | None = None
    deletion: bool = False

    def to_plain(self):
        """JSON-ready fields (for a worker of :mod:`robocal.parallel`)."""
        return {"name": self.name, "kind": self.kind, "tests": [np.asarray(t).tolist() for t in self.tests],
                "fold_names": list(self.fold_names),
                "groups": None if self.groups is None else [np.asarray(g).tolist() for g in self.groups],
                "deletion": self.deletion}

    @classmethod
    def from_plain(cls, plain):
        groups = plain.get("groups")
        return cls(plain["name"], plain["kind"], tuple(np.asarray(t, dtype=int) for t in plain["tests"]),
                   tuple(plain["fold_names"]), None if groups is None else tuple(np.asarray(g, dtype=int)
                                                                                 for g in groups),
                   bool(plain.get("deletion", False)))


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


def leave_one_out(n, seed=0, groups=FOLDS):
    """Every pose held out alone; their errors pooled into ``groups`` random groups for the
    fold-to-fold spread (the groups of :func:`random_split` with the same seed)."""
    pooled = random_split(n, groups, seed).tests
    return Split("leave-one-out", "random", tuple(np.array([i]) for i in range(n)),
                 tuple(f"pose {i + 1}" for i in range(n)), groups=pooled, deletion=True)


def repeated_split(n, folds, repeats=REPEATS, seed=0):
    """k-fold repeated ``repeats`` times, each with its own random deal (seeds ``seed``,
    ``seed`` + 1, ...): every pose is held out ``repeats`` times."""
    tests, names = [], []
    for r in range(repeats):
        tests += list(random_split(n, folds, seed + r).tests)
        names += [f"repeat {r + 1} fold {k + 1}" for k in range(folds)]
    return Split(f"random {folds}-fold x {repeats}", "random", tuple(tests), tuple(names), deletion=True)


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
    from scipy.cluster.vq import ClusterError, kmeans2

    features = joint_features(chain, joints)
    rng = np.random.default_rng(seed)
    best, best_inertia = None, np.inf
    for _ in range(5):
        try:
            centres, labels = kmeans2(features, folds, minit="++", seed=rng, missing="raise")
        except ClusterError:  # a region left empty: another start (none for too few distinct poses)
            continue
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


def small(n, folds=FOLDS):
    """Whether ``n`` poses are a small campaign for ``folds`` folds: a fold's training part
    would hold fewer than MIN_TRAINING_POSES."""
    return n - -(-n // folds) < MIN_TRAINING_POSES


def random_part(n, folds=None, seed=0):
    """The random split of ``n`` position poses: ``folds``-fold (default FOLDS); on a small
    campaign leave-one-out, or with ``folds`` given, ``folds``-fold repeated REPEATS times."""
    if folds is None:
        return leave_one_out(n, seed) if small(n) else random_split(n, FOLDS, seed)
    if folds > n:
        raise InputError(f"--folds {folds} is more than the {n} poses: give at most {n}, or leave --folds out "
                         "(leave-one-out on a small campaign)")
    return repeated_split(n, folds, REPEATS, seed) if small(n, folds) else random_split(n, folds, seed)


def splits(chain, observations, *, folds=None, seed=0):
    """(splits, notes): every split that applies to ``observations`` (the random one first);
    notes say what was left out.  ``folds``: of the random split and of the joint-space
    clusters (default FOLDS; see :func:`random_part` for small campaigns)."""
    n, notes = observations.n_poses, []
    if observations.positions is None:
        if observations.placement is None or len(set(observations.placement.tolist())) < 2:
            raise InputError(f"{observations.path or 'the data'} has one fixture placement: comparing models on "
                             "ball-in-socket data leaves a placement out and needs two or more")
        k = folds or FOLDS
        if n < 2 * k:
            raise InputError(f"{observations.path or 'the data'} holds {n} poses: {k} folds need at least {2 * k}")
        sockets = np.char.add(np.char.add(observations.placement.astype(str), "/"), observations.socket.astype(str))
        return [random_split(n, k, seed, groups=sockets), placement_split(observations.placement)], notes
    out = [random_part(n, folds, seed)]
    clusters = folds or FOLDS
    regions = []
    if n - n // clusters >= MIN_TRAINING_POSES:
        try:
            regions.append(cluster_split(chain, observations.joints, clusters, seed))
        except InputError as refusal:
            notes.append(f"no joint-space regions: {refusal}")
    branch = branch_split(chain, observations.joints)
    if branch is not None:
        regions.append(branch)
    else:
        notes.append("no arm-branch split: the poses lie on one side of every arm branch (or the robot has no "
                     "closed form that defines them)")
    if observations.times is not None:
        regions.append(time_split(observations.times))
    for split in regions:
        smallest = min(n - len(test) for test in split.tests)
        if smallest < MIN_TRAINING_POSES:
            notes.append(f"{split.name} left out: a fold would train on {smallest} poses, fewer than the "
                         f"{MIN_TRAINING_POSES} a region needs to say anything about another")
        else:
            out.append(split)
    if n - n // clusters < MIN_TRAINING_POSES:
        notes.append(f"joint-space regions left out: {clusters} clusters of {n} poses would leave about "
                     f"{n - n // clusters} to train on, fewer than {MIN_TRAINING_POSES}")
    return out, notes
