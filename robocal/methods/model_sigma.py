"""The model's own standard deviation σ(x) of the position error, which the 95 % bound
(:mod:`robocal.methods.bound`) starts from, and the joint-space distance it grows with
outside the training domain.

* a parametric calibration: its posterior covariance Σ (issue 23's,
  :mod:`robocal.estimation.prediction`) propagated through the identification Jacobian,
  σ² = trace(J Σ Jᵀ) over the position rows;
* a Kriging error model: its predicted variance;
* the hybrid: both, in quadrature; the network: none (its cross-validated spread is the
  bound's residual scale).
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from ..errors import RobocalWarning
from ..kinematics.program import PointProgram

# At most this many training poses form a posterior (evenly spread; their information
# scaled up to all poses), as robocal.estimation.prediction does.
POSTERIOR_POSES = 2000
# A prismatic joint's travel counts as this many rad per mm in the joint-space distance:
# a metre of travel moves the TCP about as far as a radian of a 1 m arm's shoulder.
PRISMATIC_RAD_PER_MM = 1e-3


def joint_distance(joints, training, revolute):
    """(N,) rad: the joint-space distance from each of ``joints`` (N, n) to the nearest of
    ``training`` (M, n) (rad; mm for prismatic joints).  Revolute joints count by the chord
    of their angle difference (±180 deg is one place), prismatic ones by
    PRISMATIC_RAD_PER_MM."""
    return NearestTraining(training, revolute).distance(joints)


class NearestTraining:
    """:func:`joint_distance` to fixed ``training`` configurations (M, n), its search tree
    built once (for 500 configurations the tree costs more than a query of one)."""

    def __init__(self, training, revolute):
        from scipy.spatial import cKDTree

        self.revolute = np.asarray(revolute, dtype=bool)
        self.tree = cKDTree(self._features(training))

    def _features(self, q):
        q = np.atleast_2d(np.asarray(q, dtype=float))
        # 2 sin(Δ/2) is the chord of (cos, sin): equal to Δ for small Δ.
        parts = [np.cos(q[:, self.revolute]), np.sin(q[:, self.revolute]), q[:, ~self.revolute] * PRISMATIC_RAD_PER_MM]
        return np.hstack(parts)

    def distance(self, joints):
        """(N,) rad from each of ``joints`` (N, n) to the nearest training configuration; NaN
        for a NaN row."""
        joints = np.atleast_2d(np.asarray(joints, dtype=float))
        out = np.full(len(joints), np.nan)
        known = np.all(np.isfinite(joints), axis=1)
        if known.any():
            out[known] = self.tree.query(self._features(joints[known]))[0]
        return out


# ------------------------------------------------------------------ the model's own σ
def calibration_posterior(calibration, joints, positions):
    """(names, (P, P) covariance in mm and rad) of a fitted
    :class:`~robocal.estimation.calibration.KinematicCalibration`'s parameters on its
    training ``joints`` (N, n) rad and ``positions`` (N, 3) mm: the parameters it identified
    and, at nominal, those it held fixed that have a tolerance, as
    :func:`robocal.estimation.prediction.prediction_draws` propagates them."""
    from ..estimation.prediction import _posterior, _posterior_names, _rows

    result = calibration.result_
    q = np.asarray(joints, dtype=float)
    names, prior_std = _posterior_names(calibration, q)
    pick = np.linspace(0, len(q) - 1, min(len(q), POSTERIOR_POSES)).astype(int)
    jac = _rows(calibration.chain_, q[pick], names)
    information = jac.T @ jac * (len(q) / len(pick))
    residual = np.asarray(positions, dtype=float) - calibration.chain_.fk_positions(q)
    noise = float(np.sum(residual ** 2)) / max(3 * len(q) - len(result.names), 1)
    return list(names), _posterior(information, np.asarray(prior_std) * result.tolerance_scale, noise)


def posterior_sigma(chain, joints, names, covariance):
    """(N,) mm: the standard deviation of the TCP position's error norm that the parameter
    posterior ``covariance`` (P, P) of ``names`` gives at ``joints`` (N, n) rad of ``chain``,
    sqrt(trace(J Σ Jᵀ)) over the three position rows; NaN for a NaN configuration."""
    joints = np.atleast_2d(np.asarray(joints, dtype=float))
    out = np.full(len(joints), np.nan)
    known = np.all(np.isfinite(joints), axis=1)
    if known.any():
        jac = chain.identification_jacobian(joints[known], list(names))[:, :3, :]
        out[known] = np.sqrt(np.maximum(np.einsum("nip,pq,niq->n", jac, covariance, jac), 0.0))
    return out


class PointPosterior:
    """:func:`posterior_sigma` of one configuration at a time, prepared once per chain and
    posterior: what a controller asking point by point (``robocal serve``) needs without the
    batch machinery, which costs some 200 us for a batch of one (the identification
    Jacobian's bookkeeping, numpy on (3, 1) arrays).

    The position rows of :meth:`~robocal.kinematics.chain.Chain.identification_jacobian` are
    built from the same tags (a parameter rotating about an axis of a mark moves the TCP by
    that axis crossed with the lever arm from the mark; one translating moves it along the
    axis), the frames at the marks from straight-line Python on floats
    (:class:`~robocal.kinematics.program.PointProgram`): equal to the batch to rounding.
    A joint gain's column is the joint's offset column times the model joint value, as the
    batch has it.  ``sigma(q)`` is None for a chain this does not cover (a compliant chain):
    ask :func:`posterior_sigma`.
    """

    def __init__(self, chain, names, covariance):
        self.covariance = np.asarray(covariance, dtype=float)
        self._ready = False
        names = list(names)
        if getattr(type(chain), "_compiled", None) is None:
            return
        space = chain.parameters
        gains = [j for j, name in enumerate(names) if name in space and space[name].group == "gains"]
        # Columns computed: the other parameters, then each gain's joint offset.
        self._others = [j for j in range(len(names)) if j not in gains]
        self._gains = gains
        self._gain_joints = [space[names[j]].joint - 1 for j in gains]
        self._joint_map = chain.joint_map
        names = [names[j] for j in self._others] + [chain.offset_parameter(k) for k in self._gain_joints]
        ops, tags = chain._compiled
        if any(n not in tags for n in names):
            return
        flat = [(j, mark, motion == "rot", axis, coef)
                for j, name in enumerate(names) for mark, motion, axis, coef in tags[name]]
        column, mark_of, rotational, axis_of, coef = (np.array(v) for v in zip(*flat))
        needed = sorted(set(mark_of.tolist()) - {"W"})
        self._program = PointProgram(ops, chain.joint_map, chain.revolute, marks=needed)
        index = {m: k + 1 for k, m in enumerate(needed)}
        index["W"] = 0
        which = np.array([index[m] for m in mark_of])
        # The world axes at the base origin, as the batch's mark 'W'.
        self._world = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, *chain.base[:3, 3].tolist())
        rot, trans = np.flatnonzero(rotational), np.flatnonzero(~rotational)
        self._rot = (column[rot], which[rot], axis_of[rot], coef[rot, None])
        self._trans = (column[trans], which[trans], axis_of[trans], coef[trans, None])
        # POE axis parameters act at two marks: their columns add up.
        self._repeated = len(set(column.tolist())) < len(column)
        self._size = len(names)
        self._ready = True

    def sigma(self, joints):
        """The standard deviation (mm, a float) at one configuration ``joints`` (n,) rad, as
        :func:`posterior_sigma` gives it for that row; NaN for a NaN configuration; None
        when this chain needs the batch."""
        if not self._ready:
            return None
        q = [float(v) for v in joints]
        if not math.isfinite(sum(q)):
            return math.nan
        pose, frames = self._program.pose_marks(q)
        stack = np.array((self._world,) + frames).reshape(-1, 4, 3)  # (marks, columns x y z t, 3)
        tcp = np.array(pose[9:])
        jac = np.zeros((self._size, 3))
        place = np.add.at if self._repeated else _assign
        column, which, axis, coef = self._rot
        if len(column):
            axes = (stack[which, axis] * coef).T
            lever = (tcp - stack[which, 3]).T
            # axis × lever, written out: np.cross costs 15 us on arrays this small.
            (ux, uy, uz), (vx, vy, vz) = axes, lever
            place(jac, column, np.stack([uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx], axis=1))
        column, which, axis, coef = self._trans
        if len(column):
            place(jac, column, stack[which, axis] * coef)
        if self._gains:
            # Gain k moves the TCP as joint k's offset does, times the model joint value.
            model = self._joint_map @ np.asarray(q)
            out = np.empty_like(jac)
            out[self._others] = jac[:len(self._others)]
            out[self._gains] = jac[len(self._others):] * model[self._gain_joints, None]
            jac = out
        # trace(J Σ Jᵀ) over the position rows (an einsum of one row costs 16 us, this 3 us).
        return math.sqrt(max(float(np.sum((jac.T @ self.covariance) * jac.T)), 0.0))


def _assign(array, index, values):
    array[index] = values


def kinematic_calibration(method):
    """The method's own parametric calibration (kinematic; the hybrid's and a kinematic-based
    network's base are not kept by their fits), or None."""
    calibration = getattr(method, "calibration_", None)
    if calibration is not None and hasattr(calibration.result_, "orientation_rms_deg"):
        return calibration
    return None


def base_calibration(method, chain, observations):
    """The parametric calibration under ``method``'s prediction, fitted here when the method
    did not keep it (the hybrid's base), or None for a method without one."""
    own = kinematic_calibration(method)
    if own is not None:
        return own
    if method.name == "hybrid" or (method.name == "ann" and getattr(method, "base_model", None) == "kinematic"):
        from .kinematic import KinematicMethod

        base = KinematicMethod(**{s.name: getattr(method, s.name) for s in KinematicMethod.settings})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RobocalWarning)
            base._fit(chain, observations, None)
        return base.calibration_
    return None


def model_sigma(method, joints, posterior):
    """(N,) mm: the model's own standard deviation at ``joints``: the parametric posterior's
    (``posterior``: (names, covariance) or None) and the error model's, combined in
    quadrature; zeros for a method with neither."""
    joints = np.atleast_2d(np.asarray(joints, dtype=float))
    variance = np.zeros(len(joints))
    if posterior is not None:
        variance = variance + posterior_sigma(chain_of(method), joints, *posterior) ** 2
    own = method.uncertainty(joints) if method.compensator_.error_model is not None else None
    if own is not None:
        variance = variance + np.asarray(own, dtype=float) ** 2
    return np.sqrt(variance)


def chain_of(method):
    """The chain a method predicts with (the chosen model's for a domain fallback)."""
    compensator = method.compensator_
    return getattr(compensator, "inside", compensator).chain
