"""Vecchia approximation of the Kriging likelihood and predictor (Vecchia 1988; Katzfuss &
Guinness 2021), for training sets too large for the exact O(n³) fit.

The training points are put in an order x_1 … x_n.  The joint density of the data is the
product of the conditionals p(y_i | y_1 … y_{i−1}); the approximation conditions each y_i on
its m nearest previously ordered points N(i) only:

    y_i | y_N(i) ~ N(f_iᵀβ + b_iᵀ(y_N − F_N β), σ² d_i),
    b_i = A_i⁻¹ c_i,   d_i = C_ii − c_iᵀ b_i,   A_i = C[N(i), N(i)],   c_i = C[N(i), i],

with C = R + (nugget + jitter) I as in :mod:`robocal.estimation.kriging`.  The whitened values
ỹ_i = (y_i − b_iᵀ y_N)/√d_i and F̃_i = (F_i − b_iᵀ F_N)/√d_i turn the likelihood into ordinary
least squares, so β̂ and σ̂² come out as in the exact model and

    ℓ(θ) = −½ (n log σ̂²(θ) + Σ_i log d_i + n (1 + log 2π)).

With m ≥ n − 1 every point is conditioned on all earlier ones and ℓ is the exact likelihood.
The cost is O(n m³) in time and O(n m) in memory, computed over blocks of points: each
point's (m + 1) × (m + 1) correlation matrix, bordered by its neighbours' outputs and trend
columns, is factorised in one batched Cholesky, whose last rows hold L⁻¹[Y_N, F_N], √d_i and
the whitened ỹ_i, F̃_i directly (for any large diagonal in the border the lower-left block of
the factor of [[A, B], [Bᵀ, D]] is (L_A⁻¹B)ᵀ).

The gradient in log θ (and log nugget) is analytic.  As for the exact model the envelope
theorem removes β̂ and σ̂²; per point and parameter k, with u_i = y_i − b_iᵀ y_N,
g_i = A_i⁻¹(y_N − F_N β̂), b̂_i = (b_i, −1) and ∂K the derivative of the point's
(m + 1)-matrix,

    ∂d_i = b̂_iᵀ ∂K b̂_i,   ∂u_i = (∂K b̂_i)[:m]ᵀ g_i,
    ∂ℓ = −½ Σ_i [∂d_i (1/d_i − u_i²/(σ̂² d_i²)) + 2 u_i ∂u_i /(σ̂² d_i)],

and since u_i and g_i are linear in (1, −β̂) the sums are accumulated in one pass, before β̂
is known.

Prediction conditions each target on its m nearest training points (in the metric of θ),
batched the same way:

    ŷ(x) = f(x)ᵀβ̂ + rᵀA⁻¹(y_N − F_N β̂),   MSE(x) = σ̂² (1 + uᵀ(F̃ᵀF̃)⁻¹u − rᵀA⁻¹r),
    u = F_NᵀA⁻¹r − f(x),

which is the exact predictor when m ≥ n.

The settings, with what was measured for them (one core, 3 error components, one θ per
component), are the constants below.  What the approximation cannot do: on a field that is
smooth over many data spacings and measured with noise, exact Kriging averages the noise over
hundreds of points and a predictor from m neighbours cannot (bench field with 0.01 mm noise at
n = 2,000: 2.2e-3 mm RMS exact, 5.2e-3 Vecchia; noise-free, 9e-8 against 3e-6 mm).  On the
UR10's measured errors, where the field varies within a few data spacings, the two agree to
2 %.  The coarse-to-fine ordering was chosen for the literature's reasons (Guinness 2018:
maxmin-like orders approximate the likelihood far better than coordinate orders); random
ordering was not measured here.
"""
import math

import numpy as np
from scipy.spatial import cKDTree

from .kriging import JITTER_START, MAX_CONDITION, correlation_from_squared, matern52_slope

# Neighbours m of every point in the likelihood and of every target in prediction.  Measured
# on the bench's smooth field with 0.01 mm noise (n = 2,000, 3 outputs, one core; held-out
# RMS, exact Kriging 2.2e-3 mm; a one-round search): m = 10, 20, 30, 40 in the likelihood
# (30 in prediction): fit 0.9, 2.0, 4.6, 7.2 s, RMS 6.8e-3, 5.2e-3, 5.2e-3, 5.3e-3 mm; in
# prediction (30 in the likelihood) 15, 20, 30, 40 neighbours: 6.9e-3, 6.0e-3, 5.2e-3,
# 4.9e-3 mm at 1, 1.5, 2.9 and 5.8 times the time of 15.  On the UR10's residuals m = 30
# lands within 2 % of exact Kriging.
NEIGHBOURS = 30
# Prediction targets that share one set of neighbours (see VecchiaState.predict): groups of
# the first size, then of the next for the targets left, then one by one; and targets per
# batch of factorisations.  100,000 predictions of 3 outputs from n = 2,000 (m = 30): one
# target a set 7.4 s, 16 a set 1.9 s, 32 4.1 s, 64 6.0 s (more targets fall outside the set's
# reach and go alone); with groups of 16, then 4: n = 2,000 1.2 s, 10,000 3.1 s, 100,000 7.7 s
# against 7.2, 7.0 and 7.0 s one by one, at a cost in accuracy on a noise-free field (30,000
# dense targets: RMS 1.01e-4 against 9.2e-5 mm at n = 2,000, 4.1e-5 against 3.5e-5 at 10,000;
# with 0.01 mm noise the two differ by 0.1 %).
PREDICTION_GROUPS = (16, 4)
PREDICTION_BLOCK = 4096
# A target shares its group's neighbours only within this fraction of the distance from the
# group's centre to the farthest of them.  Measured at n = 10,000 (30,000 dense targets, the
# bench field): 0.5 as accurate as one target a set (RMS 3.52e-5 against 3.51e-5 mm) but few
# targets share (the same time); 1.0 twice as fast and a third less accurate.
GROUP_REACH = 0.5
# Points factorised at once: (BLOCK, m + 1 + r, m + 1 + r) doubles per array, 8 MB at m = 30.
BLOCK = 1024
# The diagonal of the border of the bordered factorisation (see the module docstring): any
# value that keeps the matrix positive definite gives the same lower-left block.
BORDER = 1e200
# The hyperparameter search (several starts, L-BFGS-B) runs on the first SEARCH_POINTS points
# of the ordering, which spread over the whole input box, SEARCH_ROUNDS runs per start with
# the neighbours re-found in the metric of θ at the start of each (one run kept the
# neighbours of the standardised inputs and missed the UR10's strongly anisotropic optimum:
# held out 0.340 mm against exact Kriging's 0.308 on series B's 70 % split; two runs 0.306).
# Searching on 500 or 1,000 of those 1,046 poses gave 0.335 and 0.323 mm.  REFINE_OPTIONS
# then bound one run on all points from the search's optimum (n = 10,000: 25 s of fit).
SEARCH_POINTS = 2000
SEARCH_ROUNDS = 2
# Starts of a search over all points (n ≤ SEARCH_POINTS) at least, where the exact model's
# default takes one above 1,500 points: the Vecchia search costs less.  UR10 series A, the
# hybrid on 2,000 random poses, held out on the other 9,911 (mean, mm; fit CPU s): 1 start
# 0.206 (8 s), 2 starts 0.202 (16 s), 4 starts 0.185 (38 s); exact Kriging 0.193 (29 s).
SEARCH_STARTS = 2
REFINE_OPTIONS = {"maxiter": 15, "ftol": 1e-6, "gtol": 1e-4, "maxls": 5}


# ------------------------------------------------------------------------ ordering

def coarse_to_fine_order(X, seed=0):
    """An approximate maxmin ordering of the rows of X (n, d): a permutation whose first
    points spread over the whole box and whose later ones fill in between.

    Level ℓ lays a grid of cells 2^−ℓ of the box's largest side and takes, from every cell
    that holds no point taken before, one of its points (the first in a fixed random order);
    levels go on until every point is taken.  Within a level the points are in that random
    order.  Exact maxmin ordering (Guinness 2018) costs O(n²) naively; this grid form costs
    O(n log n) per level and keeps what matters for the approximation: a point late in the
    order has neighbours close by among the earlier ones, an early one far-reaching ones."""
    n, d = X.shape
    rng = np.random.default_rng(seed)
    shuffled = rng.permutation(n)
    lo = X.min(axis=0)
    side = float(np.max(X.max(axis=0) - lo))
    if n <= 2 or side == 0.0:
        return shuffled
    unit = (X[shuffled] - lo) / side  # in [0, 1]
    taken = np.zeros(n, dtype=bool)
    parts = []
    level = 0
    while not taken.all():
        cells = 2.0 ** level
        if cells > 1e15:  # repeated points: the rest in the random order
            parts.append(np.flatnonzero(~taken))
            break
        keys = np.minimum(np.floor(unit * cells), cells - 1).astype(np.int64)
        _, cell, = np.unique(keys, axis=0, return_inverse=True)
        cell = cell.reshape(-1)
        occupied = np.zeros(cell.max() + 1, dtype=bool)
        occupied[cell[taken]] = True
        free = np.flatnonzero(~taken & ~occupied[cell])
        # The first free point of each free cell (free is ascending: the random order).
        _, first = np.unique(cell[free], return_index=True)
        chosen = np.sort(free[first])
        taken[chosen] = True
        parts.append(chosen)
        level += 1
    return shuffled[np.concatenate(parts)]


def previous_neighbours(Z, m):
    """(n, m) indices of the m nearest earlier rows of Z (Euclidean) for each row, −1 where a
    row has fewer than m earlier rows; the nearest first.

    Rows are taken in blocks [start, end) with end ≤ 1.25·start: a k-d tree of rows [0, end)
    is queried for more than m neighbours, and those not earlier than the row are dropped
    (at most a fifth of the tree lies after any row of the block); a row left with fewer
    than m is queried again with more."""
    n = len(Z)
    m = int(min(m, max(n - 1, 0)))
    neighbours = np.full((n, m), -1, dtype=np.int64)
    head = min(n, m + 1)  # these condition on every earlier row
    for i in range(1, head):
        neighbours[i, :i] = np.arange(i)[::-1]
    start = head
    while start < n:
        end = min(n, max(start + 1, int(math.ceil(1.25 * start))))
        tree = cKDTree(Z[:end])
        rows = np.arange(start, end)
        k = min(end, int(1.5 * m) + 2)
        while len(rows):
            _, found = tree.query(Z[rows], k=k)
            found = found.reshape(len(rows), -1)
            earlier = found < rows[:, None]
            enough = earlier.sum(axis=1) >= m
            done = rows[enough]
            if len(done):
                # Stable: the first m earlier ones, in order of distance.
                keep = np.argsort(~earlier[enough], axis=1, kind="stable")[:, :m]
                neighbours[done] = np.take_along_axis(found[enough], keep, axis=1)
            rows = rows[~enough]
            k = min(end, 2 * k)
        start = end
    return neighbours


# ------------------------------------------------------------------- likelihood

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


class VecchiaProblem:
    """The Vecchia likelihood of one fit's standardised data, with the interface of the exact
    problem in :mod:`robocal.estimation.kriging` (``condition``, ``final``, ``focus``,
    ``search_problem``).

    X (n, d) and F (n, p) are the standardised inputs and trend columns *in the problem's
    order*; ``rows`` (n,) are the rows of the caller's outputs in that order (``condition``
    takes the outputs in the caller's order).  Build one with :meth:`of`.
    """

    REFINE_OPTIONS = REFINE_OPTIONS
    ROUNDS = SEARCH_ROUNDS

    def __init__(self, X, F, correlation, neighbours, rows):
        self.X, self.F = X, F
        self.correlation = correlation
        self.neighbours = int(neighbours)
        self.rows = np.asarray(rows)
        self._focus_key = None
        self._nb = None  # found by focus, at the latest when first conditioned

    @classmethod
    def of(cls, X, F, correlation, neighbours=None, order=None):
        """The problem of X, F in the caller's row order with ``neighbours`` (None:
        NEIGHBOURS), ordered coarse to fine (or by the given permutation ``order``)."""
        order = coarse_to_fine_order(X) if order is None else np.asarray(order)
        return cls(X[order], F[order], correlation, NEIGHBOURS if neighbours is None else neighbours, order)

    @property
    def order(self):
        return self.rows

    def focus(self, theta):
        """Condition each point on its nearest earlier points in the metric of θ (None: of
        the standardised inputs).  The neighbours stay until the next call, so that the
        likelihood is a smooth function of θ while it is optimised."""
        scale = np.ones(self.X.shape[1]) if theta is None else np.sqrt(np.asarray(theta, dtype=float))
        key = scale.tobytes()
        if key != self._focus_key:
            self._nb = previous_neighbours(self.X * scale, self.neighbours)
            self._focus_key = key

    @property
    def least_starts(self):
        """The fewest starts of a search left to its default: SEARCH_STARTS when it runs on all
        the points, else one (as the exact model)."""
        return SEARCH_STARTS if len(self.X) <= SEARCH_POINTS else 1

    def search_problem(self):
        """The problem the hyperparameter search runs on: this one up to SEARCH_POINTS
        points, else the first SEARCH_POINTS points of the order, which spread over the box."""
        if len(self.X) <= SEARCH_POINTS:
            return self
        count = SEARCH_POINTS
        return VecchiaProblem(self.X[:count], self.F[:count], self.correlation, self.neighbours,
                              self.rows[:count])

    def final(self, theta, nugget, Y, start_jitter=0.0):
        """The state at θ with the neighbours found in θ's own metric, ready to predict: what
        a fit ends with and a saved model is rebuilt from."""
        self.focus(theta)
        return self.condition(theta, nugget, Y, start_jitter)

    def condition(self, theta, nugget, Y, start_jitter=0.0, gradient=False):
        """Condition the process on ``Y`` (n, q) (the caller's row order) at θ and the nugget:
        a :class:`VecchiaState`, with ``gradient`` (d log-likelihood / d log θ, and / d log
        nugget, summed over the columns) when asked for."""
        theta = np.asarray(theta, dtype=float)
        Y = Y[self.rows]
        if self._nb is None:
            self.focus(None)
        m = self._nb.shape[1]
        jitter, first_condition = start_jitter, None
        while True:
            try:
                sums = self._accumulate(theta, nugget + jitter, Y, gradient)
                if first_condition is None:
                    first_condition = sums["condition"]
                break
            except _Failed:
                if first_condition is None:
                    first_condition = np.inf
                jitter = JITTER_START * (m + 1) if jitter == 0 else jitter * 10.0
        n, q = Y.shape
        Q, G = np.linalg.qr(sums["F"])
        beta = np.linalg.solve(G, Q.T @ sums["Y"])
        residual = sums["Y"] - sums["F"] @ beta
        sigma2 = np.maximum(np.einsum("ij,ij->j", residual, residual) / n, 1e-300)
        log_likelihood = -0.5 * (n * np.log(sigma2) + sums["log_det"] + n * (1.0 + math.log(2 * math.pi)))
        state = VecchiaState(self, theta, nugget, jitter, first_condition, beta, sigma2, G, log_likelihood,
                             Y - self.F @ beta)
        if gradient:
            state.gradient = self._gradient(sums, beta, sigma2, q, nugget)
        return state

    def _accumulate(self, theta, diagonal_add, Y, gradient):
        """One pass over the blocks: the whitened outputs and trend, Σ log d_i, a lower bound
        of the worst condition number and (with ``gradient``) the sums of the gradient.
        The last points of the order, whose neighbours lie closest together, come first: a
        factorisation that needs jitter fails there, before the pass has cost much."""
        n, d = self.X.shape
        q, p = Y.shape[1], self.F.shape[1]
        r = q + p
        Z = self.X * np.sqrt(theta)
        values = np.hstack([Y, self.F])  # (n, r)
        whitened = np.empty((n, r))
        log_det, worst_pivot = 0.0, np.inf
        sums = {"a": np.zeros(d + 1), "Q1": np.zeros((d + 1, r, r)), "Q2": np.zeros((d + 1, r, r))}
        for start in range(BLOCK * ((n - 1) // BLOCK), -1, -BLOCK):
            rows = np.arange(start, min(n, start + BLOCK))
            nb = self._nb[rows]
            m = nb.shape[1]
            valid = nb >= 0
            safe = np.where(valid, nb, 0)
            # The point last; coordinates relative to it (distances are the same, rounding less).
            points = np.concatenate([Z[safe], Z[rows][:, None, :]], axis=1) - Z[rows][:, None, :]
            S = _squared_distances(points)
            R = correlation_from_squared(S, self.correlation, out=np.empty_like(S))
            inside = np.concatenate([valid, np.ones((len(rows), 1), dtype=bool)], axis=1)
            pair = inside[:, :, None] & inside[:, None, :]
            R *= pair
            R[:, np.arange(m + 1), np.arange(m + 1)] = 1.0  # a missing neighbour: independent
            try:
                L = _bordered_factor(R, diagonal_add, values[safe] * valid[:, :, None], values[rows])
            except np.linalg.LinAlgError:
                raise _Failed from None
            pivots = np.diagonal(L[:, :m + 1, :m + 1], axis1=1, axis2=2)
            smallest = float(np.min(pivots))
            if not smallest > 0 or 1.0 / smallest ** 2 > MAX_CONDITION:
                raise _Failed
            worst_pivot = min(worst_pivot, smallest)
            s = L[:, m, m]  # √d_i
            log_det += 2.0 * float(np.log(s).sum())
            whitened[rows] = L[:, m + 1:, m]
            if gradient:
                self._gradient_sums(sums, L, S, R, points, pair, s, m, q)
        sums.update(Y=whitened[:, :q], F=whitened[:, q:], log_det=log_det, condition=1.0 / worst_pivot ** 2)
        return sums

    def _gradient_sums(self, sums, L, S, R, points, pair, s, m, q):
        """Add a block's terms: a_k = Σ ∂d/d, Q1_k = Σ (∂d/d²) w wᵀ, Q2_k = Σ (1/d) w h_kᵀ,
        with w = (u_Y, u_F) the unwhitened innovations and h_k = (∂K b̂)[:m]ᵀ A⁻¹[Y_N, F_N];
        k runs over the d inputs (in log θ) and the nugget."""
        d = points.shape[2]
        L_A = L[:, :m, :m]
        v = L[:, m, :m]
        W = L[:, m + 1:, :m]  # (L_A⁻¹ [Y_N, F_N])ᵀ
        solved = _back_substitute(L_A, np.concatenate([v[:, :, None], np.swapaxes(W, 1, 2)], axis=2))
        b, G = solved[:, :, 0], solved[:, :, 1:]  # A⁻¹c, A⁻¹[Y_N, F_N]
        b_hat = np.concatenate([b, -np.ones((len(b), 1))], axis=1)  # (B, m + 1)
        # dR/dS: the Gaussian's is −R; the diagonal never counts (zero squared distance).
        slope = -R if self.correlation == "gaussian" else matern52_slope(S) * pair
        # (∂K_k b̂)_j = Σ_l slope_jl (p_jk − p_lk)² b̂_l, from one product with [b̂, p b̂, p² b̂].
        columns = np.concatenate([b_hat[:, :, None], points * b_hat[:, :, None],
                                  points ** 2 * b_hat[:, :, None]], axis=2)
        product = slope @ columns  # (B, m + 1, 1 + 2d)
        T = (points ** 2 * product[:, :, :1] - 2.0 * points * product[:, :, 1:1 + d]
             + product[:, :, 1 + d:])  # (B, m + 1, d)
        T = np.concatenate([T, b_hat[:, :, None]], axis=2)  # the nugget: ∂K = I
        d_i = s ** 2
        dd = np.einsum("bj,bjk->bk", b_hat, T)  # ∂d_i, (B, d + 1)
        h = np.einsum("bjk,bjr->bkr", T[:, :m, :], G)  # (B, d + 1, r)
        w = s[:, None] * L[:, m + 1:, m]  # unwhitened innovations (B, r)
        sums["a"] += (dd / d_i[:, None]).sum(axis=0)
        sums["Q1"] += np.einsum("bk,br,bs->krs", dd / d_i[:, None] ** 2, w, w)
        sums["Q2"] += np.einsum("b,br,bks->krs", 1.0 / d_i, w, h)

    @staticmethod
    def _gradient(sums, beta, sigma2, q, nugget):
        """(d ℓ/d log θ (d,), d ℓ/d log nugget), summed over the q outputs."""
        total = np.zeros(len(sums["a"]))
        for j in range(q):
            rho = np.concatenate([np.eye(q)[j], -beta[:, j]])
            quadratic1 = np.einsum("r,krs,s->k", rho, sums["Q1"], rho)
            quadratic2 = np.einsum("r,krs,s->k", rho, sums["Q2"], rho)
            total += -0.5 * (sums["a"] - quadratic1 / sigma2[j] + 2.0 * quadratic2 / sigma2[j])
        return total[:-1], nugget * total[-1]


class VecchiaState:
    """A Vecchia fit at fixed θ (standardised units), as the exact model's state: θ, nugget,
    jitter, condition (a lower bound, inf if the factorisation failed without jitter), β̂,
    σ̂², the log-likelihood; G the R factor of the whitened trend (F̃ᵀF̃ = GᵀG) and the
    standardised training residuals y − Fβ̂ (in the problem's order) for prediction."""

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
        self._tree = None

    def predict(self, Xs, f, with_mse):
        """(standardised mean (N, q), mse in units of σ̂² (N,) or None) at the standardised
        points Xs (N, d) whose trend columns are f (N, p).

        Targets are conditioned on their nearest training points in the metric of θ, the
        exact model's formulas on those (C = R + (nugget + jitter)·I); with m ≥ n they are the
        exact model's predictions.  Targets are sorted along a space-filling curve and taken
        PREDICTION_GROUPS[0] at a time: a group shares the m training points nearest its
        centre, factorised once, if every target of it lies within GROUP_REACH of the distance
        from that centre to the m-th of them; the other targets are grouped again by the next
        size, and those left at the end get their own m nearest."""
        scale = np.sqrt(self.theta)
        if self._tree is None:
            self._tree = cKDTree(self._X * scale)
        k = min(self.neighbours, len(self._X))
        Z = Xs * scale
        mean = f @ self.beta
        mse = np.empty(len(Xs)) if with_mse else None
        left = _curve_order(Z)  # the targets not predicted yet, along the curve
        batches = []
        for size in PREDICTION_GROUPS + (1,):
            whole = len(left) // size
            groups = left[:whole * size].reshape(whole, size)
            reach, shared = self._tree.query(Z[groups].mean(axis=1), k=k)
            reach, shared = reach.reshape(whole, k), shared.reshape(whole, k)
            offset = np.linalg.norm(Z[groups] - Z[groups].mean(axis=1, keepdims=True), axis=2)
            together = np.all(offset <= GROUP_REACH * reach[:, -1:], axis=1) | (size == 1)
            batches.append((groups[together], shared[together]))
            left = np.concatenate([groups[~together].ravel(), left[whole * size:]])
        for targets, neighbours in batches:
            step = max(1, PREDICTION_BLOCK // targets.shape[1])
            for start in range(0, len(targets), step):
                block = slice(start, start + step)
                self._predict_groups(Z, f, targets[block], neighbours[block], mean, mse)
        return mean, mse

    def _predict_groups(self, Z, f, targets, neighbours, mean, mse):
        """Fill ``mean`` (and ``mse``) at the rows ``targets`` (G, g) of Z, each group of g
        conditioned on its training points ``neighbours`` (G, k)."""
        groups, g = targets.shape
        k = neighbours.shape[1]
        q = self._residual.shape[1]
        centre = Z[targets].mean(axis=1, keepdims=True)  # coordinates relative to it: less rounding
        training = self._tree.data[neighbours] - centre
        points = Z[targets] - centre
        A = correlation_from_squared(_squared_distances(training), self._correlation)
        cross = (np.einsum("gkd,gkd->gk", training, training)[:, :, None]
                 + np.einsum("gtd,gtd->gt", points, points)[:, None, :]
                 - 2.0 * training @ np.swapaxes(points, 1, 2))
        r = correlation_from_squared(np.maximum(cross, 0.0, out=cross), self._correlation)  # (G, k, g)
        borders = [r, self._residual[neighbours]] + ([self._F[neighbours]] if mse is not None else [])
        L = _factor_in_prediction(A, self.nugget + self.jitter, np.concatenate(borders, axis=2))
        v = L[:, k:k + g, :k]  # (L⁻¹r_t)ᵀ per target
        mean[targets] += np.einsum("gtk,gck->gtc", v, L[:, k + g:k + g + q, :k])
        if mse is not None:
            u = np.einsum("gtk,gck->gtc", v, L[:, k + g + q:, :k]) - f[targets]  # F_NᵀA⁻¹r − f
            w = np.linalg.solve(self.G.T, u.reshape(groups * g, -1).T)  # uᵀ(GᵀG)⁻¹u = |w|²
            mse[targets] = np.maximum(1.0 + np.einsum("ij,ij->j", w, w).reshape(groups, g)
                                      - np.einsum("gtk,gtk->gt", v, v), 0.0)


def _curve_order(Z, bits=None):
    """An order of the rows of Z (N, d) along a Morton (Z-order) curve: rows close in the
    order are close in space, so consecutive rows can share neighbours."""
    N, d = Z.shape
    bits = min(21, 63 // d) if bits is None else bits
    lo = Z.min(axis=0)
    side = float(np.max(Z.max(axis=0) - lo)) or 1.0
    cells = np.minimum(((Z - lo) / side * (2 ** bits)).astype(np.uint64), np.uint64(2 ** bits - 1))
    code = np.zeros(N, dtype=np.uint64)
    for bit in range(bits):
        for j in range(d):
            code |= ((cells[:, j] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(bit * d + j)
    return np.argsort(code, kind="stable")
