"""The exact Kriging predictor at one point: its mean and mean squared error, prepared once per
fitted model.  ``Kriging.predict`` of one row takes this path; ``robocal serve`` asks for it
twice a request (the mean at the target, the MSE of the 95 % bound at the command's position).

The batch predictor (:meth:`.model.Kriging._predict_block`) spends most of its 45 µs for the
mean of one point, and 140 µs with its MSE (500 training points, 3 outputs with their own θ),
on array set-up.  Here the same formulas (package docstring) run on one point, with what does
not depend on it taken from the fit once.  Per group of outputs sharing θ:

* the cross-correlations r = R(x, X) (n,), by the batch's product of augmented coordinates;
* the mean f(x)ᵀβ + rᵀα;
* for the MSE, one triangular solve v = L⁻¹r (BLAS ``dtpsv`` on the fit's Cholesky factor),
  which gives both rᵀC⁻¹r = |v|² and FᵀC⁻¹r = F̃ᵀv (F̃ = L⁻¹F, stored), then the trend's
  w = G⁻ᵀ(F̃ᵀv − f) with the R factor G of F̃ inverted once (p × p).

That solve reads L's lower triangle, n²/2 floats (1 MB at n = 500): what is left of the cost
is memory traffic, not arithmetic or set-up.  The formulas are the batch's, so that one point
agrees with its row of a batch to rounding (``tests/test_model_sigma.py``).  The
Vecchia approximation keeps its own predictor (local, O(k) per point): :func:`point_predictor`
returns None for it.
"""
import numpy as np
from scipy.linalg import blas

from .correlation import correlation_from_squared


def point_predictor(model):
    """The :class:`PointPredictor` of a fitted exact ``model`` (a :class:`.model.Kriging`),
    built at its first use and kept with the fit it is of; None for a Vecchia fit."""
    point = model.__dict__.get("_point")
    if point is None or point.states is not model._states:  # fitted again since
        point = model._point = None if model.approximation_ == "vecchia" else PointPredictor(model)
    return point


class PointPredictor:
    """One point of a fitted exact Kriging: ``predict`` gives the mean (m,) and MSE (m,) of one
    input (d,) in the units of ``fit``'s X and Y (mm and mm² for the position error model).

    The G groups of outputs sharing θ (one per output, or one for all with ``shared_theta``)
    are stacked, so that their cross-correlations, means and dot products are one numpy call
    each; only the triangular solves go group by group.  Groups hold k outputs each, and the
    groups' columns in order are the outputs'.
    """

    def __init__(self, model):
        self.states = model._states  # the fit this is of (point_predictor checks it)
        self.regression, self.correlation = model.regression, model.correlation
        self.x_mean, self.x_scale = model._x_mean.tolist(), model._x_scale.tolist()
        # A point beyond the training box and its margin gets the batch's warning
        # (Kriging._warn_extrapolation); the test is the batch's, on floats.
        _, low, high, margin, _ = model._training_box()
        self.box = (low.tolist(), high.tolist(), margin.tolist())
        states, groups = model._states, model._groups
        self.root_theta = [np.sqrt(state.theta).tolist() for state in states]  # as the batch scales
        self.factors = np.stack(model._training_factors)  # (G, d + 2, n): Kriging._cross_correlation's
        self.beta = np.stack([state.beta for state in states])  # (G, p, k)
        self.alpha = np.stack([state.alpha.T for state in states])  # (G, k, n)
        # L's lower triangle column by column (BLAS packed storage), for dtpsv: one stream of
        # n²/2 floats, read faster than the triangle of the full (n, n) factor by dtrsv (3
        # groups of n = 500: 45 against 49 µs on a quiet machine; 83–95 against 99–117 µs,
        # best of 500 calls, at a load of 5 to 7 on its 2 cores), for n²/2 more floats kept.
        self.packed = [np.ascontiguousarray(state.L.T[np.triu_indices(len(state.L))]) for state in states]
        self.Ft = np.stack([state.Ft.T for state in states])  # (G, p, n): L⁻¹F
        # G⁻ᵀ (G, p, p), G the upper triangular factor of FᵀC⁻¹F = GᵀG: the trend's part of
        # the MSE, |G⁻ᵀu|², is then one product for all groups (p ≤ 10 for three inputs).
        self.G_inverse_T = np.stack([np.linalg.inv(state.G).T for state in states])
        self.y_mean = np.stack([model._y_mean[cols] for cols in groups])  # (G, k)
        self.y_scale = np.stack([model._y_scale[cols] for cols in groups])
        self.mse_scale = np.stack([state.sigma2 for state in states]) * self.y_scale ** 2  # σ̂², Y's units²
        d = len(self.x_mean)
        self.pairs = list(zip(*np.triu_indices(d))) if self.regression == "quadratic" else []

    def outside_box(self, x):
        """Whether the point ``x`` (d floats, X's units) lies farther outside the training box
        than predict warns of."""
        return any(lo - v > 0.0 or v - hi - m > 0.0 for v, lo, hi, m in zip(x, *self.box))

    def predict_row(self, X, with_mse):
        """:meth:`predict` of the one row of X (1, d) as (mean (1, m), MSE (1, m) or None,
        whether the point lies beyond the training box: Kriging.predict warns of it)."""
        x = X[0].tolist()
        mean, mse = self.predict(x, with_mse)
        return mean[None], None if mse is None else mse[None], self.outside_box(x)

    def predict(self, x, with_mse):
        """(mean (m,), MSE (m,) or None) at one point ``x`` (d floats, X's units)."""
        xs = [(v - mean) / scale for v, mean, scale in zip(x, self.x_mean, self.x_scale)]
        f = [1.0]  # trend_basis's columns: 1, then x_i, then x_i x_j (i <= j)
        if self.regression != "constant":
            f += xs
            f += [xs[i] * xs[j] for i, j in self.pairs]
        f = np.array(f)
        augmented = []  # [a, |a|², 1] of each group, a the θ-scaled point
        for root in self.root_theta:
            a = [v * w for v, w in zip(xs, root)]
            squared = 0.0
            for v in a:
                squared += v * v
            augmented.append(a + [squared, 1.0])
        minus_S = (np.array(augmented)[:, None, :] @ self.factors)[:, 0]  # (G, n)
        if self.correlation == "gaussian":
            r = np.exp(minus_S, out=minus_S)
        else:
            S = np.maximum(np.negative(minus_S, out=minus_S), 0.0, out=minus_S)
            r = correlation_from_squared(S, self.correlation, out=S)
        standard = f @ self.beta + (self.alpha @ r[:, :, None])[:, :, 0]  # (G, k)
        mean = (self.y_mean + self.y_scale * standard).reshape(-1)
        if not with_mse:
            return mean, None
        for g, packed in enumerate(self.packed):
            r[g] = blas.dtpsv(len(r[g]), packed, r[g], lower=1)  # v = L⁻¹r, in r's place
        v = r
        u = (self.Ft @ v[:, :, None])[:, :, 0] - f  # FᵀC⁻¹r − f, (G, p)
        w = (self.G_inverse_T @ u[:, :, None])[:, :, 0]  # G⁻ᵀu: uᵀ(GᵀG)⁻¹u = |w|²
        unit = 1.0 + np.einsum("ij,ij->i", w, w) - np.einsum("ij,ij->i", v, v)  # (G,)
        return mean, (np.maximum(unit, 0.0)[:, None] * self.mse_scale).reshape(-1)
