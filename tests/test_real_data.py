"""Methods on the real measured datasets (packaged in robocal/io/data), scored on held-out poses only."""
import numpy as np

from robocal.compensation.methods import evaluate, fit_kriging
from robocal.io.datasets import ur5_tsinghua


def test_kriging_on_ur5_predicts_the_other_half():
    chain, data = ur5_tsinghua()
    q = chain.joints_from_file(data.joints)
    order = np.random.default_rng(0).permutation(data.n_poses)
    train, test = order[:500], order[500:]
    compensator, _, record = fit_kriging(chain, q[train], data.positions[train], register="auto")
    assert not record["registered"]  # the data are in the robot base frame already
    result = evaluate(compensator, chain, q[test], data.positions[test])
    assert result["n"] == 500
    # 2.6 mm mean before; Cartesian Kriging must remove most of it on poses it never saw.
    assert result["nominal"]["mean_mm"] > 2.5
    assert result["mean_mm"] < 0.25 * result["nominal"]["mean_mm"]
    assert result["max_mm"] < 0.5 * result["nominal"]["max_mm"]


def _split(n, fraction, seed=0):
    order = np.random.default_rng(seed).permutation(n)
    cut = int(round(fraction * n))
    return order[:cut], order[cut:]


def test_kinematic_and_hybrid_on_ur5_beat_the_published_result():
    from robocal.compensation.methods import fit_hybrid, fit_kinematic

    chain, data = ur5_tsinghua()
    q = chain.joints_from_file(data.joints)
    train, test = _split(data.n_poses, 0.5)
    unregistered = np.linalg.norm(data.positions[test] - chain.fk_positions(q[test]), axis=1).mean()
    assert unregistered > 2.5  # the authors report 2.5664 mm before on their test poses
    kinematic, reference, _ = fit_kinematic(chain, q[train], data.positions[train])
    kin = evaluate(kinematic, reference, q[test], data.positions[test])
    # The authors reach 0.1549 mm with calibration plus a graph neural network.
    assert kin["mean_mm"] < 0.1549
    hybrid, reference, _ = fit_hybrid(chain, q[train], data.positions[train])
    hyb = evaluate(hybrid, reference, q[test], data.positions[test])
    assert hyb["mean_mm"] < kin["mean_mm"]


def test_kinematic_on_ur10_with_unknown_base_and_probe():
    from robocal.compensation.methods import fit_kinematic
    from robocal.io.datasets import ipa_ur10

    chain, data = ipa_ur10("B")
    q = chain.joints_from_file(data.joints)
    train, test = _split(data.n_poses, 0.7)
    compensator, reference, record = fit_kinematic(chain, q[train], data.positions[train], sigmas=data.sigmas[train])
    result = evaluate(compensator, reference, q[test], data.positions[test])
    # Base and probe are found from nothing (tracker frame); the geometry then removes more
    # than half of what nominal geometry with the best base and probe still misses.
    assert result["nominal"]["mean_mm"] > 0.9
    assert result["mean_mm"] < 0.5 * result["nominal"]["mean_mm"]
