"""The exact concentrated likelihood of a Kriging fit and its analytic gradient (the formulas are
in the package docstring): O(n³) time and O(n²) memory per evaluation."""
import math

import numpy as np
from scipy.linalg import lapack

from .correlation import _cholesky_with_jitter, _triangular_solve, correlation_from_squared, matern52_slope


class _Problem:
    """The standardised data of one fit and the likelihood of a group of outputs sharing θ."""

    def __init__(self, X, F, correlation):
        self.X = X
        self.F = F
        self.correlation = correlation
        n, d = X.shape
        # Per-dimension squared differences, (d, n·n): R and the gradient are then one
        # matrix-vector product each over them.  Memory: 8·d·n² bytes (216 MB at n = 3000).
        self.sqdiff = ((X[:, None, :] - X[None, :, :]) ** 2).reshape(n * n, d).T.copy()

    ROUNDS = 1  # runs of the optimiser per start (see Kriging._minimise)
    least_starts = 1  # the fewest starts of a search left to its default (see the Vecchia problem's)

    def search_problem(self):
        """The problem the hyperparameter search runs on: this one (see the Vecchia problem's)."""
        return self

    def refinement(self, search):
        """None: a search on the exact likelihood is final (see the Vecchia problem's)."""
        return None

    def focus(self, theta):
        """Nothing: the exact likelihood conditions on every point (see the Vecchia problem's)."""

    def final(self, theta, nugget, Y, start_jitter=0.0):
        """The state a fit ends with, or a saved model is rebuilt from, at θ and the nugget."""
        return self.condition(theta, nugget, Y, start_jitter)

    def factor(self, theta, nugget, start_jitter=0.0):
        """(S, C, L, jitter, condition) at θ and the nugget: the θ-weighted squared distances,
        the correlation matrix with the nugget and jitter on its diagonal, its lower Cholesky
        factor, the jitter and the condition estimate (see :func:`_cholesky_with_jitter`)."""
        n = len(self.X)
        S = (theta @ self.sqdiff).reshape(n, n)
        C = correlation_from_squared(S, self.correlation, out=np.empty_like(S))  # R
        C[np.diag_indices(n)] += nugget
        # Correlations are ≥ 0, so the 1-norm is the largest column sum.
        L, jitter, condition = _cholesky_with_jitter(C, C.sum(axis=0).max(), start_jitter)
        return S, C, L, jitter, condition

    def condition(self, theta, nugget, Y, start_jitter=0.0, gradient=False):
        """Condition the process on ``Y`` (n, m) at θ and the nugget: a `_State`."""
        n = len(self.X)
        S, C, L, jitter, condition = self.factor(theta, nugget, start_jitter)
        Ft = _triangular_solve(L, self.F)
        Yt = _triangular_solve(L, Y)
        Q, G = np.linalg.qr(Ft)
        beta = np.linalg.solve(G, Q.T @ Yt)
        residual = Yt - Ft @ beta
        # A constant output leaves no residual; the floor keeps log σ² finite.
        sigma2 = np.maximum(np.einsum("ij,ij->j", residual, residual) / n, 1e-300)
        log_det = 2.0 * np.log(L.diagonal()).sum()
        log_likelihood = -0.5 * (n * np.log(sigma2) + log_det + n * (1.0 + math.log(2 * math.pi)))
        alpha = _triangular_solve(L, residual, transpose=True)
        state = _State(theta, nugget, jitter, condition, L, Ft, G, beta, sigma2, alpha,
                       log_likelihood)
        if gradient:
            state.gradient = self._gradient(theta, nugget, S, C, L, alpha, sigma2)
        return state

    def _gradient(self, theta, nugget, S, C, L, alpha, sigma2):
        """d(Σ_j ℓ_j)/d(log θ_k) and d/d(log nugget): ½ tr(W ∂C/∂·), W = Σ_j α_jα_jᵀ/σ_j² − m C⁻¹.

        ∂C/∂θ_k = (dR/dS) ∘ Δ_k², and Δ_k² is zero on the diagonal, so only off-diagonal
        entries matter: there C equals R (the Gaussian's dR/dS = −R is read from C), and the
        symmetric C⁻¹ can be used through its lower triangle, counted twice.
        """
        m = alpha.shape[1]
        C_inverse_lower, _ = lapack.dpotri(L, lower=1)  # upper triangle stays zero
        W = (alpha / sigma2) @ alpha.T
        d_nugget = 0.5 * nugget * (np.trace(W) - m * np.trace(C_inverse_lower))
        W -= (2 * m) * C_inverse_lower
        slope = -C if self.correlation == "gaussian" else matern52_slope(S)
        # With log θ as the variable the chain rule brings a factor θ_k.
        d_theta = 0.5 * theta * (self.sqdiff @ (W * slope).reshape(-1))
        return d_theta, d_nugget


class _State:
    """Everything a fit at fixed θ leaves behind (standardised units)."""

    def __init__(self, theta, nugget, jitter, condition, L, Ft, G, beta, sigma2, alpha,
                 log_likelihood):
        self.theta = theta
        self.nugget = nugget
        self.jitter = jitter
        self.condition = condition
        self.L = L
        self.Ft = Ft  # L⁻¹F
        self.G = G  # R factor of L⁻¹F = QG, so FᵀC⁻¹F = GᵀG
        self.beta = beta
        self.sigma2 = sigma2
        self.alpha = alpha  # C⁻¹(Y − Fβ): the prediction weights
        self.log_likelihood = log_likelihood
        self.gradient = None

