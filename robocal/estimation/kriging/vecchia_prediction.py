"""The state of a Vecchia fit and its local predictors (:mod:`.vecchia` has the likelihood).

Prediction is local too.  Every training point j gets, once per fit, a predictor on the set
S_j of its k = ⌈4m/3⌉ nearest training points (itself included, in the metric of θ):

    ŷ(x) = f(x)ᵀβ̂ + r(x, S_j)ᵀ c_j,   c_j = A_j⁻¹ w_S,

and a target takes the predictor of its nearest training point: one nearest-point search and
O(k) per target.  With noise (a nugget τ²) exact Kriging averages the readings over every
point within the correlation length, hundreds of them on a smooth field, and k noisy
neighbours cannot (the predictor that conditioned each target on its m nearest readings: 1.3
to 2.3 times the exact held-out error on smooth noisy fields, all of it the predictor's: with
the exact θ and nugget it was as far off).  So w is the posterior mean of the noise-free
field at the training points,

    w = ỹ − τ² C⁻¹ỹ,   ỹ = y − Fβ̂,   A_j = R[S_j, S_j] + jitter·I,

with C⁻¹ỹ from conjugate gradients (the Vecchia factor C⁻¹ ≈ UᵀD⁻¹U as preconditioner),
and the local predictors interpolate that smooth field, where the screening effect holds.
The prediction is E[z(x) | y] with E[z(x) | z(X)] replaced by its local version; with k ≥ n
it is exact, R C⁻¹ỹ = (C − τ²I)C⁻¹ỹ.  Up to 2,000 points (vecchia.EXACT_SEARCH_UP_TO, where
the search's exact likelihood leaves the Cholesky factor of C at θ) C⁻¹ỹ comes from that
factor; up to NOISE_FREE_UP_TO points the gradients multiply by C itself (O(n²)); above, by
the Vecchia approximation of the latent field (the latent form of Katzfuss & Guinness 2021,
solved here by conjugate gradients rather than their incomplete Cholesky): R + ℓI ≈
U_ℓ⁻¹D_ℓU_ℓ⁻ᵀ in the same order with the same neighbours, ℓ = LATENT_NUGGET_SHARE·τ², and C
≈ U_ℓ⁻¹D_ℓU_ℓ⁻ᵀ + (τ² − ℓ)I, two sparse triangular solves per product, O(n m); then w = ỹ −
(τ² − ℓ)C⁻¹ỹ and A_j = R[S_j, S_j] + (jitter + ℓ)I.  This is what makes more readings a
better model: bench field with 0.01 mm noise, held-out RMS 2.25e-3 mm at n = 2,000, 1.51e-3
at 10,000 and 7.8e-4 at 100,000 (the readings averaged at 10,000: 4.05e-3).  Without a
nugget, or if the gradients do not converge, w = ỹ and A_j = C[S_j, S_j].  The MSE is the
exact formula on the readings of S_j,

    MSE(x) = σ̂² (1 + uᵀ(F̃ᵀF̃)⁻¹u − rᵀA⁻¹r),   A = C[S_j, S_j],   u = F_SᵀA⁻¹r − f(x),

never below the exact model's, which conditions on all the readings.
"""
import math

import numpy as np
from scipy.linalg import cho_solve

from .bordered import _back_substitute, _factor_in_prediction, _Failed, _forward_substitute, _squared_distances
from .correlation import correlation_from_squared

# A training point's local predictor (VecchiaState.prepare_prediction) conditions on this
# times m of its nearest training points.  Targets predicted from their nearest training
# point's set, 100,000 of them from n = 2,000 and 10,000 on the bench field (noise-free, 3
# outputs, fixed θ, one core, CPU s; RMS on 30,000 dense targets): factor 1 0.42 and 0.47 s,
# 6.4e-6 and 2.8e-6 mm; 4/3 0.51 and 0.60 s, 2.6e-6 and 9.6e-7 mm; 5/3 0.62 and 0.69 s,
# 1.2e-6 and 4.7e-7 mm; each target with its own 30 nearest (groups of 16, then 4, then one
# by one, sharing within half the reach) 1.12 and 2.52 s, 6.0e-6 and 2.4e-6 mm.  Building
# them costs O(n k³) once per fit: at 4/3, 0.5 and 2.5 s of CPU for the two sizes.
PREDICTION_SET_FACTOR = 4 / 3
# Targets (and training points, when their local predictors are built) taken at a time.
PREDICTION_BLOCK = 4096
# With a nugget, the local predictors interpolate the posterior mean of the noise-free field
# at the training points (VecchiaState.prepare_prediction) up to this many training points:
# its conjugate gradients multiply by the whole correlation matrix, 8n² bytes and O(n²) per
# iteration (100 to 300 of them; the Vecchia preconditioner saves few).  Bench field with
# 0.01 mm noise at n = 10,000, the Vecchia fit's θ and nugget: held-out RMS 1.41e-3 mm with
# these predictors, 4.05e-3 with the readings averaged, but 36 s of CPU more for 3 outputs
# (and 800 MB), beyond the fit budget of 30 s at that size.  Above, the same posterior mean
# comes from the Vecchia approximation of the latent field (LATENT_NUGGET_SHARE).
NOISE_FREE_UP_TO = 4000
# Above NOISE_FREE_UP_TO points the conjugate gradients multiply by R̂ + (τ² − ℓ)I instead of
# C, R̂ = U_ℓ⁻¹ D_ℓ U_ℓ⁻ᵀ the Vecchia approximation of R + ℓI (the same order and neighbours,
# no noise in the conditionals, so the screening effect holds; two sparse triangular solves
# per product), ℓ this share of the nugget τ²: a latent field with a little noise of its own
# conditions far better than the noise-free one.  Bench field, n = 10,000, 0.01 mm noise, the
# Vecchia fit's θ and nugget (3 outputs, one core, on a machine shared with other work):
# share 1e-4, 1e-3, 1e-2, 1e-1: held-out RMS 1.60e-3, 1.49e-3, 1.51e-3, 2.10e-3 mm (exact
# products: 1.41e-3; readings averaged: 4.05e-3); 150-174, 133-157, 96-110, 47-58 iterations;
# fit 11.6, 9.9, 9.6, 8.0 s of CPU against 6.1 with the readings averaged.  On the UR10's
# residual (series A, kriging on 6,000 random poses, held out on the other 5,911) it changes
# nothing: mean 0.2008 mm against 0.2009 with the readings averaged, 17.9 s of CPU against 17.7.
LATENT_NUGGET_SHARE = 1e-2
# Relative residual at which those conjugate gradients stop, and their most iterations (not
# converged: the predictors average the noisy readings instead).  Bench field, n = 2,000,
# 0.01 mm noise, exact Kriging's θ and nugget (3 outputs, products recomputed each time):
# 1e-10, 1e-8, 1e-6 cost 14.2, 9.9, 7.1 s of the fit's conditioning and moved predictions by
# at most 8e-8 and 7e-7 mm against 1e-10 (held-out RMS 2.25e-3 mm for all three).
CG_TOLERANCE = 1e-8
CG_ITERATIONS = 1000


class VecchiaState:
    """A Vecchia fit at fixed θ (standardised units), as the exact model's state: θ, nugget,
    jitter, condition (a lower bound, inf if the factorisation failed without jitter), β̂,
    σ̂², the log-likelihood; G the R factor of the whitened trend (F̃ᵀF̃ = GᵀG) and the
    standardised training residuals y − Fβ̂ (in the problem's order) for prediction, whose
    local predictors :meth:`prepare_prediction` builds (``final`` does)."""

    def __init__(self, problem, theta, nugget, jitter, condition, beta, sigma2, G, log_likelihood, residual):
        self.theta = theta
        self.nugget = nugget
        self.jitter = jitter
        self.condition = condition
        self.beta = beta
        self.sigma2 = sigma2
        self.G = G
        self.log_likelihood = log_likelihood
        self.gradient = None
        self._X, self._F, self._residual = problem.X, problem.F, residual
        self._correlation = problem.correlation
        self.neighbours = problem.neighbours
        self.noise_free = None  # whether the local predictors interpolate the noise-free field
        self._tree = None

    # ---------------------------------------------------------- local predictors

    def prepare_prediction(self, problem, exact_factor=None):
        """Build each training point j's local predictor: the set S_j of the k = ⌈4m/3⌉
        training points nearest to it (itself included, in the metric of θ) and the
        coefficients c_j = A_j⁻¹ w_S (k, q), so that a target whose nearest training point is
        j is predicted as f(x)ᵀβ̂ + r(x, S_j)ᵀ c_j in O(k).

        With a nugget, w is the posterior mean of the noise-free field at the training points,
        w = ỹ − τ² C⁻¹ỹ (ỹ = y − Fβ̂, τ² the nugget), with C⁻¹ỹ from conjugate gradients
        preconditioned by the Vecchia factor, and A_j = R[S_j, S_j] + jitter·I: the neighbours
        then interpolate a smooth field (where the screening effect holds) instead of
        averaging k noisy readings.  Up to NOISE_FREE_UP_TO points the gradients multiply by
        C itself; above, by the Vecchia approximation of the latent field with ℓ =
        LATENT_NUGGET_SHARE·τ² of the noise kept in it (w = ỹ − (τ² − ℓ) Ĉ⁻¹ỹ,
        A_j = R[S_j, S_j] + (jitter + ℓ)·I).  Without a nugget, or if the gradients do not
        converge, w = ỹ and A_j = C[S_j, S_j].  With k ≥ n both are the exact predictor: R C⁻¹ỹ = (C − τ²I)C⁻¹ỹ.
        ``exact_factor`` (the lower Cholesky factor of C in the problem's order, its jitter),
        when the search left one at θ with this state's jitter, gives C⁻¹ỹ directly."""
        from scipy.spatial import cKDTree  # loaded when used: the command line starts faster
        Z = self._X * np.sqrt(self.theta)
        self._Z, self._tree = Z, cKDTree(Z)
        n, q = self._residual.shape
        k = min(int(math.ceil(PREDICTION_SET_FACTOR * self.neighbours)), n)
        values, diagonal, self.noise_free = self._residual, self.nugget + self.jitter, False
        if self.nugget > 0 and exact_factor is not None and exact_factor[1] == self.jitter:
            solved = cho_solve((exact_factor[0], True), self._residual)
            values, diagonal, self.noise_free = self._residual - self.nugget * solved, self.jitter, True
        elif self.nugget > 0:
            try:
                factors = problem.factors(self.theta, self.nugget + self.jitter)
            except _Failed:  # unexpected (the fit factorised these matrices): average the readings
                factors = None
            if factors is None:
                found = None
            elif n <= NOISE_FREE_UP_TO:
                solved = _conjugate_gradients(Z, self._correlation, self.nugget + self.jitter, self._residual,
                                              *factors, problem._nb)
                found = None if solved is None else (solved, self.nugget, self.jitter)
            else:
                found = _latent_conjugate_gradients(problem, self.theta, self.nugget, self.jitter, self._residual,
                                                    *factors)
            if found is not None:
                solved, noise, diagonal = found
                values, self.noise_free = self._residual - noise * solved, True
        _, sets = self._tree.query(Z, k=k)
        self._sets = sets.reshape(n, k)
        self._coefficients = np.empty((n, k, q))
        for start in range(0, n, PREDICTION_BLOCK):
            rows = np.arange(start, min(n, start + PREDICTION_BLOCK))
            S = self._sets[rows]
            A = correlation_from_squared(_squared_distances(Z[S] - Z[rows][:, None, :]), self._correlation)
            L = _factor_in_prediction(A, diagonal, values[S])
            self._coefficients[rows] = _back_substitute(L[:, :k, :k], np.swapaxes(L[:, k:, :k], 1, 2))

    def predict(self, Xs, f, with_mse):
        """(standardised mean (N, q), mse in units of σ̂² (N,) or None) at the standardised
        points Xs (N, d) whose trend columns are f (N, p).

        Each target takes the local predictor of its nearest training point j (see
        :meth:`prepare_prediction`): one nearest-point search and O(k) per target.  The MSE
        is that of conditioning on the noisy readings of S_j, the exact model's formula on
        them (C = R + (nugget + jitter)·I; one k × k factorisation per set among the targets);
        with k ≥ n mean and MSE are the exact model's."""
        Z = Xs * np.sqrt(self.theta)
        _, nearest = self._tree.query(Z, k=1)
        mean = f @ self.beta
        mse = np.empty(len(Xs)) if with_mse else None
        for start in range(0, len(Xs), PREDICTION_BLOCK):
            block = slice(start, start + PREDICTION_BLOCK)
            S = self._sets[nearest[block]]  # (B, k)
            offset = self._Z[S] - Z[block, None, :]
            r = correlation_from_squared(np.einsum("bkd,bkd->bk", offset, offset), self._correlation)
            mean[block] += np.einsum("bk,bkq->bq", r, self._coefficients[nearest[block]])
            if with_mse:
                mse[block] = self._unit_mse(nearest[block], r, f[block])
        return mean, mse

    def _unit_mse(self, nearest, r, f):
        """1 + uᵀ(F̃ᵀF̃)⁻¹u − rᵀA⁻¹r, u = F_SᵀA⁻¹r − f, for targets whose nearest training
        points are ``nearest`` (B,), with correlations r (B, k) to their sets and trend
        columns f (B, p).  Each set is factorised once for all its targets."""
        sets, inverse = np.unique(nearest, return_inverse=True)
        S = self._sets[sets]
        k = S.shape[1]
        A = correlation_from_squared(_squared_distances(self._Z[S] - self._Z[sets][:, None, :]), self._correlation)
        L = _factor_in_prediction(A, self.nugget + self.jitter, self._F[S])[inverse.reshape(-1)]
        v = _forward_substitute(L[:, :k, :k], r)  # L⁻¹r
        u = np.einsum("bk,bpk->bp", v, L[:, k:, :k]) - f  # F_SᵀA⁻¹r − f
        w = np.linalg.solve(self.G.T, u.T)  # uᵀ(GᵀG)⁻¹u = |w|²
        return np.maximum(1.0 + np.einsum("ij,ij->j", w, w) - np.einsum("bk,bk->b", v, v), 0.0)




def _conjugate_gradients(Z, correlation, diagonal_add, B, b, d, neighbours):
    """X = C⁻¹B (n, q) for C = R(Z) + diagonal_add·I, by conjugate gradients on each column
    with the exact product (C formed once: 8n² bytes, 128 MB at n = 4,000) and the Vecchia
    factor Uᵀ D⁻¹ U (b (n, m), d (n,) and the neighbours (n, m), −1 for none) as
    preconditioner; None if a column has not reached CG_TOLERANCE after CG_ITERATIONS."""
    n = len(B)
    norms = np.einsum("id,id->i", Z, Z)
    C = Z @ Z.T
    C *= -2.0
    C += norms[:, None]
    C += norms[None, :]
    C = correlation_from_squared(np.maximum(C, 0.0, out=C), correlation, out=C)
    C[np.diag_indices(n)] += diagonal_add
    valid = neighbours >= 0
    safe = np.where(valid, neighbours, 0)
    weights = np.where(valid, b, 0.0)

    def product(V):
        return C @ V

    def precondition(V):
        W = (V - np.einsum("im,imc->ic", weights, V[safe])) / d[:, None]  # D⁻¹ U V
        out = W.copy()
        for c in range(V.shape[1]):  # Uᵀ: each point's −b_i W_i goes to its neighbours
            out[:, c] -= np.bincount(safe.ravel(), (weights * W[:, c:c + 1]).ravel(), minlength=n)
        return out

    return _preconditioned_gradients(product, precondition, B)


def _vecchia_factor(b, neighbours):
    """The sparse unit lower-triangular U (n, n) of a Vecchia factor, (U v)_i = v_i − b_iᵀ v_N(i)
    in the problem's order (b (n, m), the neighbours (n, m), −1 for none)."""
    from scipy import sparse

    n, m = neighbours.shape
    valid = neighbours >= 0
    rows = np.concatenate([np.repeat(np.arange(n), m)[valid.ravel()], np.arange(n)])
    columns = np.concatenate([neighbours[valid], np.arange(n)])
    return sparse.csr_matrix((np.concatenate([-b[valid], np.ones(n)]), (rows, columns)), shape=(n, n))


def _latent_conjugate_gradients(problem, theta, nugget, jitter, B, b, d):
    """(X, τ² − ℓ, jitter + ℓ) with X = Ĉ⁻¹B (n, q), Ĉ = R̂ + (τ² − ℓ)I and R̂ = U_ℓ⁻¹ D_ℓ U_ℓ⁻ᵀ
    the Vecchia approximation of R + (jitter + ℓ)I at θ (the neighbours of ``problem``'s last
    ``focus``; ℓ = LATENT_NUGGET_SHARE·τ², ten times more while its factor fails, up to τ²),
    by conjugate gradients preconditioned by the Vecchia factor of C (b (n, m), d (n,));
    None if they do not converge or no ℓ below τ² factorises.  O(n m) per iteration."""
    from scipy.sparse.linalg import spsolve_triangular

    latent = LATENT_NUGGET_SHARE * nugget
    while True:
        if latent >= nugget:
            return None
        try:
            b_latent, d_latent = problem.factors(theta, jitter + latent)
            break
        except _Failed:
            latent *= 10.0
    U_latent = _vecchia_factor(b_latent, problem._nb)
    U_latent_t = U_latent.T.tocsr()
    U = _vecchia_factor(b, problem._nb)
    U_t = U.T.tocsr()
    rest = nugget - latent

    def product(V):  # (R̂ + (τ² − ℓ)I) V
        inner = d_latent[:, None] * spsolve_triangular(U_latent_t, V, lower=False, unit_diagonal=True)
        return spsolve_triangular(U_latent, inner, lower=True, unit_diagonal=True) + rest * V

    def precondition(V):  # Uᵀ D⁻¹ U V ≈ C⁻¹ V
        return U_t @ ((U @ V) / d[:, None])

    solved = _preconditioned_gradients(product, precondition, B)
    return None if solved is None else (solved, rest, jitter + latent)


def _preconditioned_gradients(product, precondition, B):
    """X = C⁻¹B (n, q) by preconditioned conjugate gradients on each column, given the
    products V ↦ CV and V ↦ M⁻¹V (n, q); None if a column has not reached CG_TOLERANCE after
    CG_ITERATIONS."""
    X = np.zeros_like(B)
    residual = B.copy()
    target = CG_TOLERANCE * np.linalg.norm(B, axis=0)
    z = precondition(residual)
    direction = z.copy()
    rz = np.einsum("ic,ic->c", residual, z)
    for _ in range(CG_ITERATIONS):
        if np.all(np.linalg.norm(residual, axis=0) <= target):
            return X
        Cp = product(direction)
        step = rz / np.maximum(np.einsum("ic,ic->c", direction, Cp), 1e-300)
        X += step * direction
        residual -= step * Cp
        z = precondition(residual)
        rz, previous = np.einsum("ic,ic->c", residual, z), rz
        direction = z + (rz / np.maximum(previous, 1e-300)) * direction
    return X if np.all(np.linalg.norm(residual, axis=0) <= target) else None
