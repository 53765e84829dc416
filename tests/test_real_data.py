"""Methods on the real measured datasets (packaged in robocal/io/data), scored on held-out poses only."""
import numpy as np
import pytest

from robocal.io.datasets import ipa_ur10, ur5_tsinghua
from robocal.io.observations import Observations
from robocal.methods import HybridMethod, KinematicMethod, KrigingMethod
from robocal.methods.evaluation import position_scores


def _observations(dataset, sigmas=False):
    """The dataset's joints (rad) and positions (mm) only, as the methods are fitted here:
    orientations left out; the per-reading sigmas (mm) when asked for."""
    obs = dataset.observations
    return Observations.of(obs.joints, obs.positions, sigmas=obs.sigmas if sigmas else None)


def _held_out(method, chain, obs, test):
    """Statistics of the fitted method on ``test`` rows, the registered nominal's under "nominal"."""
    return position_scores(method, obs.subset(test), chain.name)[2]


@pytest.mark.slow
def test_kriging_on_ur5_predicts_the_other_half():
    dataset = ur5_tsinghua()
    chain, obs = dataset.chain, _observations(dataset)
    order = np.random.default_rng(0).permutation(obs.n_poses)
    train, test = order[:500], order[500:]
    method = KrigingMethod(register="auto").fit(chain, obs.subset(train))
    assert not method.record_.registered  # the data are in the robot base frame already
    result = _held_out(method, chain, obs, test)
    assert result["n"] == 500
    # 2.6 mm mean before; Cartesian Kriging must remove most of it on poses it never saw.
    assert result["nominal"]["mean_mm"] > 2.5
    assert result["mean_mm"] < 0.25 * result["nominal"]["mean_mm"]
    assert result["max_mm"] < 0.5 * result["nominal"]["max_mm"]


def _split(n, fraction, seed=0):
    order = np.random.default_rng(seed).permutation(n)
    cut = int(round(fraction * n))
    return order[:cut], order[cut:]


@pytest.mark.slow
def test_kinematic_and_hybrid_on_ur5_beat_the_published_result():
    dataset = ur5_tsinghua()
    chain, obs = dataset.chain, _observations(dataset)
    train, test = _split(obs.n_poses, 0.5)
    q = obs.joints
    unregistered = np.linalg.norm(obs.positions[test] - chain.fk_positions(q[test]), axis=1).mean()
    assert unregistered > 2.5  # the authors report 2.5664 mm before on their test poses
    kin = _held_out(KinematicMethod().fit(chain, obs.subset(train)), chain, obs, test)
    # The authors reach 0.1549 mm with calibration plus a graph neural network.
    assert kin["mean_mm"] < 0.1549
    hyb = _held_out(HybridMethod().fit(chain, obs.subset(train)), chain, obs, test)
    assert hyb["mean_mm"] < kin["mean_mm"]


def test_kinematic_on_ur10_with_unknown_base_and_probe():
    dataset = ipa_ur10("B")
    chain, obs = dataset.chain, _observations(dataset, sigmas=True)
    train, test = _split(obs.n_poses, 0.7)
    result = _held_out(KinematicMethod().fit(chain, obs.subset(train)), chain, obs, test)
    # Base and probe are found from nothing (tracker frame); the geometry then removes more
    # than half of what nominal geometry with the best base and probe still misses.
    assert result["nominal"]["mean_mm"] > 0.9
    assert result["mean_mm"] < 0.5 * result["nominal"]["mean_mm"]
