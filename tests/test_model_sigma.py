"""The model's own σ and the 95 % bound of one configuration at a time (what ``robocal
serve`` asks): equal to the batch's row for every kind of model the server answers with,
inside and outside the training domain."""
import numpy as np
import pytest

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


def _fitted(name, chain, train):
    settings = {"kinematic": {}, "kriging": {"random_state": 0}, "hybrid": {"random_state": 0},
                "ann": {"generations": 3, "hidden": (4, 4)}}[name]
    method = make_method(name, **settings).fit(chain, train)
    method.bound_ = fit_bound(method, chain, train)
    return method


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
def test_the_bound_of_one_configuration_is_the_batch_row(ur5, name):
    chain, train, every = ur5
    method = _fitted(name, chain, train)
    _one_row_equals_batch(method.bound_, method.domain_, every)


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
