"""What every Kriging likelihood of this package shares: the regression trend's basis, the
correlation functions, Latin-hypercube sampling and the jittered Cholesky factorisation
(see the package docstring for the model)."""
import numpy as np
from scipy.linalg import lapack


# A correlation matrix whose estimated condition number exceeds this is treated as singular.
# Cholesky factorisation is backward stable, so Kriging predictions stay accurate up to
# condition numbers near 1/ε; the limit only catches matrices that are singular to working
# precision although the factorisation went through.  (Measured: a limit of 1e15 made the
# held-out error on smooth fields 2 to 5 times worse than this one.)
MAX_CONDITION = 1e17
# The first jitter tried is this times n (the (10 + n)·ε scale DACE always adds), then ten
# times more each try.  Every order of magnitude of jitter smooths the fit: starting at
# 1e-12·n instead made the held-out error on smooth fields up to 20 times worse.
JITTER_START = 1e-16


def trend_size(n_features, regression):
    """Number of terms of the regression trend in ``n_features`` dimensions."""
    d = n_features
    return {"constant": 1, "linear": d + 1, "quadratic": (d + 1) * (d + 2) // 2}[regression]


def trend_basis(X, regression):
    """Regression functions f(x) at the rows of ``X`` (N, d): constant, x_k, x_k x_l (k ≤ l)."""
    columns = [np.ones((len(X), 1))]
    if regression in ("linear", "quadratic"):
        columns.append(X)
    if regression == "quadratic":
        rows, cols = np.triu_indices(X.shape[1])
        columns.append(X[:, rows] * X[:, cols])
    return np.hstack(columns)


def correlation_from_squared(S, kind, out=None):
    """Correlation as a function of the θ-weighted squared distance ``S`` (≥ 0)."""
    if kind == "gaussian":
        return np.exp(np.negative(S, out=out), out=out)
    h = np.sqrt(5.0 * S, out=out)  # √5 h
    poly = 1.0 + h + h * h / 3.0  # 1 + √5h + 5h²/3
    return np.multiply(poly, np.exp(np.negative(h, out=h), out=h), out=out)


def matern52_slope(S):
    """dR/dS of the Matérn 5/2 correlation at weighted squared distance S (the Gaussian's is −R)."""
    h = np.sqrt(5.0 * S)
    return -(5.0 / 6.0) * (1.0 + h) * np.exp(-h)


def latin_hypercube(n_points, lower, upper, rng):
    """``n_points`` Latin-hypercube samples of the box [lower, upper]: one per row stratum."""
    dims = len(lower)
    strata = np.argsort(rng.random((n_points, dims)), axis=0)
    unit = (strata + rng.random((n_points, dims))) / n_points
    return lower + unit * (upper - lower)


def _cholesky_with_jitter(C, norm_1, start_jitter):
    """Lower Cholesky factor of C + jitter·I with the smallest jitter (≥ start_jitter) that works.

    A jitter "works" when the factorisation succeeds and LAPACK's condition estimate stays
    below MAX_CONDITION.  Returns (L, jitter, condition estimate at start_jitter, inf if the
    factorisation failed there).  ``C`` is modified on its diagonal; ``norm_1`` is its 1-norm.
    """
    n = len(C)
    base_diagonal = C.diagonal().copy()
    diagonal = np.diag_indices(n)
    jitter = start_jitter
    first_condition = None
    while True:
        if jitter:
            C[diagonal] = base_diagonal + jitter
        L, info = lapack.dpotrf(C, lower=1, clean=1)
        if info == 0:
            rcond, _ = lapack.dpocon(L, norm_1 + jitter, uplo="L")
            condition = 1.0 / rcond if rcond > 0 else np.inf
            if first_condition is None:
                first_condition = condition
            if condition <= MAX_CONDITION:
                return L, jitter, first_condition
        elif first_condition is None:
            first_condition = np.inf
        jitter = JITTER_START * n if jitter == 0 else jitter * 10.0


def _triangular_solve(L, B, transpose=False):
    """L⁻¹B (or L⁻ᵀB) for the lower-triangular factor L."""
    X, _ = lapack.dtrtrs(L, B, lower=1, trans=1 if transpose else 0)
    return X
