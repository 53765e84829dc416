"""Kriging error model of robocal beside SMT's KRG and scikit-learn's GaussianProcessRegressor,
and robocal's Vecchia approximation beside exact Kriging and GPBoost's Vecchia GP.

The data are a smooth positioning-error field of the size a geometrically miscalibrated robot
shows: errors of about 1 mm over a 1000 mm box, built from the linear part small joint-offset
and base-rotation errors produce, a quadratic sag, and long-wavelength sinusoids for
everything else.  For n = 50, 200, 1000 and 3000 Latin-hypercube training points (3 error
components) it prints the fit time, the time to predict 100,000 points (mean only), the time
for 10,000 points with the mean squared error, and the RMS and largest error over 1,000
held-out points.  Every model is one per error component, the paper's way; robocal's shared-θ
variant is shown too.  A peer's fit runs in a child process and is stopped after 60 s; the
output then says so and that peer is not tried at larger n.

The large section (``--large``, or after the small one) fits n = 2,000, 10,000 and 100,000
points: robocal's exact Kriging (n ≤ 3,000: its memory grows as n²) and its Vecchia
approximation (``approximation="vecchia"``), scikit-learn's exact GPR and, when it installs
(``pip install gpboost``; optional, never a dependency), GPBoost's Gaussian process with its
Vecchia approximation (ARD Matérn 5/2, 30 neighbours, one thread).  Each fit runs in its own
child process, so its peak memory (the whole process) is its own; the peers' fits are stopped
after ``--budget`` seconds.  It prints wall and CPU seconds of the fit and of the 100,000
predictions (the machine may be shared) and, where robocal's exact Kriging ran, each RMS
relative to exact Kriging's (the UR10 table: the mean error relative to it); at every n
also with 0.01 mm noise on the readings (nugget estimated; ``--noise noisy`` for those
alone, ``--peers gpboost`` for that peer alone, ``--without-robocal`` for the peers).  Under
each peer's row: its fit time over robocal vecchia's (wall and CPU; the two fits run one
after the other in the same invocation, so both see the machine's load, which is printed),
and robocal vecchia's held-out RMS over the peer's; a peer stopped at ``--budget`` gets the
lower bound of the ratio.  Then the UR10
comparison: Kriging and the hybrid on 2,000 random series-A poses, held out on the other
9,911, exact against Vecchia, and the hybrid on all 1,495 series-B poses as
``calibrate --method hybrid`` fits it (``--kriging auto``).

    python bench/kriging.py            # both sections, about 25 min on one core
    python bench/kriging.py --quick    # n = 50 and 200 only
    python bench/kriging.py --large    # the large section only
    python bench/kriging.py --large --without-peers --sizes 10000 --without-ur10   # one row
    python bench/kriging.py --search   # the search between 1,000 and 2,000 points, 5 min
    python bench/kriging.py --search --search-splits   # and on 8 more training sets, 15 min

``--search`` compares, in one process, the two ways the hyperparameters of a Vecchia fit of
1,000 to 2,000 points can be searched for (robocal.estimation.kriging.vecchia): the exact likelihood
on all points (as robocal did before, ``BLOCK_SEARCH_ABOVE`` raised to 2,000) and the block
stand-in refined on it (the default): the hybrid on all 1,495 UR10 series-B poses (CPU s),
the held-out errors of kriging and the hybrid on series B's random half (747 poses, exact
Kriging either way) and on 2,000 random series-A poses, and the bench field at n = 2,000
with 0.01 mm noise; each with the exact log-likelihood reached (summed over the components)
and the load average beside the CPU time.
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import multiprocessing  # noqa: E402
import queue  # noqa: E402
import resource  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from robocal.errors import RobocalWarning  # noqa: E402
from robocal.estimation import Kriging  # noqa: E402

SIZES = (50, 200, 1000, 3000)
QUICK_SIZES = (50, 200)
LARGE_SIZES = (2000, 10_000, 100_000)
EXACT_UP_TO = 3000  # robocal's exact Kriging holds d·n² squared differences: 216 MB at 3,000
NOISE_MM = 0.01  # tracker noise of the noisy comparison
UR10_TRAIN = 2000
BOX_LOW = np.array([1000.0, -500.0, 500.0])  # mm: a 1000 mm cube in front of the robot
BOX_SIZE = 1000.0
N_TEST = 1000
N_PREDICT = 100_000
N_MSE = 10_000
PEER_BUDGET = 60.0  # seconds: a peer fit still running then is stopped
PEER_CHUNK = 10_000  # the peers build the whole cross-correlation matrix: predict in chunks


def error_field(P):
    """Positioning error (mm) at positions P (mm): what a nominal model would leave behind."""
    u = (P - (BOX_LOW + BOX_SIZE / 2)) / 1000.0  # metres from the box centre
    x, y, z = u.T
    ex = 0.9 * y - 0.4 * z + 0.35 * np.sin(2.2 * x + 0.4) * np.cos(1.3 * z) + 0.2 * x * z
    ey = -0.7 * x + 0.5 * z + 0.3 * np.sin(1.7 * y - 0.3) + 0.25 * np.cos(1.9 * x + 1.1 * z)
    ez = 0.4 * x - 0.6 * y - 0.5 * (x ** 2 + y ** 2) + 0.2 * np.sin(2.5 * z + x)
    return np.column_stack([ex, ey, ez])


def latin_hypercube(n, rng):
    strata = np.argsort(rng.random((n, 3)), axis=0)
    return BOX_LOW + BOX_SIZE * (strata + rng.random((n, 3))) / n


def timed(func):
    t0 = time.perf_counter()
    result = func()
    return result, time.perf_counter() - t0


def peak_mb():
    """The peak resident memory of this process so far, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class RobocalModel:
    def __init__(self, shared, approximation="exact", nugget=0.0):
        self.name = ("robocal shared θ" if shared else "robocal") + ("" if approximation == "exact" else
                                                                     f" {approximation}")
        self.shared, self.approximation, self.nugget = shared, approximation, nugget

    def fit(self, X, Y):
        with warnings.catch_warnings():
            # Jitter on these very smooth fields is expected; diagnostics_ keeps the notes.
            warnings.simplefilter("ignore", RobocalWarning)
            self.model = Kriging(shared_theta=self.shared, random_state=0, approximation=self.approximation,
                                 nugget=self.nugget).fit(X, Y)

    def predict(self, X):
        return self.model.predict(X)

    def predict_mse(self, X):
        return self.model.predict(X, return_mse=True)


class SMTModel:
    """SMT KRG with its default settings (constant trend, squared exponential), per output."""

    name = "SMT KRG"

    def fit(self, X, Y):
        from smt.surrogate_models import KRG

        self.models = []
        for j in range(Y.shape[1]):
            model = KRG(print_global=False)
            model.set_training_values(X, Y[:, j])
            model.train()
            self.models.append(model)

    def predict(self, X):
        return np.column_stack([_chunked(m.predict_values, X) for m in self.models])

    def predict_mse(self, X):
        return self.predict(X), np.column_stack([m.predict_variances(X) for m in self.models])


class SklearnModel:
    """GaussianProcessRegressor: ARD RBF × constant + white noise, normalize_y, 5 restarts."""

    name = "sklearn GPR"

    def fit(self, X, Y):
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

        self.models = []
        for j in range(Y.shape[1]):
            kernel = ConstantKernel() * RBF(length_scale=np.full(3, 300.0)) + WhiteKernel(1e-5)
            model = GaussianProcessRegressor(kernel, normalize_y=True, n_restarts_optimizer=5,
                                             random_state=0)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                model.fit(X, Y[:, j])
            self.models.append(model)

    def predict(self, X):
        return np.column_stack([_chunked(m.predict, X) for m in self.models])

    def predict_mse(self, X):
        pairs = [m.predict(X, return_std=True) for m in self.models]
        return (np.column_stack([mean for mean, _ in pairs]),
                np.column_stack([std ** 2 for _, std in pairs]))


class GPBoostModel:
    """GPBoost's GPModel with its Vecchia approximation: ARD Matérn 5/2 (its closest to the
    Gaussian correlation that still conditions well), 30 neighbours, its default prediction
    (conditioning on the observed points only), one thread; inputs standardised as robocal's."""

    name = "GPBoost vecchia"

    def fit(self, X, Y):
        import gpboost

        self.mean, self.scale = X.mean(axis=0), X.std(axis=0)
        X = np.ascontiguousarray(X)
        self.models = []
        for j in range(Y.shape[1]):
            model = gpboost.GPModel(gp_coords=(X - self.mean) / self.scale, cov_function="matern_ard",
                                    cov_fct_shape=2.5, gp_approx="vecchia", num_neighbors=30,
                                    num_parallel_threads=1, seed=0)
            # GPBoost 1.8 reads a strided column as if it were contiguous: it would fit the
            # wrong targets (its earlier 0.54 mm held out here), so hand it a contiguous copy.
            model.fit(y=np.ascontiguousarray(Y[:, j]), X=np.ones((len(X), 1)))
            self.models.append(model)

    def _predict(self, X, variance):
        Z = np.ascontiguousarray((X - self.mean) / self.scale)
        out = [m.predict(gp_coords_pred=Z, X_pred=np.ones((len(Z), 1)), predict_var=variance) for m in self.models]
        return np.column_stack([o["mu"] for o in out]), (np.column_stack([o["var"] for o in out]) if variance else None)

    def predict(self, X):
        return self._predict(X, False)[0]

    def predict_mse(self, X):
        return self._predict(X, True)


def _chunked(predict, X):
    return np.concatenate([np.ravel(predict(X[i:i + PEER_CHUNK]))
                           for i in range(0, len(X), PEER_CHUNK)])


def available_peers(large=False):
    peers = []
    try:
        import smt  # noqa: F401
        peers.append(SMTModel())
    except ImportError:
        print("SMT is not installed: pip install smt to compare")
    try:
        import sklearn  # noqa: F401
        peers.append(SklearnModel())
    except ImportError:
        print("scikit-learn is not installed: pip install scikit-learn to compare")
    if large:
        peers = [p for p in peers if not isinstance(p, SMTModel)]
        try:
            import gpboost  # noqa: F401
            peers.append(GPBoostModel())
        except ImportError:
            print("GPBoost is not installed: pip install gpboost to compare a scalable GP")
    return peers


def run(model, X, Y, X_test, Y_test, X_predict, report=None):
    """Fit time, predict times, RMS and max error, then fit CPU time, mean error, this
    process's peak memory (MB) and the CPU time of the 100,000 predictions; ``report(fit_time)``
    is told when fitted."""
    cpu = time.process_time()
    _, fit_time = timed(lambda: model.fit(X, Y))
    cpu = time.process_time() - cpu
    if report:
        report(fit_time)
    predict_cpu = time.process_time()
    _, predict_time = timed(lambda: model.predict(X_predict))
    predict_cpu = time.process_time() - predict_cpu
    _, mse_time = timed(lambda: model.predict_mse(X_predict[:N_MSE]))
    error = np.linalg.norm(model.predict(X_test) - Y_test, axis=1)  # mm, per test point
    return (fit_time, predict_time, mse_time, np.sqrt(np.mean(error ** 2)), error.max(), cpu, error.mean(), peak_mb(),
            predict_cpu)


def _run_in_child(results, *args):
    # SMT prints its failed factorisations (eigenvalue dumps) on stdout: keep the table clean.
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    try:
        results.put(("row", run(*args, report=lambda seconds: results.put(("fitted", seconds)))))
    except Exception as error:  # a peer that fails is reported, not waited for
        results.put(("failed", f"{type(error).__name__}: {error}"))


def run_with_budget(*args, budget=PEER_BUDGET):
    """``run`` in a child process whose fit is stopped after ``budget`` s.

    Returns the row, or a string saying why there is none."""
    context = multiprocessing.get_context("fork")
    results = context.Queue()
    child = context.Process(target=_run_in_child, args=(results, *args))
    child.start()
    try:
        kind, value = results.get(timeout=budget)
        if kind == "fitted":
            kind, value = results.get()
    except queue.Empty:
        child.terminate()
        kind, value = "stopped", f"its fit did not finish in {budget:.0f} s (stopped)"
    child.join()
    return value if kind == "row" else f"skipped: {value}"


def rule(header):
    """Print a table's header and a rule under it."""
    print(header)
    print("-" * len(header))


def test_data():
    """The held-out points, their errors and the 100,000 prediction points (fixed seed)."""
    rng = np.random.default_rng(2024)
    X_test = latin_hypercube(N_TEST, rng)
    Y_test = error_field(X_test)
    X_predict = BOX_LOW + BOX_SIZE * rng.random((N_PREDICT, 3))
    return rng, X_test, Y_test, X_predict


def small_benchmark(sizes):
    rng, X_test, Y_test, X_predict = test_data()
    before = np.linalg.norm(Y_test, axis=1)
    print(f"error field before compensation: RMS {np.sqrt(np.mean(before ** 2)):.3f} mm, "
          f"max {before.max():.3f} mm over {N_TEST} test points (3 components, 1000 mm box)")
    print("errors below are the norm of the 3-D residual after subtracting the prediction; "
          "one core\n")
    header = (f"{'n':>5}  {'model':<17}{'fit s':>9}{'predict 100k s':>16}{'+MSE 10k s':>12}"
              f"{'RMS mm':>11}{'max mm':>11}")
    rule(header)

    models = [RobocalModel(shared=False), RobocalModel(shared=True)] + available_peers()
    given_up = {}  # peer name -> n at which its fit was stopped or failed
    for n in sizes:
        X = latin_hypercube(n, rng)
        Y = error_field(X)
        for model in models:
            if model.name in given_up:
                print(f"{n:>5}  {model.name:<17}skipped: it did not finish at n = "
                      f"{given_up[model.name]}")
                continue
            if isinstance(model, RobocalModel):
                row = run(model, X, Y, X_test, Y_test, X_predict)
            else:
                row = run_with_budget(model, X, Y, X_test, Y_test, X_predict)
            if isinstance(row, str):
                given_up[model.name] = n
                print(f"{n:>5}  {model.name:<17}{row}")
                continue
            fit_time, predict_time, mse_time, rms, worst = row[:5]
            print(f"{n:>5}  {model.name:<17}{fit_time:>9.3f}{predict_time:>16.3f}"
                  f"{mse_time:>12.3f}{rms:>11.2e}{worst:>11.2e}", flush=True)


def large_benchmark(budget, sizes=LARGE_SIZES, with_peers=True, noises=(0.0, NOISE_MM), peer_names=None,
                    with_robocal=True):
    _, X_test, Y_test, X_predict = test_data()
    print(f"\nlarge data: every fit in its own process (peak memory: that whole process); peers stopped "
          f"after {budget:.0f} s; one core")
    header = (f"{'n':>7}  {'model':<26}{'fit s':>9}{'(CPU s)':>9}{'peak MB':>9}{'predict 100k s':>16}"
              f"{'(CPU s)':>9}{'+MSE 10k s':>12}{'RMS mm':>10}{'mean mm':>10}{'max mm':>10}{'RMS/exact':>11}")
    rule(header)
    peers = available_peers(large=True) if with_peers else []
    if peer_names:
        peers = [p for p in peers if any(name in p.name.lower() for name in peer_names)]
    given_up = {}
    cases = [(n, noise) for n in sizes for noise in noises]
    for n, noise in cases:
        rng = np.random.default_rng(n)
        X = latin_hypercube(n, rng)
        Y = error_field(X) + noise * rng.normal(size=(n, 3))
        nugget = "estimate" if noise else 0.0
        models = ((([RobocalModel(False, "exact", nugget)] if n <= EXACT_UP_TO else []) +
                   [RobocalModel(False, "vecchia", nugget)]) if with_robocal else []) + peers
        label = f"{n:>7,}" + (f"  with {noise} mm noise" if noise else "")
        if noise:
            print(f"{label}  (load average {os.getloadavg()[0]:.1f})")
            label = " " * 7
        exact_rms = vecchia_row = None
        for model in models:
            if model.name in given_up:
                print(f"{label}  {model.name:<26}skipped: it did not finish at n = {given_up[model.name]:,}")
                continue
            robocal = isinstance(model, RobocalModel)
            row = run_with_budget(model, X, Y, X_test, Y_test, X_predict, budget=3600.0 if robocal else budget)
            if isinstance(row, str):
                given_up[model.name] = n
                print(f"{label}  {model.name:<26}{row}")
                if not robocal and vecchia_row and "did not finish" in row:
                    print(f"{' ' * 9}{'':<26}its fit took over {budget / vecchia_row[0]:.0f}x robocal vecchia's "
                          f"(load average {os.getloadavg()[0]:.1f})", flush=True)
                continue
            fit_time, predict_time, mse_time, rms, worst, cpu, mean, peak, predict_cpu = row
            if robocal and model.approximation == "exact":
                exact_rms = rms
            if robocal and model.approximation == "vecchia":
                vecchia_row = (fit_time, cpu, rms)
            ratio = f"{rms / exact_rms:>11.3f}" if exact_rms else ""
            print(f"{label}  {model.name:<26}{fit_time:>9.1f}{cpu:>9.1f}{peak:>9.0f}{predict_time:>16.2f}"
                  f"{predict_cpu:>9.2f}{mse_time:>12.2f}{rms:>10.2e}{mean:>10.2e}{worst:>10.2e}{ratio}", flush=True)
            if not robocal and vecchia_row:
                # Both fits ran in this case, one after the other under the same load.
                print(f"{' ' * 9}{'':<26}its fit took {fit_time / vecchia_row[0]:.1f}x robocal vecchia's "
                      f"({cpu / vecchia_row[1]:.1f}x its CPU time); robocal vecchia's RMS is "
                      f"{vecchia_row[2] / rms:.2f}x its own (load average {os.getloadavg()[0]:.1f})", flush=True)


def ur10_benchmark():
    from robocal.errors import InputError
    from robocal.io.datasets import ipa_ur10
    from robocal.io.observations import Observations
    from robocal.methods import make_method

    print(f"\nUR10 (ipa), series A: {UR10_TRAIN:,} random poses train, the others held out (mm); one core")
    header = f"{'method':<9}{'kriging':<9}{'fit s':>8}{'(CPU s)':>9}{'mean':>9}{'RMS':>9}{'max':>9}{'mean/exact':>12}"
    rule(header)
    try:
        dataset = ipa_ur10("A")
    except InputError as why:
        print(f"skipped: {why}")
        return
    chain, q, P = dataset.chain, dataset.observations.joints, dataset.observations.positions
    order = np.random.default_rng(0).permutation(len(q))
    train, test = order[:UR10_TRAIN], order[UR10_TRAIN:]
    warnings.simplefilter("ignore", RobocalWarning)  # one held-out pose lies outside the training box
    for method in ("kriging", "hybrid"):
        exact_mean = None
        for approximation in ("exact", "vecchia"):
            cpu = time.process_time()
            fitted, seconds = timed(lambda: make_method(method, kriging=approximation).fit(
                chain, Observations.of(q[train], P[train])))
            cpu = time.process_time() - cpu
            error = np.linalg.norm(P[test] - fitted.predict(q[test]), axis=1)
            exact_mean = error.mean() if approximation == "exact" else exact_mean
            print(f"{method:<9}{approximation:<9}{seconds:>8.1f}{cpu:>9.1f}{error.mean():>9.4f}"
                  f"{np.sqrt(np.mean(error ** 2)):>9.4f}{error.max():>9.4f}{error.mean() / exact_mean:>12.3f}",
                  flush=True)
    dataset = ipa_ur10("B")
    chain, data = dataset.chain, dataset.observations
    observations = Observations.of(data.joints, data.positions, sigmas=data.sigmas)  # orientations left out
    cpu = time.process_time()
    fitted, seconds = timed(lambda: make_method("hybrid").fit(chain, observations))
    cpu = time.process_time() - cpu
    used = fitted.compensator_.error_model.approximation_
    print(f"\nhybrid (--kriging auto: {used}) on all {data.n_poses:,} series-B poses: {seconds:.1f} s ({cpu:.1f} s CPU)")


def _exact_log_likelihood(model):
    """The exact log-likelihood of a fitted Kriging at its θ and nugget, summed over outputs."""
    from robocal.estimation.kriging import trend_basis
    from robocal.estimation.kriging.exact import _Problem

    X = (model._X_train - model._x_mean) / model._x_scale
    Y = (model._Y_train - model._y_mean) / model._y_scale
    problem = _Problem(X, trend_basis(X, model.regression), model.correlation)
    theta = np.atleast_2d(model.theta_)
    return sum(problem.condition(theta[0 if model.shared_theta else j], model.nugget_[j],
                                 Y[:, [j]]).log_likelihood[0] for j in range(Y.shape[1]))


def search_benchmark(splits=False):
    """The exact search on all points against the block stand-in (module docstring)."""
    from robocal.estimation.kriging import vecchia
    from robocal.io.datasets import ipa_ur10
    from robocal.io.observations import Observations
    from robocal.methods import make_method

    warnings.simplefilter("ignore", RobocalWarning)
    ways = (("exact", vecchia.EXACT_SEARCH_UP_TO), ("blocks", vecchia.BLOCK_SEARCH_ABOVE))

    def fitted(way, fit):
        vecchia.BLOCK_SEARCH_ABOVE = dict(ways)[way]
        try:
            cpu = time.process_time()
            model = fit()
            return model, time.process_time() - cpu
        finally:
            vecchia.BLOCK_SEARCH_ABOVE = dict(ways)["blocks"]

    def load():
        return f"{os.getloadavg()[0]:.1f}"

    print("\nThe hyperparameter search of Vecchia fits of 1,000 to 2,000 points: exact likelihood on all "
          "points against the block stand-in refined on it; one core, CPU s, load = 1-min load average")
    dataset = ipa_ur10("B")
    chain, obs = dataset.chain, dataset.observations
    rule(f"{'hybrid on all 1,495 UR10 B poses':<40}{'CPU s':>8}{'load':>6}{'exact log-lik.':>16}")
    for way, _ in ways:
        method, cpu = fitted(way, lambda: make_method("hybrid").fit(chain, obs))
        model = method.compensator_.error_model
        print(f"{way + ' (' + model.approximation_ + ')':<40}{cpu:>8.1f}{load():>6}"
              f"{_exact_log_likelihood(model):>16.1f}", flush=True)

    cases = [("B", 747, 0), ("A", UR10_TRAIN, 0)]
    if splits:
        cases += [("A", 1200, 2), ("A", 1500, 1), ("A", 1800, 3), ("A", 2000, 1), ("B", 1196, 0),
                  ("B", 1200, 1), ("B", 1300, 2), ("B", 1400, 3)]
    print("\nheld out: the poses of the series not trained on (random permutation of the seed); mm")
    rule(f"{'series':<7}{'train':>6}{'seed':>5}  {'method':<8}{'search':<8}{'CPU s':>7}{'load':>6}{'mean':>8}"
         f"{'RMS':>8}{'max':>8}{'mean/exact':>11}{'exact log-lik.':>16}")
    for series, n_train, seed in cases:
        dataset = ipa_ur10(series)
        chain, q, P = dataset.chain, dataset.observations.joints, dataset.observations.positions
        order = np.random.default_rng(seed).permutation(len(q))
        train, test = order[:n_train], order[n_train:]
        for method in ("kriging", "hybrid"):
            reference = None
            for way, _ in ways:
                fit, cpu = fitted(way, lambda: make_method(method).fit(chain, Observations.of(q[train], P[train])))
                error = np.linalg.norm(P[test] - fit.predict(q[test]), axis=1)
                reference = error.mean() if reference is None else reference
                print(f"{series:<7}{n_train:>6}{seed:>5}  {method:<8}{way:<8}{cpu:>7.1f}{load():>6}{error.mean():>8.4f}"
                      f"{np.sqrt(np.mean(error ** 2)):>8.4f}{error.max():>8.4f}{error.mean() / reference:>11.3f}"
                      f"{_exact_log_likelihood(fit.compensator_.error_model):>16.1f}", flush=True)

    _, X_test, Y_test, _ = test_data()
    n = 2000
    rng = np.random.default_rng(n)  # the large section's field
    X = latin_hypercube(n, rng)
    Y = error_field(X) + NOISE_MM * rng.normal(size=(n, 3))
    print(f"\nbench field, n = {n:,}, {NOISE_MM} mm noise, nugget estimated; held out on {N_TEST:,} points")
    rule(f"{'search':<8}{'CPU s':>7}{'load':>6}{'RMS mm':>10}{'RMS/exact':>11}{'exact log-lik.':>16}")
    reference = None
    for way, _ in ways:
        model, cpu = fitted(way, lambda: Kriging(random_state=0, approximation="vecchia", nugget="estimate").fit(X, Y))
        rms = np.sqrt(np.mean(np.sum((model.predict(X_test) - Y_test) ** 2, axis=1)))
        reference = rms if reference is None else reference
        print(f"{way:<8}{cpu:>7.1f}{load():>6}{rms:>10.3e}{rms / reference:>11.3f}{_exact_log_likelihood(model):>16.1f}",
              flush=True)


def one_blas_thread():
    """One BLAS thread for robocal and every peer (the child processes inherit it): the
    environment above is read only when a library loads, threadpoolctl holds it after."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return
    threadpool_limits(1)


def main():
    one_blas_thread()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="n = 50 and 200 only")
    parser.add_argument("--large", action="store_true", help="only n = 2,000, 10,000 and 100,000, and UR10")
    parser.add_argument("--budget", type=float, default=600.0, help="seconds a peer's large fit may take")
    parser.add_argument("--without-peers", action="store_true", help="robocal only in the large section")
    parser.add_argument("--sizes", type=int, nargs="+", default=list(LARGE_SIZES),
                        help="the large section's n")
    parser.add_argument("--without-ur10", action="store_true", help="no UR10 comparison")
    parser.add_argument("--peers", nargs="+", choices=("sklearn", "gpboost"),
                        help="the large section's peers (default: every one installed)")
    parser.add_argument("--without-robocal", action="store_true", help="the large section's peers only")
    parser.add_argument("--noise", choices=("both", "noisy", "noise-free"), default="both",
                        help=f"the large section's readings: exact, with {NOISE_MM} mm noise, or both (default)")
    parser.add_argument("--search", action="store_true",
                        help="only the search of Vecchia fits of 1,000 to 2,000 points: exact against blocks")
    parser.add_argument("--search-splits", action="store_true", help="with --search: 8 more training sets")
    args = parser.parse_args()
    if args.search:
        search_benchmark(args.search_splits)
        return
    if not args.large:
        small_benchmark(QUICK_SIZES if args.quick else SIZES)
    if not args.quick:
        noises = {"both": (0.0, NOISE_MM), "noisy": (NOISE_MM,), "noise-free": (0.0,)}[args.noise]
        large_benchmark(args.budget, sizes=tuple(args.sizes), with_peers=not args.without_peers, noises=noises,
                        peer_names=args.peers, with_robocal=not args.without_robocal)
        if not args.without_ur10:
            ur10_benchmark()


if __name__ == "__main__":
    main()
