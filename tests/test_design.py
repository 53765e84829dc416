"""Measurement planning (robocal.planning, `robocal design`): the rank-3 updates are exact,
the optimisers never lower their criterion and are deterministic, the tour is short, designed
poses beat random ones held out, augmenting strengthens a weak parameter, and the command line
writes a file calibrate reads and refuses bad input in one line."""
import csv
import json
import warnings

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.errors import InputError
from robocal.estimation.calibration import KinematicCalibration
from robocal.interfaces.cli import app
from robocal.io.library import builtin
from robocal.io.robot_file import write_robot
from robocal.planning import box_candidates, design_poses, information_model, joint_candidates, tour, usable
from robocal.planning.criteria import InformationState, SandwichState, SpacingState, information_start, woodbury
from robocal.planning.design import spacing_points, target_weight
from robocal.planning.exchange import exchange, greedy, select_stratified, strata
from robocal.planning.information import joint_covariance, noise_of, sag_columns
from robocal.planning.tour import path_length
from robocal.estimation.constraint import ConstraintCalibration, socket_errors
from robocal.io.fixtures import Fixture
from robocal.io.observations import read_observations
from robocal.kinematics.ik import solve_ik
from robocal.planning.criteria import VarianceKernel
from robocal.planning.sockets import design_sockets, socket_candidates
from robocal.planning.workspace import WorkingVolume
from robocal.simulation import TrueRobot, make_true_robot
from robocal.simulation.sampling import socket_plan
from robocal.spatial import compose_pose, pose_to_xyz_rpy

runner = CliRunner()


@pytest.fixture(scope="module")
def ur5():
    chain = builtin("ur5")
    candidates = joint_candidates(chain, 1500, seed=3)
    return chain, candidates, information_model(chain, candidates)


def _state(info, criterion="prediction"):
    W = target_weight(info) if criterion == "prediction" else None
    return InformationState(info.blocks, information_start(info.blocks), W)


def _greedy(info, criterion, count):
    """A state with ``count`` poses chosen greedily, and the candidates still available."""
    state = _state(info, criterion)
    available = np.ones(len(info.blocks), dtype=bool)
    greedy(state, count, available)
    return state, available


def _direct(info, chosen, W):
    flat = info.blocks[chosen].reshape(-1, info.n_parameters)
    M = information_start(info.blocks) + flat.T @ flat
    return (-float(np.sum(W * np.linalg.inv(M)))) if W is not None else float(np.linalg.slogdet(M)[1])


# ----------------------------------------------------------------------------- criteria
@pytest.mark.parametrize("criterion", ["prediction", "d-optimal"])
def test_the_rank_3_updates_equal_a_direct_recomputation(ur5, criterion):
    state, available = _greedy(ur5[2], criterion, 12)
    info = ur5[2]
    chosen = list(state.chosen)
    # The Woodbury form of adding and of removing a pose is the inverse of the changed M.
    for i, sign in ((int(np.flatnonzero(available)[0]), +1), (chosen[2], -1)):
        _, _, S_inv, AP = woodbury(state.P, info.blocks[[i]], sign)
        updated = state.P - sign * AP[0].T @ S_inv[0] @ AP[0]
        direct = np.linalg.inv(state.M + sign * info.blocks[i].T @ info.blocks[i])
        np.testing.assert_allclose(updated, direct, rtol=1e-6, atol=1e-9 * np.abs(direct).max())
    assert state.score == pytest.approx(_direct(info, chosen, state.W), rel=1e-9)
    # Each candidate's gain is the change of the criterion when it is added ...
    gains = state.gains_of_adding(available)
    for i in np.flatnonzero(available)[:: 97]:
        assert gains[i] == pytest.approx(_direct(info, chosen + [i], state.W) - state.score, rel=1e-6, abs=1e-12)
    # ... and of each chosen pose when it is removed.
    losses = state.gains_of_removing()
    for k, j in enumerate(chosen):
        rest = [c for c in chosen if c != j]
        assert losses[k] == pytest.approx(_direct(info, rest, state.W) - state.score, rel=1e-6, abs=1e-12)
    state.remove(chosen[3])
    assert state.score == pytest.approx(_direct(info, state.chosen, state.W), rel=1e-9)


def test_the_space_filling_sums_are_kept_exactly(ur5):
    chain, candidates, _ = ur5
    points, _ = spacing_points(chain, candidates)
    state = SpacingState(points)
    available = np.ones(len(points), dtype=bool)
    greedy(state, 10, available)
    state.remove(state.chosen[4])
    chosen = points[state.chosen]
    d2 = np.sum((chosen[:, None] - chosen[None]) ** 2, axis=2)
    pairs = d2[np.triu_indices(len(chosen), 1)]
    assert -state.score == pytest.approx(np.sum(pairs ** -5.0), rel=1e-9)


@pytest.mark.parametrize("criterion", ["prediction", "d-optimal"])
def test_the_exchange_never_lowers_the_criterion(ur5, criterion):
    state, available = _greedy(ur5[2], criterion, 10)
    before = state.score
    exchange(state, available, max_steps=0)
    assert state.score == before
    exchange(state, available)
    assert state.score >= before
    assert len(set(state.chosen)) == 10 and not available[state.chosen].any()


def test_the_stratified_exchange_keeps_one_pose_per_stratum_and_never_lowers_the_criterion(ur5):
    chain, candidates, info = ur5
    points = spacing_points(chain, candidates)[0]
    labels = strata(points, 12, seed=0)
    start, _ = select_stratified(_state(info), 12, np.ones(len(candidates), bool), labels, points, refine=False)
    refined_state = _state(info)
    chosen, steps = select_stratified(refined_state, 12, np.ones(len(candidates), bool), labels, points)
    assert sorted(labels[chosen]) == sorted(set(labels[chosen])) and len(chosen) == 12
    assert refined_state.score >= _direct(info, list(start), refined_state.W)
    assert steps >= 0


def test_a_design_is_deterministic_for_a_seed(ur5):
    chain, candidates, _ = ur5
    first = design_poses(chain, 12, candidates, seed=5)
    again = design_poses(chain, 12, candidates, seed=5)
    np.testing.assert_array_equal(first.indices, again.indices)
    np.testing.assert_array_equal(joint_candidates(chain, 50, seed=2), joint_candidates(chain, 50, seed=2))
    assert not np.array_equal(joint_candidates(chain, 50, seed=2), joint_candidates(chain, 50, seed=3))


# ----------------------------------------------------------------------------- joint noise
def _sandwich_direct(info, chosen, W, C, bias=None, r=None):
    """Minus the sandwich criterion of ``chosen``, from scratch: trace(W P B P) (+ the shift's)."""
    start = information_start(info.blocks)
    A = info.blocks[chosen]
    flat = A.reshape(-1, info.n_parameters)
    P = np.linalg.inv(start + flat.T @ flat)
    B = start + np.einsum("kip,kij,kjq->pq", A, C[chosen], A)
    value = np.sum(W * (P @ B @ P))
    if bias is not None:
        # One known error (N, 3), or the expectation over k shapes of unit-variance amplitudes.
        shapes = bias if bias.ndim == 3 else bias[:, :, None]
        for m in range(shapes.shape[2]):
            x = P @ np.einsum("kip,ki->p", A, shapes[chosen, :, m])
            value += x @ W @ x - 2 * x @ np.reshape(r, (info.n_parameters, -1))[:, m]
    return -float(value)


@pytest.mark.parametrize("shapes", [None, 1, 3])
def test_the_sandwich_updates_equal_a_direct_recomputation(ur5, shapes):
    chain, candidates, info = ur5
    W = target_weight(info)
    C = joint_covariance(chain, candidates, info.sigma, 0.01)
    rng = np.random.default_rng(0)
    with_bias = shapes is not None
    size = (len(candidates), 3) if shapes == 1 else (len(candidates), 3, shapes or 1)
    bias = rng.normal(scale=0.05, size=size) if with_bias else None
    r = rng.normal(scale=1e-3, size=(info.n_parameters,) + size[2:]) if with_bias else None
    state = SandwichState(info.blocks, information_start(info.blocks), W, C, bias=bias, r=r)
    available = np.ones(len(candidates), dtype=bool)
    greedy(state, 14, available)
    chosen = list(state.chosen)
    assert state.score == pytest.approx(_sandwich_direct(info, chosen, W, C, bias, r), rel=1e-8)
    gains = state.gains_of_adding(available)
    for i in np.flatnonzero(available)[::131]:
        assert gains[i] == pytest.approx(_sandwich_direct(info, chosen + [i], W, C, bias, r) - state.score,
                                         rel=1e-5, abs=1e-10 * abs(state.score))
    losses = state.gains_of_removing()
    for k, i in enumerate(chosen[::4]):
        assert losses[4 * k] == pytest.approx(
            _sandwich_direct(info, [c for c in chosen if c != i], W, C, bias, r) - state.score, rel=1e-5)
    before = state.score
    exchange(state, available)
    assert state.score >= before and len(set(state.chosen)) == 14


def test_without_joint_noise_the_sandwich_is_the_prediction_criterion(ur5):
    chain, candidates, info = ur5
    W = target_weight(info)
    plain = InformationState(info.blocks, information_start(info.blocks), W)
    sandwich = SandwichState(info.blocks, information_start(info.blocks), W,
                             np.broadcast_to(np.eye(3), (len(candidates), 3, 3)))
    for i in (3, 400, 900, 1200, 77, 5, 1499, 640, 12, 300):
        plain.add(i)
        sandwich.add(i)
    available = np.ones(len(candidates), dtype=bool)
    available[plain.chosen] = False
    assert sandwich.score == pytest.approx(plain.score, rel=1e-9)
    np.testing.assert_allclose(sandwich.gains_of_adding(available)[available],
                               plain.gains_of_adding(available)[available],
                               rtol=1e-6, atol=1e-9 * abs(plain.score))


def test_the_joint_noise_grows_with_the_reach_and_is_refused_below_zero():
    chain = builtin("kr150-2")
    q = joint_candidates(chain, 500, seed=1)
    reach = np.linalg.norm(chain.rigid.replace(base=np.eye(4)).fk_positions(q), axis=1)
    stretched, folded = q[np.argmax(reach)], q[np.argmin(reach)]
    assert reach.max() > 2 * reach.min()
    sigma = np.full(2, 0.02)
    assert joint_covariance(chain, np.array([stretched, folded]), sigma, 0.0) is None
    C = joint_covariance(chain, np.array([stretched, folded]), sigma, 0.005)
    # Relative to the tracker's 0.02 mm: 0.005 deg at a 2-3 m arm is ten times more.
    assert np.trace(C[0]) > np.trace(C[1]) > 3.0 and np.trace(C[0]) > 100
    np.testing.assert_allclose(C, np.swapaxes(C, 1, 2))
    with pytest.raises(InputError, match="joint noise must be a standard deviation >= 0 deg"):
        joint_covariance(chain, np.array([stretched]), sigma[:1], -0.001)


def test_the_sag_bends_the_most_loaded_joint_by_its_size():
    chain = builtin("kr150-2")
    q = joint_candidates(chain, 400, seed=2)
    assert sag_columns(chain, q, 0.0) is None
    columns = sag_columns(chain, q, 0.02)
    assert columns.shape[:2] == (400, 3) and 2 <= columns.shape[2] <= chain.n_joints
    # The largest displacement is the most loaded joint bending 0.02 deg at its largest torque:
    # about 0.02 deg times the reach (2-3 m: 0.7-1.2 mm), never more than that joint's lever.
    jac = chain.rigid.jacobian(q)[:, :3, :]
    lever = np.linalg.norm(jac, axis=1).max()
    largest = np.linalg.norm(columns, axis=1).max()
    assert 0.3 < largest < np.radians(0.02) * lever * (1 + 1e-9)
    np.testing.assert_allclose(sag_columns(chain, q[:50], 0.02, reference=q), columns[:50])
    with pytest.raises(InputError, match="the sag must be an angle >= 0 deg"):
        sag_columns(chain, q, -0.01)


def test_the_sag_counts_for_parameters_without_compliance_only():
    """With "full" the sag's shapes enter the criterion and the prediction (what the geometry
    cannot absorb of it stays at the targets); with "full+compliance" the sag is modelled and
    the design is the one without it."""
    chain = builtin("kr150-2")
    candidates = joint_candidates(chain, 2000, seed=0)
    plain = design_poses(chain, 20, candidates)
    sagging = design_poses(chain, 20, candidates, sag_deg=0.05)
    assert sagging.sag_deg == 0.05 and sagging.to_dict()["sag_deg"] == 0.05
    assert sagging.model_rms > plain.model_rms and sagging.model_rms < sagging.random_model_rms
    assert not np.array_equal(np.sort(sagging.indices), np.sort(plain.indices))
    compliant = design_poses(chain, 20, candidates, parameters="full+compliance")
    ignored = design_poses(chain, 20, candidates, parameters="full+compliance", sag_deg=0.05)
    np.testing.assert_array_equal(compliant.indices, ignored.indices)
    assert ignored.sag_deg == 0.0 and ignored.model_rms == compliant.model_rms
    # The predicted error of the sagging design is the criterion recomputed from scratch.
    info = information_model(chain, candidates)
    shapes = sag_columns(chain, candidates, 0.05)
    W = target_weight(info)
    rows = info.blocks * info.sigma[:, None, None]
    r = np.einsum("tip,tim->pm", rows, shapes) / len(rows)
    floor = np.mean(np.sum(shapes ** 2, axis=(1, 2)))
    ones = np.broadcast_to(np.eye(3), (len(candidates), 3, 3))
    direct = -_sandwich_direct(info, list(sagging.indices), W, ones, shapes / 0.02, r) + floor
    assert sagging.model_rms == pytest.approx(np.sqrt(direct), rel=1e-6)


def test_the_joint_noise_design_predicts_the_held_out_error_that_backlash_gives():
    """A simulated UR5 with 0.01 deg backlash (much more than its 0.02 mm tracker noise at the
    TCP), 20 designed poses measured in a random order: the design with that joint noise
    predicts the held-out RMS within 30 %, the design that knows only the tracker's noise
    predicts less than half of it; the joint-noise design's covariance is the sandwich."""
    warnings.simplefilter("ignore")
    chain = builtin("ur5")
    typical = make_true_robot(chain, "typical", seed=4)
    truth = TrueRobot(nominal=chain, deviations=typical.deviations, backlash=np.full(6, 0.01), noise=0.02)
    candidates = joint_candidates(chain, 2000, seed=0)
    test_q = chain.random_configurations(400, np.random.default_rng(9))
    test_p = truth.measure(test_q, np.random.default_rng(10))
    plain = design_poses(chain, 20, candidates, order="random")
    noisy = design_poses(chain, 20, candidates, order="random", joint_noise_deg=0.01)
    measured = []
    for s in range(4):
        q = noisy.joints[np.random.default_rng(s).permutation(20)]
        fit = KinematicCalibration("full").fit(chain, q, truth.measure(q, np.random.default_rng(s)))
        measured.append(np.sqrt(np.mean(np.sum((fit.predict(test_q) - test_p) ** 2, axis=1))))
    measured = float(np.mean(measured))
    assert abs(noisy.held_out_rms / measured - 1) < 0.3, (noisy.held_out_rms, measured)
    assert plain.held_out_rms < 0.5 * measured
    info = information_model(chain, candidates)
    C = joint_covariance(chain, candidates, info.sigma, 0.01)
    direct = np.sqrt(-_sandwich_direct(info, list(noisy.indices), target_weight(info), C))
    assert noisy.model_rms == pytest.approx(direct, rel=1e-6)
    assert noisy.joint_noise_deg == 0.01 and noisy.to_dict()["joint_noise_deg"] == 0.01
    assert noisy.model_rms < noisy.random_model_rms


# ----------------------------------------------------------------------------- tour
def test_the_tour_is_no_longer_than_the_order_given_and_visits_every_pose_once():
    rng = np.random.default_rng(0)
    for count in (3, 8, 40):
        q = rng.uniform(-3, 3, (count, 6))
        order = tour(q)
        assert sorted(order) == list(range(count))
        assert path_length(q, order) <= path_length(q) + 1e-12
        start = rng.uniform(-3, 3, 6)
        assert path_length(q, tour(q, start), start) <= path_length(q, start=start) + 1e-12
    q = rng.uniform(-3, 3, (40, 6))
    assert path_length(q, tour(q)) < 0.6 * path_length(q)


# ----------------------------------------------------------------------------- candidates
def test_candidates_keep_the_margins_and_a_box_is_reached_with_its_orientation():
    chain = builtin("kr150-2")
    q = joint_candidates(chain, 400, seed=1, margin_deg=5)
    assert np.all(q >= chain.lower + np.radians(5) - 1e-12) and np.all(q <= chain.upper - np.radians(5) + 1e-12)
    assert usable(chain, q).all()
    posture = np.radians([0.0, -90.0, 90.0, 0.0, 90.0, 0.0])
    down = chain.fk(posture)[:3, :3]
    qb = box_candidates(chain, 300, (1200, -800, 400), (2200, 800, 1400), down, seed=0, hint=posture)
    poses = chain.fk(qb)
    assert len(qb) > 250
    assert np.all((poses[:, :3, 3] >= [1200 - 1e-6, -800 - 1e-6, 400 - 1e-6])
                  & (poses[:, :3, 3] <= [2200 + 1e-6, 800 + 1e-6, 1400 + 1e-6]))
    np.testing.assert_allclose(poses[:, :3, :3], np.broadcast_to(down, poses[:, :3, :3].shape), atol=1e-7)
    with pytest.raises(InputError, match="reachable"):
        box_candidates(chain, 100, (9000, 0, 0), (9500, 100, 100), down, seed=0)


def test_the_tracker_noise_grows_with_distance():
    chain = builtin("ur5")
    q = joint_candidates(chain, 100, seed=0)
    sigma = noise_of(chain, q, 0.02, tracker=(2000.0, 0.0, 0.0))
    distance = np.linalg.norm(chain.fk_positions(q) - [2000.0, 0.0, 0.0], axis=1)
    assert np.all(sigma > 0.02) and np.corrcoef(sigma, distance)[0, 1] > 0.99


# ----------------------------------------------------------------------------- held out
def _held_out(chain, truth, q, test_q, test_p, seed):
    fit = KinematicCalibration("full").fit(chain, q, truth.measure(q, np.random.default_rng(seed)))
    return float(np.mean(np.linalg.norm(fit.predict(test_q) - test_p, axis=1)))


def test_designed_poses_beat_random_ones_held_out():
    """UR5 with typical errors, 2,000 candidates: 14 designed poses against 10 random sets of
    14 (both measured with noise, compliance and backlash), on 300 held-out poses."""
    warnings.simplefilter("ignore")
    chain = builtin("ur5")
    truth = make_true_robot(chain, "typical", seed=4)
    candidates = joint_candidates(chain, 2000, seed=0)
    test_q = chain.random_configurations(300, np.random.default_rng(9))
    test_p = truth.measure(test_q, np.random.default_rng(10))
    design = design_poses(chain, 14, candidates)
    designed = np.mean([_held_out(chain, truth, design.joints, test_q, test_p, s) for s in range(3)])
    rng = np.random.default_rng(11)
    random = []
    for s in range(10):
        try:
            random.append(_held_out(chain, truth, candidates[rng.choice(len(candidates), 14, replace=False)],
                                    test_q, test_p, s))
        except InputError:
            pass
    assert designed < 0.85 * np.mean(random), (designed, np.mean(random))
    assert design.model_rms < design.random_model_rms


def test_augmenting_strengthens_the_weak_parameter():
    """30 poses measured with joints 2 and 3 barely moving leave d2 weak; 10 designed poses
    to add shrink its standard error, and the predicted TCP error they aim at, more than 10
    random ones (the poses measured before counted once, as in the random draws)."""
    chain = builtin("kr150-2")
    candidates = joint_candidates(chain, 1500, seed=0)
    middle = (chain.lower + chain.upper) / 2
    narrow = np.abs(candidates[:, 1:3] - middle[1:3]).max(axis=1) < np.radians(15)
    measured = candidates[narrow][:30]
    alone = design_poses(chain, 1, candidates, existing=measured)
    added = design_poses(chain, 10, candidates, existing=measured)
    d2 = list(added.names).index("d2")
    info = information_model(chain, candidates)
    rng = np.random.default_rng(0)
    blocks = info.rows_of(measured, np.full(len(measured), 0.02)).reshape(-1, info.n_parameters)
    random_std = []
    for _ in range(10):
        extra = info.blocks[rng.choice(len(candidates), 10, replace=False)].reshape(-1, info.n_parameters)
        flat = np.vstack([blocks, extra])
        cov = np.linalg.inv(information_start(info.blocks) + flat.T @ flat)
        random_std.append(np.sqrt(cov[d2, d2]) / info.scale[d2])
    assert added.std_errors[d2] < 0.95 * np.median(random_std) < alone.std_errors[d2]
    assert added.n_existing == 30 and added.model_rms < alone.model_rms
    assert added.model_rms < 0.8 * added.random_model_rms
    # The summary's covariance is that of the measured and the added poses, each once.
    flat = np.vstack([blocks, info.rows_of(added.joints, np.full(10, 0.02)).reshape(-1, info.n_parameters)])
    cov = np.linalg.inv(information_start(info.blocks) + flat.T @ flat)
    assert added.std_errors[d2] == pytest.approx(np.sqrt(cov[d2, d2]) / info.scale[d2], rel=1e-6)


def test_too_few_poses_for_the_parameters_are_refused(ur5):
    chain, candidates, _ = ur5
    with pytest.raises(InputError, match="ask for at least 9 poses"):
        design_poses(chain, 5, candidates)
    with pytest.raises(InputError, match="only 1500 candidates"):
        design_poses(chain, 2000, candidates)


# ----------------------------------------------------------------------------- command line
def _rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_the_poses_file_is_the_joint_part_of_a_measurement_file(tmp_path):
    out = tmp_path / "poses.csv"
    result = runner.invoke(app, ["design", "ur5", "--n", "15", "--pool", "800", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "predicted standard errors" in result.output
    rows = _rows(out)
    assert len(rows) == 15 and list(rows[0])[:7] == ["pose", "q1", "q2", "q3", "q4", "q5", "q6"]
    # Measure them (nominal positions plus a little noise) and calibrate.
    chain = builtin("ur5")
    q = chain.joints_from_file([[float(r[f"q{k}"]) for k in range(1, 7)] for r in rows])
    p = make_true_robot(chain, "typical", seed=1).measure(q, np.random.default_rng(0))
    meas = tmp_path / "meas.csv"
    with open(meas, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(list(rows[0]) + ["x", "y", "z"])
        for r, xyz in zip(rows, p):
            writer.writerow(list(r.values()) + [f"{v:.4f}" for v in xyz])
    calibrated = runner.invoke(app, ["calibrate", "ur5", str(meas), "--out", str(tmp_path / "m.json")])
    assert calibrated.exit_code == 0, calibrated.output
    # The same seed writes the same file; --existing complements it.
    again = tmp_path / "again.csv"
    assert runner.invoke(app, ["design", "ur5", "--n", "15", "--pool", "800", "--out", str(again)]).exit_code == 0
    assert again.read_text() == out.read_text()
    shuffled = tmp_path / "shuffled.csv"
    assert runner.invoke(app, ["design", "ur5", "--n", "15", "--pool", "800", "--order", "random", "--out",
                               str(shuffled)]).exit_code == 0
    key = [tuple(r[f"q{k}"] for k in range(1, 7)) for r in _rows(shuffled)]
    assert sorted(key) == sorted(tuple(r[f"q{k}"] for k in range(1, 7)) for r in rows) and key != [
        tuple(r[f"q{k}"] for k in range(1, 7)) for r in rows]
    more = runner.invoke(app, ["design", "ur5", "--n", "5", "--pool", "800", "--existing", str(meas), "--json",
                               "--out", str(tmp_path / "next.csv")])
    assert more.exit_code == 0, more.output
    assert '"existing": 15' in more.output and "residual of a calibration" in more.output


def _one_line(result, fragment):
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2, result.output
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], result.output


def _candidates_file(path, rows, header=("q1", "q2", "q3", "q4", "q5", "q6")):
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(rows)
    return str(path)


@pytest.mark.parametrize("case, fragment", [
    ("more", "--n 50 poses asked for but there are 40 candidates"),
    ("few", "ask for at least 9 poses"),
    ("box", "are reachable by robot"),
    ("missing", "lacks column q6"),
    ("nan", "row 4, column 'q2': 'nan' is not a finite number"),  # as a measurement file says it
    ("radians", "they look like radians"),
    ("metres", "looks like metres"),
    ("suffix", "names a JSON file: name it"),
    ("pool", "--pool must be a whole number >= 10"),
])
def test_refusals_are_one_line(tmp_path, case, fragment):
    chain = builtin("ur5")
    # Candidates a user could give: inside the default working volume (above the mounting plane).
    degrees = chain.joints_to_file(joint_candidates(chain, 40, seed=0, volume=WorkingVolume()))
    out = str(tmp_path / "p.csv")
    args = {
        "more": ["--n", "50", "--candidates", _candidates_file(tmp_path / "more.csv", degrees)],
        "few": ["--n", "5", "--pool", "200"],
        "box": ["--n", "10", "--pool", "200", "--box", "5000,5100,0,100,0,100"],
        "missing": ["--n", "10", "--candidates", _candidates_file(tmp_path / "missing.csv", degrees[:, :5],
                                                                   ("q1", "q2", "q3", "q4", "q5"))],
        "nan": ["--n", "10", "--candidates", _candidates_file(tmp_path / "nan.csv", [*degrees[:2],
                                                                                  [1, "nan", 3, 4, 5, 6]])],
        "radians": ["--n", "10", "--candidates", _candidates_file(tmp_path / "radians.csv", np.radians(degrees))],
        "metres": ["--n", "10", "--pool", "200"],
        "suffix": ["--n", "10", "--out", str(tmp_path / "p.json")],
        "pool": ["--n", "10", "--pool", "5"],
    }[case]
    robot = "ur5"
    if case == "metres":
        robot = str(tmp_path / "ur5_m.toml")
        write_robot(chain.replace(a=chain.a / 1000, d=chain.d / 1000), robot)
    if "--out" not in args:
        args = args + ["--out", out]
    _one_line(runner.invoke(app, ["design", robot, *args]), fragment)
    assert not (tmp_path / "p.csv").exists()


def test_the_joint_noise_and_the_sag_on_the_command_line(tmp_path):
    out = str(tmp_path / "p.csv")
    plain = runner.invoke(app, ["design", "ur5", "--n", "12", "--pool", "600", "--out", out, "--json"])
    noisy = runner.invoke(app, ["design", "ur5", "--n", "12", "--pool", "600", "--out", out, "--json",
                                "--joint-noise", "0.01", "--sag", "0.02"])
    assert plain.exit_code == 0 and noisy.exit_code == 0, noisy.output
    plain, noisy = json.loads(plain.output), json.loads(noisy.output)
    assert plain["joint_noise_deg"] == 0 and noisy["joint_noise_deg"] == 0.01
    assert plain["sag_deg"] == 0 and noisy["sag_deg"] == 0.02
    # 0.01 deg at a UR5's joints is several times its 0.02 mm tracker noise at the TCP.
    assert noisy["predicted"]["held_out_rms_mm"] > 2 * plain["predicted"]["held_out_rms_mm"]
    _one_line(runner.invoke(app, ["design", "ur5", "--n", "12", "--out", out, "--joint-noise", "-0.1"]),
              "--joint-noise must be a number >= 0")
    _one_line(runner.invoke(app, ["design", "panda", "--fixture", str(tmp_path / "plate.toml"), "--n", "12",
                                  "--joint-noise", "0.01", "--out", out]), "do not apply to a ball-in-socket design")
    _one_line(runner.invoke(app, ["design", "ur5", "--n", "12", "--out", out, "--sag", "-1"]),
              "--sag must be a number >= 0")


# ----------------------------------------------------------------- largest predictive variance
def _largest_variance(points, kernel, chosen):
    """Largest predictive variance over the candidates given ``chosen``, computed directly
    (a dense GP posterior), not through the state's updates."""
    def corr(a, b):
        return np.exp(-(((a[:, None, :] - b[None]) ** 2) @ kernel.theta))
    K = corr(points[chosen], points[chosen]) + kernel.nugget * np.eye(len(chosen))
    cross = corr(points, points[chosen])
    return float(np.max(1.0 - np.einsum("ij,ji->i", cross, np.linalg.solve(K, cross.T))))


def test_the_variance_criterion_leaves_less_variance_than_random_or_space_filling_poses(ur5):
    chain, candidates, _ = ur5
    kernel = VarianceKernel.default(chain, candidates)
    points = kernel.points(chain, candidates)
    design = design_poses(chain, 30, candidates, criterion="variance")
    own = _largest_variance(points, kernel, design.indices)
    # The rank-one updates are exact: the reported maximum is the dense posterior's.
    assert own == pytest.approx(design.max_variance, rel=1e-6)
    spread = _largest_variance(points, kernel, design_poses(chain, 30, candidates, criterion="space-filling").indices)
    rng = np.random.default_rng(0)
    random = [_largest_variance(points, kernel, rng.choice(len(candidates), 30, replace=False)) for _ in range(10)]
    assert own < 0.9 * min(random), (own, random)
    assert own < 0.9 * spread, (own, spread)
    # Poses measured before are conditioned on: the design fills in elsewhere.
    before = candidates[design.indices[:10]]
    more = design_poses(chain, 20, candidates, criterion="variance", existing=before)
    assert not set(more.indices) & set(design.indices[:10])
    both = np.concatenate([design.indices[:10], more.indices])
    assert _largest_variance(points, kernel, both) == pytest.approx(more.max_variance, rel=1e-6)


def test_the_variance_criterion_on_the_command_line_takes_its_prior_from_measured_poses(tmp_path):
    chain = builtin("ur5")
    q = joint_candidates(chain, 60, seed=5)
    p = make_true_robot(chain, "typical", seed=1).measure(q, np.random.default_rng(0))
    meas = tmp_path / "meas.csv"
    with open(meas, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z"])
        writer.writerows(np.hstack([chain.joints_to_file(q), p]).round(5))
    fixed = runner.invoke(app, ["design", "ur5", "--n", "10", "--pool", "500", "--criterion", "variance", "--json",
                                "--out", str(tmp_path / "a.csv")])
    assert fixed.exit_code == 0, fixed.output
    assert '"prior": "fixed' in fixed.output
    fitted = runner.invoke(app, ["design", "ur5", "--n", "10", "--pool", "500", "--criterion", "variance",
                                 "--existing", str(meas), "--json", "--out", str(tmp_path / "b.csv")])
    assert fitted.exit_code == 0, fitted.output
    assert "sincos Kriging of the residual" in fitted.output


# ----------------------------------------------------------------- ball in sockets
PLATE = Fixture("plate", {"A": [0.0, 0.0, 0.0], "B": [150.0, 0.0, 0.0], "C": [0.0, 120.0, 0.0]})


def _panda():
    return builtin("panda").replace(tool=compose_pose([0.0, 0.0, 133.4], np.zeros(3)))


def _seated(truth, candidates, index, draw):
    """Joint readings of the true robot with its ball in the sockets the designed rows name,
    in the orientation the design planned, with 0.005 deg reading noise."""
    sockets = np.array([PLATE.sockets[s] for s in PLATE.ids])
    poses = candidates.poses[candidates.placement[index]]
    target = truth.nominal.fk(candidates.joints[index])
    target[:, :3, 3] = np.einsum("kij,kj->ki", poses[:, :3, :3], sockets[candidates.socket[index]]) + poses[:, :3, 3]
    seated = solve_ik(truth.actual, target, candidates.joints[index])
    assert seated.success.all()
    return seated.q + np.random.default_rng(draw).normal(size=seated.q.shape) * np.radians(0.005)


def test_designed_placements_and_configurations_beat_random_ones_held_out():
    chain = _panda()
    deviations = make_true_robot(chain, "typical", 6).deviations
    truth = TrueRobot(nominal=chain, deviations={k: v for k, v in deviations.items() if not k.startswith("base")})
    candidates = socket_candidates(chain, PLATE, socket_plan(chain, PLATE, 8, 1, rng=20).placements)
    test = socket_plan(truth, PLATE, 3, 8, rng=4)  # other placements, exact readings

    def held_out(index, draw):
        fit = ConstraintCalibration().fit(chain, _seated(truth, candidates, index, draw),
                                          np.array(candidates.names)[candidates.placement[index]],
                                          np.array(PLATE.ids)[candidates.socket[index]], PLATE)
        return socket_errors(fit.chain_, test.joints, test.fixture_ids, test.socket_ids, PLATE)["mean_mm"]

    design = design_sockets(chain, candidates, 4, 3)
    assert len(design.poses) == 3 and len(design.joints) == 3 * 3 * 4
    assert design.model_rms < design.random_model_rms
    designed = np.mean([held_out(design.indices, draw) for draw in range(2)])
    rng = np.random.default_rng(1)
    random = []
    for draw in range(4):
        places = rng.choice(len(candidates.poses), 3, replace=False)
        random.append(held_out(np.concatenate([rng.choice(np.flatnonzero(candidates.group == k * 3 + s), 4,
                                                          replace=False) for k in places for s in range(3)]), draw))
    # Measured here: designed 0.030 mm (two noise draws), random 0.032 to 0.058 (mean 0.046 over these four).
    assert designed < 0.85 * np.mean(random), (designed, random)


def test_the_socket_plan_is_a_constraint_measurement_file(tmp_path):
    (tmp_path / "plate.toml").write_text('name = "plate"\n[sockets]\nA = [0.0, 0.0, 0.0]\nB = [150.0, 0.0, 0.0]\n'
                                         'C = [0.0, 120.0, 0.0]\n')
    chain = _panda()
    poses = socket_plan(chain, PLATE, 4, 1, rng=20).placements
    with open(tmp_path / "where.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["fixture", "x", "y", "z", "rx", "ry", "rz"])
        for k, pose in enumerate(poses):
            xyz, rpy = pose_to_xyz_rpy(pose)
            writer.writerow([f"table{k + 1}", *xyz.round(4), *np.degrees(rpy).round(5)])
    out = tmp_path / "plan.csv"
    args = ["design", "panda", "--tool", "0,0,133.4", "--fixture", str(tmp_path / "plate.toml"), "--placements",
            str(tmp_path / "where.csv"), "--per-socket", "3", "--out", str(out)]
    result = runner.invoke(app, args + ["--n", "18"])
    assert result.exit_code == 0, result.output
    rows = _rows(out)
    assert len(rows) == 18 and {"fixture", "socket", "q1", "q7"} <= set(rows[0])
    assert len({r["fixture"] for r in rows}) == 2 and {r["socket"] for r in rows} == {"A", "B", "C"}
    observations = read_observations(str(out), chain)
    # The nominal robot seats its ball where the plan says: every socket's centres coincide.
    errors = socket_errors(chain, observations.joints, observations.placement, observations.socket, PLATE)
    assert errors["max_mm"] < 1e-3 and errors["socket_distance"]["max_mm"] < 1e-3
    _one_line(runner.invoke(app, args + ["--n", "20"]), "--n 20 is not a whole number of placements")
    _one_line(runner.invoke(app, args[:-2] + ["--n", "18", "--criterion", "variance", "--out", str(out)]),
              "a ball-in-socket design takes prediction or d-optimal")
    _one_line(runner.invoke(app, ["design", "panda", "--placements", str(tmp_path / "where.csv"), "--n", "18",
                                  "--out", str(out)]), "give --fixture too")
