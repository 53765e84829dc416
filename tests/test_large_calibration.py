"""Large parametric calibrations in bounded memory: the Jacobian formed over blocks of poses
gives the calibration the whole Jacobian gives (robocal.estimation.least_squares)."""
import numpy as np
import pytest

from robocal.estimation import least_squares
from robocal.estimation.calibration import KinematicCalibration, OutlierError
from robocal.estimation.least_squares import (NormalEquations, blocked_normal_equations, blocked_r_factor,
                                              damped_least_squares)
from robocal.io.library import builtin
from robocal.simulation import uniform_joints


@pytest.fixture(scope="module")
def data():
    chain = builtin("kr150-2")
    rng = np.random.default_rng(7)
    links = [n for n in chain.parameter_names(("links",)) if not n.startswith("beta")]
    sigma = [np.radians(0.05) if chain.is_angular(n) else 0.5 for n in links]
    truth = chain.perturbed(links, rng.normal(size=len(sigma)) * np.array(sigma))
    q = uniform_joints(chain, 240, rng)
    positions = truth.fk_positions(q) + rng.normal(scale=0.02, size=(len(q), 3))
    return chain, truth, q, positions


def test_blocked_r_factor_and_normal_equations_are_those_of_the_whole_matrix():
    rng = np.random.default_rng(0)
    J, r = rng.normal(size=(300, 7)), rng.normal(size=(100, 3))
    rows_of = lambda poses: J.reshape(100, 3, 7)[poses].reshape(-1, 7)  # noqa: E731
    R = blocked_r_factor(rows_of, 100, 7, size=13)
    assert np.allclose(R.T @ R, J.T @ J, rtol=1e-12, atol=1e-10)
    equations = blocked_normal_equations(rows_of, r, 100, size=13)
    assert np.allclose(equations.normal, J.T @ J, rtol=1e-12, atol=1e-10)
    assert np.allclose(equations.projected, J.T @ r.reshape(-1), rtol=1e-12, atol=1e-10)


def test_a_step_from_normal_equations_is_the_step_from_the_jacobian(data):
    chain, _, q, positions = data
    names = chain.parameter_names(("base",)) + chain.parameter_names(("tool",))[:3]

    def residual(c):
        return (positions - c.fk_positions(q)).reshape(-1)

    def jacobian(c):
        return -c.identification_jacobian(q, names)[:, :3, :].reshape(-1, len(names))

    whole = damped_least_squares(chain, names, lambda c: (residual(c), jacobian(c)), residual, max_iterations=1)
    normal = damped_least_squares(
        chain, names,
        lambda c: (residual(c), NormalEquations(jacobian(c).T @ jacobian(c), jacobian(c).T @ residual(c))),
        residual, max_iterations=1)
    a, b = whole.chain.parameter_values(names), normal.chain.parameter_values(names)
    assert np.allclose(a, b, rtol=1e-9, atol=1e-9 * np.abs(a).max())


def calibrations(chain, q, positions, monkeypatch, settings=None, **data):
    """The same calibration with the whole Jacobian and with blocks of 37 poses."""
    settings = settings or {}
    whole = KinematicCalibration(**settings).fit(chain, q, positions, **data)
    monkeypatch.setattr(least_squares, "BLOCK_POSES", 37)
    blocked = KinematicCalibration(**settings).fit(chain, q, positions, **data)
    monkeypatch.undo()
    return whole, blocked


@pytest.mark.parametrize("settings", [{}, {"parameters": "full+gains"}, {"loss": "huber"}])
def test_the_blocked_calibration_is_the_whole_one(data, monkeypatch, settings):
    chain, _, q, positions = data
    whole, blocked = calibrations(chain, q, positions, monkeypatch, settings=settings)
    a, b = whole.result_, blocked.result_
    assert a.names == b.names and a.iterations == b.iterations
    # The model's positions agree to 1e-9 of their size; the parameters far inside their
    # standard errors (the optimum itself is defined only to rounding in the gradient, a
    # sum of large terms cancelling to zero, which blocks add up in another order).
    reach = np.abs(whole.predict(q)).max()
    assert np.allclose(blocked.predict(q), whole.predict(q), rtol=0, atol=1e-9 * reach)
    assert np.all(np.abs(a.values - b.values) <= 1e-4 * a.std_errors)
    assert np.allclose(a.std_errors, b.std_errors, rtol=1e-5)
    for field in ("rank", "rows", "condition_number", "o1", "o3", "noise_amplification"):
        assert getattr(b.identifiability, field) == pytest.approx(getattr(a.identifiability, field), rel=1e-9), field
    assert a.identifiability.fixed == b.identifiability.fixed
    assert [pair[:2] for pair in a.correlated_pairs] == [pair[:2] for pair in b.correlated_pairs]
    assert np.allclose([pair[2] for pair in a.correlated_pairs], [pair[2] for pair in b.correlated_pairs], atol=1e-6)


def test_full_poses_blocked(data, monkeypatch):
    chain, truth, q, positions = data
    rotations = truth.fk(q)[:, :3, :3]
    whole, blocked = calibrations(chain, q, positions, monkeypatch, orientations=rotations)
    assert whole.result_.names == blocked.result_.names
    assert np.allclose(blocked.predict(q), whole.predict(q), rtol=0, atol=1e-9 * np.abs(whole.predict(q)).max())
    assert blocked.result_.orientation_rms_deg == pytest.approx(whole.result_.orientation_rms_deg, rel=1e-6)


def test_outliers_are_named_in_blocks_as_whole(data, monkeypatch):
    chain, _, q, positions = data
    spoilt = positions.copy()
    spoilt[[5, 77, 200]] += [[40.0, 0, 0], [0, -60.0, 0], [0, 0, 55.0]]
    whole, blocked = calibrations(chain, q, spoilt, monkeypatch, settings={"loss": "huber"})
    assert whole.result_.outliers == blocked.result_.outliers == (5, 77, 200)
    # A plain fit of far worse data fails in both ways, naming the same poses.
    wrecked = positions.copy()
    wrecked[[5, 77, 200]] += 2000.0
    messages = []
    for block in (least_squares.BLOCK_POSES, 37):
        monkeypatch.setattr(least_squares, "BLOCK_POSES", block)
        with pytest.raises(OutlierError) as caught:
            KinematicCalibration().fit(chain, q, wrecked)
        messages.append((caught.value.poses, str(caught.value)))
    assert messages[0][0] == messages[1][0] and set(messages[0][0]) == {5, 77, 200}
