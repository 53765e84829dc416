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
from scipy.linalg.lapack import dgesv as _gesv

from ...errors import InputError
from ..program import PointProgram
from .limits import nearest_equivalent_one, periodic_joints
from .numeric import LEVER_ARM, TOL_ORIENTATION, TOL_POSITION
from .one import Degenerate
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
        self._periodic = periodic_joints(chain)
        n = chain.n_joints
        self._n = n
        self._zeros = [0.0] * n
        # The limits as floats: the Newton iterates' check, and the final whole turns.
        self._lower, self._upper = chain.lower.tolist(), chain.upper.tolist()
        self._periodic_f = self._periodic.tolist()
        self._fast = (self.solver is not None and n == 6 and self.program.pose_jacobian is not None)

    def solve(self, target, hint=None):
        target = np.asarray(target, dtype=float)
        if target.shape != (4, 4):
            raise InputError(f"a target must be one (4, 4) pose, got shape {target.shape}")
        reference = self._reference(hint)
        q = self._first_attempt(target, reference) if self._fast and reference is not None else None
        if q is None:
            result = solve_ik(self.chain, target[None], hint=hint, nominal=self.nominal)
            return result.q[0], bool(result.success[0])
        q = nearest_equivalent_one(q, reference, self._lower, self._upper, self._periodic_f)[0]
        return np.array(q), True

    def _reference(self, hint):
        """The hint as n floats (zeros without one); None when it is not n finite numbers
        (``solve_ik`` then takes it, and refuses it or does what the batch does)."""
        if hint is None:
            return self._zeros
        if type(hint) is np.ndarray and hint.shape == (self._n,) and hint.dtype == np.float64:
            values = hint.tolist()
        else:
            try:
                array = np.asarray(hint, dtype=float)
            except (TypeError, ValueError):
                return None
            if array.shape not in ((self._n,), (1, self._n)):  # as solve_ik takes a hint
                return None
            values = array.reshape(-1).tolist()
        return values if math.isfinite(sum(values)) else None

    def _first_attempt(self, target, reference):
        """The nearest closed-form branch refined by Newton steps, or None when that does
        not simply work."""
        try:
            found = self.solver.nearest_one(target, reference, not self.exact, ALLOWANCE_RANK)
        except Degenerate:
            return None
        return None if found is None else self._newton(target, found[0])

    def _newton(self, target, seed):
        """Newton's method on the 6 x 6 pose residual from ``seed`` (6 floats); the joints
        (a list of 6 floats) when it converges to TOL_POSITION / TOL_ORIENTATION, else None.

        Levenberg–Marquardt from the same seed (the batch) takes these very steps as long as
        each one lowers the cost and stays within the joint limits (its damping is 1e-9 of
        the normal matrix); where one does not, the batch damps, projects or gives the seed
        up, and so this returns None and leaves the target to the batch.
        """
        rows = target.tolist()  # floats: numpy scalars would slow every operation below
        goal = (rows[0][3], rows[1][3], rows[2][3])
        rt = (rows[0][:3], rows[1][:3], rows[2][:3])
        lower, upper = self._lower, self._upper
        q = seed
        if not _within(q, lower, upper):
            return None
        pose_jacobian = self.program.pose_jacobian
        cost = math.inf
        for _ in range(NEWTON_STEPS + 1):
            pose, columns = pose_jacobian(q)
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
            # Square: the rows' weights (orientation times the lever arm) cancel.  LAPACK's
            # gesv directly: numpy.linalg.solve's checks and wrapping cost twice as much.
            _, _, step, info = _gesv(np.array(columns).reshape(6, 6).T, dp + dw,
                                     overwrite_a=1, overwrite_b=1)
            if info != 0:
                return None
            q = [a + b for a, b in zip(q, step.tolist())]
            if not _within(q, lower, upper):
                return None
        return None


def _within(q, lower, upper):
    """Whether every joint of q is within its limits (sequences of floats)."""
    for value, low, high in zip(q, lower, upper):
        if not low <= value <= high:
            return False
    return True


def _residual(goal, rt, pose):
    """(dp, dw) lists: target position minus the pose's, and the rotation vector of
    R_target R^T; None beyond MAX_ROTATION."""
    xx, xy, xz, yx, yy, yz, zx, zy, zz, tx, ty, tz = pose
    dp = [goal[0] - tx, goal[1] - ty, goal[2] - tz]
    # M = R_target R^T: M[i][j] = sum_k R_target[i][k] R[j][k], R's columns x, y, z; only the
    # trace and the antisymmetric part are needed.
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = rt
    m00 = a0 * xx + a1 * yx + a2 * zx
    m11 = b0 * xy + b1 * yy + b2 * zy
    m22 = c0 * xz + c1 * yz + c2 * zz
    vx = 0.5 * ((c0 * xy + c1 * yy + c2 * zy) - (b0 * xz + b1 * yz + b2 * zz))
    vy = 0.5 * ((a0 * xz + a1 * yz + a2 * zz) - (c0 * xx + c1 * yx + c2 * zx))
    vz = 0.5 * ((b0 * xx + b1 * yx + b2 * zx) - (a0 * xy + a1 * yy + a2 * zy))
    sine = math.sqrt(vx * vx + vy * vy + vz * vz)
    cosine = 0.5 * (m00 + m11 + m22 - 1.0)
    angle = math.atan2(sine, cosine)
    if angle > MAX_ROTATION:
        return None
    scale = angle / sine if sine > 1e-12 else 1.0 + angle * angle / 6.0
    return dp, [vx * scale, vy * scale, vz * scale]
