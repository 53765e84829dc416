"""The bound outside the training domain (robocal.methods.omitted): the spread of what a model
did not model, and the variance model its held-out regions calibrate."""
import json

import numpy as np
import pytest

from robocal.io.library import load_robot
from robocal.io.observations import Observations
from robocal.methods import make_method
from robocal.methods.bound import conformal_quantile
from robocal.methods.model_sigma import calibration_posterior, chain_of
from robocal.methods.omitted import Omitted, OutsideScale, fit_outside, omitted_of
from robocal.simulation import make_true_robot
from robocal.simulation.sampling import uniform_joints


@pytest.fixture(scope="module")
def ur5():
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=8)
    rng = np.random.default_rng(8)
    q = uniform_joints(chain, 300, rng)
    lower = q[:, 1] < np.median(q[:, 1])
    return chain, truth.observations(q[lower][:100], rng), q[~lower][:100]


@pytest.mark.filterwarnings("ignore")
def test_a_calibration_omits_what_its_parameter_set_leaves_out(ur5):
    chain, train, _ = ur5
    for parameters, expected in (("full", {"gain1", "compliance2"}), ("full+gains", {"compliance2"})):
        fitted = make_method("kinematic", parameters=parameters).fit(chain, train)
        calibration = fitted.calibration_
        posterior = calibration_posterior(calibration, train.joints, train.positions)
        omitted = omitted_of(fitted, chain_of(fitted), train, calibration, posterior)
        assert expected <= set(omitted.names) and not set(omitted.names) & set(posterior[0])
        assert omitted.response.shape == (len(posterior[0]), len(omitted.names))
    # Over the nominal robot (Kriging): the links are omitted too, the registration absorbs.
    kriging = make_method("kriging", random_state=0).fit(chain, train)
    nominal = omitted_of(kriging, chain_of(kriging), train)
    assert {"theta2", "a2", "gain1"} <= set(nominal.names)


@pytest.mark.filterwarnings("ignore")
def test_the_omitted_spread_is_small_where_the_training_poses_were_and_survives_its_document(ur5):
    chain, train, beyond = ur5
    fitted = make_method("kinematic").fit(chain, train)
    calibration = fitted.calibration_
    omitted = omitted_of(fitted, chain_of(fitted), train, calibration,
                         calibration_posterior(calibration, train.joints, train.positions))
    model = chain_of(fitted)
    at_training, elsewhere = omitted.sigma(model, train.joints), omitted.sigma(model, beyond)
    assert np.median(elsewhere) > 1.5 * np.median(at_training)
    # The fitted parameters absorb part of it: without their response it is larger.
    bare = Omitted(fitted=(), names=omitted.names, prior_std=omitted.prior_std,
                   response=np.zeros((0, len(omitted.names))), compliant=omitted.compliant)
    assert np.median(bare.sigma(model, train.joints)) > np.median(at_training)
    again = Omitted.from_dict(json.loads(json.dumps(omitted.to_dict())))
    np.testing.assert_allclose(again.sigma(model, beyond), elsewhere, rtol=1e-12)
    assert np.isnan(omitted.sigma(model, np.full((1, 6), np.nan))[0])


def test_the_likelihood_keeps_kappa_only_where_the_held_out_regions_show_it():
    rng = np.random.default_rng(0)
    scale = rng.uniform(0.5, 1.5, 400)
    spread = rng.uniform(0.0, 4.0, 400)
    chi = np.linalg.norm(rng.normal(size=(400, 3)), axis=1) / np.sqrt(3.0)
    marker = Omitted(fitted=(), names=("gain1",), prior_std=np.ones(1), response=np.zeros((0, 1)))
    # Errors that follow s alone: no κ, a = their scale.
    alone = fit_outside(2.0 * scale * chi, scale, spread, marker, conformal_quantile)
    assert alone.omitted_scale == 0.0 and alone.residual_growth == pytest.approx(2.0, rel=0.1)
    # Errors that follow σ_o: κ found, and the bound covers about 95 % of them.
    error = np.sqrt(scale ** 2 + (0.5 * spread) ** 2) * chi
    both = fit_outside(error, scale, spread, marker, conformal_quantile)
    assert both.omitted_scale == pytest.approx(0.5, rel=0.2)
    assert 0.93 <= np.mean(error <= both.bound(scale, spread, 0.0)) <= 0.97
    # Never below the bound inside the domain.
    assert np.all(both.bound(scale, spread, 10.0) == 10.0 * scale)
    assert both.bound_one(scale[0], spread[0], 0.0) == pytest.approx(both.bound(scale[:1], spread[:1], 0.0)[0])
    assert fit_outside([], [], [], marker, conformal_quantile) is None
    again = OutsideScale.from_dict(json.loads(json.dumps(both.to_dict())))
    np.testing.assert_allclose(again.bound(scale, spread, 1.0), both.bound(scale, spread, 1.0))


@pytest.mark.filterwarnings("ignore")
def test_a_kriging_over_the_position_is_bounded_on_the_other_elbow_side_of_a_real_arm():
    # UR10 series B trained on one elbow side, scored on the other: the same TCP positions
    # reached with the other elbow carry another error, which a model over the position
    # cannot see.  σ_o against the training configuration at the nearest position, and κ
    # from the training poses where the regions left out do not identify it: covered 0.28
    # when σ_o was that of the configuration alone (κ unidentified, so 0).
    from robocal.io.datasets import ipa_ur10
    from robocal.methods.bound import fit_bound
    from robocal.methods.domain import arm_branches

    dataset = ipa_ur10("B")
    chain, observations = dataset.chain, dataset.observations
    _, sides = arm_branches(chain, observations.joints)
    one_side = np.flatnonzero(sides["elbow"] == 0)
    train = observations.subset(np.sort(np.random.default_rng(0).choice(one_side, 400, replace=False)))
    test = observations.subset(np.flatnonzero(sides["elbow"] == 1))
    fitted = make_method("kriging", inputs="position").fit(chain, train)
    bound_model = fit_bound(fitted, chain, train, seed=0)
    omitted = bound_model.outside.omitted
    assert omitted.anchors is not None and omitted.scale > 0
    # Small where a training configuration reached the position as the pose does.
    assert np.median(omitted.sigma(chain_of(fitted), train.joints)) < 0.1 * np.median(
        omitted.sigma(chain_of(fitted), test.joints))
    error = np.linalg.norm(test.positions - fitted.predict(test.joints), axis=1)
    bound = bound_model.predict(test.joints)
    assert np.mean(error <= bound) >= 0.85
    assert np.median(bound) <= 3.0 * np.median(error)
    again = Omitted.from_dict(json.loads(json.dumps(omitted.to_dict())))
    np.testing.assert_allclose(again.sigma(chain_of(fitted), test.joints[:50]),
                               omitted.sigma(chain_of(fitted), test.joints[:50]), rtol=1e-12)


def test_where_the_regions_do_not_identify_kappa_the_training_scale_holds():
    rng = np.random.default_rng(0)
    scale, spread = rng.uniform(0.5, 1.5, 400), rng.uniform(0.0, 0.01, 400)
    chi = np.linalg.norm(rng.normal(size=(400, 3)), axis=1) / np.sqrt(3.0)
    marker = Omitted(fitted=(), names=("gain1",), prior_std=np.ones(1), response=np.zeros((0, 1)), scale=0.3)
    fitted = fit_outside(scale * chi, scale, spread, marker, conformal_quantile)
    assert fitted.omitted_scale == 0.3 and fitted.residual_growth == pytest.approx(1.0, rel=0.1)
    without = fit_outside(scale * chi, scale, spread, Omitted(fitted=(), names=("gain1",), prior_std=np.ones(1),
                                                               response=np.zeros((0, 1))), conformal_quantile)
    assert without.omitted_scale == 0.0


def test_a_damaged_outside_entry_is_refused():
    with pytest.raises(ValueError):
        OutsideScale.from_dict({"factor": -1.0, "residual_growth": 1.0, "omitted_scale": 0.0})
    with pytest.raises(ValueError):
        Omitted.from_dict({"fitted": [], "names": ["gain1", "gain2"], "prior_std": [1e-3], "response": []})
    for damaged in ({"anchors": [[float("nan")] * 6]}, {"anchors": [1.0, 2.0]}, {"scale": -1.0}):
        with pytest.raises(ValueError):
            Omitted.from_dict({"fitted": [], "names": ["gain1"], "prior_std": [1e-3], "response": [], **damaged})


def test_a_calibration_that_models_compliance_and_gains_omits_nothing():
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=2)
    q = uniform_joints(chain, 60, np.random.default_rng(2))
    train = truth.observations(q, np.random.default_rng(2))
    fitted = make_method("kinematic", parameters="full+compliance+gains").fit(chain, train)
    calibration = fitted.calibration_
    posterior = calibration_posterior(calibration, train.joints, train.positions)
    omitted = omitted_of(fitted, chain_of(fitted), Observations.of(train.joints, train.positions), calibration,
                         posterior)
    assert omitted is None
