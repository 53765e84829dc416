"""Real-data loaders (packaged copy) and base/tool registration against the nominal residuals
recorded in shared/data/README.md."""
import numpy as np
import pytest

from robocal.errors import InputError
from robocal.estimation.registration import kabsch, register_base_and_tool
from robocal.io.datasets import ipa_ur10, ur5_tsinghua
from robocal.spatial import so3_exp


def _stats(chain, obs):
    e = np.linalg.norm(obs.positions - chain.fk_positions(obs.joints), axis=1)
    return e.mean(), np.sqrt(np.mean(e**2)), e.max()


def test_ur5_loader_reproduces_the_authors_targets():
    dataset = ur5_tsinghua()
    chain, data = dataset.chain, dataset.measurements  # the targets are columns of the file
    assert data.n_poses == 1000
    q = dataset.observations.joints
    target = np.column_stack([np.asarray(data.extra[k], float) for k in ("x_t", "y_t", "z_t")])
    assert np.abs(chain.fk_positions(q) - target).max() < 0.01


@pytest.mark.parametrize(
    "loader, expected",
    [(lambda: ur5_tsinghua(), (0.63, 0.70, 2.28)), (lambda: ipa_ur10("B"), (1.03, 1.09, 2.14))],
    ids=["ur5", "ur10-B"],
)
def test_registration_reaches_the_documented_nominal_residual(loader, expected):
    dataset = loader()
    chain, obs = dataset.chain, dataset.observations
    registered, report = register_base_and_tool(chain, obs.joints, obs.positions)
    assert report.converged
    mean, rms, worst = _stats(registered, obs)
    np.testing.assert_allclose([mean, rms, worst], expected, atol=0.015)


def test_registration_recovers_a_known_frame_from_any_placement():
    dataset = ur5_tsinghua()
    chain, q = dataset.chain, dataset.observations.joints[:200]
    true_base = np.eye(4)
    true_base[:3, :3] = so3_exp([0.3, -2.0, 1.2])
    true_base[:3, 3] = [2500.0, -800.0, 300.0]
    truth = chain.replace(base=true_base, tool=chain.tool @ np.array(
        [[1, 0, 0, 1.5], [0, 1, 0, -2.0], [0, 0, 1, 4.0], [0, 0, 0, 1.0]]))
    measured = truth.fk_positions(q)
    registered, report = register_base_and_tool(chain, q, measured)
    assert report.rms_after_mm < 1e-8
    np.testing.assert_allclose(registered.base, true_base, atol=1e-9)
    np.testing.assert_allclose(registered.tool[:3, 3], truth.tool[:3, 3], atol=1e-8)


def test_kabsch_refuses_collinear_points():
    line = np.outer(np.linspace(0, 1, 10), [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="collinear"):
        kabsch(line, line + 5.0)
