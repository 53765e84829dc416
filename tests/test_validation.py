"""Held-out validation: k-fold cross-validation and learning curves of a kinematic
calibration on a simulated KUKA KR 150-2, and refusals of inputs that cannot be used."""
import numpy as np
import pytest

from robocal.errors import InputError
from robocal.estimation.validation import k_fold, learning_curve
from robocal.io.observations import Observations
from robocal.methods import KinematicMethod
from robocal.methods.validation import method_fitter
from robocal.io.library import builtin
from robocal.simulation import TrueRobot, make_true_robot, uniform_joints

NOISE_MM = 0.02
# |e| of isotropic Gaussian noise in 3-D: mean sigma·sqrt(8/pi), RMS sigma·sqrt(3).
NOISE_RMS_MM = NOISE_MM * np.sqrt(3.0)


@pytest.fixture(scope="module")
def kr150():
    """A KR 150-2 off by the ``typical`` geometric deviations, measured with tracker noise.

    Only the geometry of the preset is kept: its backlash and compliance are not kinematic,
    so no kinematic model could bring the held-out error down to the noise with them.
    """
    chain = builtin("kr150-2")
    geometry = make_true_robot(chain, "typical", seed=7).deviations
    truth = TrueRobot(nominal=chain, deviations=geometry, noise=NOISE_MM)
    rng = np.random.default_rng(1)
    joints = uniform_joints(chain, 200, rng)
    return chain, joints, truth.measure(joints, rng)


def test_k_fold_predicts_every_pose_once_near_the_noise(kr150):
    chain, joints, measured = kr150
    result = k_fold(len(joints), kinematic_fitter(chain, joints, measured), measured, k=5, seed=3)
    assert result["k"] == 5
    # Every pose is held out in exactly one fold, and the folds cover the data.
    assert np.array_equal(np.bincount(result["fold_of"], minlength=5), [40] * 5)
    assert [f["held_out"]["n"] for f in result["folds"]] == [40] * 5
    assert all(f["n_train"] == 160 for f in result["folds"])
    assert result["pooled"]["n"] == len(joints)
    np.testing.assert_allclose(result["errors"], measured - result["predicted"])
    # The held-out error is the tracker noise plus a little model error; nominal is mm off.
    nominal_rms = np.sqrt(np.mean(np.sum((measured - chain.fk_positions(joints)) ** 2, axis=1)))
    assert result["pooled"]["rms_mm"] < 1.3 * NOISE_RMS_MM
    assert result["pooled"]["rms_mm"] > 0.8 * NOISE_RMS_MM  # it is scored against noisy data
    assert nominal_rms > 100 * result["pooled"]["rms_mm"]


def test_k_fold_never_lets_a_model_see_the_poses_it_predicts(kr150):
    chain, joints, measured = kr150
    seen = []

    def spy(train):
        seen.append(set(train.tolist()))

        def predict(test):
            assert not seen[-1] & set(test.tolist())
            return measured[test]

        return predict

    result = k_fold(len(joints), spy, measured, k=4, seed=0)
    assert len(seen) == 4 and result["pooled"]["max_mm"] == 0.0


def test_learning_curve_improves_with_more_training_poses(kr150):
    chain, joints, measured = kr150
    curve = learning_curve(len(joints), kinematic_fitter(chain, joints, measured), measured,
                           sizes=[15, 40, 140], test_fraction=0.3, repeats=3, seed=2)
    assert [point["n_train"] for point in curve] == [15, 40, 140]
    assert all(point["n_test"] == 60 for point in curve)
    # 140 is the whole training pool: every subset would be the same, so it is fitted once.
    assert [point["repeats"] for point in curve] == [3, 3, 1]
    assert curve[0]["held_out"]["n"] == 3 * 60 and len(curve[0]["per_repeat"]) == 3
    rms = [point["held_out"]["rms_mm"] for point in curve]
    assert rms[0] > rms[1] > rms[2]
    assert rms[2] < 1.3 * NOISE_RMS_MM


def kinematic_fitter(chain, joints, measured, **settings):
    return method_fitter(KinematicMethod(**settings), chain, Observations.of(joints, measured))


def test_method_fitter_exposes_the_fitted_method_and_takes_settings(kr150):
    chain, joints, measured = kr150
    fit = kinematic_fitter(chain, joints, measured, parameters="offsets")
    predict = fit(np.arange(100))
    assert set(predict.fitted.calibration_.names_) <= set(chain.parameter_names(("offsets", "base", "tool")))
    assert predict(np.arange(100, 110)).shape == (10, 3)


def test_bad_inputs_are_refused(kr150):
    chain, joints, measured = kr150
    n = len(joints)
    fit = kinematic_fitter(chain, joints, measured)
    with pytest.raises(InputError, match="at least 2"):
        k_fold(n, fit, measured, k=1)
    with pytest.raises(InputError, match="k <= 200"):
        k_fold(n, fit, measured, k=n + 1)
    with pytest.raises(InputError, match="whole number"):
        k_fold(n, fit, measured, k=2.5)
    with pytest.raises(InputError, match=r"\(200, 3\)"):
        k_fold(n, fit, measured[:-1])
    with pytest.raises(InputError, match="sizes <= 140"):
        learning_curve(n, fit, measured, sizes=[20, 141])
    with pytest.raises(InputError, match="at least 1"):
        learning_curve(n, fit, measured, sizes=[0])
    with pytest.raises(InputError, match="at least one"):
        learning_curve(n, fit, measured, sizes=[])
    with pytest.raises(InputError, match="test_fraction"):
        learning_curve(n, fit, measured, sizes=[20], test_fraction=1.0)
    with pytest.raises(InputError, match=r"positions must have shape \(200, 3\)"):
        kinematic_fitter(chain, joints, measured[:10])
    with pytest.raises(InputError, match=r"returned shape \(3,\)"):
        k_fold(n, lambda train: lambda test: np.zeros(3), measured)
