"""The network error model: joint vector q → position error Δp, fit/predict like scikit-learn.

Inputs are the joint variables standardised to zero mean and unit spread ("joints"), or the
cosine and sine of each (revolute) joint, standardised ("trig"): an extension beyond the
method as specified, for robots whose joints turn through more than one revolution (a UR's
±360°), where the error is periodic in q and a network on the raw angles must learn every
period separately.  Outputs are the three components of Δp, standardised.

Training (``trainer``):

* "ga": the genetic algorithm of :mod:`~robocal.estimation.network.genetic` evolves the
  hidden structure, weights and thresholds; with ``refine="lbfgs"`` the best network is then
  polished by L-BFGS on the mean squared error with its structure kept.
* "lbfgs": L-BFGS from ``restarts`` random starts with every neuron active, the best on the
  training data kept — the gradient-only baseline.

The L-BFGS objective is (E/E₀)², the square of the error term of the GA's fitness, so both
trainers minimise the same error on the same scale; its gradient is exact (backpropagation).
"""
import math
import numbers
import time

import numpy as np

from ...errors import InputError
from ..arrays import (as_matrix, check_choice, check_header, check_random_state, check_whole,
                      damaged, is_real, is_whole, not_fitted, standard_scaler)
from .genetic import ALPHA, MAX_BITS, MIN_BITS, Encoding, Fitness, GeneticAlgorithm
from .mlp import Layout, forward_one, loss_and_gradient

FORMAT = "robocal.network"
FORMAT_VERSION = 1
WHAT = "network error model"  # how messages about a document name it
TRAINERS = ("ga", "lbfgs")
REFINEMENTS = ("lbfgs", None)
INPUTS = ("joints", "trig")
N_OUTPUTS = 3
# Fewer equations (3 per pose) than weights leave a network free to pass through every
# training point; five times as many is where held-out errors stop improving quickly.
ADVISED_EQUATIONS_PER_WEIGHT = 5


class NetworkErrorModel:
    """Position error (mm) as a function of the joint vector (rad), by a GA-trained network.

    The error is e = measured − model (N, 3) in mm, the model being the kinematic model the
    errors were computed against.  The settings are stored as given; ``fit`` checks them.

    Parameters
    ----------
    hidden : sequence of ≥ 2 ints, optional (default: (16, 16))
        Widths of the hidden layers (tanh).

    trainer : "ga" | "lbfgs", optional (default: "ga")
        See the module docstring.

    refine : "lbfgs" | None, optional (default: "lbfgs")
        Gradient polish of the GA's best network.

    populations : int ≥ 1, optional (default: 4)
        Independent GA sub-populations.

    population_size : even int ≥ 4, optional (default: 30)
        Individuals per sub-population.

    generations : int ≥ 0, optional (default: 300)
        GA generation limit; it stops earlier when the best fitness has risen by less than
        ``tolerance`` over ``window`` generations.

    tolerance : float, optional (default: 1e-5)
        Rise of the best fitness below which the GA has converged (< 0: never).

    window : int ≥ 1, optional (default: 50)
        Generations over which that rise is measured.

    migration_interval : int ≥ 1 or None, optional (default: None)
        Generations between ring migrations of each sub-population's best; None keeps the
        sub-populations independent.

    alpha : float in (0, 1], optional (default: 0.95)
        Weight of the error against the share of active neurons in the fitness.

    bits : int in [2, 30], optional (default: 16)
        Bits of a fixed-point gene.

    bound : float > 0, optional (default: 4.0)
        Genes cover [−bound, bound] (standardised units).

    max_iterations : int ≥ 1, optional (default: 2000)
        L-BFGS iteration limit (refinement and baseline).

    restarts : int ≥ 1, optional (default: 1)
        Random starts of the "lbfgs" trainer.

    inputs : "joints" | "trig", optional (default: "joints")
        See the module docstring.

    random_state : None, int or numpy Generator, optional (default: 0)
        Seeds the initial population and the random starts: an int ≥ 0 makes training
        reproducible, a Generator is used (and advanced) as is, None draws fresh entropy.

    Attributes
    ----------
    history_ : list of float
        Best GA fitness after each generation (entry 0: the initial population); empty for
        the "lbfgs" trainer.

    active_ : list of arrays, shape (h_l,)
        The active neurons (bool) of each hidden layer.

    training_ : dict
        Trainer, generations, why the GA stopped, times (s), training RMS (mm) after the GA
        and at the end, number of active weights.

    n_features_in_ : int
        Number of joints n.

    All are set by ``fit`` or ``from_dict``.
    """

    def __init__(self, hidden=(16, 16), *, trainer="ga", refine="lbfgs", populations=4,
                 population_size=30, generations=300, tolerance=1e-5, window=50,
                 migration_interval=None, alpha=ALPHA, bits=16, bound=4.0, max_iterations=2000,
                 restarts=1, inputs="joints", random_state=0):
        self.hidden = hidden
        self.trainer = trainer
        self.refine = refine
        self.populations = populations
        self.population_size = population_size
        self.generations = generations
        self.tolerance = tolerance
        self.window = window
        self.migration_interval = migration_interval
        self.alpha = alpha
        self.bits = bits
        self.bound = bound
        self.max_iterations = max_iterations
        self.restarts = restarts
        self.inputs = inputs
        self.random_state = random_state

    # ------------------------------------------------------------------ checks
    def _check_settings(self):
        """Raise an InputError naming the first invalid setting and the values it may take;
        return the hidden widths as a tuple of ints."""
        try:
            hidden = tuple(self.hidden)
            valid = len(hidden) >= 2 and all(is_whole(h) and h >= 1 for h in hidden)
        except TypeError:
            valid = False
        if not valid:
            raise InputError(f"hidden must list at least two layer widths >= 1 (e.g. (16, 16)), "
                             f"got {self.hidden!r}")
        check_choice("trainer", self.trainer, TRAINERS)
        check_choice("refine", self.refine, REFINEMENTS)
        check_choice("inputs", self.inputs, INPUTS)
        if not (is_real(self.alpha) and 0.0 < self.alpha <= 1.0):
            raise InputError(f"alpha must be a number in (0, 1], got {self.alpha!r}")
        check_whole("populations", self.populations, 1)
        check_whole("population_size", self.population_size, 4)
        if self.population_size % 2:
            raise InputError(f"population_size must be even, got {self.population_size!r}")
        check_whole("generations", self.generations, 0)
        if not is_real(self.tolerance):
            raise InputError(f"tolerance must be a finite number, got {self.tolerance!r}")
        check_whole("window", self.window, 1)
        check_whole("migration_interval", self.migration_interval, 1, none_allowed=True)
        if not (is_whole(self.bits) and MIN_BITS <= self.bits <= MAX_BITS):
            raise InputError(f"bits must be a whole number from {MIN_BITS} to {MAX_BITS}, got "
                             f"{self.bits!r}")
        if not (is_real(self.bound) and self.bound > 0):
            raise InputError(f"bound must be a finite number > 0, got {self.bound!r}")
        check_whole("max_iterations", self.max_iterations, 1)
        check_whole("restarts", self.restarts, 1)
        check_random_state(self.random_state)
        return tuple(int(h) for h in hidden)

    def _features(self, q):
        return np.hstack([np.cos(q), np.sin(q)]) if self.inputs == "trig" else q

    # ------------------------------------------------------------------ fitting
    def fit(self, X, Y, progress=None):
        """Train the network on measured position errors.

        Parameters
        ----------
        X : array-like, shape (N, n)
            Joint vectors in rad.

        Y : array-like, shape (N, 3)
            Position errors e = measured − model in mm at those joint vectors.

        progress : callable, optional (default: None)
            Called as progress(generation, best fitness) after every GA generation.

        Returns
        -------
        self : NetworkErrorModel
            The fitted model.

        Raises
        ------
        InputError
            If a setting is invalid (checked first, before any work) or the data cannot be
            used.  A fit that raises leaves an already fitted model as it was.
        """
        hidden = self._check_settings()
        q, dp, features, layout = self._check_data(X, Y, hidden)
        x_mean, x_scale = standard_scaler(features)
        y_mean, y_scale = standard_scaler(dp)
        Xs = (features - x_mean) / x_scale
        Ys = (dp - y_mean) / y_scale
        rng = np.random.default_rng(self.random_state)
        fitness = Fitness(layout, Xs, Ys, y_scale, alpha=self.alpha)
        training = {"trainer": self.trainer, "poses": len(q)}
        started = time.perf_counter()
        theta, mask, history = self._train(layout, fitness, Xs, Ys, y_scale, rng, progress,
                                           training)
        training["seconds"] = time.perf_counter() - started
        training["rms_mm"] = float(fitness.rms(theta[None], mask[None])[0])
        training["active_weights"] = layout.active_weights(mask)
        self._install(layout, theta, mask, x_mean, x_scale, y_mean, y_scale, q.shape[1])
        self.history_ = history
        self.training_ = training
        return self

    def _check_data(self, X, Y, hidden):
        """Joint vectors q (N, n), errors dp (N, 3), network inputs (N, d) and the layout, or
        an InputError saying why the data cannot train this network."""
        q, dp = as_matrix(X, "X (joint values)"), as_matrix(Y, "Y (position errors)")
        if dp.shape[1] != N_OUTPUTS:
            raise InputError(f"Y must have 3 columns (the x, y, z position errors in mm), got "
                             f"{dp.shape[1]}")
        if len(q) != len(dp):
            raise InputError(f"X has {len(q)} rows but Y has {len(dp)}: give one position error "
                             f"per joint vector")
        features = self._features(q)
        layout = Layout(features.shape[1], hidden, N_OUTPUTS)
        equations = N_OUTPUTS * len(q)
        if equations < layout.n_weights:
            raise InputError(
                f"{len(q)} poses give {equations} equations for the {layout.n_weights} weights and "
                f"thresholds of a network with hidden layers {hidden} on {q.shape[1]} joints: "
                f"measure at least {math.ceil(layout.n_weights / N_OUTPUTS)} poses (about "
                f"{math.ceil(ADVISED_EQUATIONS_PER_WEIGHT * layout.n_weights / N_OUTPUTS)} for "
                f"a good fit) or use smaller hidden layers")
        if np.all(dp.min(axis=0) == dp.max(axis=0)):
            raise InputError("every position error is the same: there is nothing for a network "
                             "to learn (a constant offset is a base or tool frame error)")
        return q, dp, features, layout

    def _train(self, layout, fitness, X, Y, y_scale, rng, progress, training):
        """Run the trainer on standardised data: (θ, mask of active neurons, GA history).
        What the GA reports is added to ``training``."""
        if self.trainer == "lbfgs":
            mask = np.ones(layout.n_hidden, dtype=bool)
            runs = [self._lbfgs(layout, layout.initial(rng), mask, X, Y, y_scale, fitness.e0)
                    for _ in range(int(self.restarts))]
            return min(runs, key=lambda run: run[1])[0], mask, []
        started = time.perf_counter()
        migration = self.migration_interval
        ga = GeneticAlgorithm(
            fitness, Encoding(int(self.bits), float(self.bound)), populations=int(self.populations),
            population_size=int(self.population_size), generations=int(self.generations),
            tolerance=float(self.tolerance), window=int(self.window),
            migration_interval=None if migration is None else int(migration))
        best = ga.run(rng, progress)
        theta, mask = best["theta"], best["structure"]
        training.update(generations=best["generations"], stopped=best["stopped"],
                        ga_seconds=time.perf_counter() - started,
                        ga_rms_mm=float(fitness.rms(theta[None], mask[None])[0]))
        if self.refine == "lbfgs":
            refined = time.perf_counter()
            theta, _ = self._lbfgs(layout, theta, mask, X, Y, y_scale, fitness.e0)
            training["refine_seconds"] = time.perf_counter() - refined
        return theta, mask, best["history"]

    def _lbfgs(self, layout, theta, mask, X, Y, y_scale, e0):
        """Minimise (E/E₀)² from θ with the structure ``mask`` fixed: (θ, objective)."""
        from scipy.optimize import minimize  # loaded when used: the command line starts faster
        weights = y_scale**2 / (len(X) * e0**2)
        result = minimize(lambda x: loss_and_gradient(layout, x, mask, X, Y, weights),
                          np.asarray(theta, dtype=float), jac=True, method="L-BFGS-B",
                          options={"maxiter": int(self.max_iterations),
                                   "maxfun": 2 * int(self.max_iterations)})
        return result.x, float(result.fun)

    def _install(self, layout, theta, mask, x_mean, x_scale, y_mean, y_scale, n_features):
        self._layout = layout
        self._theta = np.asarray(theta, dtype=float)
        self._mask = np.asarray(mask, dtype=bool)
        self._x_mean, self._x_scale = x_mean, x_scale
        self._y_mean, self._y_scale = y_mean, y_scale
        self.n_features_in_ = int(n_features)
        self.active_ = [self._mask[s].copy() for s in layout.mask_slices]

    # ---------------------------------------------------------------- prediction
    def predict(self, X):
        """Predict the position error at joint vectors.

        Parameters
        ----------
        X : array-like, shape (N, n) or (n,)
            Joint vectors in rad, the joints in the order of ``fit``.

        Returns
        -------
        Y : array, shape (N, 3), or (3,) for one joint vector (n,)
            Predicted position error e = measured − model in mm.

        Raises
        ------
        InputError
            If the model is not fitted, or X has another number of joints than in ``fit`` or
            contains NaN or infinite values.
        """
        if not hasattr(self, "_theta"):
            raise not_fitted("NetworkErrorModel", "fit(X, Y)")
        if np.ndim(X) == 1 and np.size(X) == self.n_features_in_:
            return self.predict(np.asarray(X)[None])[0]
        q = as_matrix(X, "X (joint values)")
        if q.shape[1] != self.n_features_in_:
            raise InputError(f"the network was trained on {self.n_features_in_} joint values per "
                             f"pose, got {q.shape[1]}: is this model for another robot?")
        Xs = (self._features(q) - self._x_mean) / self._x_scale
        return self._y_mean + self._y_scale * forward_one(self._layout, self._theta, self._mask, Xs)

    # ------------------------------------------------------------ serialisation
    def to_dict(self):
        """The fitted model as a JSON-ready dict, from which ``from_dict`` rebuilds it.

        Returns
        -------
        document : dict
            Lists, numbers and strings only: the format tag and version, the settings, the
            scalings, every layer's weights and thresholds, the active neurons and the
            training record.  The seed is stored under "random_state" (files written before
            used "seed"; ``from_dict`` reads both).

        Raises
        ------
        InputError
            If the model is not fitted.
        """
        if not hasattr(self, "_theta"):
            raise not_fitted("NetworkErrorModel", "fit(X, Y)")
        layers = [{"weights": W.tolist(), "thresholds": b.tolist()}
                  for W, b in self._layout.unpack(self._theta)]
        seed = self.random_state
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "settings": {"hidden": list(self._layout.hidden), "inputs": self.inputs,
                         "trainer": self.trainer, "refine": self.refine, "alpha": float(self.alpha),
                         # A Generator has no JSON form; the file then records no seed.
                         "random_state": int(seed) if isinstance(seed, numbers.Integral) else None},
            "n_joints": self.n_features_in_,
            "input_mean": self._x_mean.tolist(),
            "input_scale": self._x_scale.tolist(),
            "output_mean": self._y_mean.tolist(),
            "output_scale": self._y_scale.tolist(),
            "layers": layers,
            "active": [a.tolist() for a in self.active_],
            "history": [float(f) for f in self.history_],
            "training": dict(self.training_),
        }

    @classmethod
    def from_dict(cls, document):
        """Rebuild a fitted model from ``to_dict`` output: identical predictions, no training.

        Parameters
        ----------
        document : dict
            What ``to_dict`` returned (possibly after a round trip through JSON); documents
            written before the seed was called ``random_state`` (key "seed") load too.

        Returns
        -------
        model : NetworkErrorModel
            The fitted model.

        Raises
        ------
        FileFormatError
            If the document is not a network error model of this format version, or is
            incomplete or inconsistent.
        """
        check_header(document, WHAT, FORMAT, FORMAT_VERSION)
        model, parts = _read_document(cls, document)
        n_joints, arrays, layers, active = (parts[k] for k in ("n_joints", "arrays", "layers",
                                                                "active"))
        try:
            hidden = model._check_settings()
        except InputError as error:
            raise damaged(WHAT, f"invalid settings: {error}") from None
        if n_joints < 1:
            raise damaged(WHAT, f"{n_joints} joints")
        n_features = 2 * n_joints if model.inputs == "trig" else n_joints
        layout = Layout(n_features, hidden, N_OUTPUTS)
        expected = list(zip(layout.sizes[:-1], layout.sizes[1:]))
        shapes_ok = (
            all(arrays[k].shape == (n_features,) for k in ("input_mean", "input_scale"))
            and all(arrays[k].shape == (N_OUTPUTS,) for k in ("output_mean", "output_scale"))
            and len(layers) == len(expected)
            and all(W.shape == (i, o) and b.shape == (o,) for (W, b), (i, o) in zip(layers, expected))
            and len(active) == len(hidden)
            and all(a.shape == (h,) and a.dtype == bool for a, h in zip(active, hidden))
        )
        if not shapes_ok:
            raise damaged(WHAT, "inconsistent array sizes: layers, scales or active neurons do "
                                "not match its hidden layers and joints")
        values = [v for pair in layers for v in pair] + list(arrays.values())
        if not all(np.all(np.isfinite(v)) for v in values) or np.any(arrays["input_scale"] <= 0) \
                or np.any(arrays["output_scale"] <= 0):
            raise damaged(WHAT, "non-finite weights or non-positive scales")
        theta = np.concatenate([np.concatenate([W.ravel(), b]) for W, b in layers])
        model._install(layout, theta, np.concatenate(active), arrays["input_mean"],
                       arrays["input_scale"], arrays["output_mean"], arrays["output_scale"], n_joints)
        model.history_ = parts["history"]
        model.training_ = parts["training"]
        return model


def _read_document(cls, document):
    """The settings of a network document (as an unfitted model) and its other parts as
    numbers and arrays, or a FileFormatError saying what is missing or malformed."""
    try:
        settings = document["settings"]
        # Documents written before the setting was renamed store the seed as "seed".
        seed = settings["random_state"] if "random_state" in settings else settings.get("seed")
        model = cls(hidden=tuple(settings["hidden"]), inputs=settings["inputs"],
                    trainer=settings["trainer"], refine=settings["refine"],
                    alpha=settings["alpha"], random_state=seed)
        parts = {
            "n_joints": int(document["n_joints"]),
            "arrays": {key: np.array(document[key], dtype=float) for key in
                       ("input_mean", "input_scale", "output_mean", "output_scale")},
            "layers": [(np.array(layer["weights"], dtype=float),
                        np.array(layer["thresholds"], dtype=float))
                       for layer in document["layers"]],
            "active": [np.array(a) for a in document["active"]],
            "history": [float(f) for f in document["history"]],
            "training": dict(document["training"]),
        }
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise damaged(WHAT, error) from None
    return model, parts
