"""The model's own σ and the 95 % bound of one configuration at a time (what ``robocal
serve`` asks), and the Kriging's mean and MSE of one point: equal to the batch's row for every
kind of model the server answers with, inside and outside the training domain."""
import warnings

import numpy as np
import pytest

from robocal.errors import RobocalWarning
from robocal.estimation import Kriging
from robocal.estimation.kriging.point import point_predictor
from robocal.io.library import load_robot
from robocal.kinematics import to_poe
from robocal.methods import make_method
from robocal.methods.bound import fit_bound
from robocal.methods.model_sigma import PointPosterior, chain_of, posterior_sigma
from robocal.simulation import make_true_robot, uniform_joints
from simulated_models import ur5_auto_model

# The one-row paths compute on floats what the batch computes on arrays: equal to rounding.
RELATIVE = 1e-12


@pytest.fixture(scope="module")
def ur5():
    """A UR5 with the typical errors, 120 training poses with q1 in the lower half of its
    range (so that random configurations fall on both sides of the domain), and 120 random
    configurations over the whole joint space."""
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=4)
    rng = np.random.default_rng(4)
    q = uniform_joints(chain, 400, rng)
    train = truth.observations(q[q[:, 0] < 0.0][:120], rng)
    return chain, train, uniform_joints(chain, 120, np.random.default_rng(5))


@pytest.fixture(scope="module")
def fitted(ur5):
    """The method of a name fitted to the UR5's training poses, with its bound (each fitted once)."""
    chain, train, _ = ur5
    methods = {}

    def method_of(name):
        if name not in methods:
            settings = {"kinematic": {}, "kriging": {"random_state": 0}, "hybrid": {"random_state": 0},
                        "ann": {"generations": 3, "hidden": (4, 4)}}[name]
            method = make_method(name, **settings).fit(chain, train)
            method.bound_ = fit_bound(method, chain, train)
            methods[name] = method
        return methods[name]

    return method_of


@pytest.fixture(scope="module")
def auto():
    """ur5_auto_model's (chain, training observations, model, fallback)."""
    chain, _, _, train, model, fallback = ur5_auto_model()
    return chain, train, model, fallback


def _one_row_equals_batch(bound, domain, joints):
    inside = domain.check(joints).inside
    assert 0 < inside.sum() < len(joints)  # both sides of the domain are tried
    batch = bound.predict(joints, inside=inside)
    one = np.array([bound.predict_one(q, flag) for q, flag in zip(joints, inside)])
    assert np.all(np.isfinite(batch))
    np.testing.assert_allclose(one, batch, rtol=RELATIVE, atol=0)
    # An unreachable target's NaN configuration has no bound, either way.
    nan = np.full(joints.shape[1], np.nan)
    assert np.isnan(bound.predict_one(nan, True)) and np.isnan(bound.predict(nan[None], inside=[True])[0])


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("name", ["kinematic", "kriging", "hybrid", "ann"])
def test_the_bound_of_one_configuration_is_the_batch_row(ur5, fitted, name):
    method = fitted(name)
    _one_row_equals_batch(method.bound_, method.domain_, ur5[2])


def _one_point_equals_batch(model, X, mean_scale, mse_scale=0.0):
    """Kriging.predict of each row of X alone against the rows of the batch: the mean to 1e-12
    of ``mean_scale`` (a mean crosses zero, where no relative tolerance holds), the MSE to 1e-12
    relative, or of ``mse_scale`` where that is larger.  (The MSE is σ²(1 + |w|² − |v|²): near
    the training points the difference cancels, and both paths' rounding is of σ², not of it.)"""
    batch_mean, batch_mse = model.predict(X, return_mse=True)
    one = [model.predict(x[None], return_mse=True) for x in X]
    np.testing.assert_allclose(np.concatenate([m for m, _ in one]), batch_mean, rtol=0, atol=1e-12 * mean_scale)
    np.testing.assert_allclose(np.concatenate([v for _, v in one]), batch_mse, rtol=1e-12, atol=1e-12 * mse_scale)
    assert np.all(batch_mse > 0)


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("name", ["kriging", "hybrid"])
def test_the_kriging_of_one_point_is_the_batch_row(ur5, fitted, name):
    # The error model of the served Kriging and hybrid models at the positions of 120
    # configurations over the whole joint space, which are the MSE's of the bound.
    method = fitted(name)
    model = method.compensator_.error_model
    assert point_predictor(model) is not None  # the one-point path, not a batch of one
    X = method.compensator_.chain.fk_positions(ur5[2])
    _one_point_equals_batch(model, X, np.abs(model._Y_train).max())


@pytest.mark.parametrize("regression, correlation, shared", [
    ("constant", "gaussian", False), ("linear", "matern52", False), ("quadratic", "gaussian", True),
    ("linear", "gaussian", True)])
def test_one_point_of_every_kind_of_kriging_is_the_batch_row(regression, correlation, shared):
    # θ fixed (no search): the trend's p × p solve, the Matérn correlation and outputs sharing θ.
    rng = np.random.default_rng(3)
    X = rng.uniform(-400.0, 400.0, (80, 3))
    Y = np.column_stack([np.sin(X[:, 0] / 150) + X[:, 2] / 400, np.cos(X[:, 1] / 200), X[:, 0] * X[:, 1] / 1e5])
    model = Kriging(regression=regression, correlation=correlation, shared_theta=shared, theta0=[0.4, 0.6, 0.3],
                    n_starts=0, nugget=1e-3).fit(X, Y + rng.normal(0.0, 0.01, Y.shape))
    _one_point_equals_batch(model, rng.uniform(-380.0, 380.0, (40, 3)), np.abs(Y).max(), model.sigma2_.max())


def test_one_point_of_a_single_output_kriging_keeps_its_shapes_and_warnings(monkeypatch):
    rng = np.random.default_rng(4)
    X = rng.uniform(-1.0, 1.0, (40, 2))
    model = Kriging(theta0=[1.0, 2.0], n_starts=0, nugget=1e-6).fit(X, np.sin(3 * X[:, 0]) + X[:, 1])
    inside, far = np.array([[0.1, -0.2]]), np.array([[0.1, 3.0]])
    with pytest.warns(RobocalWarning, match="1 of 2 points"):
        batch_mean, batch_mse = model.predict(np.vstack([inside, far]), return_mse=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # inside the training box: no warning
        mean, mse = model.predict(inside, return_mse=True)
    assert mean.shape == (1,) and mse.shape == (1,)
    np.testing.assert_allclose([mean[0], mse[0]], [batch_mean[0], batch_mse[0]], rtol=1e-12)
    # Beyond the box, the batch's warning, its standard deviation quoted from the batch.
    with pytest.warns(RobocalWarning, match=r"1 of 1 points lie more than 10%.*standard deviation is") as record:
        assert model.predict(far)[0] == pytest.approx(batch_mean[1], rel=1e-12)
    assert record[0].filename == __file__  # the caller's line, as the batch's warning names it
    # One point does not go through the batch's block predictor.
    monkeypatch.setattr(model, "_predict_block", None)
    model.predict(inside, return_mse=True)


def test_a_vecchia_kriging_of_one_point_is_its_batch_row():
    # The Vecchia approximation keeps its own (local) predictor for one point too.
    rng = np.random.default_rng(5)
    X = rng.uniform(-1.0, 1.0, (60, 3))
    model = Kriging(approximation="vecchia", neighbours=10, theta0=[1.0, 1.0, 1.0], n_starts=0,
                    nugget=1e-4).fit(X, np.sin(2 * X[:, 0]) * X[:, 1] + X[:, 2])
    assert point_predictor(model) is None
    T = rng.uniform(-0.9, 0.9, (10, 3))
    np.testing.assert_allclose(np.concatenate([model.predict(t[None]) for t in T]), model.predict(T), rtol=1e-12)


@pytest.mark.filterwarnings("ignore")
def test_the_bound_of_one_configuration_of_an_auto_model_is_the_batch_row(auto):
    # Joint gains inside the domain, a compliant fallback outside: both one-row paths.
    chain, train, model, _ = auto
    bound = fit_bound(model, chain, train)
    _one_row_equals_batch(bound, model.domain_, uniform_joints(chain, 120, np.random.default_rng(6)))


@pytest.mark.parametrize("convention", ["dh", "poe"])
@pytest.mark.parametrize("groups", [("links", "base", "tool"), ("links", "base", "tool", "gains")])
def test_posterior_sigma_of_one_configuration_is_the_batch_row(convention, groups):
    # A chain with a base and a tool away from identity, POE axes (two marks per parameter,
    # whose columns add) and joint gains (an offset column times the joint value).
    chain = load_robot("kr150-2")
    chain = to_poe(chain) if convention == "poe" else chain
    rng = np.random.default_rng(7)
    names = chain.parameter_names(tuple(g for g in groups if g != "home" or convention == "poe"))
    chain = chain.perturbed(names, rng.normal(0.0, 1e-3, len(names)))
    root = rng.normal(size=(len(names), len(names)))
    covariance = root @ root.T * 1e-4
    joints = uniform_joints(chain, 50, rng)
    point = PointPosterior(chain, names, covariance)
    one = np.array([point.sigma(q) for q in joints])
    np.testing.assert_allclose(one, posterior_sigma(chain, joints, names, covariance), rtol=RELATIVE, atol=0)


def test_a_compliant_chain_is_left_to_the_batch(auto):
    chain = chain_of(auto[3])
    point = PointPosterior(chain, ["theta2"], np.eye(1))
    assert point.sigma(np.zeros(chain.n_joints)) is None
