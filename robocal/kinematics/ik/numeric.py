"""Numerical inverse kinematics for any chain: batched, bounded Levenberg–Marquardt.

Every target has its own iterate and damping.  Iterations run on all still-active targets at
once, chunk by chunk: chunks small enough for the temporaries to stay in cache matter a lot
for speed, and iterating all targets in lockstep (rather than each chunk to the end) lets the
few slow targets share chunks instead of each costing a nearly empty pass per iteration.

The residual is r = [p_target - p; log(R_target R^T)] in the world frame, matching the rows of
the geometric Jacobian J (:meth:`Chain.fk_jacobian`, analytic).  The step is dq = P r with
P = (J^T J + lambda I)^-1 J^T (or J^T (J J^T + lambda I)^-1 for redundant arms).  Evaluating
J and P costs several times a pose, so P is kept while it works: a step that cuts the cost at
least a thousandfold (the error thirtyfold) is followed by another with the same P (a chord
step, costing one pose), and J and P are refreshed only after a weaker or rejected step.  From
the seeds of a closed form this is 15-20 % faster than refreshing them at every step.

Iterates are projected onto the joint limits (see :mod:`.limits`), so a target that needs a
joint beyond its limit stalls there and is reported as a failure.
"""
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...spatial import so3_log
from .limits import JointLimits

# Iterations go on until the residual is within these...
TOL_POSITION = 1e-9  # mm
TOL_ORIENTATION = 1e-10  # rad
# ...but near a singularity rounding can stall them a little short: a target within these
# still counts as reached.
ACCEPT_POSITION = 1e-6  # mm
ACCEPT_ORIENTATION = 1e-8  # rad
MAX_ITERATIONS = 100
# Orientation residuals weigh like position residuals at this lever arm: an industrial arm's
# TCP sits about a metre from its axes, so 1 mrad there is 1 mm.
LEVER_ARM = 1000.0  # mm
# Damping, relative to the mean diagonal of the normal matrix, adapted per target by
# Nielsen's rule from the ratio of actual to predicted cost reduction: start close to
# Gauss–Newton (seeds are usually near), relax it after good steps, stiffen it (faster and
# faster) after rejected ones.
DAMPING_START = 1e-9
DAMPING_MIN = 1e-12
# Keep P for the next step when the cost fell below this fraction (tuned on seeds from the
# closed forms of calibrated robots).
CHORD_CONTRACTION = 1e-3
# A target whose cost has not dropped by 1 % in this many iterations is given up: it needs a
# joint beyond its limit, lies outside the workspace, or sits in a local minimum.
STALL_ITERATIONS = 10
PROGRESS = 0.99
CHUNK = 2048


@dataclass(frozen=True)
class IKResult:
    """Inverse kinematics of N targets.

    q: (N, n) controller joint values (rad, mm), NaN where ``success`` is False.
    success: (N,) bool, the target is reached within the joint limits: to the requested
    tolerance, or where iterations stalled short of it, to 1e-6 mm and 1e-8 rad.
    position_error: (N,) mm and orientation_error: (N,) rad, the residual of the best
    iterate (for failed targets: how far the closest attempt stayed from the target).
    """

    q: np.ndarray
    success: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray


def _numbers(values, message):
    """``values`` as a float array; InputError(``message``) for text or other non-numbers."""
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(message) from None


def as_targets(targets):
    """(N, 4, 4) float array of target poses; a single (4, 4) pose becomes N = 1."""
    out = _numbers(targets, "targets must be 4x4 poses of numbers (mm), shape (N, 4, 4)")
    if out.shape == (4, 4):
        out = out[None]
    if out.ndim != 3 or out.shape[1:] != (4, 4):
        raise InputError(f"targets must be 4x4 poses of shape (N, 4, 4); got shape {out.shape}")
    return out


def as_joints(chain, values, count, what):
    """(count, n) joint array from (n,) or (count, n) values."""
    out = _numbers(values, f"{what} must be joint values, numbers (rad; mm for prismatic joints)")
    if out.ndim == 1:
        out = np.broadcast_to(out, (count, out.size))
    if out.shape != (count, chain.n_joints):
        raise InputError(f"{what} must have shape ({count}, {chain.n_joints}) or "
                         f"({chain.n_joints},); got {np.shape(values)}")
    return np.array(out)


def pose_error(targets, poses):
    """World-frame residuals (position (N, 3) mm, rotation vector (N, 3) rad) from poses to targets."""
    dp = targets[:, :3, 3] - poses[:, :3, 3]
    dw = so3_log(targets[:, :3, :3] @ np.swapaxes(poses[:, :3, :3], 1, 2))
    return dp, dw


_ROW_WEIGHTS = np.array([1.0, 1.0, 1.0, LEVER_ARM, LEVER_ARM, LEVER_ARM])


def _gain_matrix(jac, damping):
    """P (N, n, m) with dq = P r the damped least-squares step, for weighted Jacobians (N, m, n)."""
    m, n = jac.shape[1:]
    jac_t = np.swapaxes(jac, 1, 2)
    # Square or over-determined: (J^T J + lambda I)^-1 J^T, from an n x n system.
    # Redundant: J^T (J J^T + lambda I)^-1 = ((J J^T + lambda I)^-1 J)^T, the damped
    # minimum-norm step, from an m x m system.
    normal = jac_t @ jac if n <= m else jac @ jac_t
    size = normal.shape[-1]
    # (The tiny floor keeps a chain whose Jacobian vanishes entirely solvable.)
    scale = np.trace(normal, axis1=1, axis2=2) / size + 1e-300
    normal += (damping * scale)[:, None, None] * np.eye(size)
    return np.linalg.solve(normal, jac_t) if n <= m else np.swapaxes(np.linalg.solve(normal, jac), 1, 2)


class _State:
    """Iterates, residuals, Jacobians and step matrices of all targets, updated chunk by chunk.

    The residual is stored weighted (orientation rows times LEVER_ARM; position rows only
    when ``position_only``) and so is the Jacobian, so a step is a plain least-squares step.
    """

    def __init__(self, chain, targets, seeds, position_only, tolerances, likely_reached):
        self.chain, self.targets, self.position_only = chain, targets, position_only
        self.tol_position, self.tol_orientation = tolerances
        self.limits = JointLimits(chain)
        count, n = targets.shape[0], chain.n_joints
        m = 3 if position_only else 6
        self.q = self.limits.project(np.array(seeds, dtype=float))
        self.residual = np.empty((count, m))
        self.position_error, self.orientation_error = np.empty(count), np.empty(count)
        self.jac = np.empty((count, m, n))  # at the iterate where fresh is True
        self.gain = np.empty((count, n, m))
        # Seeds that are probably solutions need only their pose; the others will need their
        # Jacobian too, and computing both at once costs little more than the Jacobian.
        self.fresh = np.full(count, not likely_reached)
        for rows in _chunks(np.arange(count)):
            if likely_reached:
                poses = chain.fk(self.q[rows])
            else:
                poses, jac = chain.fk_jacobian(self.q[rows])
                self.jac[rows] = self._weighted(jac)
            (self.residual[rows], self.position_error[rows],
             self.orientation_error[rows]) = self._residuals(rows, poses)
        self.reached = self.converged(self.position_error, self.orientation_error)
        self.cost = np.einsum("ij,ij->i", self.residual, self.residual)
        self.damping = np.full(count, DAMPING_START)
        self.stiffen = np.full(count, 2.0)
        self.stalls = np.zeros(count, dtype=int)

    def _weighted(self, jac):
        return jac[:, :3] if self.position_only else jac * _ROW_WEIGHTS[:, None]

    def _residuals(self, rows, poses):
        """Weighted residuals (A, m) and position / orientation errors of poses of targets rows."""
        dp, dw = pose_error(self.targets[rows], poses)
        position_error, orientation_error = np.linalg.norm(dp, axis=1), np.linalg.norm(dw, axis=1)
        residual = dp if self.position_only else np.concatenate([dp, LEVER_ARM * dw], axis=1)
        return residual, position_error, orientation_error

    def converged(self, position_error, orientation_error):
        return (position_error <= self.tol_position) & (
            self.position_only | (orientation_error <= self.tol_orientation))

    def refresh(self, rows):
        """Jacobians at the current iterates (where stale) and step matrices.

        A joint sitting at a limit that the descent direction J^T r pushes further out is
        left out of the step (its column dropped), so the other joints make up for it instead
        of the step being clipped away.
        """
        stale = rows[~self.fresh[rows]]
        if stale.size:
            self.jac[stale] = self._weighted(self.chain.fk_jacobian(self.q[stale])[1])
            self.fresh[stale] = True
        jac, q = self.jac[rows], self.q[rows]
        descent = np.einsum("ijk,ij->ik", jac, self.residual[rows])
        blocked = ((q <= self.limits.lower) & (descent < 0.0)) | ((q >= self.limits.upper) & (descent > 0.0))
        if blocked.any():
            jac = jac * ~blocked[:, None, :]
        self.gain[rows] = _gain_matrix(jac, self.damping[rows])

    def iterate(self, rows):
        """One step for the targets ``rows``: keep it where it lowers the cost, and decide
        whether the next step may reuse the step matrix."""
        residual = self.residual[rows]
        step = np.einsum("ijk,ik->ij", self.gain[rows], residual)
        trial = self.limits.project(self.q[rows] + step)
        new_residual, position_error, orientation_error = self._residuals(rows, self.chain.fk(trial))
        cost = np.einsum("ij,ij->i", new_residual, new_residual)
        old_cost, damping, stiffen = self.cost[rows], self.damping[rows], self.stiffen[rows]
        better = cost < old_cost
        # Nielsen's damping update, from the gain ratio of actual to predicted reduction; it is
        # meaningful only with the Jacobian taken at the iterate, and kept as is otherwise.
        relax = np.ones(rows.size)
        fresh = np.flatnonzero(self.fresh[rows])
        if fresh.size:
            miss = residual[fresh] - np.einsum("ijk,ik->ij", self.jac[rows[fresh]], step[fresh])
            predicted = old_cost[fresh] - np.einsum("ij,ij->i", miss, miss)
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.clip(np.nan_to_num((old_cost[fresh] - cost[fresh]) / predicted), 0.0, 1.0)
            relax[fresh] = np.maximum(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
        self.damping[rows] = np.where(better, np.maximum(damping * relax, DAMPING_MIN), damping * stiffen)
        self.stiffen[rows] = np.where(better, 2.0, stiffen * 2.0)
        self.stalls[rows] = np.where(cost < PROGRESS * old_cost, 0, self.stalls[rows] + 1)
        take = rows[better]
        self.q[take], self.residual[take], self.cost[take] = trial[better], new_residual[better], cost[better]
        self.position_error[take] = position_error[better]
        self.orientation_error[take] = orientation_error[better]
        self.fresh[take] = False
        self.reached[take] = self.converged(position_error[better], orientation_error[better])
        # A strong step keeps its step matrix (a chord step next); anything else refreshes it.
        keep = better & (cost <= CHORD_CONTRACTION * old_cost)
        redo = rows[~keep & ~self.reached[rows]]
        if redo.size:
            self.refresh(redo)


def _chunks(rows):
    return (rows[start:start + CHUNK] for start in range(0, rows.size, CHUNK))


def refine(chain, targets, seeds, *, position_only=False, max_iterations=MAX_ITERATIONS,
           tol_position=TOL_POSITION, tol_orientation=TOL_ORIENTATION, likely_reached=False):
    """Iterate from ``seeds`` (N, n) towards ``targets`` (N, 4, 4).

    Iterations stop at ``tol_position`` (mm) and ``tol_orientation`` (rad).  ``likely_reached``:
    the seeds are expected to be solutions already (an exact closed form), which makes
    checking them cheaper.  Returns (q, reached, position_error, orientation_error); q is the
    last accepted iterate for every target (within the joint limits), whether or not it
    reached its target (see :class:`IKResult` for what counts as reached).
    """
    state = _State(chain, targets, seeds, position_only,
                   (tol_position, tol_orientation), likely_reached)
    active = np.flatnonzero(~state.reached)
    for rows in _chunks(active):
        state.refresh(rows)
    for _ in range(max_iterations):
        if active.size == 0:
            break
        for rows in _chunks(active):
            state.iterate(rows)
        active = active[~state.reached[active] & (state.stalls[active] < STALL_ITERATIONS)]
    reached = ((state.position_error <= max(tol_position, ACCEPT_POSITION))
               & (position_only | (state.orientation_error <= max(tol_orientation, ACCEPT_ORIENTATION)))
               & state.limits.within(state.q))
    return state.q, reached, state.position_error, state.orientation_error


def solve_numeric(chain, targets, seeds, *, position_only=False, max_iterations=MAX_ITERATIONS,
                  tol_position=TOL_POSITION, tol_orientation=TOL_ORIENTATION) -> IKResult:
    """Numerical IK of any chain (any number of joints) from seeds.

    targets: (N, 4, 4) TCP poses in the world frame; seeds: (N, n) or (n,) starting joint
    values (clipped to the limits).  ``position_only`` ignores the targets' orientation.
    Iterations aim at a residual within ``tol_position`` (mm) and ``tol_orientation`` (rad).
    """
    targets = as_targets(targets)
    seeds = as_joints(chain, seeds, targets.shape[0], "seeds")
    q, reached, position_error, orientation_error = refine(
        chain, targets, seeds, position_only=position_only, max_iterations=max_iterations,
        tol_position=tol_position, tol_orientation=tol_orientation)
    q[~reached] = np.nan
    return IKResult(q, reached, position_error, orientation_error)
