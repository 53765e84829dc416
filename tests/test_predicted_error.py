"""The error to expect where the robot will work (predicted_error) against what the model
then misses there: the mean over joint-uniform configurations of a simulated robot, scored
against its truth, for well-spread and clustered poses, re-registration on a cluster, the
hybrid, an error model, and the socket consistency of the constraint calibration on
placements left out.  A prediction must lie within a factor 2 of the held-out mean."""
from itertools import combinations

import numpy as np
import pytest

from robocal.errors import InputError, RobocalWarning
from robocal.estimation import ConstraintCalibration
from robocal.estimation.constraint import socket_errors
from robocal.estimation.constraint.data import socket_data
from robocal.estimation import prediction
from robocal.estimation.prediction import socket_prediction, working_range, working_sockets
from robocal.io.fixtures import Fixture
from robocal.io.datasets import mukca
from robocal.io.library import builtin
from robocal.io.observations import Observations
from robocal.methods import make_method
from robocal.methods.expectation import expected_error, fall_back_outside_if_worse, refuse_if_worse_than_nominal
from robocal.methods.reregistration import reregister
from robocal.simulation import make_true_robot, uniform_joints
from robocal.simulation.sampling import socket_plan
from robocal.spatial import compose_pose

FACTOR = 2.0
PLATE_SOCKETS = Fixture("plate", {"A": [0.0, 0.0, 0.0], "B": [150.0, 0.0, 0.0], "C": [0.0, 120.0, 0.0]})


@pytest.fixture(scope="module")
def kr150():
    chain = builtin("kr150-2")
    truth = make_true_robot(chain, "typical", seed=2)
    work = working_range(chain).joints
    return chain, truth, work, truth.positions(work)


def _measured(truth, q, seed):
    return Observations.of(q, truth.measure(q, np.random.default_rng(seed)))


def _held_out(method, work, truth_positions):
    return float(np.linalg.norm(truth_positions - method.predict(work), axis=1).mean())


def _cluster(chain, half_width_deg, count, seed):
    rng = np.random.default_rng(seed)
    centre = uniform_joints(chain, 1, rng)[0]
    return centre + np.radians(rng.uniform(-half_width_deg, half_width_deg, size=(count, chain.n_joints)))


@pytest.mark.parametrize("method, parameters", [("kinematic", "full"), ("kinematic", "full+compliance"),
                                                ("hybrid", "full")])
def test_predicted_error_matches_the_held_out_mean_on_well_spread_poses(kr150, method, parameters):
    chain, truth, work, true_positions = kr150
    obs = _measured(truth, uniform_joints(chain, 60, np.random.default_rng(11)), seed=12)
    fitted = make_method(method, parameters=parameters).fit(chain, obs)
    predicted = expected_error(fitted, chain, obs)
    held = _held_out(fitted, work, true_positions)
    assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (predicted.mean_mm, held)
    assert not predicted.worse_than_nominal and predicted.nominal_mean_mm > 3 * predicted.mean_mm


def test_predicted_error_of_poses_clustered_within_5_deg_matches_or_is_refused(kr150):
    chain, truth, work, true_positions = kr150
    obs = _measured(truth, _cluster(chain, 5.0, 25, seed=21), seed=22)
    fitted = make_method("kinematic").fit(chain, obs)
    predicted = expected_error(fitted, chain, obs)
    if predicted.worse_than_nominal:
        with pytest.raises(InputError, match="--accept-extrapolation"):
            refuse_if_worse_than_nominal(predicted, fitted.domain_)
        return
    held = _held_out(fitted, work, true_positions)
    assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (predicted.mean_mm, held)
    # Far worse than the well-spread calibration, and the prediction says so.
    assert predicted.mean_mm > 1.0


@pytest.mark.slow
@pytest.mark.parametrize("method", ["kinematic", "hybrid"])
def test_predicted_error_of_a_re_registration_on_a_cluster(kr150, method):
    chain, truth, work, true_positions = kr150
    obs = _measured(truth, uniform_joints(chain, 200, np.random.default_rng(31)), seed=32)
    fitted = make_method(method).fit(chain, obs)
    fitted.record_ = fitted.record_.replace(predicted_error=expected_error(fitted, chain, obs).to_dict())
    moved = compose_pose([1500.0, -800.0, 200.0], np.radians([0.5, -0.3, 40.0]))
    for q, seed in ((uniform_joints(chain, 25, np.random.default_rng(33)), 34), (_cluster(chain, 5.0, 25, 35), 36)):
        measured = truth.measure(q, np.random.default_rng(seed)) @ moved[:3, :3].T + moved[:3, 3]
        poses = Observations.of(q, measured)
        new = reregister(fitted, poses)
        predicted = expected_error(new, chain, poses)
        held = float(np.linalg.norm(true_positions @ moved[:3, :3].T + moved[:3, 3] - new.predict(work), axis=1).mean())
        assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (predicted.mean_mm, held)


def test_an_error_model_that_would_do_worse_than_the_registered_nominal_robot_says_so(tmp_path):
    # Kriging over the TCP position from 80 poses spread over a UR5's whole joint space: it
    # learns little and, where the robot works, misses by more than the nominal robot with its
    # base and tool registered.  Its prediction says so and is near what it then misses.
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=0)
    obs = _measured(truth, uniform_joints(chain, 80, np.random.default_rng(41)), seed=42)
    fitted = make_method("kriging").fit(chain, obs)
    predicted = expected_error(fitted, chain, obs)
    work = working_range(chain).joints
    held = _held_out(fitted, work, truth.positions(work))
    assert predicted.worse_than_nominal
    assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (predicted.mean_mm, held)


@pytest.mark.parametrize("moving", [(0,), (0, 1, 2)], ids=["only joint 1 moves", "three joints move by 40 deg"])
def test_what_an_error_model_adds_beyond_its_domain_is_predicted(moving):
    # A Kriging over the position from 40 poses where only joint 1 moves (a circle), or
    # three joints within ±40 deg: beyond them the model still adds its extrapolated trend,
    # and misses by many times the nominal robot over the working range.  Taken as its
    # fallback there (the nominal robot), it was predicted as good as that and accepted (the
    # second, with an earlier Kriging: 2.6 mm predicted, 8.9 mm missed; now 7.32 and 7.74).
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=3)
    rng = np.random.default_rng(5)
    q = np.tile(np.radians([0.0, -70.0, 100.0, -120.0, -90.0, 15.0]), (40, 1))
    for k in moving:
        q[:, k] += np.radians(rng.uniform(-40.0 if k else -130.0, 40.0 if k else 170.0, 40))
    obs = _measured(truth, q, seed=6)
    fitted = make_method("kriging").fit(chain, obs)
    predicted = expected_error(fitted, chain, obs)
    work = working_range(chain).joints
    held = _held_out(fitted, work, truth.positions(work))
    assert predicted.worse_than_nominal, (predicted.mean_mm, predicted.nominal_mean_mm, held)
    assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (predicted.mean_mm, held)


def test_an_error_model_predicted_worse_beyond_its_domain_answers_there_with_the_kinematic_calibration():
    # The Kriging of the test above whose three joints move: beyond its poses its trend misses
    # by many times the nominal robot (7.7 mm).  The rigid kinematic calibration answers there
    # instead (0.84 mm), and the prediction of the whole is again near what it then misses.
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=3)
    rng = np.random.default_rng(5)
    q = np.tile(np.radians([0.0, -70.0, 100.0, -120.0, -90.0, 15.0]), (40, 1))
    for k in (0, 1, 2):
        q[:, k] += np.radians(rng.uniform(-40.0 if k else -130.0, 40.0 if k else 170.0, 40))
    obs = _measured(truth, q, seed=6)
    fitted = make_method("kriging").fit(chain, obs)
    work = working_range(chain).joints
    alone = expected_error(fitted, chain, obs)
    held_alone = _held_out(fitted, work, truth.positions(work))
    with pytest.warns(RobocalWarning, match="the kinematic full calibration answers there"):
        answered = fall_back_outside_if_worse(fitted, chain, obs, alone)
    held = _held_out(fitted, work, truth.positions(work))
    assert not answered.worse_than_nominal and answered.mean_mm < alone.mean_mm
    assert held / FACTOR <= answered.mean_mm <= FACTOR * held, (answered.mean_mm, held)
    assert held < held_alone / 4, (held, held_alone)
    # Inside its domain the Kriging still answers.
    inside = fitted.domain_.check(q).inside
    assert inside.all() and np.allclose(fitted.predict(q), fitted.compensator_.inside.predict_positions(q))


@pytest.mark.parametrize("poses, answers, outside_at_least, gain", [(150, "full", 20, 0.5), (25, "offsets", 400, 0.75)],
                         ids=["150 poses", "25 poses"])
def test_kriging_on_a_corner_of_real_data_answers_beyond_it_with_a_kinematic_calibration(tmp_path, poses, answers,
                                                                                         outside_at_least, gain):
    # Poses of UR5 Tsinghua (a corner of the joint space, q1 -24..57 deg): the Kriging alone is
    # predicted to miss by more than the registered nominal robot over the joint range.
    # `calibrate` keeps it where the poses are and lets a kinematic calibration answer beyond,
    # of the parameters the prediction rests on (the data check's): the offsets from 25 poses.
    # (With the full calibration there, 25 poses were refused: the prediction drew the robot
    # from one model and scored another, 3.10 mm against the nominal's 1.75.)  On the other
    # half of the data it then misses less where the calibration answers.
    import json

    from user_files import invoke

    assert invoke(tmp_path, ["dataset", "ur5-tsinghua", "--out", "ts", "--split", "0.5", "--seed", "4"]).code == 0
    lines = (tmp_path / "ts_train.csv").read_text().splitlines()
    (tmp_path / "t.csv").write_text("\n".join(lines[:poses + 1]) + "\n")
    models = {}
    for name, extra in (("answered", []), ("alone", ["--accept-extrapolation"])):
        done = invoke(tmp_path, ["calibrate", "ts.toml", "t.csv", "--method", "kriging", "--out", f"{name}.json",
                                 "--json", *extra])
        assert done.code == 0, done.lines
        predicted = json.loads(done.result.stdout)["predicted_error"]
        scored = invoke(tmp_path, ["evaluate", f"{name}.json", "ts_test.csv", "--json"])
        models[name] = predicted, json.loads(scored.result.stdout), done.lines
    (answered, scored, said), (alone, scored_alone, _) = models["answered"], models["alone"]
    assert alone["mean_mm"] > alone["nominal_mean_mm"] and answered["mean_mm"] < answered["nominal_mean_mm"]
    assert any(f"the kinematic {answers} calibration answers there" in line for line in said), said
    outside, outside_alone = scored["out_of_domain"], scored_alone["out_of_domain"]
    assert outside["n"] == outside_alone["n"] >= outside_at_least
    assert outside["mean_mm"] < gain * outside_alone["mean_mm"], (outside, outside_alone)
    assert scored["in_domain"] == scored_alone["in_domain"]


def _left_out(chain, joints, placement, socket, fixture, train, **settings):
    """(the calibration trained on ``train`` (N,) bool, its training SocketData, the socket
    consistency (mean mm) of the configurations left out)."""
    cal = ConstraintCalibration(**settings).fit(chain, joints[train], placement[train], socket[train], fixture)
    data = socket_data(cal.start_chain_, joints[train], placement[train], socket[train], fixture)
    held = socket_errors(cal.chain_, joints[~train], placement[~train], socket[~train], fixture)["mean_mm"]
    return cal, data, held


@pytest.mark.parametrize("unit, placements", [("panda_1", slice(None)), ("panda_3", slice(0, 3))])
def test_predicted_socket_consistency_matches_placements_left_out(unit, placements):
    # Panda 1 is trained on two placements: with back-high left out the prediction made at the
    # training configurations was 0.31 mm against 0.64 held out.
    dataset = mukca(unit)
    panda, sockets, fixture = dataset.chain, dataset.observations, dataset.fixture
    for left_out in np.unique(sockets.placement)[placements]:
        cal, data, held = _left_out(panda, sockets.joints, sockets.placement, sockets.socket, fixture,
                                    sockets.placement != left_out, gains=True)
        predicted = socket_prediction(cal, data)
        assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (left_out, predicted.mean_mm, held)


def test_a_socket_prediction_from_two_similar_seatings_a_socket_is_not_optimistic():
    # Two consecutive seatings of each socket of three MUKCa Panda 3 placements: the stick
    # turned about itself by at most 36 deg between them, where the whole protocol turns it
    # by up to 180.  Reached like the training, the working sockets were predicted 0.29 mm
    # against 1.04 mm on the three placements left out; tilted and turned at random, 0.85 mm.
    dataset = mukca("panda_3")
    panda, sockets, fixture = dataset.chain, dataset.observations, dataset.fixture
    trained = np.isin(sockets.placement, np.unique(sockets.placement)[[0, 2, 3]])
    first_two = np.zeros(len(trained), dtype=bool)
    for placement in np.unique(sockets.placement[trained]):
        for socket in np.unique(sockets.socket):
            first_two[np.flatnonzero((sockets.placement == placement) & (sockets.socket == socket))[:2]] = True
    cal, data, _ = _left_out(panda, sockets.joints, sockets.placement, sockets.socket, fixture, first_two)
    held = socket_errors(cal.chain_, sockets.joints[~trained], sockets.placement[~trained], sockets.socket[~trained],
                         fixture)["mean_mm"]
    predicted = socket_prediction(cal, data)
    assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (predicted.mean_mm, held)
    tilt = max(prediction.REACH_TILT_DEG, prediction.training_tilt(cal.start_chain_.rigid, data))
    assert f"tilted up to {tilt:.0f} deg and turned" in predicted.where


@pytest.mark.parametrize("seed", [2, 4])
def test_the_socket_prediction_sees_beyond_placements_confined_to_one_region(seed):
    # A simulated KR 150-2 (typical errors, compliance and backlash) at 8 random placements of
    # the plate, trained on the two closest together and scored on the other six.  Made where
    # the training sockets are, the prediction misses most of what the model then misses
    # elsewhere (seed 2: 0.18 mm against 0.83; seeds 0 to 4: 0.22 to 0.78 of it); made at
    # sockets over the working range it is within a factor 2 (0.99 to 1.44 of it).
    chain = builtin("kr150-2").replace(tool=compose_pose([20.0, -10.0, 150.0], np.zeros(3)))
    plan = socket_plan(make_true_robot(chain, "typical", seed), PLATE_SOCKETS, 8, 8, rng=seed,
                       joint_noise_deg=0.002)
    centre = {p: plan.ball[plan.fixture_ids == p].mean(axis=0) for p in np.unique(plan.fixture_ids)}
    closest = min(combinations(centre, 2), key=lambda pair: np.linalg.norm(centre[pair[0]] - centre[pair[1]]))
    cal, data, held = _left_out(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE_SOCKETS,
                                np.isin(plan.fixture_ids, closest))
    predicted = socket_prediction(cal, data)
    assert held / FACTOR <= predicted.mean_mm <= FACTOR * held, (predicted.mean_mm, held)
    assert "uniform within the joint limits" in predicted.where
    # At sockets where the training configurations put the ball (the user's targets) it is
    # far smaller: the growth comes from where the sockets are.
    like_training = socket_prediction(cal, data, work_joints=data.joints)
    assert "given configurations" in like_training.where
    assert like_training.mean_mm < 0.6 * predicted.mean_mm
    assert predicted.p95_mm > predicted.mean_mm and predicted.nominal_mean_mm > 3 * predicted.mean_mm


def test_working_sockets_are_reached_by_several_configurations_within_the_limits(monkeypatch):
    chain = builtin("kr150-2").replace(tool=compose_pose([20.0, -10.0, 150.0], np.zeros(3)))
    plan = socket_plan(chain, PLATE_SOCKETS, 2, 6, rng=5)
    data = socket_data(chain, plan.joints, plan.fixture_ids, plan.socket_ids, PLATE_SOCKETS)
    sockets, where = working_sockets(chain, data, sockets=40, reaches=5)
    sizes = np.bincount(sockets.group)
    assert np.all(sizes >= 2) and np.all(sizes <= 5) and len(sizes) >= 30
    assert chain.within_limits(sockets.joints).all() and np.array_equal(where.joints, sockets.joints)
    balls = chain.fk_positions(sockets.joints)
    means = np.stack([np.bincount(sockets.group, weights=balls[:, c]) for c in range(3)], axis=1) / sizes[:, None]
    assert np.abs(balls - means[sockets.group]).max() < 1e-6
    # Reached in other postures, not the same configuration again.
    spread = np.array([np.ptp(sockets.joints[sockets.group == g], axis=0).max() for g in range(len(sizes))])
    assert np.median(np.degrees(spread)) > 5.0
    # Where the IK reaches no socket, the training configurations stand for the working range.
    monkeypatch.setattr(prediction, "IK_ITERATIONS", 0)
    fallback, where = working_sockets(chain, data, sockets=10, reaches=3)
    assert fallback is data and "training configurations" in where.text and len(where.joints) == len(data.joints)


def test_the_domain_of_a_model_re_registered_on_a_corner_does_not_call_the_rest_inside(kr150):
    from robocal.methods.domain import Domain

    chain, truth, work, _ = kr150
    obs = _measured(truth, uniform_joints(chain, 200, np.random.default_rng(31)), seed=32)
    fitted = make_method("kinematic").fit(chain, obs)
    fitted.record_ = fitted.record_.replace(predicted_error=expected_error(fitted, chain, obs).to_dict())
    assert fitted.domain_.check(work).inside.all()
    spread = Observations.of(q := uniform_joints(chain, 25, np.random.default_rng(33)),
                             truth.measure(q, np.random.default_rng(34)))
    assert reregister(fitted, spread).domain_.check(work).inside.mean() > 0.95
    corner = Observations.of(q := _cluster(chain, 5.0, 25, 35), truth.measure(q, np.random.default_rng(36)))
    moved = reregister(fitted, corner)
    check = moved.domain_.check(work)
    assert check.inside.mean() < 0.1 and "base and tool pinned too loosely" in check.summary
    # The model file keeps it.
    again = Domain.from_dict(moved.domain_.to_dict(), chain)
    assert np.array_equal(again.check(work).inside, check.inside)
