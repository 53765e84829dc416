"""The 95 % bound on the position error (robocal.methods.bound): it covers about 95 % of
held-out poses without being huge, grows outside the training domain, is kept in the model
file, and appears in evaluate --per-pose / --json, compensate and serve.  Real-data figures:
bench/bound_coverage.py."""
import csv
import hashlib
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.errors import FileFormatError, InputError
from robocal.interfaces.cli import app
from robocal.io.csv_writing import PER_POSE_COLUMNS
from robocal.io.library import load_robot
from robocal.io.model_file import _canonical
from robocal.io.tables import write_measurements
from robocal.methods import make_method
from robocal.methods.bound import (
    NO_BOUND,
    PositionBound,
    bound95,
    conformal_quantile,
    fit_bound,
    joint_distance,
)
from robocal.simulation import make_true_robot
from robocal.simulation.sampling import uniform_joints
from robocal.spatial import matrix_to_rpy
from simulated_models import ur5_auto_model

runner = CliRunner()


@pytest.fixture(scope="module")
def ur5():
    """A UR5 with the typical errors: 150 training poses over the joint space, 400 held out."""
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=3)
    rng = np.random.default_rng(3)
    q = uniform_joints(chain, 550, rng)
    return chain, truth.observations(q[:150], rng), truth.observations(q[150:], rng)


def test_conformal_quantile_is_the_rank_that_covers_95_percent():
    assert conformal_quantile(np.arange(1.0, 100.0)) == 95.0  # ceil(100 * 0.95) = 95th of 99
    assert conformal_quantile(np.arange(1.0, 20.0)) == 19.0  # ceil(20 * 0.95) = 19th of 19
    # Too few scores for the rank: the largest, widened by (m + 1) / m.
    assert conformal_quantile([1.0, 2.0, 4.0]) == pytest.approx(4.0 * 4 / 3)
    assert np.isnan(conformal_quantile([]))


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("method", ["kinematic", "kriging"])
def test_the_bound_covers_about_95_percent_of_held_out_poses_without_being_huge(ur5, method):
    chain, train, held = ur5
    fitted = make_method(method).fit(chain, train)
    bound = fit_bound(fitted, chain, train)
    error = np.linalg.norm(held.positions - fitted.predict(held.joints), axis=1)
    limit = bound.predict(held.joints)
    coverage = np.mean(error <= limit)
    assert 0.88 <= coverage <= 0.99, (method, coverage, bound.calibration)
    assert np.median(limit) <= 3.0 * np.median(error)
    # The model's own σ alone (what compensate wrote before) covers far less for Kriging.
    if method == "kriging":
        assert np.mean(error <= fitted.uncertainty(held.joints)) < 0.6


@pytest.mark.filterwarnings("ignore")
def test_the_bound_outside_the_domain_grows_with_what_the_model_did_not_model():
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=5)
    rng = np.random.default_rng(5)
    q = uniform_joints(chain, 400, rng)
    lower = q[:, 1] < np.median(q[:, 1])
    train = truth.observations(q[lower][:120], rng)
    fitted = make_method("kinematic").fit(chain, train)
    bound = fit_bound(fitted, chain, train)
    # Outside: what the calibration left out (gains, compliances), not the joint-space distance.
    assert bound.outside is not None and bound.growth_per_rad is None and bound.sigma_growth_per_rad is None
    assert bound.calibration["outside"]["poses"] > 0
    assert {"gain2", "compliance2"} <= set(bound.outside.omitted.names)
    other = truth.observations(q[~lower], rng)
    out = ~bound.inside_mask(other.joints)
    assert out.sum() > 50
    # What the training poses pinned down is small there, and grows where they were not.
    assert np.median(bound.omitted_sigma(other.joints[out])) > 1.5 * np.median(bound.omitted_sigma(train.joints))
    limit = bound.predict(other.joints)
    # Never below what the same configuration would get inside the domain.
    assert np.all(limit[out] >= bound._own(other.joints[out], inside=True) * (1 - 1e-12))
    assert np.median(limit[out]) > np.median(bound.predict(train.joints))
    # Held out on the other half of q2: covered, and not by being huge.
    error = np.linalg.norm(other.positions - fitted.predict(other.joints), axis=1)
    assert np.mean(error[out] <= limit[out]) >= 0.85
    assert np.median(limit[out]) <= 3.0 * np.median(error[out])


@pytest.mark.filterwarnings("ignore")
def test_a_bound_written_with_the_distance_growth_still_reads_and_grows_with_the_distance(ur5):
    # Model files written before robocal.methods.omitted (and ball-in-socket bounds) keep the
    # growth with the joint-space distance from the training configurations.
    chain, train, _ = ur5
    fitted = make_method("kinematic").fit(chain, train)
    document = {**fit_bound(fitted, chain, train).to_dict(), "growth_per_rad": 0.5, "sigma_growth_per_rad": 2.0}
    del document["outside"]
    old = PositionBound.from_dict(json.loads(json.dumps(document)), fitted)
    assert old.outside is None
    start = train.joints[np.argmax(train.joints[:, 1])]
    path = start + np.outer(np.radians(np.arange(0.0, 60.0, 5.0)), np.eye(6)[1])
    along = old.predict(path, inside=np.zeros(len(path), dtype=bool))
    assert np.all(np.isfinite(along)) and np.all(np.diff(along) > 0)


@pytest.mark.filterwarnings("ignore")
def test_an_auto_model_is_bounded_by_its_fallback_outside_its_domain():
    chain, _, _, train, model, _ = ur5_auto_model()
    bound = fit_bound(model, chain, train)
    assert bound.fallback is not None and bound.growth_per_rad is None  # the chosen model answers inside only
    every = uniform_joints(chain, 200, np.random.default_rng(6))
    inside = bound.inside_mask(every)
    limit = bound.predict(every)
    assert np.all(np.isfinite(limit))
    np.testing.assert_allclose(limit[~inside], bound.fallback._own(every[~inside], inside=False))
    np.testing.assert_allclose(limit[inside], bound._own(every[inside], inside=True))


@pytest.mark.filterwarnings("ignore")
def test_the_bound_survives_its_document_and_a_damaged_one_is_refused(ur5):
    chain, train, held = ur5
    fitted = make_method("hybrid").fit(chain, train)
    bound = fit_bound(fitted, chain, train)
    again = PositionBound.from_dict(json.loads(json.dumps(bound.to_dict())), fitted)
    np.testing.assert_allclose(again.predict(held.joints), bound.predict(held.joints))
    fitted.bound_ = again
    np.testing.assert_allclose(bound95(fitted, held.joints), bound.predict(held.joints))
    damaged = {**bound.to_dict(), "inside_factor": "wide"}
    with pytest.raises(FileFormatError, match="bound is damaged"):
        PositionBound.from_dict(damaged, fitted, "m.json")
    fitted.bound_ = None
    with pytest.raises(InputError, match="holds no 95 % bound"):
        bound95(fitted, held.joints)


def test_joint_distance_counts_a_full_turn_as_no_distance():
    training = np.zeros((1, 2))
    got = joint_distance(np.array([[2 * np.pi, 0.0], [0.1, 0.0], [np.nan, 0.0]]), training, [True, True])
    np.testing.assert_allclose(got[:2], [0.0, 2 * np.sin(0.05)], atol=1e-12)
    assert np.isnan(got[2])


# ---------------------------------------------------------------- the command line
@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A simulated UR5's training and held-out measurement files and a targets file."""
    folder = tmp_path_factory.mktemp("bound")
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=7)
    rng = np.random.default_rng(7)
    q = uniform_joints(chain, 260, rng)
    train, held, targets = folder / "train.csv", folder / "held.csv", folder / "targets.csv"
    write_measurements(train, truth.measurements(q[:120], rng))
    write_measurements(held, truth.measurements(q[120:240], rng))
    poses = chain.fk(q[240:])
    rpy = np.degrees(matrix_to_rpy(poses[:, :3, :3]))
    with open(targets, "w") as f:
        f.write("x,y,z,rx,ry,rz\n")
        f.writelines(",".join(f"{v:.6f}" for v in (*p, *r)) + "\n" for p, r in zip(poses[:, :3, 3], rpy))
    return folder, train, held, targets


def _calibrated(files, method, *options):
    folder, train, _, _ = files
    out = folder / f"{method}.json"
    if not out.exists():
        result = runner.invoke(app, ["calibrate", "ur5", str(train), "--method", method, "--out", str(out),
                                     "--json", "--accept-extrapolation", *options])
        assert result.exit_code == 0, result.output
    return out


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.filterwarnings("ignore")
def test_evaluate_per_pose_writes_one_row_per_pose_and_json_says_the_share_within(files):
    folder, _, held, _ = files
    model = _calibrated(files, "kinematic")
    per_pose = folder / "poses.csv"
    result = runner.invoke(app, ["evaluate", str(model), str(held), "--json", "--per-pose", str(per_pose)])
    assert result.exit_code == 0, result.output
    shown = json.loads(result.output)
    with open(per_pose, newline="") as f:
        assert next(csv.reader(f)) == list(PER_POSE_COLUMNS) + ["robocal_file"]
    rows = _rows(per_pose)
    measured = _rows(held)
    assert len(rows) == len(measured) == shown["n"]
    assert [int(r["row"]) for r in rows] == list(range(2, len(measured) + 2))
    xyz = np.array([[float(r[f"{a}_measured"]) for a in "xyz"] for r in rows])
    np.testing.assert_allclose(xyz, [[float(m[a]) for a in "xyz"] for m in measured])
    model_xyz = np.array([[float(r[f"{a}_model"]) for a in "xyz"] for r in rows])
    error = np.array([float(r["error_mm"]) for r in rows])
    np.testing.assert_allclose(error, np.linalg.norm(xyz - model_xyz, axis=1), rtol=1e-5)
    assert error.mean() == pytest.approx(shown["mean_mm"], rel=1e-5)
    bound = np.array([float(r["bound95_mm"]) for r in rows])
    assert np.all(bound > 0)
    assert {r["in_domain"] for r in rows} <= {"0", "1"}
    assert shown["bound95"]["within_share"] == pytest.approx(np.mean(error <= bound), abs=1e-9)
    assert 0.85 <= shown["bound95"]["within_share"] <= 1.0


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("method, options", [("kinematic", ()), ("kriging", ()), ("hybrid", ()),
                                             ("ann", ("--generations", "3", "--hidden", "4,4"))])
def test_compensate_writes_bound95_for_every_target_whatever_the_method(files, method, options):
    folder, _, _, targets = files
    model = _calibrated(files, method, *options)
    out = folder / f"commands_{method}.csv"
    result = runner.invoke(app, ["compensate", str(model), str(targets), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    rows = [r for r in _rows(out) if r["reachable"] == "1"]
    assert rows
    bound = np.array([float(r["bound95_mm"]) for r in rows])
    assert np.all(np.isfinite(bound)) and np.all(bound > 0)
    assert json.loads(result.output)["bound95_median_mm"] == pytest.approx(np.median(bound), rel=1e-3)


def _without_bound(path, out):
    """A copy of a model file as robocal wrote it before it computed bounds."""
    doc = json.loads(path.read_text())
    doc.pop("bound")
    doc.pop("checksum")
    doc["checksum"] = hashlib.sha256(_canonical(doc).encode()).hexdigest()
    out.write_text(json.dumps(doc))
    return out


@pytest.mark.filterwarnings("ignore")
def test_a_model_file_without_a_bound_says_so_and_gives_none(files):
    folder, _, held, targets = files
    old = _without_bound(_calibrated(files, "kinematic"), folder / "old.json")
    result = runner.invoke(app, ["evaluate", str(old), str(held), "--json", "--per-pose", str(folder / "old.csv")])
    assert result.exit_code == 0, result.output
    shown = json.loads(result.output)
    assert shown["bound95"] is None and shown["bound_note"] == NO_BOUND
    assert {r["bound95_mm"] for r in _rows(folder / "old.csv")} == {""}
    out = folder / "old_commands.csv"
    result = runner.invoke(app, ["compensate", str(old), str(targets), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["bound_note"] == NO_BOUND
    assert {r["bound95_mm"] for r in _rows(out)} == {""}



@pytest.mark.filterwarnings("ignore")
def test_a_dozen_poses_get_a_bound_that_covers_held_out_poses():
    """Leave-one-out through the calibration's hat matrix: no refit of 11 poses needed."""
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=8)
    rng = np.random.default_rng(8)
    train = truth.observations(uniform_joints(chain, 12, rng), rng)
    test = truth.observations(uniform_joints(chain, 400, rng), rng)
    fitted = make_method("kinematic").fit(chain, train)
    bound = fit_bound(fitted, chain, train)
    error = np.linalg.norm(test.positions - fitted.predict(test.joints), axis=1)
    limit = bound.predict(test.joints)
    assert np.mean(error <= limit) >= 0.85 and np.median(limit) <= 4 * np.median(error)


def test_a_campaign_too_small_for_folds_gets_no_bound_and_a_warning_not_a_refusal():
    from robocal.errors import RobocalWarning

    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=8)
    rng = np.random.default_rng(8)
    train = truth.observations(uniform_joints(chain, 12, rng), rng)
    # A robust loss is refitted on every fold; a leave-one-out fold keeps 11 poses, fewer
    # than the calibration takes.
    fitted = make_method("kinematic", loss="huber").fit(chain, train)
    with pytest.warns(RobocalWarning, match="no 95 % bound"):
        assert fit_bound(fitted, chain, train) is None
