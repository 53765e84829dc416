"""The problems a Vecchia fit's hyperparameter search runs on instead of the Vecchia likelihood
(:meth:`.vecchia.VecchiaProblem.search_problem`): the exact likelihood in the Vecchia
problem's order, and the block-independent (composite) likelihood of spatially compact blocks."""
import math

import numpy as np

from .correlation import _triangular_solve
from .exact import _Problem


class _ExactInOrder(_Problem):
    """The exact likelihood of X, F given in the order ``rows`` of the caller's outputs (a
    Vecchia problem's order): ``condition`` takes the outputs in the caller's order."""

    def __init__(self, X, F, correlation, rows):
        super().__init__(X, F, correlation)
        self.rows = rows

    def condition(self, theta, nugget, Y, start_jitter=0.0, gradient=False):
        return super().condition(theta, nugget, Y[self.rows], start_jitter, gradient)


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
        self.parts = [_Problem(X[b], F[b], correlation) for b in blocks]

    def focus(self, theta):
        """Nothing: each block conditions on all its points."""

    def condition(self, theta, nugget, Y, start_jitter=0.0, gradient=False):
        """A :class:`_BlockState` at θ and the nugget for the outputs ``Y`` (n, q) (the
        caller's row order): the log-likelihood summed over the blocks and, with
        ``gradient``, its derivatives in log θ and log nugget (each block with its own jitter)."""
        Y = Y[self.rows]
        n = len(Y)
        factors, whitened_F, whitened_Y = [], [], []
        log_det = 0.0
        for part, rows in zip(self.parts, self.blocks):
            S, C, L, _, _ = part.factor(theta, nugget, start_jitter)
            factors.append((S, C, L))
            whitened_F.append(_triangular_solve(L, part.F))
            whitened_Y.append(_triangular_solve(L, Y[rows]))
            log_det += 2.0 * np.log(L.diagonal()).sum()
        Ft, Yt = np.vstack(whitened_F), np.vstack(whitened_Y)
        Q, G = np.linalg.qr(Ft)
        beta = np.linalg.solve(G, Q.T @ Yt)
        residual = Yt - Ft @ beta
        sigma2 = np.maximum(np.einsum("ij,ij->j", residual, residual) / n, 1e-300)
        state = _BlockState(-0.5 * (n * np.log(sigma2) + log_det + n * (1.0 + math.log(2 * math.pi))))
        if gradient:
            d_theta, d_nugget, start = np.zeros(len(theta)), 0.0, 0
            for part, (S, C, L) in zip(self.parts, factors):
                size = len(part.X)
                alpha = _triangular_solve(L, residual[start:start + size], transpose=True)
                start += size
                block_theta, block_nugget = part._gradient(theta, nugget, S, C, L, alpha, sigma2)
                d_theta, d_nugget = d_theta + block_theta, d_nugget + block_nugget
            state.gradient = (d_theta, d_nugget)
        return state


class _BlockState:
    """What a search takes of a block problem at fixed θ: the log-likelihood (one per output
    column) and, when asked for, its gradient."""

    def __init__(self, log_likelihood):
        self.log_likelihood = log_likelihood
        self.gradient = None

