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

Prediction is local too (:mod:`.vecchia_prediction`): every training point gets a predictor on
its nearest training points, and a target takes that of its nearest training point.

The settings, with what was measured for them (one core, 3 error components, one θ per
component), are the constants below.  What the approximation still cannot do: on a smooth
field measured with noise the Vecchia likelihood's optimum is off, so up to
EXACT_SEARCH_UP_TO points the hyperparameters maximise the exact likelihood, found from
the optima of a block-independent stand-in (spatially compact blocks of at most BLOCK_POINTS
points taken as independent, O(n·BLOCK_POINTS²)) and refined on the exact one (O(n³) per
step, a few steps); above, such a field's θ and nugget are those of the Vecchia likelihood
(bench field with 0.01 mm noise, n = 10,000, exact products with C: held-out RMS 1.41e-3
mm with them, 1.12e-3 with exact Kriging's θ and nugget from 2,000 of those points).
Noise-free, k
neighbours interpolate less closely than all n points (bench field, n = 2,000: 5e-6 against
9e-8 mm RMS), far below any measurement's resolution.
The coarse-to-fine ordering was chosen for the literature's reasons (Guinness 2018:
maxmin-like orders approximate the likelihood far better than coordinate orders); random
ordering was not measured here.
"""
import math

import numpy as np

from .bordered import _back_substitute, _bordered_factor, _Failed, _squared_distances
from .correlation import JITTER_START, MAX_CONDITION, correlation_from_squared, matern52_slope
from .stand_ins import _BlockProblem, _Dense, _ExactInOrder, spatial_blocks
from . import vecchia_prediction
from .vecchia_prediction import VecchiaState

# Neighbours m of every point in the likelihood (prediction: PREDICTION_SET_FACTOR).  Measured
# on the bench's smooth field with 0.01 mm noise (n = 2,000, 3 outputs, one core; held-out
# RMS, exact Kriging 2.2e-3 mm; a one-round search): m = 10, 20, 30, 40 in the likelihood
# (30 in prediction): fit 0.9, 2.0, 4.6, 7.2 s, RMS 6.8e-3, 5.2e-3, 5.2e-3, 5.3e-3 mm; with
# the earlier predictor (each target on its own nearest noisy readings; 30 in the likelihood)
# 15, 20, 30, 40 neighbours: 6.9e-3, 6.0e-3, 5.2e-3, 4.9e-3 mm at 1, 1.5, 2.9 and 5.8 times
# the time of 15.  On the UR10's residuals m = 30 lands within 2 % of exact Kriging.
NEIGHBOURS = 30
# Points factorised at once: (BLOCK, m + 1 + r, m + 1 + r) doubles per array, 8 MB at m = 30.
BLOCK = 1024
# The hyperparameter search (several starts, L-BFGS-B) runs on the first SEARCH_POINTS points
# of the ordering, which spread over the whole input box, SEARCH_ROUNDS runs per start with
# the neighbours re-found in the metric of θ at the start of each (one run kept the
# neighbours of the standardised inputs and missed the UR10's strongly anisotropic optimum:
# held out 0.340 mm against exact Kriging's 0.308 on series B's 70 % split; two runs 0.306).
# Searching on 500 or 1,000 of those 1,046 poses gave 0.335 and 0.323 mm.  REFINE_OPTIONS
# then bound one run on all points from the search's optimum (n = 10,000: 25 s of fit; 26 s
# with the local predictors built, one core, nothing else running).
SEARCH_POINTS = 2000
SEARCH_ROUNDS = 2
# Up to this many points the search maximises the exact likelihood (on all of them, as exact
# Kriging, up to BLOCK_SEARCH_ABOVE; above, from the block stand-in below): on a smooth field
# measured with noise the Vecchia likelihood's optimum is off (its θ and nugget with the
# exact predictor: held-out RMS 1.33 times exact Kriging's on the bench field at n = 2,000
# with 0.01 mm noise; the exact likelihood prefers exact Kriging's by 6 to 20 log-units per
# output, the Vecchia one its own, by 8 to 12 still at m = 60).  The exact likelihood on a
# subset and no refinement was as good there (1,000 of the 2,000: +0.7 %) but not on the
# UR10 (series A, 2,000 poses, held out on the rest: kriging 0.289, hybrid 0.224 mm against
# 0.255 and 0.203 with the Vecchia refinement on all, which brings the noisy field's bias
# back: 1.31 times exact).  Above, the Vecchia search as below: the exact likelihood's O(n³)
# would exceed the fit budget (n = 10,000 in 30 s).
EXACT_SEARCH_UP_TO = 2000
REFINE_OPTIONS = {"maxiter": 15, "ftol": 1e-6, "gtol": 1e-4, "maxls": 5}
# Above BLOCK_SEARCH_ABOVE points (and up to EXACT_SEARCH_UP_TO) the search for the exact
# likelihood's optimum runs on a stand-in: the points cut into spatially compact blocks of
# at most BLOCK_POINTS, taken as independent (a composite likelihood; one β and σ² for all).
# A block keeps every point's near neighbours, so the nugget and the short correlation
# lengths of the UR10's residual are seen at the data's own density, and its likelihood is
# exact, so a noisy smooth field's θ is not pulled off as by the Vecchia likelihood.  One
# step on the exact likelihood costs what five on 500-point blocks do at n = 1,495.  The
# stand-in's runs start from the best scaled theta0 (search.SCALE_DECADES) and the best
# screened candidates, BLOCK_STARTS of them
# up to BLOCK_STARTS_UP_TO points and BLOCK_STARTS_ABOVE above; ends further apart than
# EXACT_REFINE_OPTIONS["apart"] are judged by the exact likelihood, and the best is refined
# on it by quasi-Newton steps (search._quasi_newton) that start from the stand-in's
# curvature there (EXACT_REFINE_OPTIONS: at most "evaluations" steps, until the predicted
# gain is below "tolerance" log-units, none longer than "longest" in log θ or log nugget).
# The stand-in's curvature is a third to three times the exact one's (bench field, n = 2,000,
# each output at its optimum), and two to four steps reach the optimum L-BFGS-B reached in
# eleven evaluations of the exact likelihood (each 0.2 to 0.3 s of CPU at n = 2,000; its
# first steps from a new start are short).  A tolerance of 0.01 stopped the steps along a
# flat direction of the nugget (θ and nugget 0.1 off in log, predictions 1e-3 of the
# outputs' spread off, tests/test_vecchia.py); 0.001 costs a step more, at most.
# One start above 1,500 points: bench field, n = 2,000, 0.01 mm noise, CPU s on a machine
# with load average 8 to 11 (2 cores): L-BFGS-B refinement (as before) 12.7 s, held-out RMS
# 2.249e-3 mm; quasi-Newton, 2 starts 8.0 s, 2.255e-3; 1 start 4.8 s, 2.265e-3, the exact
# log-likelihood summed over the outputs 0.1 below.  UR10 A, 2,000 random poses (seed 0),
# held out on the other 9,911: kriging mean/RMS/max 0.2591, 0.3745, 2.414 mm against 0.2592,
# 0.3784, 2.578 before; hybrid 0.1855, 0.2366, 1.210 against 0.1856, 0.2366, 1.209 (before: 10.6
# and 10.2 s of CPU; now 6.2 and 5.7).  Blocks of 250 or 350 points: 6.5 and 7.3 s (two
# starts), the exact steps then need four steps per output.  From the best scaled theta0
# (search.SCALE_DECADES) instead of theta0: kriging 0.2553 mm, hybrid 0.1924 (one component
# in another local optimum, 131 below on the exact likelihood; 5.4 and 5.1 s of CPU at a
# load average of 3); over the ten training sets of ``bench/kriging.py --search
# --search-splits`` (747 to 2,000 poses, kriging and hybrid, 20 fits) held-out mean error
# 0.983 to 1.037 times the one before (geometric mean 1.000), the exact log-likelihood summed
# over their 60 components 51 lower (the exact search on all points: 0.993 and 449 higher).
# Before (L-BFGS-B refinement, two starts above 1,500 points), against the exact search on
# all points, one core, CPU s (bench/kriging.py --search, load average 3.1 to 4.4):
#   hybrid on all 1,495 UR10 B poses: 12.8 s against 29.3 s; the exact log-likelihood 20
#   units higher (on one error component, the same on the others);
#   UR10 A, 2,000 random poses: kriging mean 0.2592 against 0.2616 mm, hybrid 0.1924 against
#   0.1929 (14.2 and 14.0 s against 31.0 and 28.7);
#   eight more random training sets of series A and B (1,196 to 2,000 poses; kriging and
#   hybrid, 16 fits): held-out mean error 0.971 to 1.020 times (geometric mean 0.999), the
#   exact log-likelihood summed over their 48 components 184 units higher.
# Stand-ins measured before: the exact likelihood of half of the points (a random half, the
# first half of the order), refined on all: UR10 A 2,000 hybrid +3.7 % and +4.7 % held out
# (their optima lay in other basins); the Vecchia likelihood (m = 30) refined on the exact
# one: as accurate, but 16 s on all of series B (m = 15 or 20: +7 % and +43 % on A 2,000);
# blocks of 750 points: as accurate, 15.6 s; 2 or 3 starts on 500-point blocks at n ≤ 1,500:
# held-out up to +2.9 % on B (a worse optimum of one component).  The Vecchia search at
# n = 2,000 (bench field, as above): 4.1 s, held-out RMS 2.70e-3 mm.
BLOCK_SEARCH_ABOVE = 1000
BLOCK_POINTS = 500
BLOCK_STARTS = 4
BLOCK_STARTS_UP_TO = 1500
BLOCK_STARTS_ABOVE = 1
EXACT_REFINE_OPTIONS = {"evaluations": 8, "tolerance": 0.001, "longest": 2.0, "apart": 0.5}


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
    from scipy.spatial import cKDTree  # loaded when used: the command line starts faster
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


class VecchiaProblem:
    """The Vecchia likelihood of one fit's standardised data, with the interface of the exact
    problem in :mod:`.exact` (``condition``, ``final``, ``focus``,
    ``search_problem``).

    X (n, d) and F (n, p) are the standardised inputs and trend columns *in the problem's
    order*; ``rows`` (n,) are the rows of the caller's outputs in that order (``condition``
    takes the outputs in the caller's order).  Build one with :meth:`of`.
    """

    ROUNDS = SEARCH_ROUNDS

    def __init__(self, X, F, correlation, neighbours, rows):
        self.X, self.F = X, F
        self.correlation = correlation
        self.neighbours = int(neighbours)
        self.rows = np.asarray(rows)
        self._focus_key = None
        self._nb = None  # found by focus, at the latest when first conditioned
        self._exact_problem = self._blocks = None  # the search's, built when first asked for

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
        """The fewest starts of a search left to its default: on the block stand-in
        BLOCK_STARTS up to BLOCK_STARTS_UP_TO points and BLOCK_STARTS_ABOVE above, else one,
        as the exact model."""
        n = len(self.X)
        if BLOCK_SEARCH_ABOVE < n <= EXACT_SEARCH_UP_TO:
            return BLOCK_STARTS if n <= BLOCK_STARTS_UP_TO else BLOCK_STARTS_ABOVE
        return 1

    def search_problem(self):
        """The problem the hyperparameter search runs on: the exact likelihood of all the
        points up to BLOCK_SEARCH_ABOVE of them, up to EXACT_SEARCH_UP_TO the likelihood of
        independent blocks of them (then refined on the exact one), else the Vecchia
        likelihood of the first SEARCH_POINTS points of the order, which spread over the box
        (then refined on all).  The exact and block problems are built once for all searches
        of this problem (their squared differences take 8·d·n² bytes)."""
        n = len(self.X)
        if n <= BLOCK_SEARCH_ABOVE:
            return self._exact()
        if n <= EXACT_SEARCH_UP_TO:
            if self._blocks is None:
                self._blocks = _BlockProblem(self.X, self.F, self.correlation, self.rows,
                                             spatial_blocks(self.X, -(-n // BLOCK_POINTS)))
            return self._blocks
        count = min(SEARCH_POINTS, n)
        if count == n:
            return self
        return VecchiaProblem(self.X[:count], self.F[:count], self.correlation, self.neighbours,
                              self.rows[:count])

    def refinement(self, search):
        """(problem, L-BFGS-B options) on which the optimum found on the ``search`` problem
        is refined: the exact likelihood after the block stand-in, the Vecchia likelihood of
        all points after that of a part of them; None when the search was on either itself."""
        if search is self or isinstance(search, _ExactInOrder):
            return None
        if isinstance(search, _BlockProblem):
            return self._exact(), EXACT_REFINE_OPTIONS
        return self, REFINE_OPTIONS

    def _exact(self):
        if self._exact_problem is None:
            self._exact_problem = _ExactInOrder(self.X, self.F, self.correlation, self.rows)
        return self._exact_problem

    def final(self, theta, nugget, Y, start_jitter=0.0):
        """The state at θ with the neighbours found in θ's own metric, ready to predict: what
        a fit ends with and a saved model is rebuilt from.  The searches are over: their
        exact and block problems are let go, once the exact one has handed over the factor of
        the best state it saw for these outputs, if at θ and the nugget (it saves the
        prediction's conjugate gradients)."""
        self._blocks = None
        exact = self._exact_problem
        factor = None if exact is None else exact.best_factor(theta, nugget, Y)
        if exact is not None and not exact._best:
            self._exact_problem = None
        self.focus(theta)
        state = self.condition(theta, nugget, Y, start_jitter)
        direct = nugget > 0 and len(self.X) <= min(EXACT_SEARCH_UP_TO, vecchia_prediction.NOISE_FREE_UP_TO)
        if direct and (factor is None or factor[1] != state.jitter):
            # Factorised afresh as the search did (a model read from its file, a search that
            # ended elsewhere): the same factor, so a saved model predicts as the fitted one.
            _, _, L, jitter, _ = _Dense(self.X, self.F, self.correlation).factor(theta, nugget, state.jitter)
            factor = (L, jitter)
        state.prepare_prediction(self, factor if direct and factor[1] == state.jitter else None)
        return state

    def factors(self, theta, diagonal_add):
        """Each point's b_i (n, m) and d_i (n,) at θ with ``diagonal_add`` on the diagonal
        (the neighbours of the last ``focus``): the Vecchia factor of C⁻¹ ≈ Uᵀ D⁻¹ U, with
        (U v)_i = v_i − b_iᵀ v_N(i) in the problem's order."""
        if self._nb is None:
            self.focus(None)
        n, m = self._nb.shape
        factors = {"b": np.zeros((n, m)), "d": np.ones(n)}
        self._accumulate(np.asarray(theta, dtype=float), diagonal_add, np.zeros((n, 0)), False, factors)
        return factors["b"], factors["d"]

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

    def _accumulate(self, theta, diagonal_add, Y, gradient, factors=None):
        """One pass over the blocks: the whitened outputs and trend, Σ log d_i, a lower bound
        of the worst condition number and (with ``gradient``) the sums of the gradient; with
        ``factors`` (a dict) also each point's b_i (n, m) and d_i (n,) under "b" and "d".
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
            if factors is not None:
                factors["b"][rows] = _back_substitute(L[:, :m, :m], L[:, m, :m, None])[:, :, 0]
                factors["d"][rows] = s ** 2
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

