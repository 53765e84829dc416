"""Levenberg–Marquardt over named parameters of a chain, stepping on the chain itself.

Each iteration takes the analytic identification Jacobian where the model is and applies the
step with :meth:`Chain.perturbed`, so the linearisation is always exact to first order.
Residuals are measured minus model, weighted per row; an optional per-pose weight function
turns it into iteratively reweighted least squares for robust losses.

Large data (more than BLOCK_POSES poses) never hold the whole Jacobian: each linearisation
forms it over blocks of poses and accumulates the normal equations JᵀJ and Jᵀr
(:class:`NormalEquations`), and whatever needs more than the normal equations (the
identifiability analysis, standard errors) takes the R factor of a QR decomposition
accumulated the same way (:func:`blocked_r_factor`): RᵀR = JᵀJ, the same column norms, the
same QR of the columns and the same singular values as J itself.  Only the per-pose residual,
(N, 3) or (N, 6), is held whole.
"""
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from ..spatial import so3_log

# Tracker data fit a kinematic model almost linearly: starting nearly undamped (Gauss–Newton)
# reaches the optimum in fewer steps; the damping still rises when a step fails.
KINEMATIC_DAMPING = 1e-7
# A prior's noise is read from the linearised residual of at most this many poses, evenly
# spread (all of them below it, whether the Jacobian is held whole or in blocks).
NOISE_POSES = 2000
# Above this many poses the identification Jacobian is formed BLOCK_POSES poses at a time and
# reduced to normal equations or an R factor (see the module docstring).  A block of 20,000
# poses and 40 parameters is 38 MB of Jacobian; measured on 1,000,000 simulated KR 150-2
# poses (full parameters, one core), blocks of 5,000 to 50,000 took the same time.
BLOCK_POSES = 20_000


@dataclass(frozen=True)
class NormalEquations:
    """The normal equations of a linearised least-squares problem r + J x: ``normal`` JᵀJ
    (P, P) and ``projected`` Jᵀr (P,), accumulated over blocks of rows; ``sample``: (r, J) of
    some of the rows (at most NOISE_POSES poses, evenly spread), from which a prior's noise is
    read, or None."""

    normal: np.ndarray
    projected: np.ndarray
    sample: tuple | None = None


def held_in_blocks(count):
    """Whether a Jacobian of ``count`` poses is formed in blocks rather than held whole."""
    return count > BLOCK_POSES


def blocks(count, size=None):
    """Slices of ``size`` (BLOCK_POSES) consecutive poses covering ``count`` poses."""
    size = BLOCK_POSES if size is None else int(size)
    return [slice(start, min(count, start + size)) for start in range(0, count, size)]


def blocked_r_factor(rows_of, count, columns, size=None):
    """R (P, P) of the QR decomposition of the matrix whose rows for the poses of a block
    ``rows_of(block)`` gives (k, P), over ``count`` poses: each block is stacked under the R
    of the blocks before it and decomposed again (a tall-skinny QR)."""
    R = np.zeros((0, columns))
    for block in blocks(count, size):
        R = np.linalg.qr(np.vstack([R, rows_of(block)]), mode="r")
    return R


def blocked_normal_equations(rows_of, r, count, size=None):
    """:class:`NormalEquations` of the residual r (count, k) and the Jacobian whose rows for
    the poses of a block ``rows_of(block)`` gives (k per pose, P)."""
    normal, projected = 0.0, 0.0
    for block in blocks(count, size):
        jac = rows_of(block)
        normal = normal + jac.T @ jac
        projected = projected + jac.T @ r[block].reshape(-1)
    return NormalEquations(normal, projected)


@dataclass(frozen=True)
class Prior:
    """A Gaussian prior on the deviations of named parameters from a reference model: the
    fit minimises |r|² + k² Σ (x_i / sigma_i)², maximum a posteriori for a residual whose
    rows have noise k (estimated from the data, below).

    sigma: {name: one standard deviation, internal units}; a name it lacks has no prior
    (flat).  deviation(chain, names) -> (P,) the named parameters' deviations of ``chain``
    from the reference (the prior's centre).
    """

    sigma: dict
    deviation: Callable

    def sigmas(self, names):
        """(P,) the prior standard deviations of ``names`` (inf: no prior)."""
        return np.array([self.sigma.get(n, np.inf) for n in names], dtype=float)

    def rows(self, chain, names):
        """((P,) deviations in standard deviations, (P,) 1/sigma): the prior's residual rows
        before the noise scale k, and their derivative (0 where there is no prior)."""
        inverse = 1.0 / self.sigmas(names)
        return self.deviation(chain, list(names)) * inverse, inverse


def noise_variance(residual, columns):
    """The residual rows' noise variance: their scatter (``residual``, (m,): the rows a step of
    the linearised model leaves) from their median absolute value (1.4826 x median is sigma
    for Gaussian rows, and a few gross outliers do not inflate it), corrected for the
    ``columns`` degrees of freedom the fit takes.  Estimated at every linearisation, it weighs
    the prior against the data as the data's own scatter says, so data that fit to their
    noise need no stated sigma to be weighed right."""
    rows = len(residual)
    if rows == 0:
        return 0.0
    sigma = 1.4826 * float(np.median(np.abs(residual)))
    return sigma * sigma * rows / max(rows - columns, 1)


# The common scale of the tolerances (how far this robot lies from its drawing, in
# tolerances) is estimated from the data within these bounds, by this many fixed-point steps
# of the evidence at each linearisation (see tolerance_scale_estimate).  The tolerances are
# its upper bound: a robot may be better than its tolerances say, and its unseen parameters
# are then held closer to nominal, but never held looser than a tolerance (the MUKCa Pandas'
# few wrist deviations far beyond theirs would otherwise loosen every parameter six-fold, and
# let the poorly seen last axis slide 28 mm).
SCALE_BOUNDS = (0.05, 1.0)
SCALE_STEPS = 10
# The noise and the scale count as settled when a linearisation changes them by less than this.
SETTLED = 0.01


def tolerance_scale_estimate(normal, gradient, column_scale, noise, deviation, inverse, start=1.0):
    """The scale t of the tolerances that the linearised data support: MacKay's evidence
    fixed point t² = Σ z_i² / Σ (1 - posterior_i / prior_i), over the parameters with a
    tolerance, z_i their deviations in tolerances at the maximum a posteriori step of scale
    t, and the sum below the number of parameters the data pin.  A robot 5 times better than
    its tolerances has its unseen parameters expected 5 times closer to nominal.

    normal, gradient: the column-scaled data normal matrix and -Jᵀr; column_scale: (P,);
    noise: the rows' noise variance; deviation: (P,) deviations in tolerances (x / sigma);
    inverse: (P,) 1 / sigma (0: no tolerance).  Returns t within SCALE_BOUNDS.
    """
    held = inverse > 0
    if not np.any(held) or noise <= 0:
        return start
    scale = start
    for _ in range(SCALE_STEPS):
        weight = inverse / (scale * column_scale)
        cov = _inverse(normal + np.diag(noise * weight ** 2))
        step = cov @ (gradient - noise * weight * deviation / scale)
        z = deviation + step * inverse / column_scale
        posterior = noise * np.diag(cov) * weight ** 2  # posterior over prior variance
        pinned = float(np.sum(1.0 - posterior[held]))
        new = float(np.clip(np.sqrt(np.sum(z[held] ** 2) / max(pinned, 1e-9)), *SCALE_BOUNDS))
        if abs(new - scale) <= 1e-3 * scale:
            return new
        scale = new
    return scale


def _inverse(matrix):
    """The inverse of a symmetric positive (semi-)definite matrix: LU where it is regular (a
    fifth of an SVD's time at these sizes), the pseudo-inverse where it is not."""
    try:
        return np.linalg.inv(matrix)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(matrix, hermitian=True)


@dataclass(frozen=True)
class Fit:
    """How a least-squares fit ended.

    chain: the fitted chain; iterations: steps taken; converged: whether a stopping rule was
    met (rather than ``max_iterations``); pose_weights: (N,) robust weights of the poses at
    the fit (:func:`levenberg_marquardt`; None from :func:`damped_least_squares`).
    """

    chain: object
    iterations: int
    converged: bool
    pose_weights: np.ndarray | None = None
    # With a prior: the scale of the tolerances the data support (tolerance_scale_estimate).
    prior_scale: float = 1.0


def residual(chain, joints, positions, rotations=None):
    """Measured minus model: (N, 3), or (N, 6) with the world-frame rotation vector (full
    poses computed BLOCK_POSES at a time)."""
    if rotations is None:
        return positions - chain.fk_positions(joints)
    out = np.empty((len(joints), 6))
    for block in blocks(len(joints)):
        pose = chain.fk(joints[block])
        out[block, 3:] = so3_log(rotations[block] @ np.swapaxes(pose[:, :3, :3], 1, 2))
        out[block, :3] = positions[block] - pose[:, :3, 3]
    return out


def levenberg_marquardt(chain, joints, positions, names, *, rotations=None, weights=None,
                        pose_weights=None, max_iterations=50, tolerance=1e-12, prior=None):
    """Fit the named parameters to measured positions (and rotations).  weights: (N, 3 or 6)
    row weights (1/sigma); pose_weights: callable (weighted residual (N, k)) -> (N,) robust
    weights, re-evaluated at every linearisation (iteratively reweighted least squares), or None.
    Above BLOCK_POSES poses the Jacobian is formed that many poses at a time and reduced to
    normal equations; the steps are those of the whole Jacobian.

    ``prior``: a :class:`Prior` (maximum a posteriori), or None.

    Returns a :class:`Fit` with the final pose weights (all 1 without ``pose_weights``).
    """
    names = list(names)
    rows = 6 if rotations is not None else 3
    weights = np.ones((len(joints), rows)) if weights is None else weights
    robust_of = pose_weights or (lambda r: np.ones(len(r)))
    state = {}

    def weighted(c):
        return residual(c, joints, positions, rotations) * weights

    def linearise(c):
        r = weighted(c)
        state["robust"] = robust_of(r)
        root = np.sqrt(state["robust"])
        scale = weights * root[:, None]

        def jacobian_rows(poses):
            # Residual = measured - model, so its derivative is minus the identification Jacobian.
            jac = c.identification_jacobian(joints[poses], names)[:, :rows, :] * scale[poses][:, :, None]
            return -jac.reshape(-1, len(names))

        r = r * root[:, None]
        if not held_in_blocks(len(joints)):
            return r.reshape(-1), jacobian_rows(slice(None))
        equations = blocked_normal_equations(jacobian_rows, r, len(joints))
        if prior is None:
            return r.reshape(-1), equations
        poses = np.unique(np.linspace(0, len(joints) - 1, min(len(joints), NOISE_POSES)).astype(int))
        return r.reshape(-1), NormalEquations(equations.normal, equations.projected,
                                              (r[poses].reshape(-1), jacobian_rows(poses)))

    def weighted_only(c):
        return (weighted(c) * np.sqrt(state["robust"])[:, None]).reshape(-1)

    fit = damped_least_squares(chain, names, linearise, weighted_only, max_iterations=max_iterations,
                               tolerance=tolerance, damping=KINEMATIC_DAMPING, prior=prior)
    robust = robust_of(weighted(fit.chain)) if pose_weights else state["robust"]
    return Fit(fit.chain, fit.iterations, fit.converged, robust, fit.prior_scale)


def damped_least_squares(chain, names, linearise, residual, *, max_iterations=50, tolerance=1e-12, damping=1e-4,
                         prior=None):
    """Minimise |r|^2 over deviations of the named parameters, for any residual of the chain.

    linearise(chain) -> (r (m,), J (m, P)) with r(chain.perturbed(names, x)) ~ r + J x, or
    (r, :class:`NormalEquations` of r and J) for data too large to hold J;
    residual(chain) -> r alone (trial steps need only the cost).  Levenberg–Marquardt
    damping on column-scaled normal equations; stops when a step lowers the cost by less than
    ``tolerance`` of it, the step or the cost is negligible, or no step lowers the cost.
    ``linearise`` may reweight the residual (robust losses): the cost is taken afresh at
    every linearisation.  ``damping``: the starting Levenberg–Marquardt damping, relative to
    the diagonal of the column-scaled normal matrix.  ``prior``: a :class:`Prior`, whose rows
    are weighed by the noise the linearised data leave (:func:`noise_variance`), re-estimated
    at every linearisation; None for plain least squares.  Returns a :class:`Fit`.
    """
    names = list(names)
    count = len(names)

    # The deviations from the prior's centre are read from the chain once; the steps then add
    # to them exactly as Chain.perturbed adds to the parameters (to first order for POE axis
    # shifts, whose exact values the caller reads from the fitted chain).
    if prior is not None:
        offset, inverse_sigma = prior.rows(chain, names)
        offset = offset / np.where(inverse_sigma > 0, inverse_sigma, 1.0)

    def prior_cost(x, noise, tau):
        z = x * inverse_sigma / tau
        return noise * float(z @ z)

    noise, tau, settled = 0.0, 1.0, False

    converged = False
    iteration = 0
    for iteration in range(1, max_iterations + 1):
        current, jac = linearise(chain)
        cost = float(current @ current)
        if isinstance(jac, NormalEquations):
            scale = np.sqrt(np.diag(jac.normal))
            scale[scale == 0] = 1.0
            normal, gradient = jac.normal / np.outer(scale, scale), -(jac.projected / scale)
        else:
            scale = np.linalg.norm(jac, axis=0)
            scale[scale == 0] = 1.0
            a_s = jac / scale
            normal, gradient = a_s.T @ a_s, -(a_s.T @ current)
        if prior is not None:
            if not settled:
                # The noise and the tolerances' scale are re-estimated until they hold still
                # (SETTLED), then kept, so that the last steps minimise one objective and stop
                # as a plain fit does.  The noise is that of the rows the linearised model
                # cannot explain (the residual itself would read the unfitted error as noise
                # and hold the first steps at nominal, where the scale then collapses).
                was = (noise, tau)
                step_linear = _inverse(normal) @ gradient
                if not isinstance(jac, NormalEquations):
                    noise = noise_variance(current + a_s @ step_linear, count)
                elif jac.sample is not None:
                    noise = noise_variance(jac.sample[0] + (jac.sample[1] / scale) @ step_linear, count)
                else:
                    noise = max(cost - float(gradient @ step_linear), 0.0) / max(len(current) - count, 1)
                tau = tolerance_scale_estimate(normal, gradient, scale, noise, offset * inverse_sigma,
                                               inverse_sigma, tau)
                settled = (iteration > 1 and abs(noise - was[0]) <= SETTLED * max(was[0], 1e-300)
                           and abs(tau - was[1]) <= SETTLED * was[1])
            deviation, inverse = offset * inverse_sigma / tau, inverse_sigma / tau
            normal = normal + np.diag(noise * (inverse / scale) ** 2)
            gradient = gradient - noise * deviation * inverse / scale
            cost += noise * float(deviation @ deviation)
        size = max(np.sqrt(cost), 1e-300)
        if np.max(np.abs(gradient)) <= 1e-12 * size:
            converged = True
            break
        diag = np.diag(np.diag(normal))
        while True:
            step_s = np.linalg.solve(normal + damping * diag, gradient)
            step = step_s / scale
            candidate = chain.perturbed(names, step)
            new = residual(candidate)
            new_cost = float(new @ new) + (prior_cost(offset + step, noise, tau) if prior is not None else 0.0)
            if new_cost <= cost or damping > 1e10 or np.linalg.norm(step_s) <= 1e-12 * size:
                break
            # A rejected step whose linearised model promised less than the stopping tolerance
            # failed by rounding: more damping only shrinks the promise (converged here).
            promised = 2.0 * float(gradient @ step_s) - float(step_s @ normal @ step_s)
            if promised <= tolerance * cost:
                break
            damping *= 10.0
        if new_cost > cost:
            converged = True
            break
        improvement = cost - new_cost
        chain, cost = candidate, new_cost
        if prior is not None:
            offset = offset + step
        damping = max(damping / 10.0, 1e-12)
        if (improvement <= tolerance * max(new_cost, 1e-300)
                or np.linalg.norm(step * scale) <= 1e-10 * size
                or new_cost <= 1e-20 * len(new)):
            converged = True
            break
    return Fit(chain, iteration, converged, prior_scale=tau)
