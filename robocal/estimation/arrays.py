"""Checks shared by the estimators: their numeric arrays (X, Y), their settings and their
saved documents; and the scaling of the arrays.

The settings helpers serve the contract of :class:`~robocal.estimation.Kriging` and
:class:`~robocal.estimation.network.NetworkErrorModel` (scikit-learn's): ``__init__`` stores
the settings as given and ``fit`` checks them first, so that a wrong setting is reported in
one line naming it and what it may be, before any work is done.
"""
import numbers

import numpy as np

from ..errors import FileFormatError, InputError


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


# ------------------------------------------------------------------------------ settings

def check_choice(name, value, allowed):
    """Raise an InputError unless ``value`` is one of ``allowed`` (strings or None)."""
    # A match by identity for None and by equality for strings only: an array or other
    # object compared with == would give an array or a surprise instead of a bool.
    if not any(value is a or (isinstance(value, str) and value == a) for a in allowed):
        listed = ", ".join(repr(a) for a in allowed)
        raise InputError(f"{name} must be one of {listed}, got {value!r}")


def is_whole(value):
    """True for an int or a float with an integral value (not a bool, not a string)."""
    return (isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
            and np.isfinite(float(value)) and float(value).is_integer())


def check_whole(name, value, minimum, none_allowed=False):
    """Raise an InputError unless ``value`` is a whole number ≥ ``minimum`` (or None if
    ``none_allowed``)."""
    if value is None and none_allowed:
        return
    if not (is_whole(value) and value >= minimum):
        alternative = " or None" if none_allowed else ""
        raise InputError(f"{name} must be a whole number >= {minimum}{alternative}, got {value!r}")


def is_real(value):
    """True for a finite int or float (not a bool, not a string)."""
    return (isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
            and bool(np.isfinite(float(value))))


def check_flag(name, value):
    """Raise an InputError unless ``value`` is True or False."""
    if not isinstance(value, (bool, np.bool_)):
        raise InputError(f"{name} must be True or False, got {value!r}")


def check_random_state(value):
    """Raise an InputError unless ``value`` can seed training: None (fresh entropy), a whole
    number ≥ 0 or a numpy Generator (used as is, so it advances)."""
    if value is None or isinstance(value, np.random.Generator):
        return
    if not (isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))
            and value >= 0):
        raise InputError(f"random_state must be None, a whole number >= 0 or a "
                         f"numpy.random.Generator, got {value!r}")


def not_fitted(model, how):
    """The InputError both error models raise when used before ``fit``: ``model`` names
    the estimator, ``how`` is the call that fits it."""
    return InputError(f"this {model} is not fitted: call {how} first")


# --------------------------------------------------------------------------- model files

def check_header(document, what, format_tag, version):
    """Raise a FileFormatError unless ``document`` is a dict with this format tag and version.

    ``what`` names the model in the message ("Kriging model", "network error model").
    """
    if not isinstance(document, dict):
        raise FileFormatError(f"not a {what}: expected a dict with format '{format_tag}', got "
                              f"{type(document).__name__}: load a document saved by to_dict()")
    if document.get("format") != format_tag:
        raise FileFormatError(f"not a {what}: expected format '{format_tag}', got "
                              f"{document.get('format')!r}: load a document saved by to_dict()")
    if document.get("version") != version:
        raise FileFormatError(f"{what} version {document.get('version')!r} is not supported (this "
                              f"robocal reads version {version}): refit the model and save it again")


def damaged(what, problem):
    """The FileFormatError of a model document whose content is wrong: ``problem`` says how
    (a text, or the KeyError, TypeError or ValueError met while reading the document)."""
    if isinstance(problem, KeyError):
        problem = f"no {problem.args[0]!r} entry"
    elif isinstance(problem, Exception):
        problem = "malformed: " + " ".join(str(problem).split())  # one line, whatever raised
    return FileFormatError(f"{what} is damaged ({problem}): refit the model and save it again")
