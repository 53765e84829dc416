"""Choosing poses: greedy selection, then exchange.

Two optimisers share the states of :mod:`robocal.planning.criteria`:

:func:`greedy` adds, one at a time, the candidate that improves the criterion most (every
candidate judged at once by the state, :mod:`robocal.planning.criteria`).  :func:`exchange`
then improves the set by DETMAX excursions (Mitchell, 1974): add the best candidate and remove
the chosen pose whose loss is smallest; when that removes the pose just added, try the other
way round (remove first, then add).  A step is kept only if the criterion rises by more than
a relative TOLERANCE, so the exchange never lowers it and stops; it ends when neither order
improves the set, or after ``max_steps`` exchanges.  With the Woodbury updates each step
costs two evaluations over the candidates, where a full Fedorov exchange would weigh every
(chosen, candidate) pair.  Both are deterministic: ties go to the lowest index.

:func:`select_stratified` chooses one pose per stratum: the candidates are split into as
many strata as poses are wanted (k-means in configuration space, :func:`strata`), each
stratum starts from its representative (the member nearest its centre) and the exchange
replaces each stratum's pose by the best of its own stratum, sweeping the strata until none
changes (a greedy start per stratum would end next to the extreme poses the greedy step
picks first; the representative start ends next to poses that stand for their strata).  The
chosen poses then stand for the targets as a stratified sample does, which matters when the
model does not explain everything: errors the calibration cannot represent (joint compliance and
backlash on the simulated KR 150-2, what
remains on the real UR5) bias a fit to the extreme poses an unconstrained optimum picks,
while a sample spread like the targets averages them as the targets will.  Held out
(bench/design.py, 15/20/30/50/100 poses) the unstratified optimum gave 0.110/0.110/0.113/
0.109/0.105 mm on the UR5 and the stratified designs 0.116/0.115/0.112/0.107/0.104 (mean of
five seeds, of the calibrations made: at 30 poses two of the five are refused, the fit
sliding theta5 by 11-32 deg along a valley of the UR5's model that the data hardly see): a
little behind at 15 and 20 poses, ahead from 30 on.
"""
import numpy as np

from ..errors import InputError

# An exchange is kept when it improves the criterion by more than this share of its value
# (or 1e-12 absolute): rounding cannot make the exchange cycle.
TOLERANCE = 1e-9
# Exchange steps per chosen pose at most (on the KR 150-2 and the UR5 it stops well before).
STEPS_PER_POSE = 10
# Sweeps over the strata at most (on the KR 150-2 and the UR5 three to six suffice).
SWEEPS = 20


def greedy(state, count, available):
    """Add ``count`` candidates to ``state``, each the best of those still ``available``
    ((N,) bool, updated in place).  Returns the state."""
    for _ in range(count):
        gains = state.gains_of_adding(available)
        best = int(np.argmax(gains))
        if not available[best] or not np.isfinite(gains[best]):
            raise InputError("no candidate is left to choose: give more candidates or ask for fewer poses")
        state.add(best)
        available[best] = False
    return state


def _improved(after, before):
    return after > before + max(TOLERANCE * abs(before), 1e-12)


def _add_then_remove(state, available):
    before = state.score
    gains = state.gains_of_adding(available)
    added = int(np.argmax(gains))
    if not np.isfinite(gains[added]):
        return False
    state.add(added)
    available[added] = False
    removed = state.chosen[int(np.argmax(state.gains_of_removing()))]
    if removed != added:
        state.remove(removed)
        available[removed] = True
        if _improved(state.score, before):
            return True
        state.add(removed)
        available[removed] = False
    state.remove(added)
    available[added] = True
    return False


def _remove_then_add(state, available):
    before = state.score
    removed = state.chosen[int(np.argmax(state.gains_of_removing()))]
    state.remove(removed)
    gains = state.gains_of_adding(available)
    added = int(np.argmax(gains))
    if np.isfinite(gains[added]):
        state.add(added)
        available[added] = False
        if _improved(state.score, before):
            available[removed] = True
            return True
        state.remove(added)
        available[added] = True
    state.add(removed)
    return False


def exchange(state, available, max_steps=None):
    """Improve the chosen set of ``state`` by exchanges (see the module notes); ``available``
    ((N,) bool) is updated in place.  Returns the number of exchanges made."""
    if not state.chosen:
        return 0
    max_steps = STEPS_PER_POSE * len(state.chosen) if max_steps is None else int(max_steps)
    steps = 0
    while steps < max_steps:
        if not (_add_then_remove(state, available) or _remove_then_add(state, available)):
            break
        steps += 1
    return steps


def select(state, count, available, *, refine=True, max_steps=None):
    """Greedy selection of ``count`` poses, then exchange when ``refine``.  Returns (the
    chosen candidate indices in the order of choice, the exchanges made)."""
    available = np.array(available, dtype=bool)
    greedy(state, count, available)
    steps = exchange(state, available, max_steps) if refine else 0
    return np.array(state.chosen, dtype=int), steps


def swap_within(state, available, old, allowed):
    """Replace the chosen pose ``old`` by the best candidate that is ``available`` and
    ``allowed`` ((N,) bool), if that improves the criterion; ``available`` is updated in
    place.  Returns the pose chosen in its place (``old`` when nothing was better)."""
    before = state.score
    state.remove(old)
    available[old] = True
    best = int(np.argmax(state.gains_of_adding(available & allowed)))
    state.add(best)
    available[best] = False
    if best != old and not _improved(state.score, before):
        state.remove(best)
        available[best] = True
        state.add(old)
        available[old] = False
        best = old
    return best


def strata(points, count, seed=0, reference=None):
    """(N,) stratum of each candidate: k-means (seeded, k-means++ start) of ``reference``
    (the targets' points, default ``points`` themselves) into ``count`` clusters, each of
    ``points`` (N, d) in the stratum of its nearest centre; numbered 0 .. count-1 (a stratum
    may be empty)."""
    from scipy.cluster.vq import kmeans2, vq  # loaded when used: the command line starts faster
    points = np.asarray(points, dtype=float)
    reference = points if reference is None else np.asarray(reference, dtype=float)
    if reference is points and count >= len(points):
        return np.arange(len(points))
    centres, labels = kmeans2(reference, min(count, len(reference)), seed=np.random.default_rng(seed), minit="++")
    return labels if reference is points else vq(points, centres)[0]


def select_stratified(state, count, available, labels, points, *, refine=True, max_sweeps=SWEEPS):
    """One pose per stratum (``labels`` (N,), see the module notes): each stratum starts from
    its representative (the member of ``points`` (N, d) nearest the stratum's mean), strata
    left empty are made up by greedy choices, then sweeps of exchange replace each stratum's
    pose by the best of its stratum.  Returns (the chosen candidate indices in the order of
    choice, the exchanges made)."""
    available = np.array(available, dtype=bool)
    labels = np.asarray(labels)
    owner = {}
    for stratum in np.unique(labels[available])[:count]:
        members = np.flatnonzero(available & (labels == stratum))
        centre = points[members].mean(axis=0)
        best = int(members[np.argmin(np.sum((points[members] - centre) ** 2, axis=1))])
        state.add(best)
        available[best] = False
        owner[int(stratum)] = best
    greedy(state, count - len(owner), available)
    steps = 0
    for _ in range(max_sweeps if refine else 0):
        changed = False
        for stratum, old in list(owner.items()):
            best = swap_within(state, available, old, labels == stratum)
            if best != old:
                owner[stratum] = best
                changed = True
                steps += 1
        if not changed:
            break
    return np.array(state.chosen, dtype=int), steps
