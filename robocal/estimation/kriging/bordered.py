"""Batched bordered Cholesky factorisations of many small correlation matrices at once, which
the Vecchia likelihood (:mod:`.vecchia`) and its local predictors (:mod:`.vecchia_prediction`)
are computed with (the bordering trick is in :mod:`.vecchia`'s docstring)."""
import numpy as np

from .correlation import JITTER_START

# The diagonal of the border of the bordered factorisation (see the module docstring): any
# value that keeps the matrix positive definite gives the same lower-left block.
BORDER = 1e200


def _squared_distances(P):
    """(B, k, k) squared distances between the rows of each (k, d) slice of P, from their
    Gram matrices (half the time of differences; rounding ~1e-16 of |p|², so keep P centred)."""
    norms = np.einsum("bij,bij->bi", P, P)
    S = P @ np.swapaxes(P, 1, 2)
    S *= -2.0
    S += norms[:, :, None]
    S += norms[:, None, :]
    return np.maximum(S, 0.0, out=S)


def _bordered_factor(R, diagonal_add, border_columns, border_point=None):
    """Lower Cholesky factors (B, k, k) of the correlation matrices R (B, s, s) with
    ``diagonal_add`` on their diagonal, bordered by ``border_columns`` (B, s', r) against
    the first s' rows (and ``border_point`` (B, r) against row s', if given) and BORDER on
    the border's diagonal.  Raises numpy's LinAlgError when one is not positive definite."""
    B, s, _ = R.shape
    r = border_columns.shape[2]
    M = np.zeros((B, s + r, s + r))
    M[:, :s, :s] = R
    M[:, np.arange(s), np.arange(s)] += diagonal_add
    head = border_columns.shape[1]
    M[:, s:, :head] = np.swapaxes(border_columns, 1, 2)  # numpy reads the lower triangle
    if border_point is not None:
        M[:, s:, head] = border_point
    M[:, np.arange(s, s + r), np.arange(s, s + r)] = BORDER
    return np.linalg.cholesky(M)


def _factor_in_prediction(R, diagonal_add, border_columns):
    """:func:`_bordered_factor` of a block of prediction targets, adding jitter (as the fit
    does, from JITTER_START·k up by tens) while a target's neighbours leave it singular: they
    are not the sets the fit factorised."""
    extra = 0.0
    while True:
        try:
            return _bordered_factor(R, diagonal_add + extra, border_columns)
        except np.linalg.LinAlgError:
            extra = JITTER_START * (R.shape[1] + 1) if extra == 0 else extra * 10.0


def _back_substitute(L, rhs):
    """x with Lᵀx = rhs for the lower-triangular L (B, m, m) and rhs (B, m, c), row by row."""
    x = np.empty_like(rhs)
    m = L.shape[1]
    for j in range(m - 1, -1, -1):
        total = rhs[:, j, :] - np.einsum("bl,blc->bc", L[:, j + 1:, j], x[:, j + 1:, :])
        x[:, j, :] = total / L[:, j, j, None]
    return x


class _Failed(Exception):
    """A block's factorisation failed or is singular to working precision: more jitter."""



def _forward_substitute(L, rhs):
    """x with Lx = rhs for the lower-triangular L (B, k, k) and rhs (B, k), column by column."""
    x = np.empty_like(rhs)
    for j in range(L.shape[1]):
        x[:, j] = (rhs[:, j] - np.einsum("bl,bl->b", L[:, j, :j], x[:, :j])) / L[:, j, j]
    return x

