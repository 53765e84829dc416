"""Checks and scaling of the numeric arrays the estimators take (X, Y, q, dp)."""
import numpy as np

from ..errors import InputError


def as_matrix(values, name):
    """A finite float array with 2 dimensions (a 1-D array becomes one column)."""
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric array") from None
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2 or array.size == 0:
        raise InputError(f"{name} must be a non-empty 2-D array (rows are points), got shape "
                         f"{array.shape}")
    bad = ~np.isfinite(array)
    if bad.any():
        rows = np.flatnonzero(bad.any(axis=1))
        shown = ", ".join(str(i) for i in rows[:10]) + (" …" if len(rows) > 10 else "")
        raise InputError(f"{name} contains NaN or infinite values in {len(rows)} rows "
                         f"({shown}): remove or repair those rows")
    return array


def standard_scaler(A):
    """Column means and standard deviations (n − 1 in the denominator, as DACE and SMT have
    it, so θ is comparable with theirs).  A constant column gets its value and scale 1, so
    that it standardises to exact zeros (its computed mean and spread can be off by rounding)."""
    constant = A.min(axis=0) == A.max(axis=0)
    mean = np.where(constant, A[0], A.mean(axis=0))
    scale = np.where(constant, 1.0, A.std(axis=0, ddof=1))
    return mean, scale
