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

import warnings

import numpy as np

from ..errors import RobocalWarning

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
    from scipy.spatial import cKDTree

    def features(q):
        q = np.atleast_2d(np.asarray(q, dtype=float))
        revolute_ = np.asarray(revolute, dtype=bool)
        # 2 sin(Δ/2) is the chord of (cos, sin): equal to Δ for small Δ.
        parts = [np.cos(q[:, revolute_]), np.sin(q[:, revolute_]), q[:, ~revolute_] * PRISMATIC_RAD_PER_MM]
        return np.hstack(parts)

    joints = np.atleast_2d(np.asarray(joints, dtype=float))
    out = np.full(len(joints), np.nan)
    known = np.all(np.isfinite(joints), axis=1)
    if known.any():
        out[known] = cKDTree(features(training)).query(features(joints[known]))[0]
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
