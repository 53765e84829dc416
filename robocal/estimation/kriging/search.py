"""The hyperparameter search of a Kriging fit: θ (standardised-input units: inputs scaled to
unit standard deviation) and an estimated nugget (relative to σ²) maximising the concentrated
log-likelihood (package docstring), summed over a group's outputs, by L-BFGS-B on log θ (and
log nugget).  The first run starts from the best by likelihood of theta0 times 10⁻³ … 10²,
each with a nugget of 1e-2 and of 1 when the nugget is estimated (SCALE_DECADES,
NUGGET_STARTS); the others from the best screened points of a Latin hypercube.  A run that
stops unconverged is continued from its end (RESTARTS).  The search runs on the problem a
fit's likelihood chooses to search on (the exact likelihood, or a Vecchia fit's stand-ins,
:mod:`.stand_ins`); its objective is the log-likelihood per value (over n times the number
of outputs), so that OPTIONS' tolerances and RESTART_GRADIENT do not depend on n."""
import math

import numpy as np

from ... import parallel
from ...errors import InputError
from .correlation import latin_hypercube
from .training import problem_of

# Bounds of an estimated nugget, relative to the process variance σ².
NUGGET_BOUNDS = (1e-12, 10.0)
# L-BFGS-B settings.  Near the smooth end of θ the correlation matrix is nearly singular:
# the computed log-likelihood is then noisy at about 1e-5 of its value (rounding in the
# Cholesky factor of a matrix with condition number ~1e16) and line searches that try to
# resolve that noise fail after many evaluations.  The tolerances stop the search at that
# level, which is far below any statistically meaningful change of the likelihood.  Measured
# on smooth 3-D fields (n = 50 to 1000): tighter settings cost up to 1.5 times the time
# without changing the held-out error.
OPTIONS = {"maxiter": 200, "ftol": 1e-5, "gtol": 1e-4, "maxls": 5}
# A run that stops with its projected gradient above RESTART_GRADIENT (per value, as gtol)
# where that noise cannot explain it is run again from its end, with a fresh curvature
# estimate, at most RESTARTS times while the runs gain more than OPTIONS' ftol:
# * after a failed line search, with line searches of LONG_LINE_SEARCH steps: L-BFGS-B's
#   steps can be mis-scaled by orders of magnitude (its first is one unit of log θ long, a
#   later one follows curvature learnt on another scale).  On the hybrid's residuals over the
#   12 joint sines and cosines of the UR5 and the UR10 (series A), 5 of 36 first runs stopped
#   so after 7 evaluations, 130 to 240 log-units below where longer line searches took them.
#   On the hybrid's residuals of the UR5 and UR10 A and B (400 to 600 poses, 15 components),
#   continuations with line searches of 10, 20 or 40 steps reached the same optima; with 5
#   steps two of the components stayed 237 and 336 below;
# * after the relative-reduction test stopped it on a step that went nowhere.  On the UR10's
#   error over the joints' sines and cosines this took runs from −427 to −0.3 and from −345
#   to −192.
# The noise is presumed where the correlation matrix needed jitter or its condition number
# exceeds NOISY_CONDITION: there runs again only spend evaluations (smooth 3-D fields,
# n = 500, four sets: 28 % more for the same optima; their runs end with jitter, the UR ones
# above with condition numbers below 2e5).  On the UR residuals (400 to 750 poses, 36
# components) no run needed more than two continuations.
RESTARTS = 3
RESTART_GRADIENT = 1e-3
LONG_LINE_SEARCH = 20
NOISY_CONDITION = 1e10
# Latin-hypercube points whose likelihood is evaluated to choose the starts after the first.
SCREENED_CANDIDATES = 10
# The first run starts from the best by likelihood of theta0 times 10^k for k in
# SCALE_DECADES, each (with an estimated nugget) with every nugget of NUGGET_STARTS (relative
# to σ²).  The likelihood has plateaus on which its gradient vanishes: the white-noise model
# (the nugget at its upper bound, or every θ so large that the correlation matrix is the
# identity) and inputs switched off (θ_k at its lower bound: the gradient in log θ_k is
# θ_k ∂ℓ/∂θ_k).  From a start whose likelihood is below the white-noise model's, as
# theta0 = 0.5/d with a nugget of 1e-6 was on the UR10's residual over the 12 sines and
# cosines of the joints, L-BFGS-B's first steps land on such a plateau and stop there.
# The best grid point was 10⁻¹ or 10⁰ on smooth 3-D fields (n = 50 to 500, noise 0 to 0.01
# of the field), 10⁰ to 10² on the hybrid's residuals over the joints' 12 sines and cosines
# (UR5, UR10 A and B, 400 to 750 poses); with 10³ added it was never chosen and no optimum
# changed.  The two lowest decades are margin for fields smoother than these.  A starting
# nugget of 1e-4 won on the smooth fields, which reach the same maxima from 1e-2 (one start,
# 18 cases, within 0.013: their likelihoods' rounding noise), and on the plateau: with θ so
# large that the correlation matrix is nearly the identity the nugget hardly changes the
# likelihood, and the smallest won by a
# fraction of a unit; from there the UR5's hybrid residual (full+compliance+gains, a random
# half) ran into a nearly interpolating optimum 44 below the maximum (held out 0.0686 mm
# against 0.0647), and a Gaussian-process sample over 12 joint sines and cosines 3.1 below.
# The 12 values (without gradient) cost 10 to 12 % of a one-start fit of those residuals.
SCALE_DECADES = (-3, -2, -1, 0, 1, 2)
NUGGET_STARTS = (1e-2, 1.0)


def theta0_values(theta0):
    """``theta0`` as a flat array of positive finite numbers (raises an InputError if not)."""
    try:
        values = np.asarray(theta0, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        values = np.array([np.nan])
    if not values.size or not np.all((values > 0) & np.isfinite(values)):
        raise InputError(f"theta0 must be None, one positive number or one per input "
                         f"column, got {theta0!r}")
    return values


def theta0_of(theta0, d):
    """``theta0`` as d positive numbers (None: 0.5 / d)."""
    if theta0 is None:
        return np.full(d, 0.5 / d)
    values = theta0_values(theta0)
    if values.size not in (1, d):
        raise InputError(f"theta0 must be one positive number or {d} (one per input "
                         f"column), got {theta0!r}")
    return np.broadcast_to(values, (d,)).copy()


class HyperparameterSearch:
    """The search of one Kriging's settings (``theta0``, ``theta_bounds``, ``nugget``,
    ``n_starts``, as :class:`~robocal.estimation.kriging.Kriging` takes them, already checked)."""

    def __init__(self, theta0, theta_bounds, nugget, n_starts):
        self.theta0 = theta0
        self.theta_bounds = theta_bounds
        self.nugget = nugget
        self.n_starts = n_starts

    def settings(self):
        """The settings as plain data, from which ``HyperparameterSearch(**settings)`` rebuilds it."""
        return {"theta0": self.theta0, "theta_bounds": self.theta_bounds, "nugget": self.nugget,
                "n_starts": self.n_starts}

    def starts(self, n, least=1):
        """How many L-BFGS-B runs a search makes: ``n_starts``, or by default 4 up to 400
        points, 2 up to 1,500, then 1 (at least ``least``)."""
        if self.n_starts is not None:
            return int(self.n_starts)
        return max(least, 4 if n <= 400 else 2 if n <= 1500 else 1)

    def candidates(self, problem, Y, rng):
        """The Latin hypercube of [log θ (, log nugget)] a search of outputs ``Y`` screens for
        its starts (drawn from ``rng``), or None when it has no random starts."""
        n, d = problem.X.shape
        n_starts = self.starts(n, problem.least_starts)
        if self.n_starts == 0 or not Y.any() or n_starts == 1:
            return None
        return latin_hypercube(max(SCREENED_CANDIDATES, 2 * n_starts), *self.log_bounds(d), rng)

    def starting_points(self, d, n, candidates, log_likelihood, least=1):
        """Rows of [log θ (, log nugget)] to start L-BFGS-B from: the first (:meth:`first_start`),
        then the best of the Latin hypercube ``candidates`` by ``log_likelihood``.  A value
        without gradient costs a third of one with it, and runs from good points converge in
        fewer steps: measured, 25 % less time at n = 1000 for the same optimum."""
        first = self.first_start(d, log_likelihood)
        if candidates is None:
            return first[None, :]
        best = np.argsort([-log_likelihood(c) for c in candidates])[:self.starts(n, least) - 1]
        return np.vstack([first, candidates[best]])

    def first_start(self, d, log_likelihood):
        """The [log θ (, log nugget)] of the first run: the best by ``log_likelihood`` of theta0
        scaled by 10^k (k in SCALE_DECADES), with an estimated nugget each with every nugget
        of NUGGET_STARTS (see there); within the bounds."""
        lower, upper = self.log_bounds(d)
        shape = np.log(theta0_of(self.theta0, d))
        scales = [shape + k * math.log(10.0) for k in SCALE_DECADES]
        if self.nugget == "estimate":
            grid = [np.append(theta, math.log(nugget)) for theta in scales for nugget in NUGGET_STARTS]
        else:
            grid = scales
        grid = np.unique(np.clip(grid, lower, upper), axis=0)
        values = np.array([log_likelihood(point) for point in grid])
        return grid[int(np.argmax(np.where(np.isfinite(values), values, -np.inf)))]

    def log_bounds(self, d):
        """(lower, upper) bounds of [log θ (, log nugget)], each (d,) or (d + 1,)."""
        lo, hi = (float(b) for b in self.theta_bounds)
        lower, upper = np.full(d, math.log(lo)), np.full(d, math.log(hi))
        if self.nugget == "estimate":
            lower = np.append(lower, math.log(NUGGET_BOUNDS[0]))
            upper = np.append(upper, math.log(NUGGET_BOUNDS[1]))
        return lower, upper

    def optimise(self, problem, Y, candidates):
        """Maximise the summed concentrated likelihood of the columns of Y from the best scaled
        theta0 (:meth:`first_start`) and the best of ``candidates`` (:meth:`candidates`): the
        best (θ, nugget)."""
        n, d = problem.X.shape
        estimate_nugget = self.nugget == "estimate"

        def unpack(params):
            theta = np.exp(params[:d])
            nugget = math.exp(params[d]) if estimate_nugget else float(self.nugget)
            return theta, nugget

        if self.n_starts == 0:
            return theta0_of(self.theta0, d), float(self.nugget)
        if not Y.any():  # constant outputs: the likelihood does not depend on θ
            return theta0_of(self.theta0, d), NUGGET_BOUNDS[0] if estimate_nugget else float(self.nugget)
        # The exact problem searches on itself; the Vecchia one on the exact likelihood, on
        # a cheaper stand-in for it whose optimum is then refined (robocal.estimation.kriging.vecchia).
        search = problem.search_problem()

        def screened(params):
            theta, nugget = unpack(params)
            search.focus(theta)
            return search.condition(theta, nugget, Y).log_likelihood.sum()

        starts = self.starting_points(d, n, candidates, screened, least=problem.least_starts)
        plan = problem.refinement(search)
        if plan is None:
            return unpack(self.minimise(search, Y, starts, unpack, OPTIONS))
        # The stand-in's optima are judged by the likelihood they stand in for: the runs land
        # in different local optima, and the stand-in's ranking of them is not that one's.
        refine, options = plan
        ends = self.minimise(search, Y, starts, unpack, OPTIONS, every=True)
        if "evaluations" in options:
            return unpack(self._refine_quasi_newton(search, refine, Y, ends, unpack, options))
        best = ends[0][0] if len(ends) == 1 else max((end for end, _ in ends),
                                                     key=lambda end: _judged(refine, Y, unpack(end)))
        return unpack(self.minimise(refine, Y, [best], unpack, options, rounds=1, restarts=0))

    def _refine_quasi_newton(self, search, refine, Y, ends, unpack, options):
        """The parameters that maximise the likelihood of ``refine`` (the exact one: a few
        evaluations, each costly), by quasi-Newton steps (:func:`_quasi_newton`) from the best
        of the stand-in ``search``'s ``ends`` ([(parameters, stand-in's value)]), with the
        stand-in's curvature there as the first Hessian.  Ends further apart than
        options["apart"] (in log θ or log nugget) may lie in different basins of the refined
        likelihood, which then judges them; closer, they lead to the same optimum and the
        stand-in's best is taken."""
        d = search.X.shape[1]
        bounds = self.log_bounds(d)
        objective, stand_in = self._objective(refine, Y, unpack), self._objective(search, Y, unpack)
        points = np.array([end for end, _ in ends])
        if np.ptp(points, axis=0).max() > options["apart"]:
            best, first = min(((end, objective(end)) for end in points), key=lambda pair: pair[1][0])
        else:
            best = points[int(np.argmin([value for _, value in ends]))]
            first = objective(best)
        return _quasi_newton(objective, best, first, _hessian(stand_in, best, *bounds), bounds, options)

    def _objective(self, problem, Y, unpack):
        """params ↦ (−Σ ℓ, −∇Σ ℓ) of ``problem`` for the columns of Y, params [log θ (, log nugget)]."""
        estimate_nugget = self.nugget == "estimate"

        def objective(params):
            state = problem.condition(*unpack(params), Y, gradient=True)
            d_theta, d_nugget = state.gradient
            gradient = np.append(d_theta, d_nugget) if estimate_nugget else d_theta
            return -state.log_likelihood.sum(), -gradient

        return objective

    def minimise(self, problem, Y, starts, unpack, options, rounds=None, every=False, restarts=RESTARTS):
        """L-BFGS-B from each start on the summed concentrated likelihood: the best parameters
        (with ``every``, [(end, value)] of each start's run instead, in the order of the starts).
        A run that ends unconverged is run again from its end (:func:`_lbfgsb`, ``restarts``).

        A Vecchia problem conditions on neighbours in the metric of θ (``focus``): each run
        starts with the neighbours of its start, and runs again from its end with the
        neighbours found there (``rounds`` runs in all, by default ``problem.ROUNDS``: one for
        the exact problem); the ends are compared each with its own neighbours."""
        rounds = problem.ROUNDS if rounds is None else rounds
        d = problem.X.shape[1]
        estimate_nugget = self.nugget == "estimate"
        scale = 1.0 / (len(problem.X) * Y.shape[1])  # an objective per value keeps tolerances n-independent

        last = {}

        def objective(params):
            state = problem.condition(*unpack(params), Y, gradient=True)
            last.update(params=params.copy(), state=state)
            d_theta, d_nugget = state.gradient
            gradient = np.append(d_theta, d_nugget) if estimate_nugget else d_theta
            return -scale * state.log_likelihood.sum(), -scale * gradient

        def noisy(params):
            """Whether the likelihood at ``params`` is computed from a correlation matrix that
            needed jitter or is conditioned beyond NOISY_CONDITION (unknown for the block
            stand-in, whose states do not say: not noisy)."""
            seen = last.get("params")
            state = last["state"] if seen is not None and np.array_equal(seen, params) else \
                problem.condition(*unpack(params), Y)
            return getattr(state, "jitter", 0.0) > 0 or getattr(state, "condition", 0.0) > NOISY_CONDITION

        bounds = self.log_bounds(d)
        best_value, best_params = np.inf, starts[0]
        ends = []
        for start in starts:
            for _ in range(rounds):
                problem.focus(unpack(start)[0])
                result = _lbfgsb(objective, start, bounds, options, restarts, noisy)
                start = result.x
            if rounds > 1:
                problem.focus(unpack(result.x)[0])
                result.fun = objective(result.x)[0]
            ends.append((result.x, result.fun))
            if result.fun < best_value:
                best_value, best_params = result.fun, result.x
        return ends if every else best_params

    def run(self, data, groups, drawn):
        """[(θ, nugget)] of each group of outputs (:meth:`optimise`) of the training data
        ``data`` (:class:`~.training._Training`), ``drawn`` the candidates of each group: one
        after the other here, or one group a task on the active
        :func:`robocal.parallel.executor` (``--jobs``) when there are several."""
        runner = parallel.current()
        if runner.client is None or len(groups) == 1:
            return [self.optimise(data.problem, data.Ys[:, cols], candidates)
                    for cols, candidates in zip(groups, drawn)]
        tasks = [{"settings": self.settings(), "problem": data.plain(), "Y": data.Ys[:, cols],
                  "candidates": candidates} for cols, candidates in zip(groups, drawn)]
        return [(np.asarray(theta), nugget) for theta, nugget in runner.map(search_task, tasks)]


def _lbfgsb(objective, start, bounds, options, restarts, noisy):
    """scipy's L-BFGS-B result of ``objective`` (params ↦ (value, gradient)) from ``start``
    within ``bounds`` ((lower, upper)) with ``options``, run again from its end at most
    ``restarts`` times while it stopped early where the likelihood is not ``noisy`` (params ↦
    bool; see RESTARTS) and the runs gain."""
    from scipy.optimize import minimize  # loaded when used: the command line starts faster
    pairs = list(zip(*bounds))
    result = minimize(objective, start, jac=True, method="L-BFGS-B", bounds=pairs, options=options)
    for _ in range(restarts):
        if (result.status not in (0, 2) or _projected_gradient(result.x, result.jac, bounds) <= RESTART_GRADIENT
                or noisy(result.x)):
            break
        again_options = dict(options, maxls=LONG_LINE_SEARCH) if result.status == 2 else options
        again = minimize(objective, result.x, jac=True, method="L-BFGS-B", bounds=pairs, options=again_options)
        gained = result.fun - again.fun
        if gained > 0:
            result = again
        if not gained > options["ftol"] * max(abs(result.fun), 1.0):
            break
    return result


def _projected_gradient(x, gradient, bounds):
    """The largest component of ``gradient`` at x that is not held by a bound it pushes against."""
    lower, upper = bounds
    held = ((x <= lower) & (gradient > 0)) | ((x >= upper) & (gradient < 0))
    return float(np.abs(np.where(held, 0.0, gradient)).max())


def _hessian(objective, x, lower, upper, step=1e-3):
    """The Hessian (k, k) of ``objective``'s value at x (k,) from forward differences of its
    gradient (stepping inwards at a bound), symmetrised and made positive definite (its
    eigenvalues' magnitudes, floored at 1e-6 of the largest)."""
    _, gradient = objective(x)
    columns = []
    for k in range(len(x)):
        h = step if x[k] + step <= upper[k] else -step
        moved = x.copy()
        moved[k] += h
        columns.append((objective(moved)[1] - gradient) / h)
    H = np.array(columns).T
    values, vectors = np.linalg.eigh(0.5 * (H + H.T))
    values = np.maximum(np.abs(values), 1e-6 * np.abs(values).max() + 1e-12)
    return (vectors * values) @ vectors.T


def _quasi_newton(objective, x, first, H, bounds, options):
    """Minimise ``objective`` (params ↦ (value, gradient)) from x with ``first`` its value and
    gradient there and H a positive definite Hessian estimate: BFGS steps −H⁻¹g on the
    parameters not held at a bound (``bounds``: (lower, upper)), each at most
    options["longest"] long in every coordinate, at most options["evaluations"] of them, until
    the decrease the model predicts is below options["tolerance"] (units of the value).  A
    step that does not decrease the value is not taken, but its curvature is learnt."""
    lower, upper = bounds
    f, g = first
    for _ in range(options["evaluations"]):
        free = ~(((x <= lower) & (g > 0)) | ((x >= upper) & (g < 0)))
        if not free.any():
            break
        step = np.zeros_like(x)
        step[free] = -np.linalg.solve(H[np.ix_(free, free)], g[free])
        longest = np.abs(step).max()
        if longest > options["longest"]:
            step *= options["longest"] / longest
        s = np.clip(x + step, lower, upper) - x
        if -(g @ s + 0.5 * s @ H @ s) < options["tolerance"]:
            break
        f_new, g_new = objective(x + s)
        y = g_new - g
        if s @ y > 1e-12 * np.linalg.norm(s) * np.linalg.norm(y):
            Hs = H @ s
            H = H - np.outer(Hs, Hs) / (s @ Hs) + np.outer(y, y) / (s @ y)
        elif f_new >= f:
            H = 4.0 * H  # no curvature learnt: shorter steps
        if f_new < f:
            x, f, g = x + s, f_new, g_new
    return x


def _judged(problem, Y, parameters):
    """The summed log-likelihood of ``problem`` at (θ, nugget), its neighbours found in θ's metric."""
    theta, nugget = parameters
    problem.focus(theta)
    return problem.condition(theta, nugget, Y).log_likelihood.sum()


def search_task(task):
    """One group's likelihood search (:meth:`HyperparameterSearch.optimise`) on a worker of
    :mod:`robocal.parallel`: plain data in (the settings, the problem, the standardised
    outputs, the drawn candidates), [θ, nugget] out."""
    theta, nugget = HyperparameterSearch(**task["settings"]).optimise(problem_of(task["problem"]), task["Y"],
                                                                     task["candidates"])
    return [np.asarray(theta), float(nugget)]
