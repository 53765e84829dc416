"""Inverse kinematics as the rest of robocal asks for it: pick the closed form that fits the
robot, choose among its branches, and make the answer exact on the chain actually given.

A calibrated chain rarely keeps its nominal structure exactly (axes 4-6 no longer meet to the
micrometre), so a closed form fitted to its idealised geometry — or to the ``nominal`` chain
it came from — provides branches that are seeds; the numerical solver then polishes them on
the real chain.  A chain with no closed form at all is solved numerically from a posture hint.
"""
from typing import NamedTuple

import numpy as np

from ...errors import InputError
from .closed_form import NoFit, check_joints
from .limits import nearest_equivalent, periodic_joints
from .numeric import IKResult, as_joints, as_targets, refine
from .opw import SphericalWrist
from .ur import OffsetWrist

SOLVERS = (SphericalWrist, OffsetWrist)
# Added to the squared joint distance (rad^2) of seeds that need the seed allowances, so
# that they come after every seed that does not.
ALLOWANCE_RANK = 1e6
# Tool directions (tilts from the hint's, rad) that seed position-only problems.
POSITION_ONLY_TILTS = (0.0, np.pi / 2, -np.pi / 2, np.pi)
# Targets that every other seed missed, but by less than RESTART_RADIUS (mm), get this many
# random seeds.
RESTARTS = 8
RESTART_RADIUS = 50.0


def closed_form(chain):
    """The closed-form solver that fits ``chain``'s geometry (exactly if one does).

    Raises :class:`InputError` saying why none does; the numerical solver still applies.
    The solver (or the reason) is kept on the chain, which is immutable: fitting it costs
    about 0.9 ms (the chain turned into POE, both wrist solvers tried), several times what
    one target costs to solve, and every IK of the same chain asks for it again.
    """
    found = chain.__dict__.get(_CLOSED_FORM)
    if found is None:
        try:
            found = _fit_closed_form(chain)
        except InputError as why:
            found = why
        chain.__dict__[_CLOSED_FORM] = found
    if isinstance(found, InputError):
        raise type(found)(*found.args) from None
    return found


# Where closed_form keeps its answer on a chain (as functools.cached_property would).
_CLOSED_FORM = "_closed_form_solver"


def _fit_closed_form(chain):
    """:func:`closed_form` without the cache."""
    try:
        check_joints(chain)
    except NoFit as why:
        raise InputError(f"{why}; use the numerical solver (solve_numeric, or solve_ik with a "
                         "posture hint)") from None
    reasons, fits = [], []
    for solver_class in SOLVERS:
        try:
            fits.append(solver_class(chain))
        except NoFit as why:
            reasons.append(f"not a {solver_class.kind} arm: {why}")
    if not fits:
        raise InputError(
            f"robot {chain.name!r} has no closed-form inverse kinematics ({'; '.join(reasons)}); "
            "use the numerical solver (solve_numeric, or solve_ik with a posture hint)"
        )
    return next((f for f in fits if f.exact), fits[0])


def _seed_solver(chain, nominal):
    """(solver, exact): the closed form of ``chain`` or else of ``nominal``, or (None, False);
    ``exact`` when its branches are exact solutions on ``chain`` itself."""
    if nominal is not None and nominal.n_joints != chain.n_joints:
        raise InputError(f"the nominal chain has {nominal.n_joints} joints, the chain {chain.n_joints}")
    for model in (chain, nominal):
        if model is None:
            continue
        try:
            solver = closed_form(model)
        except InputError:
            continue
        return solver, solver.exact and model is chain
    return None, False


def ik_all(chain, targets, *, nominal=None):
    """Every closed-form branch for (N, 4, 4) TCP targets in the world frame.

    Returns q (N, 8, n) and valid (N, 8): a valid branch reaches the target within the joint
    limits (periodic joints take the 2 pi equivalent nearest zero that fits the limits); the
    others are NaN.  Branch k = 4 * shoulder + 2 * elbow + wrist for spherical-wrist arms,
    4 * shoulder + 2 * wrist + elbow for UR-type arms.  A chain that only approximately has a
    closed-form structure (a calibrated robot), or that borrows the ``nominal`` chain's, gets
    each branch refined numerically on itself.
    """
    targets = as_targets(targets)
    solver, exact = _seed_solver(chain, nominal)
    if solver is None:
        closed_form(chain)  # raises the reason
    q, valid = solver.solve(targets) if exact else solver.seeds(targets)[:2]
    if not exact:
        refined, reached = refine(chain, np.repeat(targets, 8, axis=0)[valid.reshape(-1)], q[valid])[:2]
        q[valid] = nearest_equivalent(refined, 0.0, chain.lower, chain.upper, periodic_joints(chain))[0]
        valid[valid] = reached
        q[~valid] = np.nan
    return q, valid


def solve_ik(chain, targets, hint=None, *, nominal=None, position_only=False, branch=None) -> IKResult:
    """Joint values that put the TCP on each target.

    targets: (N, 4, 4) TCP poses in the world frame (mm).  hint: (N, n) or (n,) posture hint
    (rad, mm): the branch nearest to it is chosen, it seeds the numerical solver where no
    closed form applies, and periodic joints come back as the 2 pi equivalent nearest to it.
    Without a hint the branch nearest to zero is chosen, or ``branch`` (an index of
    :func:`ik_all`'s branches) is used as given.  nominal: the unperturbed chain a calibrated
    ``chain`` came from, for its closed form.  position_only: reach the positions, any
    orientation.

    The closed-form branch nearest the hint is refined numerically on ``chain``; targets it
    does not reach get every other branch within the limits at once (the nearest success
    wins), then the hint itself, then (if some attempt came within 50 mm) a few random
    postures — only then may the result lie on another branch than the nearest.  Targets that
    are unreachable (outside the workspace, or only beyond a joint limit) come back with
    success False and NaN joints.
    """
    targets = as_targets(targets)
    count = targets.shape[0]
    reference = (np.zeros((count, chain.n_joints)) if hint is None
                 else as_joints(chain, hint, count, "hint"))
    attempts = _Attempts(chain, targets, position_only)
    solver, exact = _seed_solver(chain, nominal)
    if branch is not None:
        _check_branch(chain, solver, branch)
    if solver is not None:
        seeds = _closed_form_seeds(solver, exact, chain, targets, reference, position_only, branch)
        if branch is not None:
            _try_branch(attempts, seeds, branch, exact)
        else:
            _try_nearest_branches(attempts, seeds, reference, exact)
    if branch is None:
        _try_hint_and_restarts(attempts, chain, reference)
    return attempts.result(reference)


class _Seeds(NamedTuple):
    """Closed-form branches of N targets as seeds: q (N, K, n) controller joints (rad, mm;
    K = 8 per seed pose), valid (N, K) those that exist, preferred (N, K) those that exist
    without the seed allowances (equal to valid for exact solutions)."""

    q: np.ndarray
    valid: np.ndarray
    preferred: np.ndarray


class _Attempts:
    """The best attempt so far at each of N targets, and the refinement that improves it.

    q (N, n) rad/mm, success (N,), position_error (N,) mm and orientation_error (N,) rad, as
    in :class:`IKResult`; a target's first success stays, else its closest attempt.
    """

    def __init__(self, chain, targets, position_only):
        count = targets.shape[0]
        self.chain, self.targets, self.position_only = chain, targets, position_only
        self.q = np.full((count, chain.n_joints), np.nan)
        self.success = np.zeros(count, dtype=bool)
        self.position_error = np.full(count, np.inf)
        self.orientation_error = np.full(count, np.inf)

    def attempt(self, rows, seeds, likely_reached=False):
        """Refine seeds (len(rows), n) for targets ``rows`` (a target may appear several
        times, in order of preference); record each target's first success, or else its
        closest attempt."""
        q_new, reached, pe, oe = refine(self.chain, self.targets[rows], seeds,
                                        position_only=self.position_only,
                                        likely_reached=likely_reached)
        if np.all(rows[1:] > rows[:-1]):
            pick = np.arange(rows.size)  # one seed per target
        else:
            order = np.lexsort((~reached, rows))  # by target, successes first, then preference
            rows, first = np.unique(rows[order], return_index=True)
            pick = order[first]
        keep = reached[pick] | (pe[pick] < self.position_error[rows])
        rows, pick = rows[keep], pick[keep]
        self.q[rows], self.success[rows] = q_new[pick], reached[pick]
        self.position_error[rows], self.orientation_error[rows] = pe[pick], oe[pick]

    def result(self, reference):
        """The :class:`IKResult`: periodic joints of successes moved by whole turns nearest
        ``reference`` (N, n), failures NaN."""
        chain, q, success = self.chain, self.q, self.success
        q[success] = nearest_equivalent(q[success], reference[success], chain.lower, chain.upper,
                                        periodic_joints(chain))[0]
        q[~success] = np.nan
        return IKResult(q, success, self.position_error, self.orientation_error)


def _check_branch(chain, solver, branch):
    """Raise :class:`InputError` unless ``branch`` can be used: the chain needs a closed form
    (its absence raises why) and the index must be one of the 8 branches."""
    if solver is None:
        closed_form(chain)  # raises why there are no branches to choose from
    if not 0 <= branch < 8:
        raise InputError(f"branch must be 0 to 7, got {branch}")


def _closed_form_seeds(solver, exact, chain, targets, reference, position_only, branch):
    """:class:`_Seeds` of the N targets (N, 4, 4) from the closed form ``solver``, periodic
    joints nearest ``reference`` (N, n).  Position only: any orientation will do; the seed
    poses take the hint posture's orientation, turned to face the target, and (unless a
    branch is asked for) the tool pointing down, up and back from there: K = 8 per pose."""
    if position_only:
        start = chain.fk(reference)
        tilts = (0.0,) if branch is not None else POSITION_ONLY_TILTS
        seed_targets = [solver.facing(targets[:, :3, 3], start, tilt) for tilt in tilts]
    else:
        seed_targets = [targets]
    found = [solver.solve(t, reference) if exact else solver.seeds(t, reference)
             for t in seed_targets]
    branches = np.concatenate([f[0] for f in found], axis=1)
    valid = np.concatenate([f[1] for f in found], axis=1)
    preferred = valid if exact else np.concatenate([f[2] for f in found], axis=1)
    return _Seeds(branches, valid, preferred)


def _try_branch(attempts, seeds, branch, exact):
    """Refine the given branch (0-7) for every target where it exists.  ``exact`` (here and
    below): the branches are solutions already, which makes checking them cheaper."""
    rows = np.flatnonzero(seeds.valid[:, branch])
    attempts.attempt(rows, seeds.q[rows, branch], exact)


def _try_nearest_branches(attempts, seeds, reference, exact):
    """Refine each target's branch nearest ``reference`` (N, n) (squared joint distance),
    then, for targets still failing, all its other branches at once in order of distance.
    Seeds that exist only thanks to the seed allowances rank after all others."""
    branches, valid = seeds.q, seeds.valid
    distance = np.sum((branches - reference[:, None, :]) ** 2, axis=2)
    distance = np.where(valid, np.where(seeds.preferred, distance, distance + ALLOWANCE_RANK), np.inf)
    order = np.argsort(distance, axis=1)
    ranked_valid = np.take_along_axis(valid, order, axis=1)
    rows = np.flatnonzero(ranked_valid[:, 0])
    attempts.attempt(rows, branches[rows, order[rows, 0]], exact)
    rows, ranks = np.nonzero(~attempts.success[:, None] & ranked_valid[:, 1:])
    if rows.size:
        attempts.attempt(rows, branches[rows, order[rows, ranks + 1]], exact)


def _try_hint_and_restarts(attempts, chain, reference):
    """Seeds for the targets every closed-form seed missed (or all, without a closed form):
    the hint ``reference`` (N, n) itself, then random restarts."""
    rows = np.flatnonzero(~attempts.success)
    if rows.size:
        attempts.attempt(rows, reference[rows])
    # Last resort for targets that were nearly reached (typically within millimetres of a
    # singularity, where every seed so far sat on the wrong part of a near-degenerate
    # family of postures): a few seeds spread over the joint space.
    rows = np.flatnonzero(~attempts.success & (attempts.position_error < RESTART_RADIUS))
    if rows.size:
        seeds = chain.random_configurations(rows.size * RESTARTS, np.random.default_rng(0))
        attempts.attempt(np.repeat(rows, RESTARTS), seeds)
