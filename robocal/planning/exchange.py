"""Choosing poses: greedy selection, then exchange.

:func:`greedy` adds, one at a time, the candidate that improves the criterion most (every
candidate judged at once by the state, :mod:`robocal.planning.criteria`).  :func:`exchange`
then improves the set by DETMAX excursions (Mitchell, 1974): add the best candidate and remove
the chosen pose whose loss is smallest; when that removes the pose just added, try the other
way round (remove first, then add).  A step is kept only if the criterion rises by more than
a relative TOLERANCE, so the exchange never lowers it and stops; it ends when neither order
improves the set, or after ``max_steps`` exchanges.  With the Woodbury updates each step
costs two evaluations over the candidates, where a full Fedorov exchange would weigh every
(chosen, candidate) pair.  Both are deterministic: ties go to the lowest index.
"""
import numpy as np

from ..errors import InputError

# An exchange is kept when it improves the criterion by more than this share of its value
# (or 1e-12 absolute): rounding cannot make the exchange cycle.
TOLERANCE = 1e-9
# Exchange steps per chosen pose at most (on the KR 150-2 and the UR5 it stops well before).
STEPS_PER_POSE = 10


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
