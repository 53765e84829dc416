"""Levenberg–Marquardt over named parameters of a chain, stepping on the chain itself.

Each iteration takes the analytic identification Jacobian where the model is and applies the
step with :meth:`Chain.perturbed`, so the linearisation is always exact to first order.
Residuals are measured minus model, weighted per row; an optional per-pose weight function
turns it into iteratively reweighted least squares for robust losses.
"""
import numpy as np

from ..spatial import so3_log


def residual(chain, joints, positions, rotations=None):
    """Measured minus model: (N, 3), or (N, 6) with the world-frame rotation vector."""
    if rotations is None:
        return positions - chain.fk_positions(joints)
    pose = chain.fk(joints)
    dw = so3_log(rotations @ np.swapaxes(pose[:, :3, :3], 1, 2))
    return np.hstack([positions - pose[:, :3, 3], dw])


def levenberg_marquardt(chain, joints, positions, names, *, rotations=None, weights=None,
                        pose_weights=None, max_iterations=50, tolerance=1e-12):
    """Fit the named parameters.  weights: (N, 3 or 6) row weights (1/sigma);
    pose_weights: callable (weighted residual (N, k)) -> (N,) robust weights, or None.

    Returns (chain, iterations, converged, final pose weights).
    """
    names = list(names)
    rows = 6 if rotations is not None else 3
    weights = np.ones((len(joints), rows)) if weights is None else weights
    robust_of = pose_weights or (lambda r: np.ones(len(r)))
    current = residual(chain, joints, positions, rotations) * weights
    robust = robust_of(current)
    cost = np.sum(robust[:, None] * current**2)
    damping = 1e-4
    converged = False
    iteration = 0
    for iteration in range(1, max_iterations + 1):
        jac = chain.identification_jacobian(joints, names)[:, :rows, :] * weights[:, :, None]
        root = np.sqrt(robust)[:, None, None]
        a = (jac * root).reshape(-1, len(names))
        b = (current * root[:, :, 0]).reshape(-1)
        scale = np.linalg.norm(a, axis=0)
        scale[scale == 0] = 1.0
        a_s = a / scale
        normal, gradient = a_s.T @ a_s, a_s.T @ b
        # First-order optimality: the residual is orthogonal to every (scaled) column.
        if np.max(np.abs(gradient)) <= 1e-12 * max(np.linalg.norm(b), 1e-300):
            converged = True
            break
        diag = np.diag(np.diag(normal))
        while True:
            step_s = np.linalg.solve(normal + damping * diag, gradient)
            step = step_s / scale
            candidate = chain.perturbed(names, step)
            new = residual(candidate, joints, positions, rotations) * weights
            new_cost = np.sum(robust[:, None] * new**2)
            # Give up raising the damping once the step is too small to matter.
            if new_cost <= cost or damping > 1e10 or np.linalg.norm(step_s) <= 1e-12 * max(np.linalg.norm(b), 1e-300):
                break
            damping *= 10.0
        if new_cost > cost:
            converged = True  # no step lowers the cost: a minimum to rounding
            break
        improvement = cost - new_cost
        chain, current = candidate, new
        damping = max(damping / 10.0, 1e-12)
        robust = robust_of(current)
        cost = np.sum(robust[:, None] * current**2)
        # Converged when the step no longer changes the cost beyond rounding, or the scaled
        # step is negligible (zero-residual problems never stop improving).
        if (improvement <= tolerance * max(new_cost, 1e-300)
                or np.linalg.norm(step * scale) <= 1e-10 * max(np.linalg.norm(b), 1e-300)
                or new_cost <= 1e-20 * len(b)):
            converged = True
            break
    return chain, iteration, converged, robust


def damped_least_squares(chain, names, linearise, residual, *, max_iterations=50, tolerance=1e-12):
    """Minimise |r|^2 over deviations of the named parameters, for any residual of the chain.

    linearise(chain) -> (r (m,), J (m, P)) with r(chain.perturbed(names, x)) ~ r + J x;
    residual(chain) -> r alone (trial steps need only the cost).  Same damping, column
    scaling and stopping rules as :func:`levenberg_marquardt`, which specialises them to
    measured positions with robust weights.  Returns (chain, iterations, converged).
    """
    names = list(names)
    current, jac = linearise(chain)
    cost = float(current @ current)
    damping = 1e-4
    converged = False
    iteration = 0
    for iteration in range(1, max_iterations + 1):
        if iteration > 1:
            current, jac = linearise(chain)
        size = max(np.linalg.norm(current), 1e-300)
        scale = np.linalg.norm(jac, axis=0)
        scale[scale == 0] = 1.0
        a_s = jac / scale
        normal, gradient = a_s.T @ a_s, -(a_s.T @ current)
        if np.max(np.abs(gradient)) <= 1e-12 * size:
            converged = True
            break
        diag = np.diag(np.diag(normal))
        while True:
            step_s = np.linalg.solve(normal + damping * diag, gradient)
            step = step_s / scale
            candidate = chain.perturbed(names, step)
            new = residual(candidate)
            new_cost = float(new @ new)
            if new_cost <= cost or damping > 1e10 or np.linalg.norm(step_s) <= 1e-12 * size:
                break
            damping *= 10.0
        if new_cost > cost:
            converged = True
            break
        improvement = cost - new_cost
        chain, cost = candidate, new_cost
        damping = max(damping / 10.0, 1e-12)
        if (improvement <= tolerance * max(new_cost, 1e-300)
                or np.linalg.norm(step * scale) <= 1e-10 * size
                or new_cost <= 1e-20 * len(new)):
            converged = True
            break
    return chain, iteration, converged
