"""The Kriging estimator: settings, fit, prediction and its JSON document (the model is in the
package docstring; the likelihood search in :mod:`.search`)."""
import warnings

import numpy as np

from ...errors import InputError, RobocalWarning
from ..arrays import (as_matrix, check_choice, check_flag, check_header, check_random_state,
                      check_whole, damaged, is_real, not_fitted)
from .correlation import _triangular_solve, correlation_from_squared, trend_basis, trend_size
from .point import point_predictor
from .search import NUGGET_BOUNDS, HyperparameterSearch, theta0_of, theta0_values
from .training import _Training

REGRESSIONS = ("constant", "linear", "quadratic")
CORRELATIONS = ("gaussian", "matern52")
# The exact model, or the Vecchia approximation of its likelihood and predictor
# (robocal.estimation.kriging.vecchia); "auto" takes the approximation above AUTO_VECCHIA_ABOVE points.
# Measured on the UR10's residual after kinematic calibration (series A, one core, 3 outputs,
# nugget estimated; held-out mean on 3,000 other poses): n = 750 exact 3.2 s, Vecchia 5.1 s;
# n = 1,000: 9.5 s against 6.2 s; n = 1,500: 17.5 s against 9.4 s, the held-out errors
# within 2 % of each other at every size.  Exact fits of 1,000 points or fewer stay as they were.
APPROXIMATIONS = ("exact", "vecchia", "auto")
AUTO_VECCHIA_ABOVE = 1000

FORMAT = "robocal.kriging"
FORMAT_VERSION = 1
# A parameter within this factor of a bound (in θ) is reported as having hit it.
BOUND_TOLERANCE = 1.01
# Points farther than this fraction of the training box's size outside it are extrapolated.
EXTRAPOLATION_MARGIN = 0.1
# The predicted standard deviation quoted in the extrapolation warning is computed for at
# most this many of the farthest points, so that a warning never costs more than predicting.
EXTRAPOLATION_STD_POINTS = 1000



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
        None is θ = 0.5 / d, a correlation of about e⁻¹ between typical point pairs.  The first
        run starts from the best (by likelihood) of theta0 times 10⁻³ … 10² (with an estimated
        nugget, each of them with a nugget of 1e-2 and of 1 relative to σ²; :mod:`.search`).
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
        L-BFGS-B runs: one from the scaled theta0, the others from the best (by likelihood)
        of a Latin hypercube of max(10, 2·n_starts) points in log θ (and log nugget); a run
        that stops unconverged is continued from its end.  0 fixes θ = theta0 (and needs a
        numeric nugget).  None picks 4 for n ≤ 400, 2 for n ≤ 1500, else 1:
        small designs have several optima, large ones are cheap to screen but dear to
        optimise (a fit of 1000 points and 3 outputs takes 5 to 8 s on one core).  The
        Vecchia approximation's search between 1,000 and 2,000 points runs on a cheaper
        stand-in and takes at least 4 up to 1,500 points and 2 above
        (:mod:`robocal.estimation.kriging.vecchia`).
    shared_theta : bool
        False: one θ (and nugget) per output, each maximising its own likelihood (the paper's
        way).  True: one θ for all outputs, maximising the sum of their likelihoods.
    random_state : None, int or numpy Generator
        Seeds the Latin hypercube of starts: an int ≥ 0 makes fits reproducible, a Generator
        is used (and advanced) as is, None draws fresh entropy.
    approximation : "exact" | "vecchia" | "auto"
        The exact likelihood and predictor (O(n³) time, O(n²) memory), or their Vecchia
        approximation (:mod:`robocal.estimation.kriging.vecchia`: each point conditioned on its nearest
        earlier points, O(n m³) time, O(n m) memory); "auto" is exact up to
        AUTO_VECCHIA_ABOVE training points and Vecchia above.
    neighbours : int ≥ 1 or None
        Vecchia only: the neighbours m each point is conditioned on in the likelihood (the
        local predictors take ⌈4m/3⌉, ``vecchia_prediction.PREDICTION_SET_FACTOR``); None is
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
            search = self._search()
            drawn = [search.candidates(data.problem, data.Ys[:, cols], rng) for cols in groups]
            fixed = search.run(data, groups, drawn)
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
        return theta0_values(self.theta0)

    def _theta0(self, d):
        """theta0 as d positive numbers (default 0.5 / d)."""
        return theta0_of(self.theta0, d)

    def _search(self):
        """The hyperparameter search of these settings (:mod:`.search`)."""
        return HyperparameterSearch(self.theta0, self.theta_bounds, self.nugget, self.n_starts)

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
                        f"{who}: theta hit its lower bound in dimension {k}: the error barely "
                        f"changes along that input over these points (measure points spread "
                        f"wider along it, or take the error as smooth there)")
                for k in np.flatnonzero(state.theta >= hi / BOUND_TOLERANCE):
                    self.diagnostics_.append(
                        f"{who}: theta hit its upper bound in dimension {k}: the error varies "
                        f"faster along that input than the points resolve (measure more points)")
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
        point = point_predictor(self) if len(X) == 1 else None
        if point is not None:  # one point, as robocal serve asks: the batch's formulas without its set-up
            mean, mse, beyond = point.predict_row(X, return_mse)
            if beyond:
                self._warn_extrapolation(X, (X - self._x_mean) / self._x_scale)
        else:
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

    def _training_box(self):
        """(X_train, lo − margin, hi, margin, extent), each but the first (d,): a point
        beyond [lo − margin, hi + margin] in a column is extrapolated (by excess / extent)."""
        box = self.__dict__.get("_box")
        if box is None or box[0] is not self._X_train:
            # Kept with the training points it is of: a point at a time (robocal serve) paid
            # for the training box at every prediction.
            lo, hi = self._X_train.min(axis=0), self._X_train.max(axis=0)
            margin = EXTRAPOLATION_MARGIN * (hi - lo)
            box = self._box = (self._X_train, lo - margin, hi, margin, np.where(hi > lo, hi - lo, 1.0))
        return box

    def _warn_extrapolation(self, X, Xs):
        _, low, hi, margin, extent = self._training_box()
        excess = np.maximum(low - X, X - hi - margin)
        relative = np.max(excess / extent, axis=1)
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

