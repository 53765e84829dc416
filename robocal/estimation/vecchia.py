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

Prediction is local too.  Every training point j gets, once per fit, a predictor on the set
S_j of its k = ⌈4m/3⌉ nearest training points (itself included, in the metric of θ):

    ŷ(x) = f(x)ᵀβ̂ + r(x, S_j)ᵀ c_j,   c_j = A_j⁻¹ w_S,

and a target takes the predictor of its nearest training point: one nearest-point search and
O(k) per target.  With noise (a nugget τ²) exact Kriging averages the readings over every
point within the correlation length, hundreds of them on a smooth field, and k noisy
neighbours cannot (the predictor that conditioned each target on its m nearest readings: 1.3
to 2.3 times the exact held-out error on smooth noisy fields, all of it the predictor's: with
the exact θ and nugget it was as far off).  So w is the posterior mean of the noise-free
field at the training points,

    w = ỹ − τ² C⁻¹ỹ,   ỹ = y − Fβ̂,   A_j = R[S_j, S_j] + jitter·I,

with C⁻¹ỹ from conjugate gradients (the Vecchia factor C⁻¹ ≈ UᵀD⁻¹U as preconditioner),
and the local predictors interpolate that smooth field, where the screening effect holds.
The prediction is E[z(x) | y] with E[z(x) | z(X)] replaced by its local version; with k ≥ n
it is exact, R C⁻¹ỹ = (C − τ²I)C⁻¹ỹ.  Up to NOISE_FREE_UP_TO points the gradients multiply
by C itself (O(n²)); above, by the Vecchia approximation of the latent field (the latent
form of Katzfuss & Guinness 2021, solved here by conjugate gradients rather than their
incomplete Cholesky): R + ℓI ≈ U_ℓ⁻¹D_ℓU_ℓ⁻ᵀ in the same order with the same neighbours, ℓ =
LATENT_NUGGET_SHARE·τ², and C ≈ U_ℓ⁻¹D_ℓU_ℓ⁻ᵀ + (τ² − ℓ)I, two sparse triangular solves per
product, O(n m); then w = ỹ − (τ² − ℓ)C⁻¹ỹ and A_j = R[S_j, S_j] + (jitter + ℓ)I.  This is
what makes more readings a better model: bench field with 0.01 mm noise, held-out RMS
2.25e-3 mm at n = 2,000, 1.51e-3 at 10,000 and 7.8e-4 at 100,000 (the readings averaged at
10,000: 4.05e-3).  Without a nugget, or if the gradients do not converge, w = ỹ and
A_j = C[S_j, S_j].  The MSE is the exact formula on the readings of S_j,

    MSE(x) = σ̂² (1 + uᵀ(F̃ᵀF̃)⁻¹u − rᵀA⁻¹r),   A = C[S_j, S_j],   u = F_SᵀA⁻¹r − f(x),

never below the exact model's, which conditions on all the readings.

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
from scipy.spatial import cKDTree

from .kriging import (JITTER_START, MAX_CONDITION, _Problem, _triangular_solve, correlation_from_squared,
                      matern52_slope)

# Neighbours m of every point in the likelihood (prediction: PREDICTION_SET_FACTOR).  Measured
# on the bench's smooth field with 0.01 mm noise (n = 2,000, 3 outputs, one core; held-out
# RMS, exact Kriging 2.2e-3 mm; a one-round search): m = 10, 20, 30, 40 in the likelihood
# (30 in prediction): fit 0.9, 2.0, 4.6, 7.2 s, RMS 6.8e-3, 5.2e-3, 5.2e-3, 5.3e-3 mm; with
# the earlier predictor (each target on its own nearest noisy readings; 30 in the likelihood)
# 15, 20, 30, 40 neighbours: 6.9e-3, 6.0e-3, 5.2e-3, 4.9e-3 mm at 1, 1.5, 2.9 and 5.8 times
# the time of 15.  On the UR10's residuals m = 30 lands within 2 % of exact Kriging.
NEIGHBOURS = 30
# A training point's local predictor (VecchiaState.prepare_prediction) conditions on this
# times m of its nearest training points.  Targets predicted from their nearest training
# point's set, 100,000 of them from n = 2,000 and 10,000 on the bench field (noise-free, 3
# outputs, fixed θ, one core, CPU s; RMS on 30,000 dense targets): factor 1 0.42 and 0.47 s,
# 6.4e-6 and 2.8e-6 mm; 4/3 0.51 and 0.60 s, 2.6e-6 and 9.6e-7 mm; 5/3 0.62 and 0.69 s,
# 1.2e-6 and 4.7e-7 mm; each target with its own 30 nearest (groups of 16, then 4, then one
# by one, sharing within half the reach) 1.12 and 2.52 s, 6.0e-6 and 2.4e-6 mm.  Building
# them costs O(n k³) once per fit: at 4/3, 0.5 and 2.5 s of CPU for the two sizes.
PREDICTION_SET_FACTOR = 4 / 3
# Targets (and training points, when their local predictors are built) taken at a time.
PREDICTION_BLOCK = 4096
# With a nugget, the local predictors interpolate the posterior mean of the noise-free field
# at the training points (VecchiaState.prepare_prediction) up to this many training points:
# its conjugate gradients multiply by the whole correlation matrix, 8n² bytes and O(n²) per
# iteration (100 to 300 of them; the Vecchia preconditioner saves few).  Bench field with
# 0.01 mm noise at n = 10,000, the Vecchia fit's θ and nugget: held-out RMS 1.41e-3 mm with
# these predictors, 4.05e-3 with the readings averaged, but 36 s of CPU more for 3 outputs
# (and 800 MB), beyond the fit budget of 30 s at that size.  Above, the same posterior mean
# comes from the Vecchia approximation of the latent field (LATENT_NUGGET_SHARE).
NOISE_FREE_UP_TO = 4000
# Above NOISE_FREE_UP_TO points the conjugate gradients multiply by R̂ + (τ² − ℓ)I instead of
# C, R̂ = U_ℓ⁻¹ D_ℓ U_ℓ⁻ᵀ the Vecchia approximation of R + ℓI (the same order and neighbours,
# no noise in the conditionals, so the screening effect holds; two sparse triangular solves
# per product), ℓ this share of the nugget τ²: a latent field with a little noise of its own
# conditions far better than the noise-free one.  Bench field, n = 10,000, 0.01 mm noise, the
# Vecchia fit's θ and nugget (3 outputs, one core, on a machine shared with other work):
# share 1e-4, 1e-3, 1e-2, 1e-1: held-out RMS 1.60e-3, 1.49e-3, 1.51e-3, 2.10e-3 mm (exact
# products: 1.41e-3; readings averaged: 4.05e-3); 150-174, 133-157, 96-110, 47-58 iterations;
# fit 11.6, 9.9, 9.6, 8.0 s of CPU against 6.1 with the readings averaged.  On the UR10's
# residual (series A, kriging on 6,000 random poses, held out on the other 5,911) it changes
# nothing: mean 0.2008 mm against 0.2009 with the readings averaged, 17.9 s of CPU against 17.7.
LATENT_NUGGET_SHARE = 1e-2
# Relative residual at which those conjugate gradients stop, and their most iterations (not
# converged: the predictors average the noisy readings instead).  Bench field, n = 2,000,
# 0.01 mm noise, exact Kriging's θ and nugget (3 outputs, products recomputed each time):
# 1e-10, 1e-8, 1e-6 cost 14.2, 9.9, 7.1 s of the fit's conditioning and moved predictions by
# at most 8e-8 and 7e-7 mm against 1e-10 (held-out RMS 2.25e-3 mm for all three).
CG_TOLERANCE = 1e-8
CG_ITERATIONS = 1000
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
# stand-in's runs start from theta0 and the best screened candidates, BLOCK_STARTS of them
# up to BLOCK_STARTS_UP_TO points and BLOCK_STARTS_ABOVE above; their ends are judged by the
# exact likelihood and the best is refined on it (EXACT_REFINE_OPTIONS).  The UR10's
# residual has several optima of about the same likelihood, and which one a run reaches
# depends on where it starts, so the exact search on all points (as up to 1,000) is no
# ground truth either: against it, one core, loaded machine, CPU s (bench/kriging.py
# --search, one process, load average 3.1 to 4.4):
#   hybrid on all 1,495 UR10 B poses: 12.8 s against 29.3 s; the exact log-likelihood 20
#   units higher (on one error component, the same on the others);
#   UR10 A, 2,000 random poses, held out on the other 9,911: kriging mean/RMS/max 0.2592,
#   0.3784, 2.578 mm against 0.2616, 0.3800, 2.534; hybrid 0.1924, 0.2426, 1.217 against
#   0.1929, 0.2436, 1.210 (14.2 and 14.0 s against 31.0 and 28.7);
#   bench field, n = 2,000, 0.01 mm noise: held-out RMS 0.999 times, 16.4 s against 15.1;
#   eight more random training sets of series A and B (1,196 to 2,000 poses; kriging and
#   hybrid, 16 fits): held-out mean error 0.971 to 1.020 times (geometric mean 0.999), the
#   exact log-likelihood summed over their 48 components 184 units higher.
# Stand-ins measured before: the exact likelihood of half of the points (a random half, the
# first half of the order), refined on all: UR10 A 2,000 hybrid +3.7 % and +4.7 % held out
# (their optima lay in other basins); the Vecchia likelihood (m = 30) refined on the exact
# one: as accurate, but 16 s on all of series B (m = 15 or 20: +7 % and +43 % on A 2,000);
# blocks of 750 points: as accurate, 15.6 s; 2 or 3 starts on 500-point blocks at n ≤ 1,500:
# held-out up to +2.9 % on B (a worse optimum of one component); 4 starts above 1,500
# points: the bench field's fit 21.5 s for the same optimum.
BLOCK_SEARCH_ABOVE = 1000
BLOCK_POINTS = 500
BLOCK_STARTS = 4
BLOCK_STARTS_UP_TO = 1500
BLOCK_STARTS_ABOVE = 2
# The refinement on the exact likelihood: ftol 1e-5 (OPTIONS) stopped it 2 log-units short on
# the bench field (L-BFGS-B's first steps from a new start are short), held out 1.032 times.
EXACT_REFINE_OPTIONS = {"maxiter": 30, "ftol": 1e-6, "gtol": 1e-4, "maxls": 5}


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
        exact and block problems are let go."""
        self._exact_problem = self._blocks = None
        self.focus(theta)
        state = self.condition(theta, nugget, Y, start_jitter)
        state.prepare_prediction(self)
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


class VecchiaState:
    """A Vecchia fit at fixed θ (standardised units), as the exact model's state: θ, nugget,
    jitter, condition (a lower bound, inf if the factorisation failed without jitter), β̂,
    σ̂², the log-likelihood; G the R factor of the whitened trend (F̃ᵀF̃ = GᵀG) and the
    standardised training residuals y − Fβ̂ (in the problem's order) for prediction, whose
    local predictors :meth:`prepare_prediction` builds (``final`` does)."""

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
        self.noise_free = None  # whether the local predictors interpolate the noise-free field
        self._tree = None

    # ---------------------------------------------------------- local predictors

    def prepare_prediction(self, problem):
        """Build each training point j's local predictor: the set S_j of the k = ⌈4m/3⌉
        training points nearest to it (itself included, in the metric of θ) and the
        coefficients c_j = A_j⁻¹ w_S (k, q), so that a target whose nearest training point is
        j is predicted as f(x)ᵀβ̂ + r(x, S_j)ᵀ c_j in O(k).

        With a nugget, w is the posterior mean of the noise-free field at the training points,
        w = ỹ − τ² C⁻¹ỹ (ỹ = y − Fβ̂, τ² the nugget), with C⁻¹ỹ from conjugate gradients
        preconditioned by the Vecchia factor, and A_j = R[S_j, S_j] + jitter·I: the neighbours
        then interpolate a smooth field (where the screening effect holds) instead of
        averaging k noisy readings.  Up to NOISE_FREE_UP_TO points the gradients multiply by
        C itself; above, by the Vecchia approximation of the latent field with ℓ = 
        LATENT_NUGGET_SHARE·τ² of the noise kept in it (w = ỹ − (τ² − ℓ) Ĉ⁻¹ỹ,
        A_j = R[S_j, S_j] + (jitter + ℓ)·I).  Without a nugget, or if the gradients do not
        converge, w = ỹ and A_j = C[S_j, S_j].  With k ≥ n both are the exact predictor: R C⁻¹ỹ = (C − τ²I)C⁻¹ỹ."""
        Z = self._X * np.sqrt(self.theta)
        self._Z, self._tree = Z, cKDTree(Z)
        n, q = self._residual.shape
        k = min(int(math.ceil(PREDICTION_SET_FACTOR * self.neighbours)), n)
        values, diagonal, self.noise_free = self._residual, self.nugget + self.jitter, False
        if self.nugget > 0:
            try:
                factors = problem.factors(self.theta, self.nugget + self.jitter)
            except _Failed:  # unexpected (the fit factorised these matrices): average the readings
                factors = None
            if factors is None:
                found = None
            elif n <= NOISE_FREE_UP_TO:
                solved = _conjugate_gradients(Z, self._correlation, self.nugget + self.jitter, self._residual,
                                              *factors, problem._nb)
                found = None if solved is None else (solved, self.nugget, self.jitter)
            else:
                found = _latent_conjugate_gradients(problem, self.theta, self.nugget, self.jitter, self._residual,
                                                    *factors)
            if found is not None:
                solved, noise, diagonal = found
                values, self.noise_free = self._residual - noise * solved, True
        _, sets = self._tree.query(Z, k=k)
        self._sets = sets.reshape(n, k)
        self._coefficients = np.empty((n, k, q))
        for start in range(0, n, PREDICTION_BLOCK):
            rows = np.arange(start, min(n, start + PREDICTION_BLOCK))
            S = self._sets[rows]
            A = correlation_from_squared(_squared_distances(Z[S] - Z[rows][:, None, :]), self._correlation)
            L = _factor_in_prediction(A, diagonal, values[S])
            self._coefficients[rows] = _back_substitute(L[:, :k, :k], np.swapaxes(L[:, k:, :k], 1, 2))

    def predict(self, Xs, f, with_mse):
        """(standardised mean (N, q), mse in units of σ̂² (N,) or None) at the standardised
        points Xs (N, d) whose trend columns are f (N, p).

        Each target takes the local predictor of its nearest training point j (see
        :meth:`prepare_prediction`): one nearest-point search and O(k) per target.  The MSE
        is that of conditioning on the noisy readings of S_j, the exact model's formula on
        them (C = R + (nugget + jitter)·I; one k × k factorisation per set among the targets);
        with k ≥ n mean and MSE are the exact model's."""
        Z = Xs * np.sqrt(self.theta)
        _, nearest = self._tree.query(Z, k=1)
        mean = f @ self.beta
        mse = np.empty(len(Xs)) if with_mse else None
        for start in range(0, len(Xs), PREDICTION_BLOCK):
            block = slice(start, start + PREDICTION_BLOCK)
            S = self._sets[nearest[block]]  # (B, k)
            offset = self._Z[S] - Z[block, None, :]
            r = correlation_from_squared(np.einsum("bkd,bkd->bk", offset, offset), self._correlation)
            mean[block] += np.einsum("bk,bkq->bq", r, self._coefficients[nearest[block]])
            if with_mse:
                mse[block] = self._unit_mse(nearest[block], r, f[block])
        return mean, mse

    def _unit_mse(self, nearest, r, f):
        """1 + uᵀ(F̃ᵀF̃)⁻¹u − rᵀA⁻¹r, u = F_SᵀA⁻¹r − f, for targets whose nearest training
        points are ``nearest`` (B,), with correlations r (B, k) to their sets and trend
        columns f (B, p).  Each set is factorised once for all its targets."""
        sets, inverse = np.unique(nearest, return_inverse=True)
        S = self._sets[sets]
        k = S.shape[1]
        A = correlation_from_squared(_squared_distances(self._Z[S] - self._Z[sets][:, None, :]), self._correlation)
        L = _factor_in_prediction(A, self.nugget + self.jitter, self._F[S])[inverse.reshape(-1)]
        v = _forward_substitute(L[:, :k, :k], r)  # L⁻¹r
        u = np.einsum("bk,bpk->bp", v, L[:, k:, :k]) - f  # F_SᵀA⁻¹r − f
        w = np.linalg.solve(self.G.T, u.T)  # uᵀ(GᵀG)⁻¹u = |w|²
        return np.maximum(1.0 + np.einsum("ij,ij->j", w, w) - np.einsum("bk,bk->b", v, v), 0.0)


def _forward_substitute(L, rhs):
    """x with Lx = rhs for the lower-triangular L (B, k, k) and rhs (B, k), column by column."""
    x = np.empty_like(rhs)
    for j in range(L.shape[1]):
        x[:, j] = (rhs[:, j] - np.einsum("bl,bl->b", L[:, j, :j], x[:, :j])) / L[:, j, j]
    return x


def _conjugate_gradients(Z, correlation, diagonal_add, B, b, d, neighbours):
    """X = C⁻¹B (n, q) for C = R(Z) + diagonal_add·I, by conjugate gradients on each column
    with the exact product (C formed once: 8n² bytes, 128 MB at n = 4,000) and the Vecchia
    factor Uᵀ D⁻¹ U (b (n, m), d (n,) and the neighbours (n, m), −1 for none) as
    preconditioner; None if a column has not reached CG_TOLERANCE after CG_ITERATIONS."""
    n = len(B)
    norms = np.einsum("id,id->i", Z, Z)
    C = Z @ Z.T
    C *= -2.0
    C += norms[:, None]
    C += norms[None, :]
    C = correlation_from_squared(np.maximum(C, 0.0, out=C), correlation, out=C)
    C[np.diag_indices(n)] += diagonal_add
    valid = neighbours >= 0
    safe = np.where(valid, neighbours, 0)
    weights = np.where(valid, b, 0.0)

    def product(V):
        return C @ V

    def precondition(V):
        W = (V - np.einsum("im,imc->ic", weights, V[safe])) / d[:, None]  # D⁻¹ U V
        out = W.copy()
        for c in range(V.shape[1]):  # Uᵀ: each point's −b_i W_i goes to its neighbours
            out[:, c] -= np.bincount(safe.ravel(), (weights * W[:, c:c + 1]).ravel(), minlength=n)
        return out

    return _preconditioned_gradients(product, precondition, B)


def _vecchia_factor(b, neighbours):
    """The sparse unit lower-triangular U (n, n) of a Vecchia factor, (U v)_i = v_i − b_iᵀ v_N(i)
    in the problem's order (b (n, m), the neighbours (n, m), −1 for none)."""
    from scipy import sparse

    n, m = neighbours.shape
    valid = neighbours >= 0
    rows = np.concatenate([np.repeat(np.arange(n), m)[valid.ravel()], np.arange(n)])
    columns = np.concatenate([neighbours[valid], np.arange(n)])
    return sparse.csr_matrix((np.concatenate([-b[valid], np.ones(n)]), (rows, columns)), shape=(n, n))


def _latent_conjugate_gradients(problem, theta, nugget, jitter, B, b, d):
    """(X, τ² − ℓ, jitter + ℓ) with X = Ĉ⁻¹B (n, q), Ĉ = R̂ + (τ² − ℓ)I and R̂ = U_ℓ⁻¹ D_ℓ U_ℓ⁻ᵀ
    the Vecchia approximation of R + (jitter + ℓ)I at θ (the neighbours of ``problem``'s last
    ``focus``; ℓ = LATENT_NUGGET_SHARE·τ², ten times more while its factor fails, up to τ²),
    by conjugate gradients preconditioned by the Vecchia factor of C (b (n, m), d (n,));
    None if they do not converge or no ℓ below τ² factorises.  O(n m) per iteration."""
    from scipy.sparse.linalg import spsolve_triangular

    latent = LATENT_NUGGET_SHARE * nugget
    while True:
        if latent >= nugget:
            return None
        try:
            b_latent, d_latent = problem.factors(theta, jitter + latent)
            break
        except _Failed:
            latent *= 10.0
    U_latent = _vecchia_factor(b_latent, problem._nb)
    U_latent_t = U_latent.T.tocsr()
    U = _vecchia_factor(b, problem._nb)
    U_t = U.T.tocsr()
    rest = nugget - latent

    def product(V):  # (R̂ + (τ² − ℓ)I) V
        inner = d_latent[:, None] * spsolve_triangular(U_latent_t, V, lower=False, unit_diagonal=True)
        return spsolve_triangular(U_latent, inner, lower=True, unit_diagonal=True) + rest * V

    def precondition(V):  # Uᵀ D⁻¹ U V ≈ C⁻¹ V
        return U_t @ ((U @ V) / d[:, None])

    solved = _preconditioned_gradients(product, precondition, B)
    return None if solved is None else (solved, rest, jitter + latent)


def _preconditioned_gradients(product, precondition, B):
    """X = C⁻¹B (n, q) by preconditioned conjugate gradients on each column, given the
    products V ↦ CV and V ↦ M⁻¹V (n, q); None if a column has not reached CG_TOLERANCE after
    CG_ITERATIONS."""
    X = np.zeros_like(B)
    residual = B.copy()
    target = CG_TOLERANCE * np.linalg.norm(B, axis=0)
    z = precondition(residual)
    direction = z.copy()
    rz = np.einsum("ic,ic->c", residual, z)
    for _ in range(CG_ITERATIONS):
        if np.all(np.linalg.norm(residual, axis=0) <= target):
            return X
        Cp = product(direction)
        step = rz / np.maximum(np.einsum("ic,ic->c", direction, Cp), 1e-300)
        X += step * direction
        residual -= step * Cp
        z = precondition(residual)
        rz, previous = np.einsum("ic,ic->c", residual, z), rz
        direction = z + (rz / np.maximum(previous, 1e-300)) * direction
    return X if np.all(np.linalg.norm(residual, axis=0) <= target) else None
