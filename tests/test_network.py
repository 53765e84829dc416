"""Network error model trained by a GA, and compensation in joint space (issue 6)."""
import json

import numpy as np
import pytest

from robocal.compensation.joint_space import correct_joints, damped_pseudo_inverse_solve
from robocal.errors import FileFormatError, InputError
from robocal.estimation.network import (Encoding, Fitness, GeneticAlgorithm, Layout,
                                        NetworkErrorModel, adaptive_probability)
from robocal.estimation.network.genetic import PC1, PC2, PM1, PM2, chromosome
from robocal.estimation.network.mlp import forward, forward_one, loss_and_gradient
from robocal.io.library import builtin
from robocal.simulation import TrueRobot, make_true_robot, uniform_joints


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def small_problem(rng, n=200, hidden=(5, 4)):
    X = rng.normal(size=(n, 3))
    Y = np.column_stack([np.sin(X[:, 0]), X[:, 1] * X[:, 2], np.cos(X[:, 2])])
    return Layout(3, hidden, 3), X, (Y - Y.mean(axis=0)) / Y.std(axis=0)


def naive_forward(sizes, theta, mask, X):
    """One network, written out neuron by neuron from the layout's documented θ order."""
    position, hidden_index, a = 0, 0, X
    for layer, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        W = theta[position:position + fan_in * fan_out].reshape(fan_in, fan_out)
        position += fan_in * fan_out
        b = theta[position:position + fan_out]
        position += fan_out
        z = np.column_stack([sum(a[:, i] * W[i, j] for i in range(fan_in)) + b[j]
                             for j in range(fan_out)])
        if layer < len(sizes) - 2:
            z = np.tanh(z) * mask[hidden_index:hidden_index + fan_out]
            hidden_index += fan_out
        a = z
    return a


# ----------------------------------------------------------------------------- network

def test_population_forward_equals_each_network_on_its_own(rng):
    layout, X, _ = small_problem(rng, n=30)
    theta = rng.normal(size=(6, layout.n_weights))
    mask = rng.random((6, layout.n_hidden)) < 0.7
    batched = forward(layout, theta, mask, X)
    assert batched.shape == (6, 30, 3)
    for p in range(6):
        np.testing.assert_allclose(batched[p], naive_forward(layout.sizes, theta[p], mask[p], X),
                                   rtol=0, atol=1e-12)


def test_an_inactive_neuron_is_the_same_as_a_removed_one(rng):
    layout, X, _ = small_problem(rng, n=20, hidden=(5, 4))
    theta = rng.normal(size=layout.n_weights)
    mask = np.ones(layout.n_hidden, dtype=bool)
    mask[2] = False  # third neuron of the first hidden layer
    (W1, b1), (W2, b2), (W3, b3) = layout.unpack(theta)
    smaller = Layout(3, (4, 4), 3)
    keep = [0, 1, 3, 4]
    reduced = np.concatenate([W1[:, keep].ravel(), b1[keep], W2[keep].ravel(), b2, W3.ravel(), b3])
    np.testing.assert_allclose(forward_one(layout, theta, mask, X),
                               forward_one(smaller, reduced, np.ones(8, dtype=bool), X), atol=1e-12)
    assert layout.active_weights(mask) == smaller.n_weights


def test_analytic_gradient_matches_finite_differences(rng):
    layout, X, Y = small_problem(rng, n=50)
    theta = rng.normal(scale=0.7, size=layout.n_weights)
    mask = np.ones(layout.n_hidden, dtype=bool)
    mask[[1, 6]] = False
    weights = np.array([0.5, 1.0, 2.0])
    loss, gradient = loss_and_gradient(layout, theta, mask, X, Y, weights)
    direct = np.sum((forward_one(layout, theta, mask, X) - Y) ** 2 * weights)
    assert loss == pytest.approx(direct, rel=1e-12)
    h = 1e-6
    numeric = np.empty_like(theta)
    for k in range(layout.n_weights):
        step = np.zeros_like(theta)
        step[k] = h
        numeric[k] = (loss_and_gradient(layout, theta + step, mask, X, Y, weights)[0]
                      - loss_and_gradient(layout, theta - step, mask, X, Y, weights)[0]) / (2 * h)
    np.testing.assert_allclose(gradient, numeric, rtol=1e-6, atol=1e-6 * np.abs(numeric).max())
    # Weights into an inactive neuron do nothing: exactly zero gradient.
    W1, _ = layout.unpack(gradient)[0]
    assert np.all(W1[:, 1] == 0.0)


# ----------------------------------------------------------------------------- encoding

def test_binary_genes_round_trip_to_the_quantisation_step(rng):
    encoding = Encoding(bits=12, bound=3.0)
    values = rng.uniform(-3.0, 3.0, size=(4, 50))
    codes = encoding.encode(values)
    assert codes.min() >= 0 and codes.max() <= 2**12 - 1
    assert np.abs(encoding.decode(codes) - values).max() <= encoding.step / 2 + 1e-15
    np.testing.assert_array_equal(encoding.encode(encoding.decode(codes)), codes)
    bits = encoding.to_bits(codes)
    assert bits.shape == (4, 50 * 12) and bits.dtype == bool
    np.testing.assert_array_equal(encoding.from_bits(bits), codes)
    # Most significant bit first: the top of the range is all ones, the bottom all zeros.
    np.testing.assert_array_equal(encoding.to_bits(encoding.encode([3.0, -3.0])),
                                  [True] * 12 + [False] * 12)
    # Out of range values are clipped to the range.
    np.testing.assert_allclose(encoding.decode(encoding.encode([10.0, -10.0])), [3.0, -3.0])


def test_chromosome_holds_structure_then_genes(rng):
    encoding = Encoding(bits=8, bound=1.0)
    structure = rng.random((3, 9)) < 0.5
    codes = rng.integers(0, 256, size=(3, 20))
    bits = chromosome(encoding, structure, codes)
    assert bits.shape == (3, 9 + 20 * 8)
    np.testing.assert_array_equal(bits[:, :9], structure)
    np.testing.assert_array_equal(encoding.from_bits(bits[:, 9:]), codes)


# ----------------------------------------------------------------------------- GA operators

def test_adaptive_probabilities_at_the_documented_extremes():
    y_mean, y_max = 0.4, 0.8
    for high, low in ((PC1, PC2), (PM1, PM2)):
        assert adaptive_probability(y_max, y_mean, y_max, high, low) == pytest.approx(low)
        assert adaptive_probability(0.1, y_mean, y_max, high, low) == pytest.approx(high)
        assert adaptive_probability(y_mean, y_mean, y_max, high, low) == pytest.approx(high)
        middle = adaptive_probability(0.6, y_mean, y_max, high, low)
        assert middle == pytest.approx(high - (high - low) * 0.5)
    assert (PC1, PC2, PM1, PM2) == (0.9, 0.6, 0.1, 0.01)
    # A sub-population of equal fitness: everyone is the best.
    assert adaptive_probability(0.3, 0.3, 0.3, PC1, PC2) == pytest.approx(PC2)


def ga_for(layout, X, Y, **kwargs):
    return GeneticAlgorithm(Fitness(layout, X, Y, np.ones(3)), Encoding(bits=16, bound=4.0), **kwargs)


def test_crossover_happens_with_pc2_for_the_best_pairs_and_pc1_below_the_mean(rng):
    layout, X, Y = small_problem(rng, n=20)
    pairs = 4000
    ga = ga_for(layout, X, Y, populations=1, population_size=2 * pairs)
    structure, codes = ga.initial(rng)
    # First half of the pairs at the best fitness, second half below the mean (ȳ = 0.5).
    fitness = np.where(np.arange(2 * pairs) < pairs, 1.0, 0.0)[None]
    new_structure, new_codes = ga.crossover(rng, structure, codes, fitness)
    crossed = np.any(new_codes[0, 0::2] != codes[0, 0::2], axis=1)
    sigma = np.sqrt(0.25 / (pairs / 2))
    assert abs(crossed[: pairs // 2].mean() - PC2) < 5 * sigma
    assert abs(crossed[pairs // 2:].mean() - PC1) < 5 * sigma
    # Arithmetic crossover: the children share the parents' sum and lie between them.
    a, b = codes[0, 0::2], codes[0, 1::2]
    c, d = new_codes[0, 0::2], new_codes[0, 1::2]
    assert np.abs((c + d) - (a + b)).max() <= 1
    assert np.all((c >= np.minimum(a, b)) & (c <= np.maximum(a, b)))
    # Structure bits come from one parent or the other, the two children complementary.
    sa, sb = structure[0, 0::2], structure[0, 1::2]
    sc, sd = new_structure[0, 0::2], new_structure[0, 1::2]
    assert np.all(((sc == sa) & (sd == sb)) | ((sc == sb) & (sd == sa)))


def test_mutation_rate_is_pm2_for_the_best_and_pm1_below_the_mean(rng):
    layout, X, Y = small_problem(rng, n=20)
    ga = ga_for(layout, X, Y, populations=1, population_size=1000)
    structure, codes = ga.initial(rng)
    fitness = np.where(np.arange(1000) < 500, 1.0, 0.0)[None]
    new_structure, new_codes = structure.copy(), codes.copy()
    ga.mutate(rng, new_structure, new_codes, fitness, fitness)
    changed = new_codes != codes
    genes = 500 * layout.n_weights
    for rate, part in ((PM2, changed[0, :500]), (PM1, changed[0, 500:])):
        assert abs(part.mean() - rate) < 5 * np.sqrt(rate * (1 - rate) / genes)
    # A mutation flips exactly one bit of a gene.
    flipped = np.bitwise_xor(new_codes, codes)[changed]
    assert np.all(flipped & (flipped - 1) == 0)
    bits = 500 * layout.n_hidden
    flips = new_structure != structure
    assert abs(flips[0, :500].mean() - PM2) < 5 * np.sqrt(PM2 * (1 - PM2) / bits)
    assert abs(flips[0, 500:].mean() - PM1) < 5 * np.sqrt(PM1 * (1 - PM1) / bits)


def test_elitism_keeps_each_sub_population_best(rng):
    layout, X, Y = small_problem(rng, n=50)
    ga = ga_for(layout, X, Y, populations=3, population_size=8)
    structure, codes = ga.initial(rng)
    fitness = ga.evaluate(structure, codes)
    for _ in range(5):
        best = np.argmax(fitness, axis=1)
        new_structure, new_codes, new_fitness = ga.step(rng, structure, codes, fitness)
        for s in range(3):
            kept = np.all(new_codes[s] == codes[s, best[s]], axis=1) \
                & np.all(new_structure[s] == structure[s, best[s]], axis=1)
            assert kept.any()
            assert new_fitness[s].max() >= fitness[s].max()
        np.testing.assert_allclose(new_fitness, ga.evaluate(new_structure, new_codes), rtol=1e-6)
        structure, codes, fitness = new_structure, new_codes, new_fitness


def test_fitness_is_the_documented_formula(rng):
    layout, X, Y = small_problem(rng, n=40)
    scale = np.array([2.0, 0.5, 1.0])
    fitness = Fitness(layout, X, Y, scale, dtype=np.float64)
    theta = rng.normal(size=(2, layout.n_weights))
    mask = rng.random((2, layout.n_hidden)) < 0.6
    for p in range(2):
        error = (forward_one(layout, theta[p], mask[p], X) - Y) * scale
        rms = np.sqrt(np.mean(np.sum(error**2, axis=1)))
        e0 = np.sqrt(np.mean(np.sum(((Y - Y.mean(axis=0)) * scale) ** 2, axis=1)))
        expected = 1 - 0.95 * rms / e0 - 0.05 * mask[p].mean()
        assert fitness(theta, mask)[p] == pytest.approx(expected, rel=1e-10)


def test_ga_run_improves_reports_progress_and_stops_at_convergence(rng):
    layout, X, Y = small_problem(rng, n=100)
    seen = []
    ga = ga_for(layout, X, Y, populations=2, population_size=10, generations=400,
                tolerance=1e-3, window=15)
    result = ga.run(np.random.default_rng(0), progress=lambda g, f: seen.append((g, f)))
    history = result["history"]
    assert np.all(np.diff(history) >= 0) and history[-1] > history[0]
    assert [g for g, _ in seen] == list(range(1, result["generations"] + 1))
    assert [f for _, f in seen] == history[1:]
    assert result["stopped"] == "converged" and result["generations"] < 400
    assert history[-1] - history[-16] < 1e-3
    assert result["fitness"] == history[-1]
    np.testing.assert_allclose(result["theta"], Encoding(16, 4.0).decode(result["codes"]))


# ----------------------------------------------------------------------------- estimator

@pytest.fixture(scope="module")
def kr150():
    """A KR 150-2 with the typical preset's link deviations and joint compliance, measured in
    its own base frame (base and tool registered), 0.02 mm tracker noise, no backlash."""
    chain = builtin("kr150-2")
    typical = make_true_robot(chain, "typical", seed=1)
    links = {k: v for k, v in typical.deviations.items() if not k.startswith(("base_", "tool_"))}
    truth = TrueRobot(nominal=chain, deviations=links, compliance=typical.compliance, noise=0.02)
    rng = np.random.default_rng(0)
    q = uniform_joints(chain, 1000, rng)
    dp = truth.measure(q, rng) - chain.fk_positions(q)
    test = uniform_joints(chain, 500, rng)
    return chain, truth, q, dp, test


@pytest.fixture(scope="module")
def trained(kr150):
    chain, truth, q, dp, test = kr150
    model = NetworkErrorModel(hidden=(24, 24), population_size=20, generations=40, random_state=0)
    return model.fit(q, dp)


def test_ga_then_lbfgs_and_joint_space_compensation_cut_the_error_five_times(kr150, trained):
    chain, truth, q, dp, test = kr150
    target = chain.fk_positions(test)
    before = np.linalg.norm(truth.positions(test) - target, axis=1)
    commands = correct_joints(chain, trained, test)
    after = np.linalg.norm(truth.positions(commands) - target, axis=1)
    assert before.mean() > 0.8
    assert after.mean() < before.mean() / 5
    assert trained.training_["generations"] == 40 and len(trained.history_) == 41
    assert trained.training_["rms_mm"] < trained.training_["ga_rms_mm"]


def test_correction_lands_the_real_robot_within_the_models_prediction_error(kr150, trained):
    chain, truth, q, dp, test = kr150
    target = chain.fk_positions(test)
    # Each iteration shrinks the remaining linearisation error about a hundredfold here.
    commands = correct_joints(chain, trained, test, iterations=6)
    miss = truth.positions(commands) - target
    prediction_error = truth.error(commands) - trained.predict(commands)
    np.testing.assert_allclose(miss, prediction_error, rtol=0, atol=1e-6)


def test_a_perfect_error_model_puts_the_robot_on_the_target(kr150):
    chain, truth, q, dp, test = kr150

    class Oracle:
        def predict(self, joints):
            return truth.error(joints)

    target = chain.fk_positions(test[:50])
    before = np.linalg.norm(truth.positions(test[:50]) - target, axis=1)
    one = np.linalg.norm(truth.positions(correct_joints(chain, Oracle(), test[:50])) - target, axis=1)
    # One step leaves only the (second-order) linearisation error; a wrong sign would double it.
    assert one.max() < before.max() / 100
    converged = correct_joints(chain, Oracle(), test[:50], iterations=4)
    assert np.abs(truth.positions(converged) - target).max() < 1e-8
    single = correct_joints(chain, Oracle(), test[0], iterations=4)
    np.testing.assert_allclose(single, converged[0], atol=1e-12)


def test_damped_solve_is_exact_when_regular_and_bounded_when_singular(rng):
    A = rng.normal(size=(20, 3, 6))
    b = rng.normal(size=(20, 3))
    x = damped_pseudo_inverse_solve(A, b, 0.01)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", A, x), b, atol=1e-10)
    np.testing.assert_allclose(x, np.einsum("nij,nj->ni", np.linalg.pinv(A), b), atol=1e-10)
    singular = A.copy()
    singular[:, 2] = singular[:, 1] * (1 + 1e-12)  # two rows (almost) equal
    x = damped_pseudo_inverse_solve(singular, b, 0.01)
    sigma_max = np.linalg.svd(singular, compute_uv=False)[:, 0]
    # The damped gain σ/(σ² + λ²) never exceeds 1/(2λ), λ = 0.01 σ_max.
    assert np.all(np.linalg.norm(x, axis=1) <= np.linalg.norm(b, axis=1) / (0.02 * sigma_max) + 1e-9)


def test_training_is_reproducible_with_a_seed_and_differs_without(kr150):
    chain, truth, q, dp, test = kr150
    settings = dict(hidden=(6, 6), population_size=8, generations=5, max_iterations=20)
    a = NetworkErrorModel(random_state=3, **settings).fit(q[:300], dp[:300])
    b = NetworkErrorModel(random_state=3, **settings).fit(q[:300], dp[:300])
    c = NetworkErrorModel(random_state=4, **settings).fit(q[:300], dp[:300])
    np.testing.assert_array_equal(a.predict(test), b.predict(test))
    assert a.history_ == b.history_
    assert not np.array_equal(a.predict(test), c.predict(test))


def test_lbfgs_baseline_and_ga_alone(kr150):
    chain, truth, q, dp, test = kr150
    truth_error = truth.error(test)
    ga = NetworkErrorModel(hidden=(8, 8), population_size=10, generations=20, refine=None,
                           random_state=0).fit(q[:500], dp[:500])
    assert "refine_seconds" not in ga.training_
    assert ga.training_["rms_mm"] == ga.training_["ga_rms_mm"]
    baseline = NetworkErrorModel(hidden=(8, 8), trainer="lbfgs", restarts=2, max_iterations=300,
                                 random_state=0).fit(q[:500], dp[:500])
    assert baseline.history_ == [] and baseline.training_["active_weights"] == 155
    error = lambda m: np.linalg.norm(m.predict(test) - truth_error, axis=1).mean()  # noqa: E731
    nominal = np.linalg.norm(truth_error, axis=1).mean()
    assert error(ga) < nominal and error(baseline) < error(ga)


def test_model_dict_round_trips_through_json(kr150, trained):
    chain, truth, q, dp, test = kr150
    document = json.loads(json.dumps(trained.to_dict()))
    assert document["format"] == "robocal.network" and document["version"] == 1
    again = NetworkErrorModel.from_dict(document)
    np.testing.assert_array_equal(again.predict(test), trained.predict(test))
    assert again.history_ == trained.history_
    assert [a.tolist() for a in again.active_] == [a.tolist() for a in trained.active_]


def test_bad_model_dicts_are_refused(trained):
    good = json.loads(json.dumps(trained.to_dict()))
    NetworkErrorModel.from_dict(good)  # the cases below differ from a loadable document in one thing
    settings = good["settings"]
    cases = {
        "not a network": {"format": "robocal.kriging"},
        "not a dict": [good],
        "format tag": dict(good, format="robocal.kriging"),
        "version": dict(good, version=99),
        "missing": {k: v for k, v in good.items() if k != "layers"},
        "layer shape": dict(good, layers=good["layers"][:-1]),
        "weights": dict(good, layers=[dict(good["layers"][0], weights=[[1.0]])] + good["layers"][1:]),
        "nan": dict(good, output_scale=[1.0, float("nan"), 1.0]),
        "active": dict(good, active=[[1, 0], good["active"][1]]),
        "joints": dict(good, n_joints=7),
        "no joints": dict(good, n_joints=0),
        "hidden": dict(good, settings=dict(good["settings"], hidden=[24])),
        "seed": dict(good, settings=dict(settings, random_state="zero")),
        "history": dict(good, history=["best"]),
    }
    cases.update({f"missing {key}": {k: v for k, v in good.items() if k != key}
                  for key in good if key not in ("format", "version")})
    cases.update({f"missing setting {key}": dict(good, settings={k: v for k, v in settings.items()
                                                                if k != key})
                  for key in settings if key != "random_state"})  # random_state may be absent
    for name, document in cases.items():
        with pytest.raises(FileFormatError) as caught:
            NetworkErrorModel.from_dict(document)
        message = str(caught.value)
        assert "\n" not in message and ("refit" in message or "to_dict()" in message), name


def test_the_seed_is_saved_as_random_state_and_old_seed_documents_still_load(kr150, trained):
    chain, truth, q, dp, test = kr150
    document = json.loads(json.dumps(trained.to_dict()))
    assert document["settings"]["random_state"] == 0 and "seed" not in document["settings"]
    settings = {k: v for k, v in document["settings"].items() if k != "random_state"}
    for seed in (7, None):  # a model file written before the rename
        old = NetworkErrorModel.from_dict(dict(document, settings=dict(settings, seed=seed)))
        assert old.random_state == seed
        np.testing.assert_array_equal(old.predict(test), trained.predict(test))
    assert NetworkErrorModel.from_dict(dict(document, settings=settings)).random_state is None
    generator = NetworkErrorModel(hidden=(4, 4), generations=1, population_size=4,
                                  random_state=np.random.default_rng(0)).fit(q[:300], dp[:300])
    assert generator.to_dict()["settings"]["random_state"] is None  # a Generator has no JSON form


def test_settings_are_stored_as_given_and_checked_first_by_fit(kr150):
    chain, truth, q, dp, test = kr150
    cases = [({"hidden": (16,)}, "hidden must list at least two layer widths"),
             ({"trainer": "sgd"}, "trainer must be one of 'ga', 'lbfgs', got 'sgd'"),
             ({"refine": "adam"}, "refine must be one of 'lbfgs', None, got 'adam'"),
             ({"inputs": "raw"}, "inputs must be one of 'joints', 'trig'"),
             ({"alpha": 0.0}, r"alpha must be a number in \(0, 1\]"),
             ({"alpha": "high"}, r"alpha must be a number in \(0, 1\]"),
             ({"populations": 0}, "populations must be a whole number >= 1"),
             ({"population_size": 5}, "population_size must be even"),
             ({"population_size": 2}, "population_size must be a whole number >= 4"),
             ({"population_size": "30"}, "population_size must be a whole number >= 4"),
             ({"generations": -1}, "generations must be a whole number >= 0"),
             ({"generations": 2.5}, "generations must be a whole number >= 0"),
             ({"tolerance": float("nan")}, "tolerance must be a finite number"),
             ({"window": 0}, "window must be a whole number >= 1"),
             ({"migration_interval": 0}, "migration_interval must be a whole number >= 1 or None"),
             ({"bits": 40}, "bits must be a whole number from 2 to 30"),
             ({"bound": -1.0}, "bound must be a finite number > 0"),
             ({"max_iterations": 0}, "max_iterations must be a whole number >= 1"),
             ({"restarts": 0}, "restarts must be a whole number >= 1"),
             ({"random_state": -1}, "random_state must be None, a whole number >= 0 or a numpy"),
             ({"random_state": "abc"}, "random_state must be"),
             ({"random_state": True}, "random_state must be")]
    for options, words in cases:
        model = NetworkErrorModel(**options)  # no check, no conversion in __init__
        for name, value in options.items():
            assert getattr(model, name) is value
        # The settings are reported before anything about the data (here: far too few poses).
        with pytest.raises(InputError, match=words):
            model.fit(q[:2], dp[:2])


def test_a_generator_seeds_as_its_integer_does(kr150):
    chain, truth, q, dp, test = kr150
    settings = dict(hidden=(6, 6), population_size=8, generations=5, max_iterations=20)
    by_int = NetworkErrorModel(random_state=3, **settings).fit(q[:300], dp[:300])
    generator = np.random.default_rng(3)
    by_generator = NetworkErrorModel(random_state=generator, **settings).fit(q[:300], dp[:300])
    np.testing.assert_array_equal(by_generator.predict(test), by_int.predict(test))


def test_bad_input_is_explained(kr150, trained):
    chain, truth, q, dp, test = kr150
    with pytest.raises(InputError, match=r"100 poses give 300 equations for the 435 weights.*at least 145 poses"):
        NetworkErrorModel(hidden=(16, 16)).fit(q[:100], dp[:100])
    bad = dp[:300].copy()
    bad[5, 1] = np.nan
    with pytest.raises(InputError, match="NaN"):
        NetworkErrorModel(hidden=(4, 4)).fit(q[:300], bad)
    with pytest.raises(InputError, match="3 columns"):
        NetworkErrorModel(hidden=(4, 4)).fit(q[:300], dp[:300, :2])
    with pytest.raises(InputError, match="one position error per joint vector"):
        NetworkErrorModel(hidden=(4, 4)).fit(q[:300], dp[:299])
    for hidden in ((16,), (16, 0), ("a", 4), 16):
        with pytest.raises(InputError, match="at least two layer widths"):
            NetworkErrorModel(hidden=hidden).fit(q, dp)
    with pytest.raises(InputError, match="nothing for a network to learn"):
        NetworkErrorModel(hidden=(4, 4)).fit(q[:300], np.ones((300, 3)))
    with pytest.raises(InputError, match="another robot"):
        trained.predict(np.zeros((3, 7)))
    with pytest.raises(InputError,
                       match=r"^this NetworkErrorModel is not fitted: call fit\(X, Y\) first$"):
        NetworkErrorModel().predict(test)
    with pytest.raises(InputError, match="not fitted") as caught:
        NetworkErrorModel().to_dict()
    assert not isinstance(caught.value, FileFormatError)  # the caller's mistake, not a file's
    with pytest.raises(InputError, match="6 joints"):
        correct_joints(chain, trained, np.zeros((2, 5)))
    with pytest.raises(InputError, match="iterations"):
        correct_joints(chain, trained, test[:2], iterations=0)
