"""The domain of validity: flags what lies where the training data were not, and little else."""
import csv
import dataclasses
import hashlib
import json

import numpy as np
import pytest

from robocal.errors import FileFormatError, InputError
from robocal.interfaces import jobs, plots
from robocal.io.datasets import ur5_tsinghua
from robocal.io.library import load_robot
from robocal.io.model_file import load_model, save_model
from robocal.io.tables import write_measurements
from robocal.kinematics.ik import ik_all
from robocal.methods import make_method
from robocal.methods.domain import Domain, arm_branches
from robocal.simulation import make_true_robot
from robocal.simulation.joint_effects import Compliance
from robocal.spatial import matrix_to_rpy

# Joint box the simulated cell works in (deg): a KR 150-2 over a table, wrist moderately
# turned, so that a Cartesian Kriging of the error is a fair competitor.
CELL_LOW = np.radians([-60, -120, 0, -30, 30, -30])
CELL_HIGH = np.radians([60, -20, 90, 30, 90, 30])
SPLIT_JOINT = 1  # q2, the joint that gravity loads most


@pytest.fixture(scope="module")
def cell():
    """A KR 150-2 with clear non-geometric errors: the 'typical' deviations, joints ten times
    softer than the preset's and backlash of 0.01 deg; 700 configurations of the cell, the
    ones with q2 in the lower half of its range for training."""
    chain = load_robot("kr150-2")
    typical = make_true_robot(chain, "typical", seed=1)
    soft = Compliance(typical.compliance.stiffness / 10.0, typical.compliance.link_masses, typical.compliance.payload)
    truth = dataclasses.replace(typical, compliance=soft, backlash=np.where(chain.revolute, 0.01, 0.0))
    rng = np.random.default_rng(0)
    q = CELL_LOW + rng.random((700, 6)) * (CELL_HIGH - CELL_LOW)
    lower = q[:, SPLIT_JOINT] < 0.5 * (CELL_LOW[SPLIT_JOINT] + CELL_HIGH[SPLIT_JOINT])
    train, held, other = np.flatnonzero(lower)[:120], np.flatnonzero(lower)[120:], np.flatnonzero(~lower)
    return chain, truth, q, train, held, other, truth.observations(q[train], rng)


@pytest.mark.parametrize("method, settings", [("kinematic", {}), ("kriging", {"shared_theta": True})])
def test_flag_catches_the_poses_whose_error_grows_outside_the_training_half(cell, method, settings):
    chain, truth, q, train, held, other, training = cell
    fitted = make_method(method, **settings).fit(chain, training)
    # True error after compensation: where the robot goes against where the model says.
    error = {part: np.linalg.norm(truth.positions(q[idx]) - fitted.predict(q[idx]), axis=1)
             for part, idx in (("held", held), ("other", other))}
    large = error["other"] > 3.0 * error["held"].mean()
    assert large.sum() >= 10  # the case has errors worth catching
    check = fitted.domain_.check(q[other], truth.positions(q[other]))
    caught = np.mean(~check.inside[large])
    assert caught >= 0.90, (method, caught, check.summary)
    assert "q2 beyond its training range" in check.counts
    # Poses of the training half, not trained on, are hardly ever flagged.
    assert np.mean(~fitted.domain_.check(q[held]).inside) < 0.10


def test_few_false_alarms_on_a_random_half_of_real_data():
    dataset = ur5_tsinghua()
    chain, obs = dataset.chain, dataset.observations
    rates = []
    for seed in range(3):
        order = np.random.default_rng(seed).permutation(obs.n_poses)
        train, test = order[:obs.n_poses // 2], order[obs.n_poses // 2:]
        check = Domain.of(chain, obs.subset(train)).check(obs.joints[test], obs.positions[test])
        rates.append(np.mean(~check.inside))
    # Measured: 0.8 %, 0.6 %, 1.2 % of the 500 held-out poses.
    assert max(rates) < 0.02, rates


def test_another_arm_branch_is_named():
    chain = load_robot("ur5")
    rng = np.random.default_rng(2)
    # Within +-180 deg, where ik_all puts its solutions, so that they compare with q itself.
    q = np.angle(np.exp(1j * chain.random_configurations(400, rng)))
    kind, sides = arm_branches(chain, q)
    elbow = sides["elbow"]
    one_side = q[elbow == 0]
    # The same TCP poses reached with the other elbow: every joint may stay in range.
    branches, valid = ik_all(chain, chain.fk(one_side))
    own = np.argmin(np.where(valid, np.linalg.norm(branches - one_side[:, None], axis=2), np.inf), axis=1)
    bit = 1 if kind == "UR-type" else 2
    flipped = branches[np.arange(len(own)), own ^ bit]
    ok = valid[np.arange(len(own)), own ^ bit]
    domain = Domain.of(chain, dataclasses.replace(_obs(chain, one_side), path=""))
    assert domain.branches["elbow"] == (0,)
    check = domain.check(flipped[ok])
    assert np.mean(~check.inside) > 0.9
    assert "another elbow branch" in check.counts
    assert any("elbow 2: training saw elbow 1 only" in r for r in check.reasons)
    assert domain.check(one_side).inside.all()


def _obs(chain, q):
    from robocal.io.observations import Observations
    return Observations.of(q, chain.fk_positions(q))


def test_summary_and_reasons_name_the_joint_and_its_range(cell):
    chain, truth, q, train, held, other, training = cell
    domain = Domain.of(chain, training)
    beyond = q[train[:3]].copy()
    beyond[:, SPLIT_JOINT] = np.radians(-10.0)
    check = domain.check(np.vstack([q[train[3:10]], beyond]), what="targets")
    assert check.n_outside == 3 and check.inside[:7].all()
    low, high = np.degrees(domain.joint_min[1]), np.degrees(domain.joint_max[1])
    assert check.reasons[7].startswith(f"q2 = -10.0 deg beyond the training range {low:.1f}..{high:.1f} deg")
    assert check.summary.startswith("3 of 10 targets lie outside the training domain: q2 beyond its training range (3)")
    assert "," not in "".join(check.reasons)  # they go into CSV cells
    # An unreachable target (NaN) is neither judged nor counted.
    nan = domain.check(np.full((1, 6), np.nan))
    assert nan.inside.all() and nan.reasons == ("",) and nan.summary == "all 0 targets lie inside the training domain"


def test_domain_document_round_trip_and_damage(cell):
    chain, truth, q, train, held, other, training = cell
    domain = Domain.of(chain, training)
    doc = json.loads(json.dumps(domain.to_dict()))
    # File units: degrees.
    assert np.allclose(doc["joints"]["min"], np.degrees(domain.joint_min))
    again = Domain.from_dict(doc, chain)
    probe = q[other[:50]]
    a, b = domain.check(probe, truth.positions(probe)), again.check(probe, truth.positions(probe))
    assert np.array_equal(a.inside, b.inside) and a.reasons == b.reasons
    for damage in ({"joints": {"min": [0.0] * 5, "max": doc["joints"]["max"], "margin": doc["joints"]["margin"]}},
                   {"branches": {"kind": "scara", "seen": {}}}, {"neighbours": {"joints": [[1.0, 2.0]], "radius": 1}},
                   {"box": "everywhere"}):
        with pytest.raises(FileFormatError, match="domain of validity is damaged"):
            Domain.from_dict({**doc, **damage}, chain, "m.json")
    with pytest.raises(FileFormatError, match="domain of validity is damaged"):
        Domain.from_dict({k: v for k, v in doc.items() if k != "box"}, chain, "m.json")


@pytest.fixture(scope="module")
def files(cell, tmp_path_factory):
    """A measurement file of the training half, one of the other half, a targets file of both
    halves and a kinematic model file fitted to the training half."""
    chain, truth, q, train, held, other, training = cell
    folder = tmp_path_factory.mktemp("domain")
    rng = np.random.default_rng(5)
    write_measurements(folder / "train.csv", truth.measurements(q[train], rng))
    test = np.concatenate([held[:40], other[:40]])
    write_measurements(folder / "test.csv", truth.measurements(q[test], rng))
    poses = chain.fk(q[test])
    with open(folder / "targets.csv", "w", newline="") as f:
        writer = csv.writer(f)
        # The posture hints keep the inverse kinematics on the branch the poses came from.
        writer.writerow(["x", "y", "z", "rx", "ry", "rz", *(f"q{j}" for j in range(1, 7))])
        for xyz, rpy, hint in zip(poses[:, :3, 3], np.degrees(matrix_to_rpy(poses[:, :3, :3])), np.degrees(q[test])):
            writer.writerow([*xyz, *rpy, *hint])
    jobs.calibrate_job("kr150-2", folder / "train.csv", folder / "kinematic.json", method="kinematic")
    return folder


def test_model_file_keeps_the_domain(files, cell):
    chain = cell[0]
    model, fitted = jobs.load_fitted(files / "kinematic.json")
    assert model.domain is not None and fitted.domain_.n_poses == 120
    fresh = Domain.of(chain, cell[6])
    assert np.allclose(fitted.domain_.joint_min, fresh.joint_min) and fitted.domain_.branches == fresh.branches


def test_an_old_model_file_without_a_domain_still_loads(files, tmp_path):
    doc = json.loads((files / "kinematic.json").read_text())
    del doc["domain"]
    body = {k: v for k, v in doc.items() if k != "checksum"}
    doc["checksum"] = hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    old = tmp_path / "old.json"
    old.write_text(json.dumps(doc))
    model, fitted = jobs.load_fitted(old)
    assert model.domain is None and fitted.domain_ is None
    result = jobs.evaluate_job(old, files / "test.csv")
    assert result.domain_summary == jobs.NO_DOMAIN and result.outside_domain is None
    assert result.in_domain is None and "in_domain" not in result.to_dict()
    assert result.scores["n"] == 80  # the figures themselves are there
    commands = jobs.compensate_job(old, files / "targets.csv", tmp_path / "commands.csv")
    assert commands.domain_summary == jobs.NO_DOMAIN
    # Saved again, the file stays as it was: no domain is made up.
    save_model(model, tmp_path / "again.json")
    assert load_model(tmp_path / "again.json").domain is None


def test_a_domain_entry_of_the_wrong_type_is_refused(files, tmp_path):
    doc = json.loads((files / "kinematic.json").read_text())
    doc["domain"] = [1, 2]
    body = {k: v for k, v in doc.items() if k != "checksum"}
    doc["checksum"] = hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with pytest.raises(FileFormatError, match="'domain' has the wrong type"):
        jobs.load_fitted(tmp_path / "bad.json")


def test_evaluate_scores_the_poses_inside_and_outside_apart(files):
    result = jobs.evaluate_job(files / "kinematic.json", files / "test.csv")
    inside, outside = result.in_domain, result.out_of_domain
    assert inside.n + outside.n == result.scores["n"] == 80
    assert result.outside_domain == outside.n >= 36  # the second 40 lie in the other half
    assert result.domain_summary.startswith(f"{outside.n} of 80 poses lie outside the training domain")
    # Outside, the kinematic model misses by more: what the split is for.
    assert outside.mean_mm > 1.5 * inside.mean_mm
    # The parts recombine into the whole.
    total = (inside.mean_mm * inside.n + outside.mean_mm * outside.n) / 80
    assert total == pytest.approx(result.scores["mean_mm"])


def test_compensate_writes_the_domain_columns(files, cell, tmp_path):
    result = jobs.compensate_job(files / "kinematic.json", files / "targets.csv", tmp_path / "commands.csv")
    with open(tmp_path / "commands.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert "uncertainty_mm" not in rows[0]  # the kinematic method predicts none
    flags = [row["in_domain"] for row in rows]
    reachable = [row["reachable"] == "1" for row in rows]
    assert all(flag == "" for flag, ok in zip(flags, reachable) if not ok)
    assert result.outside_domain == flags.count("0")
    assert flags[40:].count("0") >= 36  # the targets of the other half
    # The flag is the domain's verdict on the joints written (the inverse kinematics may pick
    # a wrist or shoulder the training never saw, even for a target of the training half).
    _, fitted = jobs.load_fitted(files / "kinematic.json")
    q = np.radians([[float(row[f"q{j}"]) for j in range(1, 7)] for row, ok in zip(rows, reachable) if ok])
    check = fitted.domain_.check(q, [[float(row[a]) for a in "xyz"] for row, ok in zip(rows, reachable) if ok])
    assert [f for f, ok in zip(flags, reachable) if ok] == ["1" if i else "0" for i in check.inside]
    assert flags[:40].count("1") >= 20
    for row in rows:
        assert (row["domain_note"] == "") == (row["in_domain"] != "0")
    assert result.domain_summary.startswith(f"{flags.count('0')} of {sum(reachable)} targets lie outside")


def test_compensate_adds_the_error_models_uncertainty(cell, files, tmp_path):
    chain, truth, q, train, held, other, training = cell
    fitted = make_method("kriging", shared_theta=True).fit(chain, training.subset(np.arange(60)))
    save_model(fitted.to_model_file(chain, {"file": "train.csv", "n_poses": 60, "kind": "position"}),
               tmp_path / "kriging.json")
    result = jobs.compensate_job(tmp_path / "kriging.json", files / "targets.csv", tmp_path / "commands.csv")
    with open(tmp_path / "commands.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    sigma = np.array([float(r["uncertainty_mm"]) for r in rows if r["reachable"] == "1"])
    inside = np.array([r["in_domain"] == "1" for r in rows if r["reachable"] == "1"])
    assert np.all(sigma > 0)
    # The Kriging's own uncertainty grows where the domain check flags.
    assert np.median(sigma[~inside]) > np.median(sigma[inside])
    assert "predicted uncertainty (median): inside" in result.domain_summary


def test_coverage_plot_draws_every_joint(files, cell):
    chain, truth, q, train, held, other, training = cell
    _, fitted = jobs.load_fitted(files / "kinematic.json")
    arguments = fitted.domain_.coverage(q[other[:50]])
    assert (~arguments["inside"]).sum() >= 45
    fig = plots.domain_coverage(**arguments)
    assert len([ax for ax in fig.axes if ax.has_data()]) == 6


def _probe(chain, domain, q, rng):
    """Configurations on every side of ``domain``'s criteria: ``q`` itself, nudged, random
    over the joint space (their TCP positions nudged by 40 mm RMS: the training box) and
    at corners of the training ranges (far from every training configuration)."""
    every = np.vstack([q, q + rng.normal(0.0, 0.05, q.shape), chain.random_configurations(len(q), rng)])
    within = np.where(rng.random(q.shape) < 0.5, domain.joint_min, domain.joint_max)
    return (np.vstack([every, within]),
            np.vstack([chain.fk_positions(every) + rng.normal(0.0, 40.0, (len(every), 3)), chain.fk_positions(within)]))


@pytest.mark.parametrize("robot", ["kr150-2", "ur5"])
def test_one_configuration_is_judged_as_the_batch_judges_it(cell, robot):
    # A spherical wrist (the KR 150-2 of the cell) and a UR-type arm trained on one elbow.
    rng = np.random.default_rng(8)
    if robot == "ur5":
        chain = load_robot("ur5")
        q = np.angle(np.exp(1j * chain.random_configurations(400, rng)))
        q = q[arm_branches(chain, q)[1]["elbow"] == 0][:120]
        domain = Domain.of(chain, _obs(chain, q))
    else:
        chain, _, q_cell, train, _, _, training = cell
        q, domain = q_cell[train], Domain.of(chain, training)
    # 120 configurations in six dimensions leave no gap wider than the measured radius:
    # a quarter of it, so that the nearest-neighbour criterion decides some of them too.
    domain = dataclasses.replace(domain, neighbour_radius=domain.neighbour_radius / 4.0)
    joints, positions = _probe(chain, domain, q, rng)
    batch = domain.check(joints, positions)
    # Every criterion of the batch is met by some configuration.
    categories = " ".join(batch.counts)
    for what in ("beyond its training range", "branch", "beyond the training box", "far from every"):
        assert what in categories, batch.counts
    one = np.array([domain.inside_one(j, p) for j, p in zip(joints, positions)])
    np.testing.assert_array_equal(one, batch.inside)
    without_position = np.array([domain.inside_one(j) for j in joints])
    np.testing.assert_array_equal(without_position, domain.check(joints).inside)
    # check of one row gives the batch's row, reasons included.
    for k in range(0, len(joints), 7):
        row = domain.check(joints[k:k + 1], positions[k:k + 1])
        assert row.inside[0] == batch.inside[k] and row.reasons[0] == batch.reasons[k]


def test_one_configuration_with_the_re_registration_criterion_is_judged_by_the_batch(cell):
    chain, _, q, train, _, other, training = cell
    names = ("base_x", "base_rz", "tool_x")
    domain = dataclasses.replace(Domain.of(chain, training), frames=(names, np.diag([0.01, 1e-6, 0.04]), 0.2))
    joints = np.vstack([q[train[:40]], q[other[:40]]])
    batch = domain.check(joints)
    assert "base and tool pinned too loosely here" in batch.counts
    np.testing.assert_array_equal([domain.inside_one(j) for j in joints], batch.inside)


def test_an_unreachable_target_counts_as_inside_alone_as_in_a_batch(cell):
    chain, _, _, _, _, _, training = cell
    domain = Domain.of(chain, training)
    nan = np.full(chain.n_joints, np.nan)
    assert domain.inside_one(nan) and domain.check(nan[None]).inside[0]
    with pytest.raises(InputError, match="robot with 6 joints"):
        domain.inside_one(np.zeros(5))
