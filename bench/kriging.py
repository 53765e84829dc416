"""Kriging error model of robocal beside SMT's KRG and scikit-learn's GaussianProcessRegressor.

The data are a smooth positioning-error field of the size a geometrically miscalibrated robot
shows: errors of about 1 mm over a 1000 mm box, built from the linear part small joint-offset
and base-rotation errors produce, a quadratic sag, and long-wavelength sinusoids for
everything else.  For n = 50, 200, 1000 and 3000 Latin-hypercube training points (3 error
components) it prints the fit time, the time to predict 100,000 points (mean only), the time
for 10,000 points with the mean squared error, and the RMS and largest error over 1,000
held-out points.  Every model is one per error component, the paper's way; robocal's shared-θ
variant is shown too.  A peer's fit runs in a child process and is stopped after 60 s; the
output then says so and that peer is not tried at larger n.

    python bench/kriging.py            # --quick: n = 50 and 200 only
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import multiprocessing  # noqa: E402
import queue  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402

import numpy as np  # noqa: E402

from robocal.errors import RobocalWarning  # noqa: E402
from robocal.estimation import Kriging  # noqa: E402

SIZES = (50, 200, 1000, 3000)
QUICK_SIZES = (50, 200)
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


class RobocalModel:
    def __init__(self, shared):
        self.name = "robocal shared θ" if shared else "robocal"
        self.shared = shared

    def fit(self, X, Y):
        with warnings.catch_warnings():
            # Jitter on these very smooth fields is expected; diagnostics_ keeps the notes.
            warnings.simplefilter("ignore", RobocalWarning)
            self.model = Kriging(shared_theta=self.shared, random_state=0).fit(X, Y)

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


def _chunked(predict, X):
    return np.concatenate([np.ravel(predict(X[i:i + PEER_CHUNK]))
                           for i in range(0, len(X), PEER_CHUNK)])


def available_peers():
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
    return peers


def run(model, X, Y, X_test, Y_test, X_predict, report=None):
    """Fit time, predict times, RMS and max error; ``report(fit_time)`` is told when fitted."""
    _, fit_time = timed(lambda: model.fit(X, Y))
    if report:
        report(fit_time)
    _, predict_time = timed(lambda: model.predict(X_predict))
    _, mse_time = timed(lambda: model.predict_mse(X_predict[:N_MSE]))
    error = np.linalg.norm(model.predict(X_test) - Y_test, axis=1)  # mm, per test point
    return fit_time, predict_time, mse_time, np.sqrt(np.mean(error ** 2)), error.max()


def _run_in_child(results, *args):
    # SMT prints its failed factorisations (eigenvalue dumps) on stdout: keep the table clean.
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    try:
        results.put(("row", run(*args, report=lambda seconds: results.put(("fitted", seconds)))))
    except Exception as error:  # a peer that fails is reported, not waited for
        results.put(("failed", f"{type(error).__name__}: {error}"))


def run_with_budget(*args):
    """``run`` in a child process whose fit is stopped after PEER_BUDGET s.

    Returns the row, or a string saying why there is none."""
    context = multiprocessing.get_context("fork")
    results = context.Queue()
    child = context.Process(target=_run_in_child, args=(results, *args))
    child.start()
    try:
        kind, value = results.get(timeout=PEER_BUDGET)
        if kind == "fitted":
            kind, value = results.get()
    except queue.Empty:
        child.terminate()
        kind, value = "stopped", f"its fit did not finish in {PEER_BUDGET:.0f} s (stopped)"
    child.join()
    return value if kind == "row" else f"skipped: {value}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="n = 50 and 200 only")
    sizes = QUICK_SIZES if parser.parse_args().quick else SIZES

    rng = np.random.default_rng(2024)
    X_test = latin_hypercube(N_TEST, rng)
    Y_test = error_field(X_test)
    X_predict = BOX_LOW + BOX_SIZE * rng.random((N_PREDICT, 3))
    before = np.linalg.norm(Y_test, axis=1)
    print(f"error field before compensation: RMS {np.sqrt(np.mean(before ** 2)):.3f} mm, "
          f"max {before.max():.3f} mm over {N_TEST} test points (3 components, 1000 mm box)")
    print("errors below are the norm of the 3-D residual after subtracting the prediction; "
          "one core\n")
    header = (f"{'n':>5}  {'model':<17}{'fit s':>9}{'predict 100k s':>16}{'+MSE 10k s':>12}"
              f"{'RMS mm':>11}{'max mm':>11}")
    print(header)
    print("-" * len(header))

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
            fit_time, predict_time, mse_time, rms, worst = row
            print(f"{n:>5}  {model.name:<17}{fit_time:>9.3f}{predict_time:>16.3f}"
                  f"{mse_time:>12.3f}{rms:>11.2e}{worst:>11.2e}", flush=True)


if __name__ == "__main__":
    main()
