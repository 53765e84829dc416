"""A fit's training data, standardised, and the likelihood problem built on them: exact
(:mod:`.exact`) or the Vecchia approximation (:mod:`.vecchia`)."""
import numpy as np

from ...errors import InputError
from ..arrays import standard_scaler
from .correlation import trend_basis
from .exact import _Problem
from .vecchia import VecchiaProblem


class _Training:
    """Training data, their standardisation and the likelihood problem built on them: exact,
    or with ``vecchia`` the Vecchia approximation with ``neighbours`` (None: its default),
    conditioning in ``order`` (None: its own ordering)."""

    def __init__(self, X, Y, regression, correlation, vecchia=False, neighbours=None, order=None):
        self.X, self.Y = X, Y
        self.x_mean, self.x_scale = standard_scaler(X)
        self.y_mean, self.y_scale = standard_scaler(Y)
        Xs = (X - self.x_mean) / self.x_scale
        self.Ys = (Y - self.y_mean) / self.y_scale
        F = trend_basis(Xs, regression)
        self._inputs = (Xs, F, correlation, vecchia, neighbours)
        if np.linalg.matrix_rank(F) < F.shape[1]:
            raise InputError(f"the {regression} trend cannot be estimated from these points (an "
                             f"input is constant or the points lie on a lower-dimensional "
                             f"surface): use a lower-order trend or drop that input")
        if not vecchia:
            self.problem, self.order = _Problem(Xs, F, correlation), None
        else:
            self.problem = VecchiaProblem.of(Xs, F, correlation, neighbours, order)
            self.order = self.problem.order

    def plain(self):
        """What rebuilds :attr:`problem` exactly (:func:`problem_of`), as plain data."""
        Xs, F, correlation, vecchia, neighbours = self._inputs
        return {"Xs": Xs, "F": F, "correlation": correlation, "vecchia": vecchia, "neighbours": neighbours,
                "order": self.order}


def problem_of(plain):
    """The likelihood problem :meth:`_Training.plain` describes."""
    if not plain["vecchia"]:
        return _Problem(plain["Xs"], plain["F"], plain["correlation"])
    return VecchiaProblem.of(plain["Xs"], plain["F"], plain["correlation"], plain["neighbours"], plain["order"])
