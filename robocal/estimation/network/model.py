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
import time

import numpy as np
from scipy.optimize import minimize

from ...errors import FileFormatError, InputError
from ..arrays import as_matrix, standard_scaler
from .genetic import ALPHA, Encoding, Fitness, GeneticAlgorithm
from .mlp import Layout, forward_one, loss_and_gradient

FORMAT = "robocal.network"
FORMAT_VERSION = 1
TRAINERS = ("ga", "lbfgs")
REFINEMENTS = ("lbfgs", None)
INPUTS = ("joints", "trig")
N_OUTPUTS = 3
# Fewer equations (3 per pose) than weights leave a network free to pass through every
# training point; five times as many is where held-out errors stop improving quickly.
ADVISED_EQUATIONS_PER_WEIGHT = 5


class NetworkErrorModel:
    """Position error Δp (mm) as a function of the joint vector q (rad), by a GA-trained network.

    Parameters
    ----------
    hidden : sequence of ≥ 2 ints — widths of the hidden layers (tanh).
    trainer : "ga" | "lbfgs" — see the module docstring.
    refine : "lbfgs" | None — gradient polish of the GA's best network.
    populations, population_size : independent GA sub-populations and their (even) size.
    generations : GA generation limit; it stops earlier when the best fitness has risen by
        less than ``tolerance`` over ``window`` generations.
    migration_interval : None (independent sub-populations) or generations between ring
        migrations of each sub-population's best.
    alpha : weight of the error against the share of active neurons in the fitness.
    bits, bound : fixed-point genes of ``bits`` bits over [−bound, bound] (standardised units).
    max_iterations : L-BFGS iteration limit (refinement and baseline).
    restarts : random starts of the "lbfgs" trainer.
    inputs : "joints" | "trig" — see the module docstring.
    seed : int, None or numpy Generator — makes training reproducible.

    Attributes after ``fit``
    ------------------------
    history_ : best GA fitness after each generation (entry 0: the initial population).
    active_ : list of (h_l,) boolean arrays, the active neurons of each hidden layer.
    training_ : dict — trainer, generations, why the GA stopped, times (s), training RMS (mm)
        after the GA and at the end, number of active weights.
    n_features_in_ : number of joints.
    """

    def __init__(self, hidden=(16, 16), *, trainer="ga", refine="lbfgs", populations=4,
                 population_size=30, generations=300, tolerance=1e-5, window=50,
                 migration_interval=None, alpha=ALPHA, bits=16, bound=4.0, max_iterations=2000,
                 restarts=1, inputs="joints", seed=0):
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
        self.seed = seed

    # ------------------------------------------------------------------ checks
    def _check_settings(self):
        try:
            hidden = tuple(self.hidden)
            valid = len(hidden) >= 2 and all(float(h).is_integer() and h >= 1 for h in hidden)
        except (TypeError, ValueError):
            valid = False
        if not valid:
            raise InputError(f"hidden must list at least two layer widths >= 1 (e.g. (16, 16)), "
                             f"got {self.hidden!r}")
        if self.trainer not in TRAINERS:
            raise InputError(f"trainer must be one of {', '.join(TRAINERS)}, got {self.trainer!r}")
        if self.refine not in REFINEMENTS:
            raise InputError(f"refine must be 'lbfgs' or None, got {self.refine!r}")
        if self.inputs not in INPUTS:
            raise InputError(f"inputs must be one of {', '.join(INPUTS)}, got {self.inputs!r}")
        if not 0.0 < float(self.alpha) <= 1.0:
            raise InputError(f"alpha must be in (0, 1], got {self.alpha}")
        if int(self.population_size) < 4 or int(self.population_size) % 2 or int(self.populations) < 1:
            raise InputError(f"population_size must be even and >= 4 and populations >= 1, got "
                             f"{self.population_size} and {self.populations}")
        if int(self.generations) < 0 or int(self.max_iterations) < 1 or int(self.restarts) < 1:
            raise InputError("generations must be >= 0, max_iterations and restarts >= 1")
        return tuple(int(h) for h in hidden)

    def _features(self, q):
        return np.hstack([np.cos(q), np.sin(q)]) if self.inputs == "trig" else q

    # ------------------------------------------------------------------ fitting
    def fit(self, q, dp, progress=None):
        """Train on joint vectors q (N, n) rad and position errors dp (N, 3) mm.

        progress: called as progress(generation, best fitness) after every GA generation.
        A fit that raises leaves an already fitted model as it was.
        """
        hidden = self._check_settings()
        q, dp = as_matrix(q, "q (joint values)"), as_matrix(dp, "dp (position errors)")
        if dp.shape[1] != N_OUTPUTS:
            raise InputError(f"dp must have 3 columns (the x, y, z position errors in mm), got "
                             f"{dp.shape[1]}")
        if len(q) != len(dp):
            raise InputError(f"q has {len(q)} rows but dp has {len(dp)}: give one position error "
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
        x_mean, x_scale = standard_scaler(features)
        y_mean, y_scale = standard_scaler(dp)
        X = (features - x_mean) / x_scale
        Y = (dp - y_mean) / y_scale
        rng = np.random.default_rng(self.seed)
        fitness = Fitness(layout, X, Y, y_scale, alpha=self.alpha)
        training = {"trainer": self.trainer, "poses": len(q)}
        history = []
        started = time.perf_counter()
        if self.trainer == "ga":
            ga = GeneticAlgorithm(
                fitness, Encoding(self.bits, self.bound), populations=int(self.populations),
                population_size=int(self.population_size), generations=int(self.generations),
                tolerance=float(self.tolerance), window=int(self.window),
                migration_interval=self.migration_interval)
            best = ga.run(rng, progress)
            theta, mask, history = best["theta"], best["structure"], best["history"]
            training.update(generations=best["generations"], stopped=best["stopped"],
                            ga_seconds=time.perf_counter() - started,
                            ga_rms_mm=float(fitness.rms(theta[None], mask[None])[0]))
            if self.refine == "lbfgs":
                refined = time.perf_counter()
                theta, _ = self._lbfgs(layout, theta, mask, X, Y, y_scale, fitness.e0)
                training["refine_seconds"] = time.perf_counter() - refined
        else:
            mask = np.ones(layout.n_hidden, dtype=bool)
            runs = [self._lbfgs(layout, layout.initial(rng), mask, X, Y, y_scale, fitness.e0)
                    for _ in range(int(self.restarts))]
            theta = min(runs, key=lambda run: run[1])[0]
        training["seconds"] = time.perf_counter() - started
        training["rms_mm"] = float(fitness.rms(theta[None], mask[None])[0])
        training["active_weights"] = layout.active_weights(mask)
        self._install(layout, theta, mask, x_mean, x_scale, y_mean, y_scale, q.shape[1])
        self.history_ = history
        self.training_ = training
        return self

    def _lbfgs(self, layout, theta, mask, X, Y, y_scale, e0):
        """Minimise (E/E₀)² from θ with the structure ``mask`` fixed: (θ, objective)."""
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
    def predict(self, q):
        """Predicted position errors (N, 3) mm at joint vectors q (N, n) rad; (3,) for one q (n,)."""
        if not hasattr(self, "_theta"):
            raise InputError("this network is not trained: call fit(q, dp) first")
        if np.ndim(q) == 1 and np.size(q) == self.n_features_in_:
            return self.predict(np.asarray(q)[None])[0]
        q = as_matrix(q, "q (joint values)")
        if q.shape[1] != self.n_features_in_:
            raise InputError(f"the network was trained on {self.n_features_in_} joint values per "
                             f"pose, got {q.shape[1]}: is this model for another robot?")
        X = (self._features(q) - self._x_mean) / self._x_scale
        return self._y_mean + self._y_scale * forward_one(self._layout, self._theta, self._mask, X)

    # ------------------------------------------------------------ serialisation
    def to_dict(self):
        """A JSON-ready dict (lists, numbers, strings) from which ``from_dict`` rebuilds the model."""
        if not hasattr(self, "_theta"):
            raise InputError("this network is not trained: call fit(q, dp) first")
        layers = [{"weights": W.tolist(), "thresholds": b.tolist()}
                  for W, b in self._layout.unpack(self._theta)]
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "settings": {"hidden": list(self._layout.hidden), "inputs": self.inputs,
                         "trainer": self.trainer, "refine": self.refine, "alpha": float(self.alpha),
                         "seed": self.seed if isinstance(self.seed, int) else None},
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
    def from_dict(cls, data):
        """Rebuild a trained model from ``to_dict`` output (predictions identical, no training).

        Raises FileFormatError when the content is not such a model or is inconsistent.
        """
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise FileFormatError(f"not a network error model: expected a dict with format '{FORMAT}'")
        if data.get("version") != FORMAT_VERSION:
            raise FileFormatError(f"network model version {data.get('version')!r} is not supported "
                                  f"(this robocal reads version {FORMAT_VERSION}): retrain the model")
        try:
            settings = data["settings"]
            seed = settings.get("seed")
            model = cls(hidden=tuple(settings["hidden"]), inputs=settings["inputs"],
                        trainer=settings["trainer"], refine=settings["refine"],
                        alpha=settings["alpha"], seed=seed)
            n_joints = int(data["n_joints"])
            arrays = {key: np.array(data[key], dtype=float) for key in
                      ("input_mean", "input_scale", "output_mean", "output_scale")}
            layers = [(np.array(layer["weights"], dtype=float), np.array(layer["thresholds"], dtype=float))
                      for layer in data["layers"]]
            active = [np.array(a) for a in data["active"]]
            history = [float(f) for f in data["history"]]
            training = dict(data["training"])
        except (KeyError, TypeError, ValueError, AttributeError) as error:
            raise FileFormatError(f"network model is incomplete or malformed ({error!r}): retrain "
                                  f"and save it again") from None
        try:
            hidden = model._check_settings()
        except InputError as error:
            raise FileFormatError(f"network model settings are invalid: {error}") from None
        n_features = 2 * n_joints if model.inputs == "trig" else n_joints
        layout = Layout(n_features, hidden, N_OUTPUTS)
        expected = list(zip(layout.sizes[:-1], layout.sizes[1:]))
        shapes_ok = (
            n_joints >= 1
            and all(arrays[k].shape == (n_features,) for k in ("input_mean", "input_scale"))
            and all(arrays[k].shape == (N_OUTPUTS,) for k in ("output_mean", "output_scale"))
            and len(layers) == len(expected)
            and all(W.shape == (i, o) and b.shape == (o,) for (W, b), (i, o) in zip(layers, expected))
            and len(active) == len(hidden)
            and all(a.shape == (h,) and a.dtype == bool for a, h in zip(active, hidden))
        )
        if not shapes_ok:
            raise FileFormatError("network model has inconsistent array sizes (layers, scales or "
                                  "active neurons do not match its hidden layers and joints): "
                                  "retrain and save it again")
        values = [v for pair in layers for v in pair] + list(arrays.values())
        if not all(np.all(np.isfinite(v)) for v in values) or np.any(arrays["input_scale"] <= 0) \
                or np.any(arrays["output_scale"] <= 0):
            raise FileFormatError("network model contains non-finite weights or non-positive "
                                  "scales: retrain and save it again")
        theta = np.concatenate([np.concatenate([W.ravel(), b]) for W, b in layers])
        model._install(layout, theta, np.concatenate(active), arrays["input_mean"],
                       arrays["input_scale"], arrays["output_mean"], arrays["output_scale"], n_joints)
        model.history_ = history
        model.training_ = training
        return model
