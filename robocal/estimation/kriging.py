"""Kriging error model in the DACE form (Lophaven, Nielsen & Søndergaard, 2002).

Each output column is modelled as

    y(x) = f(x)ᵀβ + z(x),

a regression trend ``f`` (constant, linear or quadratic polynomial) plus a stationary
Gaussian process ``z`` of variance σ² and correlation

    gaussian:  R(x, x') = exp(−Σ_k θ_k (x_k − x'_k)²)
    matern52:  R(x, x') = (1 + √5 h + 5h²/3) exp(−√5 h),   h² = Σ_k θ_k (x_k − x'_k)²

on inputs and outputs standardised to zero mean and unit variance.  For given θ, β comes
from generalised least squares and σ² from its residual; θ (and optionally a nugget) then
maximises the concentrated log-likelihood

    ℓ(θ) = −½ (n log σ̂²(θ) + log det C(θ) + n (1 + log 2π)),   C = R + (nugget + jitter) I,

with L-BFGS-B on log θ and the analytic gradient.  Because β̂ and σ̂² are the exact maximisers
of the full likelihood for fixed θ, their own derivatives drop out (envelope theorem) and

    ∂ℓ/∂θ_k = ½ tr((α αᵀ/σ̂² − C⁻¹) ∂C/∂θ_k),   α = C⁻¹(y − F β̂),

where α uses the GLS β̂ at the same θ; with ∂C/∂nugget = I the same formula gives the
nugget's derivative.

Prediction at x with r = R(x, X):

    ŷ(x) = f(x)ᵀβ̂ + rᵀα
    MSE(x) = σ̂² (1 + uᵀ(FᵀC⁻¹F)⁻¹u − rᵀC⁻¹r),   u = FᵀC⁻¹r − f(x),

the mean squared error of the best linear unbiased predictor of the noise-free field.
"""
import math
import warnings

import numpy as np
from scipy.linalg import lapack
from scipy.optimize import minimize

from .. import parallel
from ..errors import InputError, RobocalWarning
from .arrays import (as_matrix, check_choice, check_flag, check_header, check_random_state,
                     check_whole, damaged, is_real, not_fitted, standard_scaler)

REGRESSIONS = ("constant", "linear", "quadratic")
CORRELATIONS = ("gaussian", "matern52")
# The exact model, or the Vecchia approximation of its likelihood and predictor
# (robocal.estimation.vecchia); "auto" takes the approximation above AUTO_VECCHIA_ABOVE points.
# Measured on the UR10's residual after kinematic calibration (series A, one core, 3 outputs,
# nugget estimated; held-out mean on 3,000 other poses): n = 750 exact 3.2 s, Vecchia 5.1 s;
# n = 1,000: 9.5 s against 6.2 s; n = 1,500: 17.5 s against 9.4 s, the held-out errors
# within 2 % of each other at every size.  Exact fits of 1,000 points or fewer stay as they were.
APPROXIMATIONS = ("exact", "vecchia", "auto")
AUTO_VECCHIA_ABOVE = 1000

FORMAT = "robocal.kriging"
FORMAT_VERSION = 1

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
# Bounds of an estimated nugget, relative to the process variance σ².
NUGGET_BOUNDS = (1e-12, 10.0)
# A parameter within this factor of a bound (in θ) is reported as having hit it.
BOUND_TOLERANCE = 1.01
# L-BFGS-B settings.  Near the smooth end of θ the correlation matrix is nearly singular:
# the computed log-likelihood is then noisy at about 1e-5 of its value (rounding in the
# Cholesky factor of a matrix with condition number ~1e16) and line searches that try to
# resolve that noise fail after many evaluations.  The tolerances stop the search at that
# level, which is far below any statistically meaningful change of the likelihood.  Measured
# on smooth 3-D fields (n = 50 to 1000): tighter settings cost up to 1.5 times the time
# without changing the held-out error.
OPTIONS = {"maxiter": 200, "ftol": 1e-5, "gtol": 1e-4, "maxls": 5}
# Latin-hypercube points whose likelihood is evaluated to choose the starts after theta0.
SCREENED_CANDIDATES = 10
# Points farther than this fraction of the training box's size outside it are extrapolated.
EXTRAPOLATION_MARGIN = 0.1
# The predicted standard deviation quoted in the extrapolation warning is computed for at
# most this many of the farthest points, so that a warning never costs more than predicting.
EXTRAPOLATION_STD_POINTS = 1000


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


class _Problem:
    """The standardised data of one fit and the likelihood of a group of outputs sharing θ."""

    def __init__(self, X, F, correlation):
        self.X = X
        self.F = F
        self.correlation = correlation
        n, d = X.shape
        # Per-dimension squared differences, (d, n·n): R and the gradient are then one
        # matrix-vector product each over them.  Memory: 8·d·n² bytes (216 MB at n = 3000).
        self.sqdiff = ((X[:, None, :] - X[None, :, :]) ** 2).reshape(n * n, d).T.copy()

    ROUNDS = 1  # runs of the optimiser per start (see Kriging._minimise)
    least_starts = 1  # the fewest starts of a search left to its default (see the Vecchia problem's)

    def search_problem(self):
        """The problem the hyperparameter search runs on: this one (see the Vecchia problem's)."""
        return self

    def refinement(self, search):
        """None: a search on the exact likelihood is final (see the Vecchia problem's)."""
        return None

    def focus(self, theta):
        """Nothing: the exact likelihood conditions on every point (see the Vecchia problem's)."""

    def final(self, theta, nugget, Y, start_jitter=0.0):
        """The state a fit ends with, or a saved model is rebuilt from, at θ and the nugget."""
        return self.condition(theta, nugget, Y, start_jitter)

    def factor(self, theta, nugget, start_jitter=0.0):
        """(S, C, L, jitter, condition) at θ and the nugget: the θ-weighted squared distances,
        the correlation matrix with the nugget and jitter on its diagonal, its lower Cholesky
        factor, the jitter and the condition estimate (see :func:`_cholesky_with_jitter`)."""
        n = len(self.X)
        S = (theta @ self.sqdiff).reshape(n, n)
        C = correlation_from_squared(S, self.correlation, out=np.empty_like(S))  # R
        C[np.diag_indices(n)] += nugget
        # Correlations are ≥ 0, so the 1-norm is the largest column sum.
        L, jitter, condition = _cholesky_with_jitter(C, C.sum(axis=0).max(), start_jitter)
        return S, C, L, jitter, condition

    def condition(self, theta, nugget, Y, start_jitter=0.0, gradient=False):
        """Condition the process on ``Y`` (n, m) at θ and the nugget: a `_State`."""
        n = len(self.X)
        S, C, L, jitter, condition = self.factor(theta, nugget, start_jitter)
        Ft = _triangular_solve(L, self.F)
        Yt = _triangular_solve(L, Y)
        Q, G = np.linalg.qr(Ft)
        beta = np.linalg.solve(G, Q.T @ Yt)
        residual = Yt - Ft @ beta
        # A constant output leaves no residual; the floor keeps log σ² finite.
        sigma2 = np.maximum(np.einsum("ij,ij->j", residual, residual) / n, 1e-300)
        log_det = 2.0 * np.log(L.diagonal()).sum()
        log_likelihood = -0.5 * (n * np.log(sigma2) + log_det + n * (1.0 + math.log(2 * math.pi)))
        alpha = _triangular_solve(L, residual, transpose=True)
        state = _State(theta, nugget, jitter, condition, L, Ft, G, beta, sigma2, alpha,
                       log_likelihood)
        if gradient:
            state.gradient = self._gradient(theta, nugget, S, C, L, alpha, sigma2)
        return state

    def _gradient(self, theta, nugget, S, C, L, alpha, sigma2):
        """d(Σ_j ℓ_j)/d(log θ_k) and d/d(log nugget): ½ tr(W ∂C/∂·), W = Σ_j α_jα_jᵀ/σ_j² − m C⁻¹.

        ∂C/∂θ_k = (dR/dS) ∘ Δ_k², and Δ_k² is zero on the diagonal, so only off-diagonal
        entries matter: there C equals R (the Gaussian's dR/dS = −R is read from C), and the
        symmetric C⁻¹ can be used through its lower triangle, counted twice.
        """
        m = alpha.shape[1]
        C_inverse_lower, _ = lapack.dpotri(L, lower=1)  # upper triangle stays zero
        W = (alpha / sigma2) @ alpha.T
        d_nugget = 0.5 * nugget * (np.trace(W) - m * np.trace(C_inverse_lower))
        W -= (2 * m) * C_inverse_lower
        slope = -C if self.correlation == "gaussian" else matern52_slope(S)
        # With log θ as the variable the chain rule brings a factor θ_k.
        d_theta = 0.5 * theta * (self.sqdiff @ (W * slope).reshape(-1))
        return d_theta, d_nugget


class _State:
    """Everything a fit at fixed θ leaves behind (standardised units)."""

    def __init__(self, theta, nugget, jitter, condition, L, Ft, G, beta, sigma2, alpha,
                 log_likelihood):
        self.theta = theta
        self.nugget = nugget
        self.jitter = jitter
        self.condition = condition
        self.L = L
        self.Ft = Ft  # L⁻¹F
        self.G = G  # R factor of L⁻¹F = QG, so FᵀC⁻¹F = GᵀG
        self.beta = beta
        self.sigma2 = sigma2
        self.alpha = alpha  # C⁻¹(Y − Fβ): the prediction weights
        self.log_likelihood = log_likelihood
        self.gradient = None


class Kriging:
    """Kriging (DACE) regression of one or several outputs, fit/predict like scikit-learn.

    As robocal's Cartesian error model, X are commanded (nominal) TCP positions (N, 3) in mm
    and Y the position errors e = measured − model (N, 3) in mm; the class itself takes any
    inputs (n, d) and outputs (n, m).  The settings are stored as given; ``fit`` checks them.

    Parameters
    ----------
    regression : "constant" | "linear" | "quadratic"
        Polynomial trend f(x)ᵀβ, estimated by generalised least squares.
    correlation : "gaussian" | "matern52"
        Correlation family (see the module docstring); Gaussian is the DACE/paper choice.
    theta0 : float, sequence of d floats or None
        Starting θ, in standardised-input units (inputs scaled to unit standard deviation).
        None starts at θ = 0.5 / d, a correlation of about e⁻¹ between typical point pairs.
        With ``n_starts=0`` it is used as is, without optimisation.
    theta_bounds : (lo, hi)
        Bounds on every θ_k in standardised-input units.  The default (1e-6, 1e2) admits
        correlation lengths from 0.1 to 1000 standard deviations of the inputs: robot error
        fields are very smooth, and on them a lower bound of 1e-3 made the held-out error up
        to twice as large; the ill-conditioning long lengths bring is handled by jitter.
    nugget : float ≥ 0 or "estimate"
        Variance added to the correlation diagonal, relative to σ²: 0 interpolates the data, a
        positive value smooths measurement noise, "estimate" fits it by maximum likelihood
        (within NUGGET_BOUNDS) together with θ.  Predictions are of the noise-free field.
    n_starts : int ≥ 0 or None
        L-BFGS-B runs: one from theta0, the others from the best (by likelihood) of a Latin
        hypercube of max(10, 2·n_starts) points in log θ (and log nugget).  0 fixes θ = theta0
        (and needs a numeric nugget).  None picks 4 for n ≤ 400, 2 for n ≤ 1500, else 1:
        small designs have several optima, large ones are cheap to screen but dear to
        optimise (a fit of 1000 points and 3 outputs takes 5 to 8 s on one core).  The
        Vecchia approximation's search between 1,000 and 2,000 points runs on a cheaper
        stand-in and takes at least 4 up to 1,500 points and 2 above
        (:mod:`robocal.estimation.vecchia`).
    shared_theta : bool
        False: one θ (and nugget) per output, each maximising its own likelihood (the paper's
        way).  True: one θ for all outputs, maximising the sum of their likelihoods.
    random_state : None, int or numpy Generator
        Seeds the Latin hypercube of starts: an int ≥ 0 makes fits reproducible, a Generator
        is used (and advanced) as is, None draws fresh entropy.
    approximation : "exact" | "vecchia" | "auto"
        The exact likelihood and predictor (O(n³) time, O(n²) memory), or their Vecchia
        approximation (:mod:`robocal.estimation.vecchia`: each point conditioned on its nearest
        earlier points, O(n m³) time, O(n m) memory); "auto" is exact up to
        AUTO_VECCHIA_ABOVE training points and Vecchia above.
    neighbours : int ≥ 1 or None
        Vecchia only: the neighbours m each point is conditioned on in the likelihood (the
        local predictors take ⌈4m/3⌉, ``vecchia.PREDICTION_SET_FACTOR``); None is
        ``vecchia.NEIGHBOURS``.  With m ≥ n − 1 the approximation is exact.

    Attributes
    ----------
    theta_ : array, shape (m, d), or (d,) with ``shared_theta``
        θ in standardised-input units.
    nugget_ : array, shape (m,)
        Nugget per output, relative to σ².
    jitter_ : array, shape (m,)
        What had to be added to the diagonal for a stable factorisation.
    beta_ : array, shape (p, m)
        Trend coefficients for standardised inputs and outputs.
    sigma2_ : array, shape (m,)
        Process variance σ² in output units squared (mm² for position errors).
    log_likelihood_ : array, shape (m,)
        Concentrated log-likelihood of each (standardised) output.
    n_features_in_ : int
        Number of input columns d.
    diagnostics_ : list of str
        Notes on bounds hit, ill-conditioning and the data.
    approximation_ : "exact" or "vecchia"
        What the fit used (``approximation`` "auto" decides by the number of points).

    All are set by ``fit`` or ``from_dict``.
    """

    def __init__(self, regression="constant", correlation="gaussian", theta0=None,
                 theta_bounds=(1e-6, 1e2), nugget=0.0, n_starts=None, shared_theta=False,
                 random_state=None, approximation="auto", neighbours=None):
        self.regression = regression
        self.correlation = correlation
        self.theta0 = theta0
        self.theta_bounds = theta_bounds
        self.nugget = nugget
        self.n_starts = n_starts
        self.shared_theta = shared_theta
        self.random_state = random_state
        self.approximation = approximation
        self.neighbours = neighbours

    # ------------------------------------------------------------------ fitting

    def fit(self, X, Y):
        """Estimate θ (and the nugget), β and σ² from training points.

        Parameters
        ----------
        X : array-like, shape (n, d)
            Inputs; as an error model, commanded (nominal) TCP positions (n, 3) in mm.

        Y : array-like, shape (n,) or (n, m)
            Outputs; as an error model, position errors e = measured − model (n, 3) in mm.

        Returns
        -------
        self : Kriging
            The fitted model.

        Raises
        ------
        InputError
            If a setting is invalid (checked first, before any work) or the data cannot be
            used.  A fit that raises leaves an already fitted model as it was.
        """
        self._check_settings()
        y_is_vector = np.ndim(Y) == 1
        X, Y = as_matrix(X, "X"), as_matrix(Y, "Y")
        n, d = X.shape
        self._theta0(d)  # its length can only be checked against X
        if len(Y) != n:
            raise InputError(f"X has {n} rows but Y has {len(Y)}: give one output row per input "
                             f"point")
        needed = trend_size(d, self.regression) + 1
        if n < needed:
            lower = {"quadratic": "'linear' or 'constant'", "linear": "'constant'"}
            hint = (f", or use a lower-order trend (regression={lower[self.regression]})"
                    if self.regression in lower else "")
            raise InputError(f"a {self.regression} trend in {d} dimensions needs at least "
                             f"{needed} points, got {n}: add points{hint}")
        diagnostics = self._check_duplicates(X)
        data = _Training(X, Y, self.regression, self.correlation, self._uses_vecchia(n), self.neighbours)
        diagnostics += [f"output {j} is constant ({Y[0, j]:g}): it is predicted as that constant"
                        for j in np.flatnonzero(Y.min(axis=0) == Y.max(axis=0))]

        rng = np.random.default_rng(self.random_state)
        groups = self._groups(Y.shape[1])
        fixed = getattr(self, "_fixed_states", None)  # see conditioned_on
        if fixed is not None and len(fixed) != len(groups):
            raise InputError(f"the hyperparameters are of {len(fixed)} outputs, the data have {Y.shape[1]}")
        if fixed is None:
            # Each group's random candidates are drawn here, in order, so that the searches
            # are independent and give the same result wherever they run.
            drawn = [self._candidates(data.problem, data.Ys[:, cols], rng) for cols in groups]
            fixed = self._search(data, groups, drawn)
        states = [data.problem.final(theta, nugget, data.Ys[:, cols]) for cols, (theta, nugget) in zip(groups, fixed)]
        self._install(data, y_is_vector, groups, states, diagnostics)
        self._report(groups, states)
        return self

    def conditioned_on(self, X, Y):
        """A new Kriging with this fitted model's θ and nugget, conditioned on other training
        data (X, Y) as in :meth:`fit` but without the likelihood search: cross-validation
        of a method chooses the hyperparameters once and refits each fold in a fraction of
        the time (a Cholesky factorisation per output instead of dozens).  θ is in
        standardised-input units, so the new data's own scaling applies it."""
        if not hasattr(self, "theta_"):
            raise InputError("this Kriging is not fitted: fit it before conditioning its hyperparameters on other data")
        settings = {name: getattr(self, name) for name in ("regression", "correlation", "theta_bounds",
                                                          "shared_theta", "random_state", "approximation",
                                                          "neighbours")}
        # (the nugget setting only decides whether repeated inputs are allowed; the fitted
        # nugget of each output comes with its θ)
        model = Kriging(**settings, nugget=float(np.max(self.nugget_)))
        model._fixed_states = [(np.atleast_2d(self.theta_)[0] if self.shared_theta else self.theta_[cols[0]],
                                float(self.nugget_[cols[0]])) for cols in self._groups]  # the fitted groups
        return model.fit(X, Y)

    def _check_settings(self):
        """Raise an InputError naming the first invalid setting and the values it may take."""
        check_choice("regression", self.regression, REGRESSIONS)
        check_choice("correlation", self.correlation, CORRELATIONS)
        try:
            lo, hi = (float(b) for b in self.theta_bounds)
        except (TypeError, ValueError):
            lo = hi = np.nan
        if not 0 < lo <= hi < np.inf:
            raise InputError(f"theta_bounds must be two numbers with 0 < lo ≤ hi < inf, got "
                             f"{self.theta_bounds!r}")
        estimate = isinstance(self.nugget, str) and self.nugget == "estimate"
        if not (estimate or (is_real(self.nugget) and self.nugget >= 0)):
            raise InputError(f"nugget must be a number ≥ 0 or 'estimate', got {self.nugget!r}")
        check_whole("n_starts", self.n_starts, 0, none_allowed=True)
        if self.theta0 is not None:
            self._theta0_values()
        if self.n_starts == 0 and (self.theta0 is None or estimate):
            raise InputError("n_starts=0 fixes θ at theta0 without optimising: give theta0 and "
                             "a numeric nugget")
        check_flag("shared_theta", self.shared_theta)
        check_random_state(self.random_state)
        check_choice("approximation", self.approximation, APPROXIMATIONS)
        check_whole("neighbours", self.neighbours, 1, none_allowed=True)

    def _uses_vecchia(self, n):
        """Whether a fit of n points uses the Vecchia approximation."""
        return self.approximation == "vecchia" or (self.approximation == "auto" and n > AUTO_VECCHIA_ABOVE)

    def _groups(self, m):
        """Output columns that share θ: all together, or each on its own."""
        return [np.arange(m)] if self.shared_theta else [np.array([j]) for j in range(m)]

    def _check_duplicates(self, X):
        """Raise on repeated rows of X without a nugget; with one, warn: the diagnostics."""
        _, inverse, counts = np.unique(X, axis=0, return_inverse=True, return_counts=True)
        if counts.max() == 1:
            return []
        inverse = inverse.reshape(-1)
        repeated = [np.flatnonzero(inverse == u) for u in np.flatnonzero(counts > 1)]
        repeated.sort(key=lambda rows: rows[0])
        listed = "; ".join(" = ".join(str(i) for i in rows) for rows in repeated[:5])
        more = f" and {len(repeated) - 5} more groups" if len(repeated) > 5 else ""
        if self.nugget == 0:
            raise InputError(f"X has identical rows ({listed}{more}): with nugget=0 the "
                             f"correlation matrix is singular. Average or drop the repeats, or "
                             f"set nugget to a positive value or 'estimate'")
        message = (f"X has identical rows ({listed}{more}); the nugget makes them usable as "
                   f"repeated measurements")
        warnings.warn(message, RobocalWarning, stacklevel=3)
        return [message]

    def _theta0_values(self):
        """theta0 as a flat array of positive finite numbers (raises an InputError if not)."""
        try:
            theta0 = np.asarray(self.theta0, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            theta0 = np.array([np.nan])
        if not theta0.size or not np.all((theta0 > 0) & np.isfinite(theta0)):
            raise InputError(f"theta0 must be None, one positive number or one per input "
                             f"column, got {self.theta0!r}")
        return theta0

    def _theta0(self, d):
        """theta0 as d positive numbers (default 0.5 / d)."""
        if self.theta0 is None:
            return np.full(d, 0.5 / d)
        theta0 = self._theta0_values()
        if theta0.size not in (1, d):
            raise InputError(f"theta0 must be one positive number or {d} (one per input "
                             f"column), got {self.theta0!r}")
        return np.broadcast_to(theta0, (d,)).copy()

    def _n_starts(self, n, least=1):
        """How many L-BFGS-B runs a search makes: ``n_starts``, or by default 4 up to 400
        points, 2 up to 1,500, then 1 (at least ``least``)."""
        if self.n_starts is not None:
            return int(self.n_starts)
        return max(least, 4 if n <= 400 else 2 if n <= 1500 else 1)

    def _candidates(self, problem, Y, rng):
        """The Latin hypercube of [log θ (, log nugget)] a search of outputs ``Y`` screens for
        its starts (drawn from ``rng``), or None when it has no random starts."""
        n, d = problem.X.shape
        n_starts = self._n_starts(n, problem.least_starts)
        if self.n_starts == 0 or not Y.any() or n_starts == 1:
            return None
        return latin_hypercube(max(SCREENED_CANDIDATES, 2 * n_starts), *self._log_bounds(d), rng)

    def _starting_points(self, d, n, candidates, log_likelihood, least=1):
        """Rows of [log θ (, log nugget)] to start L-BFGS-B from: theta0, then the best of the
        Latin hypercube ``candidates`` by ``log_likelihood``.  A value without gradient costs a
        third of one with it, and runs from good points converge in fewer steps: measured,
        25 % less time at n = 1000 for the same optimum.  theta0 always gets a run: on small
        designs (n = 50) the best optimum was often reached only from there."""
        lower, upper = self._log_bounds(d)
        first = np.log(self._theta0(d))
        if self.nugget == "estimate":
            first = np.append(first, math.log(1e-6))
        if candidates is None:
            return np.clip(first, lower, upper)[None, :]
        best = np.argsort([-log_likelihood(c) for c in candidates])[:self._n_starts(n, least) - 1]
        return np.vstack([np.clip(first, lower, upper), candidates[best]])

    def _search(self, data, groups, drawn):
        """[(θ, nugget)] of each group of outputs (:meth:`_optimise`): one after the other
        here, or one group a task on the active :func:`robocal.parallel.executor` (``--jobs``)
        when there are several."""
        runner = parallel.current()
        if runner.client is None or len(groups) == 1:
            return [self._optimise(data.problem, data.Ys[:, cols], candidates)
                    for cols, candidates in zip(groups, drawn)]
        settings = {name: getattr(self, name) for name in ("regression", "correlation", "theta0", "theta_bounds",
                                                          "nugget", "n_starts")}
        tasks = [{"settings": settings, "problem": data.plain(), "Y": data.Ys[:, cols], "candidates": candidates}
                 for cols, candidates in zip(groups, drawn)]
        return [(np.asarray(theta), nugget) for theta, nugget in runner.map(search_task, tasks)]

    def _log_bounds(self, d):
        lo, hi = (float(b) for b in self.theta_bounds)
        lower, upper = np.full(d, math.log(lo)), np.full(d, math.log(hi))
        if self.nugget == "estimate":
            lower = np.append(lower, math.log(NUGGET_BOUNDS[0]))
            upper = np.append(upper, math.log(NUGGET_BOUNDS[1]))
        return lower, upper

    def _optimise(self, problem, Y, candidates):
        """Maximise the summed concentrated likelihood of the columns of Y from theta0 and the
        best of ``candidates`` (:meth:`_candidates`): the best (θ, nugget)."""
        n, d = problem.X.shape
        estimate_nugget = self.nugget == "estimate"

        def unpack(params):
            theta = np.exp(params[:d])
            nugget = math.exp(params[d]) if estimate_nugget else float(self.nugget)
            return theta, nugget

        if self.n_starts == 0:
            return self._theta0(d), float(self.nugget)
        if not Y.any():  # constant outputs: the likelihood does not depend on θ
            return self._theta0(d), NUGGET_BOUNDS[0] if estimate_nugget else float(self.nugget)
        # The exact problem searches on itself; the Vecchia one on the exact likelihood, on
        # a cheaper stand-in for it whose optimum is then refined (robocal.estimation.vecchia).
        search = problem.search_problem()

        def screened(params):
            theta, nugget = unpack(params)
            search.focus(theta)
            return search.condition(theta, nugget, Y).log_likelihood.sum()

        starts = self._starting_points(d, n, candidates, screened, least=problem.least_starts)
        plan = problem.refinement(search)
        if plan is None:
            return unpack(self._minimise(search, Y, starts, unpack, OPTIONS))
        # The stand-in's optima are judged by the likelihood they stand in for: the runs land
        # in different local optima, and the stand-in's ranking of them is not that one's.
        refine, options = plan
        ends = self._minimise(search, Y, starts, unpack, OPTIONS, every=True)
        best = ends[0] if len(ends) == 1 else max(ends, key=lambda end: self._judged(refine, Y, unpack(end)))
        return unpack(self._minimise(refine, Y, [best], unpack, options, rounds=1))

    @staticmethod
    def _judged(problem, Y, parameters):
        """The summed log-likelihood of ``problem`` at (θ, nugget), its neighbours found in θ's metric."""
        theta, nugget = parameters
        problem.focus(theta)
        return problem.condition(theta, nugget, Y).log_likelihood.sum()

    def _minimise(self, problem, Y, starts, unpack, options, rounds=None, every=False):
        """L-BFGS-B from each start on the summed concentrated likelihood: the best parameters
        (with ``every``, the end of each start's run instead, in the order of the starts).

        A Vecchia problem conditions on neighbours in the metric of θ (``focus``): each run
        starts with the neighbours of its start, and runs again from its end with the
        neighbours found there (``rounds`` runs in all, by default ``problem.ROUNDS``: one for
        the exact problem); the ends are compared each with its own neighbours."""
        rounds = problem.ROUNDS if rounds is None else rounds
        d = problem.X.shape[1]
        estimate_nugget = self.nugget == "estimate"
        scale = 1.0 / (len(problem.X) * Y.shape[1])  # an objective per value keeps tolerances n-independent

        def objective(params):
            state = problem.condition(*unpack(params), Y, gradient=True)
            d_theta, d_nugget = state.gradient
            gradient = np.append(d_theta, d_nugget) if estimate_nugget else d_theta
            return -scale * state.log_likelihood.sum(), -scale * gradient

        bounds = list(zip(*self._log_bounds(d)))
        best_value, best_params = np.inf, starts[0]
        ends = []
        for start in starts:
            for _ in range(rounds):
                problem.focus(unpack(start)[0])
                result = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=bounds,
                                  options=options)
                start = result.x
            if rounds > 1:
                problem.focus(unpack(result.x)[0])
                result.fun = objective(result.x)[0]
            ends.append(result.x)
            if result.fun < best_value:
                best_value, best_params = result.fun, result.x
        return ends if every else best_params

    def _install(self, data, y_is_vector, groups, states, diagnostics):
        """Make the model the fitted one: what prediction needs and the public attributes."""
        X, Y = data.X, data.Y
        m, d = Y.shape[1], X.shape[1]
        self._X_train, self._Y_train, self._y_is_vector = X, Y, y_is_vector
        self._x_mean, self._x_scale = data.x_mean, data.x_scale
        self._y_mean, self._y_scale = data.y_mean, data.y_scale
        self._groups, self._states = groups, states
        self._order = data.order  # the Vecchia ordering, None for the exact model
        self.approximation_ = "exact" if data.order is None else "vecchia"
        # Per group, the training side of the exact cross-correlation product (d + 2, n).
        self._training_factors = []
        for state in states if data.order is None else ():
            b = data.problem.X * np.sqrt(state.theta)
            self._training_factors.append(np.vstack([2.0 * b.T, -np.ones(len(b)),
                                                     -np.einsum("ij,ij->i", b, b)]))
        self.n_features_in_ = d
        self.diagnostics_ = list(diagnostics)
        self.nugget_, self.jitter_ = np.empty(m), np.empty(m)
        self.sigma2_, self.log_likelihood_ = np.empty(m), np.empty(m)
        self.beta_ = np.empty((data.problem.F.shape[1], m))
        theta = np.empty((m, d))
        for cols, state in zip(groups, states):
            theta[cols] = state.theta
            self.nugget_[cols] = state.nugget
            self.jitter_[cols] = state.jitter
            self.beta_[:, cols] = state.beta
            self.sigma2_[cols] = state.sigma2 * self._y_scale[cols] ** 2
            self.log_likelihood_[cols] = state.log_likelihood
        self.theta_ = theta[0].copy() if self.shared_theta else theta

    def _report(self, groups, states):
        """Diagnostics: bounds hit by θ or the nugget, jitter added (with one warning)."""
        lo, hi = (float(b) for b in self.theta_bounds)
        optimised = self.n_starts != 0
        jittered = []
        for cols, state in zip(groups, states):
            who = "all outputs" if self.shared_theta else f"output {cols[0]}"
            if optimised:
                for k in np.flatnonzero(state.theta <= lo * BOUND_TOLERANCE):
                    self.diagnostics_.append(
                        f"{who}: theta hit its lower bound in dimension {k}: the field is "
                        f"smoother than the bound allows (lower theta_bounds to let the "
                        f"correlation length grow)")
                for k in np.flatnonzero(state.theta >= hi / BOUND_TOLERANCE):
                    self.diagnostics_.append(
                        f"{who}: theta hit its upper bound in dimension {k}: the field varies "
                        f"faster than the points resolve (add points or raise theta_bounds)")
                if self.nugget == "estimate" and state.nugget >= NUGGET_BOUNDS[1] / BOUND_TOLERANCE:
                    self.diagnostics_.append(
                        f"{who}: the nugget hit its upper bound {NUGGET_BOUNDS[1]:g}: the data "
                        f"look like noise without a correlated field")
            if state.jitter > 0:
                trouble = ("numerically singular" if np.isinf(state.condition)
                           else f"ill-conditioned (cond {state.condition:.0e})")
                note = f"{who}: correlation matrix {trouble}: added jitter {state.jitter:.0e}"
                self.diagnostics_.append(note)
                jittered.append(note)
        if jittered:
            warnings.warn("Kriging fit: " + "; ".join(jittered) + ". The model then smooths "
                          "the data very slightly instead of interpolating them exactly; this "
                          "happens on very smooth fields and is usually harmless (see "
                          "diagnostics_).", RobocalWarning, stacklevel=3)

    # ---------------------------------------------------------------- prediction

    def predict(self, X, return_mse=False, batch_size=1000):
        """Predict the outputs at new inputs: as an error model, the position error there.

        Parameters
        ----------
        X : array-like, shape (N, d)
            Points with the columns of the X given to ``fit``; as an error model, commanded
            (nominal) TCP positions (N, 3) in mm.

        return_mse : bool, optional (default: False)
            Also return the mean squared error of each prediction.

        batch_size : int, optional (default: 1000)
            Points processed at a time by the exact model, so that memory stays at
            batch_size × n floats (the Vecchia approximation needs O(m) per point).

        Returns
        -------
        Y : array, shape (N, m), or (N,) if Y was 1-D in ``fit``
            Predicted mean; as an error model, the position error e = measured − model
            (N, 3) in mm.

        mse : array, same shape as Y
            Only with ``return_mse``: the mean squared error of each prediction, in output
            units squared (mm² for position errors).

        Raises
        ------
        InputError
            If the model is not fitted, or X has other columns than in ``fit`` or contains
            NaN or infinite values.

        Warns
        -----
        RobocalWarning
            For points farther outside the training box than 10 % of its size.
        """
        if not hasattr(self, "_states"):
            raise not_fitted("Kriging model", "fit(X, Y)")
        X = as_matrix(X, "X")
        if X.shape[1] != self.n_features_in_:
            raise InputError(f"X has {X.shape[1]} columns but the model was fitted on "
                             f"{self.n_features_in_}: give points with the same columns, in "
                             f"the same order")
        Xs = (X - self._x_mean) / self._x_scale
        mean = np.empty((len(X), len(self._y_mean)))
        mse = np.empty_like(mean) if return_mse else None
        # The Vecchia predictor bounds its own memory (blocks of targets): all at once.
        step = max(1, len(X) if self.approximation_ == "vecchia" else int(batch_size))
        for start in range(0, len(X), step):
            block = slice(start, start + step)
            self._predict_block(Xs[block], mean[block], None if mse is None else mse[block])
        self._warn_extrapolation(X, Xs)
        if self._y_is_vector:
            return (mean[:, 0], mse[:, 0]) if return_mse else mean[:, 0]
        return (mean, mse) if return_mse else mean

    def _predict_block(self, Xs, mean, mse):
        """Fill ``mean`` (and ``mse``) for the standardised points Xs, group by group."""
        f = trend_basis(Xs, self.regression)
        if self.approximation_ == "vecchia":
            for cols, state in zip(self._groups, self._states):
                standard, unit = state.predict(Xs, f, mse is not None)
                mean[:, cols] = self._y_mean[cols] + self._y_scale[cols] * standard
                if mse is not None:
                    mse[:, cols] = unit[:, None] * (state.sigma2 * self._y_scale[cols] ** 2)
            return
        for cols, state, factor in zip(self._groups, self._states, self._training_factors):
            r = self._cross_correlation(Xs, state.theta, factor)
            standard = f @ state.beta + r @ state.alpha
            mean[:, cols] = self._y_mean[cols] + self._y_scale[cols] * standard
            if mse is not None:
                v = _triangular_solve(state.L, r.T)  # L⁻¹r, (n, B)
                u = state.Ft.T @ v - f.T  # FᵀC⁻¹r − f, (p, B)
                w = np.linalg.solve(state.G.T, u)  # G⁻ᵀu: uᵀ(GᵀG)⁻¹u = |w|²
                unit = np.maximum(1.0 + np.einsum("ij,ij->j", w, w)
                                  - np.einsum("ij,ij->j", v, v), 0.0)
                mse[:, cols] = unit[:, None] * (state.sigma2 * self._y_scale[cols] ** 2)

    def _cross_correlation(self, Xs, theta, training_factor):
        """R(x, X_train) for the rows of Xs: (B, n).

        −S = 2aᵀb − |a|² − |b|² (a, b the θ-scaled points) comes out of one matrix product of
        augmented coordinates [a, |a|², 1]·[2b, −1, −|b|²]ᵀ, so the only other pass over the
        B × n block is the exponential.
        """
        a = Xs * np.sqrt(theta)
        minus_S = np.column_stack([a, np.einsum("ij,ij->i", a, a), np.ones(len(a))]) \
            @ training_factor
        if self.correlation == "gaussian":
            # Rounding can leave −S slightly positive for a training point: R = 1 + O(ε).
            return np.exp(minus_S, out=minus_S)
        S = np.maximum(np.negative(minus_S, out=minus_S), 0.0, out=minus_S)
        return correlation_from_squared(S, self.correlation, out=S)

    def _warn_extrapolation(self, X, Xs):
        lo, hi = self._X_train.min(axis=0), self._X_train.max(axis=0)
        margin = EXTRAPOLATION_MARGIN * (hi - lo)
        excess = np.maximum(lo - margin - X, X - hi - margin)
        relative = np.max(excess / np.where(hi > lo, hi - lo, 1.0), axis=1)
        outside = np.flatnonzero(relative > 0)
        if not len(outside):
            return
        farthest = outside[np.argsort(relative[outside])[::-1][:EXTRAPOLATION_STD_POINTS]]
        mean = np.empty((len(farthest), len(self._y_mean)))
        mse = np.empty_like(mean)
        self._predict_block(Xs[farthest], mean, mse)
        std = np.sqrt(mse)
        j = int(np.argmax(std.max(axis=0)))
        among = "" if len(farthest) == len(outside) else f" (among the {len(farthest)} farthest)"
        warnings.warn(f"{len(outside)} of {len(X)} points lie more than "
                      f"{EXTRAPOLATION_MARGIN:.0%} of the training box's size outside it: "
                      f"Kriging extrapolates there; the largest predicted standard deviation"
                      f"{among} is {std.max():.3g} (output {j}). Add training points that "
                      f"cover these targets", RobocalWarning, stacklevel=3)

    # ------------------------------------------------------------ serialisation

    def to_dict(self):
        """The fitted model as a JSON-ready dict, from which ``from_dict`` rebuilds it.

        Returns
        -------
        document : dict
            Lists, numbers and strings only: the format tag and version, the settings, the
            training data and the fitted θ, nugget and jitter.

        Raises
        ------
        InputError
            If the model is not fitted.
        """
        if not hasattr(self, "_states"):
            raise not_fitted("Kriging model", "fit(X, Y)")
        theta = np.atleast_2d(self.theta_)
        document = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "settings": {
                "regression": self.regression,
                "correlation": self.correlation,
                "theta_bounds": [float(b) for b in self.theta_bounds],
                "nugget": self.nugget if isinstance(self.nugget, str) else float(self.nugget),
                "shared_theta": bool(self.shared_theta),
                "approximation": self.approximation,
                "neighbours": None if self.neighbours is None else int(self.neighbours),
            },
            "y_is_vector": bool(self._y_is_vector),
            "X": self._X_train.tolist(),
            "Y": self._Y_train.tolist(),
            "theta": theta.tolist(),
            "nugget": self.nugget_.tolist(),
            "jitter": self.jitter_.tolist(),
            "diagnostics": list(self.diagnostics_),
        }
        if self._order is not None:
            # What the Vecchia fit conditioned on: its ordering of the training rows and its
            # number of neighbours (the neighbours themselves follow from θ).
            document["vecchia"] = {"neighbours": int(self._states[0].neighbours),
                                   "order": self._order.tolist()}
        return document

    @classmethod
    def from_dict(cls, document):
        """Rebuild a fitted model from ``to_dict`` output: identical predictions, no optimisation.

        Parameters
        ----------
        document : dict
            What ``to_dict`` returned (possibly after a round trip through JSON).

        Returns
        -------
        model : Kriging
            The fitted model.

        Raises
        ------
        FileFormatError
            If the document is not a Kriging model of this format version, or is incomplete
            or inconsistent.
        """
        check_header(document, "Kriging model", FORMAT, FORMAT_VERSION)
        model, parts = _read_document(cls, document)
        X, Y, theta, nugget, jitter = (parts[k] for k in ("X", "Y", "theta", "nugget", "jitter"))
        y_is_vector = parts["y_is_vector"]
        groups = model._groups(Y.shape[1])
        m, d = Y.shape[1], X.shape[1]
        if theta.shape != (len(groups), d) or nugget.shape != (m,) or jitter.shape != (m,) \
                or len(X) != len(Y) or (y_is_vector and m != 1):
            raise damaged("Kriging model", "inconsistent array sizes")
        # A NaN θ or jitter would make the factorisation below retry forever.
        if not (np.all(theta > 0) and np.all(nugget >= 0) and np.all(jitter >= 0)
                and np.all(np.isfinite(np.concatenate([theta.ravel(), nugget, jitter])))):
            raise damaged("Kriging model", "theta, nugget or jitter is negative or not finite")
        try:
            data = _Training(X, Y, model.regression, model.correlation, *parts["vecchia"])
        except InputError as error:
            raise damaged("Kriging model", str(error)) from None
        # The stored jitter is tried first, so the factorisation is the one the fit ended with.
        states = [data.problem.final(theta[i], nugget[cols[0]], data.Ys[:, cols], start_jitter=jitter[cols[0]])
                  for i, cols in enumerate(groups)]
        model._install(data, y_is_vector, groups, states, parts["diagnostics"])
        return model


def _read_document(cls, document):
    """The settings of a Kriging document (as an unfitted model) and its other parts as
    arrays and plain values, or a FileFormatError saying what is missing or malformed."""
    try:
        settings = document["settings"]
        # Documents written before the Vecchia approximation existed are exact fits.
        model = cls(regression=settings["regression"], correlation=settings["correlation"],
                    theta_bounds=tuple(settings["theta_bounds"]), nugget=settings["nugget"],
                    shared_theta=settings["shared_theta"], approximation=settings.get("approximation", "auto"),
                    neighbours=settings.get("neighbours"))
        parts = {"X": as_matrix(document["X"], "X"), "Y": as_matrix(document["Y"], "Y")}
        parts.update((key, np.array(document[key], dtype=float))
                     for key in ("theta", "nugget", "jitter"))
        parts.update((key, document[key]) for key in ("y_is_vector", "diagnostics"))
        parts["vecchia"] = _read_vecchia(document.get("vecchia"), len(parts["X"]))
    except (KeyError, TypeError, ValueError) as error:  # InputError is a ValueError
        raise damaged("Kriging model", error) from None
    if not isinstance(parts["y_is_vector"], bool) or not isinstance(parts["diagnostics"], list):
        raise damaged("Kriging model", "'y_is_vector' or 'diagnostics' has the wrong type")
    parts["diagnostics"] = [str(note) for note in parts["diagnostics"]]
    try:
        model._check_settings()
    except InputError as error:
        raise damaged("Kriging model", f"invalid settings: {error}") from None
    return model, parts


def _read_vecchia(entry, n):
    """(True, neighbours, order) of a document's "vecchia" entry, (False, None, None) without
    one; ValueError if it is malformed."""
    if entry is None:
        return False, None, None
    neighbours, order = entry["neighbours"], entry["order"]
    if not (isinstance(neighbours, int) and not isinstance(neighbours, bool) and neighbours >= 1):
        raise ValueError(f"'vecchia' 'neighbours' must be a whole number >= 1, got {neighbours!r}")
    order = np.asarray(order)
    if order.shape != (n,) or order.dtype.kind not in "iu" or not np.array_equal(np.sort(order), np.arange(n)):
        raise ValueError("'vecchia' 'order' must list every training row once")
    return True, neighbours, order


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
            from .vecchia import VecchiaProblem

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
    from .vecchia import VecchiaProblem

    return VecchiaProblem.of(plain["Xs"], plain["F"], plain["correlation"], plain["neighbours"], plain["order"])


def search_task(task):
    """One group's likelihood search (:meth:`Kriging._optimise`) on a worker of
    :mod:`robocal.parallel`: plain data in (the settings, the problem, the standardised
    outputs, the drawn candidates), [θ, nugget] out."""
    theta, nugget = Kriging(**task["settings"])._optimise(problem_of(task["problem"]), task["Y"], task["candidates"])
    return [np.asarray(theta), float(nugget)]
