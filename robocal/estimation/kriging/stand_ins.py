"""The problems a Vecchia fit's hyperparameter search runs on instead of the Vecchia likelihood
(:meth:`.vecchia.VecchiaProblem.search_problem`): the exact likelihood in the Vecchia
problem's order, and the block-independent (composite) likelihood of spatially compact blocks.

Both are computed as the exact model's likelihood (:mod:`.exact`, same formulas) but without
its per-dimension squared differences (8·d·n² bytes, 96 MB and 0.3 s to build at n = 2,000):
the squared distances come from the Gram matrix of the θ-scaled inputs, and the gradient's
sums Σ_ij M_ij (x_ik − x_jk)² from one product M [1, X, X²],

    Σ_ij M_ij (x_ik − x_jk)² = Σ_i x_ik² (M 1)_i + Σ_j x_jk² (1ᵀM)_j − 2 Σ_i x_ik (M X)_ik,

with M's diagonal set to zero first (the differences vanish there).  Measured at n = 2,000,
one output, one core: 0.22 s for the likelihood and its gradient against 0.25 s."""
import math

import numpy as np
from scipy.linalg import blas, lapack

from .bordered import _squared_distances
from .correlation import _cholesky_with_jitter, _triangular_solve, correlation_from_squared, matern52_slope


class _Dense:
    """The exact likelihood of the standardised points X (n, d) with trend columns F (n, p)
    and its gradient in log θ and log nugget: :class:`.exact._Problem`'s, computed without
    the squared differences (module docstring)."""

    def __init__(self, X, F, correlation):
        self.X, self.F, self.correlation = X, F, correlation

    def factor(self, theta, nugget, start_jitter=0.0):
        """(S, C, L, jitter, condition) as :meth:`.exact._Problem.factor`: the θ-weighted
        squared distances (n, n), the correlation matrix with nugget and jitter on its diagonal,
        its lower Cholesky factor, the jitter and the condition estimate."""
        n = len(self.X)
        S = _squared_distances((self.X * np.sqrt(theta))[None])[0]
        S[np.diag_indices(n)] = 0.0
        C = correlation_from_squared(S, self.correlation, out=np.empty_like(S))
        C[np.diag_indices(n)] += nugget
        # Correlations are ≥ 0, so the 1-norm is the largest column sum.
        L, jitter, condition = _cholesky_with_jitter(C, C.sum(axis=0).max(), start_jitter)
        return S, C, L, jitter, condition

    def whiten(self, L, Y):
        """(L⁻¹F, L⁻¹Y, log det C) of the factor L and outputs Y (n, q)."""
        return _triangular_solve(L, self.F), _triangular_solve(L, Y), 2.0 * np.log(L.diagonal()).sum()

    def gradient(self, theta, nugget, S, C, L, residual, sigma2):
        """(d Σ_j ℓ_j / d log θ (d,), d Σ_j ℓ_j / d log nugget) given the factor L of C and
        the whitened residuals L⁻¹(Y − Fβ̂) (n, q) (formulas: :mod:`.exact`).  L is overwritten."""
        n = len(self.X)
        alpha = _triangular_solve(L, residual, transpose=True)
        q = alpha.shape[1]
        scaled = alpha / sigma2
        M, _ = lapack.dpotri(L, lower=1, overwrite_c=1)  # C⁻¹'s lower triangle, upper zero
        d_nugget = 0.5 * nugget * (np.einsum("ij,ij->", scaled, alpha) - q * np.trace(M))
        # W = Σ_j α_jα_jᵀ/σ_j² − q C⁻¹ (C⁻¹ through its lower triangle counted twice) as
        # −2q (C⁻¹_lower − Σ_j α_jα_jᵀ/(2q σ_j²)): rank-one updates in place, one pass each.
        for j in range(q):
            M = blas.dger(-1.0 / (2.0 * q * sigma2[j]), alpha[:, j], alpha[:, j], a=M, overwrite_a=1)
        # Times dR/dS off the diagonal: the Gaussian's is −R (read from C).
        if self.correlation == "gaussian":
            M *= C
            sign = 2.0 * q
        else:
            M *= matern52_slope(S)
            sign = -2.0 * q
        M[np.diag_indices(n)] = 0.0
        # Σ_ij M_ij (x_ik − x_jk)² from one product M [1, X, X²] (module docstring).
        X = self.X
        squares = X * X
        d = X.shape[1]
        product = M @ np.hstack([np.ones((n, 1)), X, squares])
        sums = (squares.T @ product[:, 0] + product[:, 1 + d:].sum(axis=0)
                - 2.0 * np.einsum("ik,ik->k", X, product[:, 1:1 + d]))
        # With log θ as the variable the chain rule brings a factor θ_k.
        return (0.5 * sign) * theta * sums, d_nugget



def _concentrated(F_whitened, Y_whitened, log_det, n):
    """(β̂ (p, q), whitened residuals (n, q), σ̂² (q,), log-likelihood (q,)) of whitened trend
    and outputs and log det C (the exact model's formulas)."""
    Q, G = np.linalg.qr(F_whitened)
    beta = np.linalg.solve(G, Q.T @ Y_whitened)
    residual = Y_whitened - F_whitened @ beta
    # A constant output leaves no residual; the floor keeps log σ² finite.
    sigma2 = np.maximum(np.einsum("ij,ij->j", residual, residual) / n, 1e-300)
    return beta, residual, sigma2, -0.5 * (n * np.log(sigma2) + log_det + n * (1.0 + math.log(2 * math.pi)))


class _ExactInOrder:
    """The exact likelihood of X, F given in the order ``rows`` of the caller's outputs (a
    Vecchia problem's order): ``condition`` takes the outputs in the caller's order."""

    ROUNDS = 1
    least_starts = 1

    def __init__(self, X, F, correlation, rows):
        self.X, self.F, self.correlation, self.rows = X, F, correlation, rows
        self._dense = _Dense(X, F, correlation)
        self._best = {}  # outputs' bytes -> (Σ ℓ, θ, nugget, jitter, factor) of the best state seen

    def focus(self, theta):
        """Nothing: the exact likelihood conditions on every point."""

    def best_factor(self, theta, nugget, Y):
        """(lower Cholesky factor of C (n, n) in the problem's order, its jitter) at θ and the
        nugget if the best likelihood of the outputs ``Y`` seen so far was there, else None;
        forgotten either way (a search ends at its best state: the fit's final state then
        solves with C by this factor, not by conjugate gradients)."""
        best = self._best.pop(Y.tobytes(), None)
        if best is None or best[2] != nugget or not np.array_equal(best[1], theta):
            return None
        return best[4], best[3]

    def condition(self, theta, nugget, Y, start_jitter=0.0, gradient=False):
        """A :class:`_SearchState` at θ and the nugget for the outputs ``Y`` (n, q) (the
        caller's row order), with the gradient in log θ and log nugget when asked for."""
        key = Y.tobytes()
        Y = Y[self.rows]
        S, C, L, jitter, _ = self._dense.factor(theta, nugget, start_jitter)
        _, residual, sigma2, log_likelihood = _concentrated(*self._dense.whiten(L, Y), len(Y))
        if key not in self._best or log_likelihood.sum() > self._best[key][0]:
            self._best[key] = (log_likelihood.sum(), np.array(theta), nugget, jitter, L.copy())
        state = _SearchState(log_likelihood)
        if gradient:
            state.gradient = self._dense.gradient(theta, nugget, S, C, L, residual, sigma2)
        return state


def spatial_blocks(X, count):
    """``count`` spatially compact blocks of the rows of X (n, d): a list of ascending index
    arrays whose sizes differ by at most one.  A set is cut across its widest coordinate at
    the quantile that gives each side its share of the blocks, and each side likewise."""
    def cut(rows, count):
        if count == 1:
            return [np.sort(rows)]
        part = X[rows]
        axis = int(np.argmax(part.max(axis=0) - part.min(axis=0)))
        ranked = rows[np.argsort(part[:, axis], kind="stable")]
        left = count // 2
        size = len(rows) * left // count
        return cut(ranked[:size], left) + cut(ranked[size:], count - left)

    return cut(np.arange(len(X)), max(1, min(int(count), len(X))))


class _BlockProblem:
    """The likelihood of spatially compact blocks of the points taken as independent, with
    one β and σ² for all (a composite likelihood: the exact likelihood of a block-diagonal
    correlation matrix), and its gradient: the exact model's, block by block.  X, F in the
    problem's order, ``rows`` the caller's rows in that order (``condition`` takes the
    outputs in the caller's order, as :class:`_ExactInOrder`); ``blocks`` index arrays into X."""

    ROUNDS = 1
    least_starts = 1

    def __init__(self, X, F, correlation, rows, blocks):
        self.X, self.F, self.correlation, self.rows = X, F, correlation, rows
        self.blocks = blocks
        self.parts = [_Dense(X[b], F[b], correlation) for b in blocks]

    def focus(self, theta):
        """Nothing: each block conditions on all its points."""

    def condition(self, theta, nugget, Y, start_jitter=0.0, gradient=False):
        """A :class:`_SearchState` at θ and the nugget for the outputs ``Y`` (n, q) (the
        caller's row order): the log-likelihood summed over the blocks and, with
        ``gradient``, its derivatives in log θ and log nugget (each block with its own jitter)."""
        Y = Y[self.rows]
        factors, whitened_F, whitened_Y = [], [], []
        log_det = 0.0
        for part, rows in zip(self.parts, self.blocks):
            S, C, L, _, _ = part.factor(theta, nugget, start_jitter)
            factors.append((S, C, L))
            F_whitened, Y_whitened, block_log_det = part.whiten(L, Y[rows])
            whitened_F.append(F_whitened)
            whitened_Y.append(Y_whitened)
            log_det += block_log_det
        _, residual, sigma2, log_likelihood = _concentrated(np.vstack(whitened_F), np.vstack(whitened_Y), log_det,
                                                            len(Y))
        state = _SearchState(log_likelihood)
        if gradient:
            d_theta, d_nugget, start = np.zeros(len(theta)), 0.0, 0
            for part, (S, C, L) in zip(self.parts, factors):
                size = len(part.X)
                block_theta, block_nugget = part.gradient(theta, nugget, S, C, L, residual[start:start + size], sigma2)
                start += size
                d_theta, d_nugget = d_theta + block_theta, d_nugget + block_nugget
            state.gradient = (d_theta, d_nugget)
        return state


class _SearchState:
    """What a search takes of a stand-in at fixed θ: the log-likelihood (one per output
    column) and, when asked for, its gradient."""

    def __init__(self, log_likelihood):
        self.log_likelihood = log_likelihood
        self.gradient = None
