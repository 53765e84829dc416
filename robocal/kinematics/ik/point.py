"""Inverse kinematics of one target at a time, for a controller that asks point by point.

:func:`~.solve.solve_ik` is built for batches: for one target its fixed cost (arrays of one
row through some hundred numpy calls, the Levenberg–Marquardt bookkeeping) is most of the
time.  A :class:`PointSolver` is built once per chain and does for one target what
``solve_ik`` does first: the closed-form branch nearest the hint (of the chain, or of its
``nominal`` chain when the chain is a calibrated one), then Newton steps on the chain itself
in plain Python floats (:class:`~robocal.kinematics.program.PointProgram`).  Whenever that
first attempt is not a clean success — no closed form, the branch missed, an iterate beyond
a joint limit, slow convergence — the target goes to ``solve_ik`` as a batch of one, so the
answer is always the batch's: the same branch, converged to the same tolerances.
"""
import math

import numpy as np

from ...errors import InputError
from ..program import PointProgram
from .limits import JointLimits, nearest_equivalent, periodic_joints
from .numeric import LEVER_ARM, TOL_ORIENTATION, TOL_POSITION, as_joints
from .solve import ALLOWANCE_RANK, _seed_solver, solve_ik

# Newton steps from a closed-form seed of the nominal robot: a calibrated model 1 mm / 0.1 deg
# away from it converges in 2 or 3; a target that needs more goes to the batch solver.
NEWTON_STEPS = 8
# Beyond this rotation (rad) between an iterate and its target the small-angle-safe rotation
# vector below is not used (the batch solver takes the target).
MAX_ROTATION = 1.5


class PointSolver:
    """``solve(target, hint)`` for one (4, 4) TCP target in the world frame (mm) and an
    optional (n,) posture hint (rad, mm): (q (n,), success), as ``solve_ik`` of that target
    alone returns them (q NaN where not reached)."""

    def __init__(self, chain, nominal=None):
        self.chain, self.nominal = chain, nominal
        self.program = PointProgram.of(chain)
        self.solver, self.exact = _seed_solver(chain, nominal)
        self._limits = JointLimits(chain)
        self._periodic = periodic_joints(chain)
        self._zeros = np.zeros(chain.n_joints)

    def solve(self, target, hint=None):
        target = np.asarray(target, dtype=float)
        if target.shape != (4, 4):
            raise InputError(f"a target must be one (4, 4) pose, got shape {target.shape}")
        reference = self._zeros if hint is None else as_joints(self.chain, hint, 1, "hint")[0]
        q = self._first_attempt(target, reference) if self._fast else None
        if q is None:
            result = solve_ik(self.chain, target[None], hint=None if hint is None else reference[None],
                              nominal=self.nominal)
            return result.q[0], bool(result.success[0])
        q = nearest_equivalent(q, reference, self.chain.lower, self.chain.upper, self._periodic)[0]
        return q, True

    @property
    def _fast(self):
        return (self.solver is not None and self.chain.n_joints == 6
                and self.program.pose_jacobian is not None)

    def _first_attempt(self, target, reference):
        """The nearest closed-form branch refined by Newton steps, or None when that does
        not simply work."""
        if not np.all(np.isfinite(target)):
            return None
        found = (self.solver.solve(target[None], reference) if self.exact
                 else self.solver.seeds(target[None], reference))
        branches, valid = found[0][0], found[1][0]
        if not valid.any():
            return None
        distance = np.sum((branches - reference) ** 2, axis=1)
        if not self.exact:
            distance = np.where(found[2][0], distance, distance + ALLOWANCE_RANK)
        distance = np.where(valid, distance, np.inf)
        seed = branches[int(np.argmin(distance))]
        return self._newton(target, seed)

    def _newton(self, target, seed):
        """Newton's method on the 6 x 6 pose residual from ``seed``; the joints (6,) when it
        converges to TOL_POSITION / TOL_ORIENTATION, else None.

        Levenberg–Marquardt from the same seed (the batch) takes these very steps as long as
        each one lowers the cost and stays within the joint limits (its damping is 1e-9 of
        the normal matrix); where one does not, the batch damps, projects or gives the seed
        up, and so this returns None and leaves the target to the batch.
        """
        goal = target[:3, 3].tolist()
        rt = target[:3, :3].tolist()
        lower, upper = self._limits.lower, self._limits.upper
        if not (np.all(seed >= lower) and np.all(seed <= upper)):
            return None
        q = seed
        pose_jacobian = self.program.pose_jacobian
        cost = math.inf
        for _ in range(NEWTON_STEPS + 1):
            pose, rows = pose_jacobian(q.tolist())
            residual = _residual(goal, rt, pose)
            if residual is None:
                return None
            dp, dw = residual
            position = dp[0] ** 2 + dp[1] ** 2 + dp[2] ** 2
            orientation = dw[0] ** 2 + dw[1] ** 2 + dw[2] ** 2
            if math.sqrt(position) <= TOL_POSITION and math.sqrt(orientation) <= TOL_ORIENTATION:
                return q
            step_cost = position + LEVER_ARM ** 2 * orientation
            if step_cost >= cost:
                return None
            cost = step_cost
            try:
                # Square: the rows' weights (orientation times the lever arm) cancel.
                q = q + np.linalg.solve(rows, dp + dw)
            except np.linalg.LinAlgError:
                return None
            if not (np.all(q >= lower) and np.all(q <= upper)):
                return None
        return None


def _residual(goal, rt, pose):
    """(dp, dw) lists: target position minus the pose's, and the rotation vector of
    R_target R^T; None beyond MAX_ROTATION."""
    xx, xy, xz, yx, yy, yz, zx, zy, zz, tx, ty, tz = pose
    dp = [goal[0] - tx, goal[1] - ty, goal[2] - tz]
    # M = R_target R^T: M[i][j] = sum_k R_target[i][k] R[j][k], R's columns x, y, z.
    r0, r1, r2 = rt
    m = [[r[0] * c0 + r[1] * c1 + r[2] * c2 for c0, c1, c2 in ((xx, yx, zx), (xy, yy, zy), (xz, yz, zz))]
         for r in (r0, r1, r2)]
    vx, vy, vz = 0.5 * (m[2][1] - m[1][2]), 0.5 * (m[0][2] - m[2][0]), 0.5 * (m[1][0] - m[0][1])
    sine = math.sqrt(vx * vx + vy * vy + vz * vz)
    cosine = 0.5 * (m[0][0] + m[1][1] + m[2][2] - 1.0)
    angle = math.atan2(sine, cosine)
    if angle > MAX_ROTATION:
        return None
    scale = angle / sine if sine > 1e-12 else 1.0 + angle * angle / 6.0
    return dp, [vx * scale, vy * scale, vz * scale]
