"""Constraint calibration (ball in sockets): recovery against a known truth up to the
unobservable base frame, the linearised constraints against finite differences, pairing,
identifiability reporting, refusals, the sockets sampling plan and the MUKCa data."""
import warnings

import numpy as np
import pytest

from robocal.errors import InputError, RobocalWarning
from robocal.estimation.constraint import (
    ConstraintCalibration,
    constraint_pairs,
    constraint_rows,
    socket_data,
    socket_errors,
)
from robocal.estimation.registration import kabsch
from robocal.io.fixtures import Fixture
from robocal.io.library import builtin
from robocal.kinematics import to_poe
from robocal.simulation import TrueRobot, make_true_robot
from robocal.simulation.sampling import socket_plan
from robocal.spatial import compose_pose

PLATE = Fixture("plate", {"A": [0.0, 0.0, 0.0], "B": [150.0, 0.0, 0.0], "C": [0.0, 120.0, 0.0]})


def _robot(name):
    chain = builtin(name)
    if name == "panda":
        chain = chain.replace(tool=compose_pose([0.0, 0.0, 133.4], np.zeros(3)))
    elif not np.any(chain.tool[:3, 3]):
        chain = chain.replace(tool=compose_pose([20.0, -10.0, 150.0], np.zeros(3)))
    return chain


def _geometric_truth(chain, seed):
    """Every link parameter and the ball offset off as in the 'typical' preset; no compliance.
    (Base deviations are left out: nothing here could see them.)"""
    deviations = make_true_robot(chain, "typical", seed).deviations
    return TrueRobot(nominal=chain, deviations={k: v for k, v in deviations.items() if not k.startswith("base")})


def _rigid_error(predicted, true, align_predicted=None, align_true=None):
    """|true - (R predicted + t)| with R, t fitted on the alignment points (default: the same)."""
    rot, shift = kabsch(predicted if align_predicted is None else align_predicted,
                        true if align_true is None else align_true)
    return np.linalg.norm(predicted @ rot.T + shift - true, axis=1)


@pytest.fixture(scope="module", params=["panda", "kr150-2"])
def noise_free(request):
    chain = _robot(request.param)
    truth = _geometric_truth(chain, seed=4)
    plan = socket_plan(truth, PLATE, 3, 6, rng=1)
    cal = ConstraintCalibration().fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE)
    return chain, truth, plan, cal


def test_noise_free_recovery_up_to_the_base_frame(noise_free):
    chain, truth, plan, cal = noise_free
    assert cal.result_.converged
    r = cal.result_
    assert r.residual_before["mean_mm"] > 0.1 and r.residual_after["max_mm"] < 1e-6
    assert r.residual_after["socket_distance"]["max_mm"] < 1e-6
    # Ball positions anywhere in the workspace, with the base frame taken from the training
    # configurations: the calibrated model is the true robot, moved rigidly.
    q_test = chain.random_configurations(300, np.random.default_rng(9))
    after = _rigid_error(cal.predict(q_test), truth.positions(q_test), cal.predict(plan.joints), plan.ball)
    before = _rigid_error(chain.fk_positions(q_test), truth.positions(q_test))
    assert before.max() > 1.0
    assert after.max() < 1e-4


def test_identified_parameters_are_those_of_a_minimal_model(noise_free):
    chain, _, _, cal = noise_free
    report = cal.result_.identifiability
    # A point on a chain of revolute joints: 4 per joint and 3 for the ball, minus the base.
    assert len(cal.names_) == 4 * chain.n_joints + 3 - 6
    assert {"tool_x", "tool_y", "tool_z"} <= set(cal.names_)
    assert {"base_x", "base_rz", "theta1", "ux1", "wy1"} <= set(report.fixed)
    assert "scale" not in report.fixed
    assert "base frame" in report.fixed["base_rz"] and "base frame" in report.fixed["theta1"]
    assert cal.result_.unobservable == ("base frame",)
    assert np.all(np.isfinite(cal.result_.std_errors)) and np.all(cal.result_.std_errors >= 0)
    # The calibrated model keeps the starting base: joint 1's axis is where it was.
    start = to_poe(chain)
    assert np.allclose(cal.chain_.axes[0], start.axes[0]) and np.allclose(cal.chain_.points[0], start.points[0])


def test_deviations_rebuild_the_calibrated_chain(noise_free):
    chain, _, plan, cal = noise_free
    r = cal.result_
    rebuilt = cal.start_chain_.perturbed(list(r.names), r.values)
    assert np.abs(rebuilt.fk_positions(plan.joints) - cal.predict(plan.joints)).max() < 1e-6
    as_dict = r.to_dict(cal.chain_)
    assert set(as_dict["parameters"]) == set(r.names)
    assert as_dict["residual_after"]["n"] == len(plan.joints)


def test_spanning_pairs_reach_the_same_model():
    chain = _robot("panda")
    truth = _geometric_truth(chain, seed=8)
    plan = socket_plan(truth, PLATE, 3, 5, rng=2)
    spanning = ConstraintCalibration("spanning").fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE)
    q_test = chain.random_configurations(200, np.random.default_rng(1))
    assert _rigid_error(spanning.predict(q_test), truth.positions(q_test)).max() < 1e-4
    assert spanning.result_.pairs["position"] == 3 * 3 * 4  # 3 placements x 3 sockets x (5 - 1)


def test_joint_noise_leaves_a_small_fraction_of_the_nominal_error():
    chain = _robot("panda")
    truth = _geometric_truth(chain, seed=6)
    train = socket_plan(truth, PLATE, 4, 8, rng=3, joint_noise_deg=0.005)
    test = socket_plan(truth, PLATE, 2, 8, rng=4)  # other placements, exact readings
    cal = ConstraintCalibration().fit(chain, train.joints, train.fixture_ids, train.socket_ids, PLATE)
    after = _rigid_error(cal.predict(test.joints), test.ball, cal.predict(train.joints), train.ball)
    before = _rigid_error(chain.fk_positions(test.joints), test.ball, chain.fk_positions(train.joints), train.ball)
    assert after.mean() < 0.1 * before.mean(), (after.mean(), before.mean())
    held_out = socket_errors(cal.chain_, test.joints, test.fixture_ids, test.socket_ids, PLATE)
    nominal = socket_errors(chain, test.joints, test.fixture_ids, test.socket_ids, PLATE)
    assert held_out["mean_mm"] < 0.1 * nominal["mean_mm"]


def test_without_distances_the_scale_is_reported_unidentifiable():
    chain = _robot("panda")
    truth = _geometric_truth(chain, seed=4)
    plan = socket_plan(truth, PLATE, 3, 6, rng=1)
    # Plain least squares, where noise-free data are fitted to rounding and the analysis at
    # the fit counts exactly what the constraints leave; under the tolerances (below) too.
    cal = ConstraintCalibration(distance=False, prior="none").fit(chain, plan.joints, plan.fixture_ids,
                                                                  plan.socket_ids, PLATE)
    prior = ConstraintCalibration(distance=False).fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE)
    assert "scale" in prior.result_.identifiability.fixed and prior.result_.residual_after["max_mm"] < 1e-4
    r = cal.result_
    assert r.unobservable == ("base frame", "scale")
    assert "scale" in r.identifiability.fixed
    assert len(cal.names_) == 4 * chain.n_joints + 3 - 6 - 1
    assert any("with the scale" in reason for reason in r.identifiability.fixed.values())
    assert r.pairs["distance"] == 0
    # The shape is right: every socket is consistent, only the size is the nominal's guess.
    assert r.residual_after["max_mm"] < 1e-6
    with_distance = ConstraintCalibration(prior="none").fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids,
                                                            PLATE)
    assert len(with_distance.names_) == len(cal.names_) + 1


def test_one_socket_of_one_placement_reports_what_it_cannot_identify():
    chain = _robot("panda")
    plan = socket_plan(_geometric_truth(chain, seed=2), PLATE, 1, 20, rng=5)
    one = plan.socket_ids == "A"
    # The structure of what one point leaves unseen, counted at the exact fit of noise-free data
    # (plain least squares: the tolerances would hold a borderline direction at 1e-5 mm).
    cal = ConstraintCalibration(distance=False, prior="none").fit(chain, plan.joints[one], plan.fixture_ids[one],
                                                                  plan.socket_ids[one], PLATE)
    r = cal.result_
    # A single point: no distance, so the scale goes with the base frame.
    assert r.unobservable == ("base frame", "scale") and r.pairs["distance"] == 0
    assert len(cal.names_) == 4 * chain.n_joints + 3 - 7
    fixed = r.identifiability.fixed
    assert all(reason for reason in fixed.values())
    assert not set(fixed) & set(cal.names_)
    everything = set(to_poe(chain).parameter_names(("links", "home", "base"))) | {"tool_x", "tool_y", "tool_z", "scale"}
    assert set(fixed) | set(cal.names_) == everything
    assert r.residual_after["max_mm"] < 1e-6


def test_compliance_from_one_placement_is_warned_about():
    chain = _robot("panda")
    plan = socket_plan(_geometric_truth(chain, seed=2), PLATE, 1, 12, rng=5)
    with pytest.warns(RobocalWarning, match="one fixture placement"):
        ConstraintCalibration(compliance=True).fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE)
    two = socket_plan(_geometric_truth(chain, seed=2), PLATE, 2, 12, rng=5)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RobocalWarning)
        ConstraintCalibration(compliance=True).fit(chain, two.joints, two.fixture_ids, two.socket_ids, PLATE)


# ------------------------------------------------------------------- linearisation
def _small_data(chain, rng):
    q = chain.random_configurations(12, rng)
    placements = np.repeat(["P1", "P2"], 6)
    sockets = np.array(["A", "A", "A", "B", "B", "C"] * 2)
    return socket_data(chain, q, placements, sockets, PLATE)


@pytest.mark.parametrize("pairing", ["all", "spanning"])
@pytest.mark.parametrize("name", ["panda", "kr150-2"])
def test_constraint_jacobian_matches_finite_differences(name, pairing):
    chain = to_poe(_robot(name)).perturbed({"ux3": 0.7, "wy2": 0.002, "tool_x": 3.0})
    data = _small_data(chain, np.random.default_rng(0))
    pairs = constraint_pairs(data, pairing)
    names = ["tool_x", "tool_z", "theta2", "ux3", "uy5", "wx4", "wy6", "home_z", "home_ry"]
    r, jac = constraint_rows(chain, data.joints, pairs, names)
    assert np.allclose(r, constraint_rows(chain, data.joints, pairs)[0])
    step = 1e-6
    numeric = np.column_stack([
        (constraint_rows(chain.perturbed([n], [step]), data.joints, pairs)[0]
         - constraint_rows(chain.perturbed([n], [-step]), data.joints, pairs)[0]) / (2 * step)
        for n in names
    ])
    assert np.abs(jac - numeric).max() < 1e-5 * np.abs(numeric).max()


def test_pair_counts_for_all_and_spanning():
    chain = _robot("panda")
    data = _small_data(chain, np.random.default_rng(1))
    # Per placement: sockets A (3), B (2), C (1) configurations.
    every = constraint_pairs(data, "all")
    assert len(every.position) == 2 * (3 + 1 + 0)
    assert len(every.distance) == 2 * (3 * 2 + 3 * 1 + 2 * 1)
    spanning = constraint_pairs(data, "spanning")
    assert len(spanning.position) == 2 * (2 + 1 + 0)
    assert len(spanning.distance) == 2 * (3 + 3)  # A-B and A-C, max of the two sizes each
    for pairs in (every, spanning):
        i, j = pairs.position.T
        assert np.all(data.group[i] == data.group[j]) and np.all(i != j)
        k, m = pairs.distance.T
        assert np.all(data.placement[k] == data.placement[m]) and np.all(data.socket[k] != data.socket[m])
        ids = np.array(PLATE.ids)
        known = [PLATE.distance(a, b) for a, b in zip(ids[data.socket[k]], ids[data.socket[m]])]
        assert np.allclose(pairs.target, known)
    # Spanning pairs still touch every configuration of every socket that has a partner.
    assert set(np.unique(spanning.distance)) == set(range(12))
    # All position pairs take a centred form of N rows with the same sum of squares.
    p = chain.fk_positions(data.joints)
    r = constraint_rows(chain, data.joints, every)[0]
    assert every.position_rows == 3 * 12 and r.size == 3 * 12 + len(every.distance)
    i, j = every.position.T
    assert np.isclose(r[:36] @ r[:36], np.sum((p[i] - p[j]) ** 2))


def test_socket_errors_are_zero_for_the_true_chain_and_see_a_wrong_distance():
    chain = _robot("panda")
    truth = _geometric_truth(chain, seed=1)
    plan = socket_plan(truth, PLATE, 2, 4, rng=0)
    exact = socket_errors(truth.actual, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE)
    assert exact["n"] == len(plan.joints) and exact["max_mm"] < 1e-6
    assert exact["socket_distance"]["n"] == 2 * 3 and exact["socket_distance"]["max_mm"] < 1e-6
    stretched = Fixture("wide", {k: 1.1 * v for k, v in PLATE.sockets.items()})
    wrong = socket_errors(truth.actual, plan.joints, plan.fixture_ids, plan.socket_ids, stretched)
    assert wrong["max_mm"] < 1e-6
    assert wrong["socket_distance"]["signed_mean_mm"] < -10.0


# ------------------------------------------------------------------------ refusals
@pytest.fixture(scope="module")
def small_plan():
    chain = _robot("panda")
    return chain, socket_plan(_geometric_truth(chain, seed=3), PLATE, 3, 5, rng=7)


def _fit(chain, q, placements, sockets, fixture=PLATE):
    return ConstraintCalibration().fit(chain, q, placements, sockets, fixture)


def test_refuses_a_socket_with_a_single_configuration(small_plan):
    chain, plan = small_plan
    keep = np.ones(len(plan.joints), dtype=bool)
    group = np.flatnonzero((plan.fixture_ids == "P2") & (plan.socket_ids == "B"))
    keep[group[1:]] = False
    with pytest.raises(InputError, match="placement 'P2', socket 'B' has a single configuration"):
        _fit(chain, plan.joints[keep], plan.fixture_ids[keep], plan.socket_ids[keep])


def test_refuses_a_socket_missing_from_the_fixture(small_plan):
    chain, plan = small_plan
    sockets = plan.socket_ids.copy()
    sockets[sockets == "C"] = "D"
    with pytest.raises(InputError, match=r"socket id\(s\) D are not in fixture 'plate'"):
        _fit(chain, plan.joints, plan.fixture_ids, sockets)


def test_refuses_socket_distances_the_data_contradict(small_plan):
    chain, plan = small_plan
    wrong = Fixture("wrong", {"A": [0.0, 0.0, 0.0], "B": [250.0, 0.0, 0.0], "C": [0.0, 120.0, 0.0]})
    # Under the tolerances the fit judges it: no robot within them leaves such distance errors.
    message = r"misses the fixture's socket distances by \d+\.\d mm RMS .* not this robot's with this fixture"
    with pytest.raises(InputError, match=message):
        _fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, wrong)
    # Without them the data must agree with the fixture before the fit.
    message = r"sockets A and B are 1[45]\d\.\d mm apart by the starting model but 250.0 mm"
    with pytest.raises(InputError, match=message):
        ConstraintCalibration(prior="none").fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, wrong)


def test_a_fixture_in_another_length_unit_is_named(small_plan):
    chain, plan = small_plan
    inches = Fixture("inches", {k: v / 25.4 for k, v in PLATE.sockets.items()})
    with pytest.raises(InputError, match="they look like inches"):
        _fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, inches)


def test_refuses_nan_mismatched_and_too_few(small_plan):
    chain, plan = small_plan
    q = plan.joints.copy()
    q[4, 2] = np.nan
    with pytest.raises(InputError, match="NaN"):
        _fit(chain, q, plan.fixture_ids, plan.socket_ids)
    with pytest.raises(InputError, match="one entry per configuration"):
        _fit(chain, plan.joints, plan.fixture_ids[:-1], plan.socket_ids)
    with pytest.raises(InputError, match="joints must be"):
        _fit(chain, plan.joints[:, :6], plan.fixture_ids, plan.socket_ids)
    few = np.flatnonzero(plan.fixture_ids == "P1")[:4]
    with pytest.raises(InputError, match="independent constraint equations"):
        ConstraintCalibration(prior="none").fit(chain, plan.joints[few], plan.fixture_ids[few], plan.socket_ids[few],
                                                PLATE)
    # Settings are stored as given and checked by fit, which names the bad one.
    for settings, message in (({"pairs": "some"}, "pairs must be one of"), ({"payload": -1.0}, "payload must be")):
        unchecked = ConstraintCalibration(**settings)
        assert all(getattr(unchecked, k) == v for k, v in settings.items())
        with pytest.raises(InputError, match=message):
            unchecked.fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE)


# ------------------------------------------------------------------------ sampling
def test_socket_plan_seats_the_true_ball_through_compliance_and_backlash():
    chain = _robot("panda")
    truth = make_true_robot(chain, "typical", seed=2)  # geometry, compliance, backlash
    plan = socket_plan(truth, PLATE, 2, 4, rng=11)
    assert plan.joints.shape == (2 * 3 * 4, chain.n_joints)
    assert np.abs(truth.positions(plan.joints) - plan.ball).max() < 1e-6
    # The balls sit in the sockets: the fixture's distances between the seats.
    for placement in ("P1", "P2"):
        seats = {s: plan.ball[(plan.fixture_ids == placement) & (plan.socket_ids == s)] for s in PLATE.ids}
        for points in seats.values():
            assert np.ptp(points, axis=0).max() < 1e-9
        assert abs(np.linalg.norm(seats["A"][0] - seats["B"][0]) - 150.0) < 1e-9
    # Varied orientations: the flange axis turns between the configurations of one socket.
    z = truth.actual.fk(plan.joints[:4])[:, :3, 2]
    assert np.degrees(np.arccos(np.clip(z @ z.T, -1, 1))).max() > 5.0
    assert chain.within_limits(plan.joints).all()
    again = socket_plan(truth, PLATE, 2, 4, rng=11)
    assert np.array_equal(again.joints, plan.joints)
    table = plan.measurements(chain)
    assert table.kind == "constraint" and np.allclose(chain.joints_from_file(table.joints), plan.joints)
    assert set(table.socket) == set(PLATE.ids) and set(table.fixture) == {"P1", "P2"}


def test_socket_plan_noise_and_seating_error():
    chain = _robot("panda")
    exact = socket_plan(chain, PLATE, 1, 4, rng=3)
    noisy = socket_plan(chain, PLATE, 1, 4, rng=3, joint_noise_deg=0.01, seating_mm=0.05)
    assert np.allclose(exact.placements, noisy.placements)
    spread = np.linalg.norm(noisy.ball - exact.ball, axis=1)
    assert 0.0 < spread.max() < 0.5
    # The readings are what the joints do plus noise: they miss the seats by about that much.
    miss = np.linalg.norm(chain.fk_positions(noisy.joints) - noisy.ball, axis=1)
    assert 1e-3 < miss.mean() < 1.0
    with pytest.raises(InputError, match="max_tilt_deg"):
        socket_plan(chain, PLATE, 1, 4, max_tilt_deg=95.0)


# ---------------------------------------------------------------------- real data
def test_mukca_loader():
    from robocal.io.datasets import mukca

    dataset = mukca("panda_1")
    chain, data, fixture = dataset.chain, dataset.measurements, dataset.fixture
    assert data.kind == "constraint" and data.n_joints == 7
    assert set(data.socket) == {"0", "1"} and len(set(data.fixture)) == 3
    assert fixture.distance("0", "1") == 50.0
    assert np.abs(data.joints).max() > 2 * np.pi  # degrees in file units
    assert chain.within_limits(dataset.observations.joints).all()
    assert 120.0 < chain.tool[2, 3] < 140.0
    with pytest.raises(InputError, match="no MUKCa unit"):
        mukca("panda_9")


def test_mukca_panda_1_held_out_placement():
    from robocal.io.datasets import mukca

    dataset = mukca("panda_1")
    chain, data, fixture = dataset.chain, dataset.observations, dataset.fixture
    q = data.joints
    train = data.placement != "right"
    cal = ConstraintCalibration().fit(chain, q[train], data.placement[train], data.socket[train], fixture)
    r = cal.result_
    assert r.residual_before["mean_mm"] > 5.0  # nominal Panda: several mm (the authors: 8.28)
    assert r.residual_after["mean_mm"] < 0.1 * r.residual_before["mean_mm"]
    test = ~train
    before = socket_errors(chain, q[test], data.placement[test], data.socket[test], fixture)
    after = socket_errors(cal.chain_, q[test], data.placement[test], data.socket[test], fixture)
    assert before["mean_mm"] > 5.0
    assert after["mean_mm"] < 0.15 * before["mean_mm"]
    assert after["socket_distance"]["max_mm"] < 0.1 * fixture.distance("0", "1")


# ------------------------------------------------------------------- documents
@pytest.mark.parametrize("settings", [{}, {"compliance": True, "gains": True, "pairs": "spanning", "payload": 1.0}])
def test_a_fitted_calibration_round_trips_through_its_document(small_plan, settings):
    import copy
    import json

    from robocal.errors import FileFormatError

    chain, plan = small_plan
    cal = ConstraintCalibration(**settings).fit(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE)
    doc = json.loads(json.dumps(cal.to_dict()))
    back = ConstraintCalibration.from_dict(doc)
    q_test = chain.random_configurations(200, np.random.default_rng(3))
    assert np.abs(back.predict(q_test) - cal.predict(q_test)).max() < 1e-9
    assert back.get_settings() == cal.get_settings() and back.names_ == cal.names_
    assert type(back.chain_) is type(cal.chain_)
    assert back.result_.to_dict(back.chain_).keys() == doc["result"].keys()
    assert back.result_.unobservable == cal.result_.unobservable and back.result_.pairs == cal.result_.pairs
    np.testing.assert_allclose(back.result_.std_errors, cal.result_.std_errors, rtol=1e-12, atol=1e-15)
    for change in (lambda d: d["chain"].pop("robot"), lambda d: d["settings"].update(pairs="some"),
                   lambda d: d["result"].pop("unobservable"), lambda d: d.update(estimator="kinematic")):
        broken = copy.deepcopy(doc)
        change(broken)
        with pytest.raises(FileFormatError) as refused:
            ConstraintCalibration.from_dict(broken)
        assert "\n" not in str(refused.value)
    with pytest.raises(InputError, match="not fitted"):
        ConstraintCalibration().to_dict()
