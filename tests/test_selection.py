"""Model choice (robocal compare, calibrate --method auto): the splits hold out what they say,
the conservative rule chooses as documented, and a robot whose errors are non-geometric is
given the parameter set that models them.  Real-data acceptance: bench/model_choice.py."""
import dataclasses
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from robocal.errors import InputError
from robocal.estimation.kriging import Kriging
from robocal.interfaces.cli import app
from robocal.io.fixtures import Fixture
from robocal.io.library import load_robot
from robocal.io.model_file import load_model
from robocal.io.observations import Observations
from robocal.io.tables import write_measurements
from robocal.methods import selection
from robocal.methods.domain import arm_branches
from robocal.methods.selection import (Candidate, Score, Split, branch_split, cluster_split, compare, outside_choice,
                                       recommend, splits)
from robocal.simulation import make_true_robot
from robocal.simulation.joint_effects import Compliance
from robocal.simulation.sampling import uniform_joints

runner = CliRunner()


@pytest.fixture(scope="module")
def ur5():
    """A UR5 with the typical errors and 120 measured poses uniform in joint space."""
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=3)
    rng = np.random.default_rng(3)
    q = uniform_joints(chain, 120, rng)
    return chain, truth, truth.observations(q, rng)


def _nominal_observations(chain, q):
    return Observations.of(q, chain.fk_positions(q))


# ---------------------------------------------------------------------------- splits
def test_random_and_cluster_folds_are_disjoint_and_cover_every_pose(ur5):
    chain, _, obs = ur5
    found, _ = splits(chain, obs, folds=5, seed=1)
    kinds = {split.name: split for split in found}
    for name in ("random 5-fold", "joint-space regions"):
        tests = kinds[name].tests
        assert len(tests) == 5 and all(len(t) > 0 for t in tests)
        joined = np.concatenate(tests)
        assert len(joined) == len(np.unique(joined)) == obs.n_poses
    # A cluster is a region: its poses lie nearer its own centre in joint space than the
    # poses of the other clusters do, on average.
    features = selection.joint_features(chain, obs.joints)
    for test in kinds["joint-space regions"].tests:
        centre = features[test].mean(axis=0)
        rest = np.setdiff1d(np.arange(obs.n_poses), test)
        assert (np.linalg.norm(features[test] - centre, axis=1).mean()
                < np.linalg.norm(features[rest] - centre, axis=1).mean())


def test_cluster_split_is_reproducible_with_its_seed(ur5):
    chain, _, obs = ur5
    first = cluster_split(chain, obs.joints, 5, seed=4)
    again = cluster_split(chain, obs.joints, 5, seed=4)
    assert first.fold_names == again.fold_names
    assert all(np.array_equal(a, b) for a, b in zip(first.tests, again.tests))


@pytest.fixture(scope="module")
def ur5_branches():
    """UR5 configurations within +-180 deg (where the closed form numbers the branches) on
    shoulder 0 and wrist 0, split by their elbow side."""
    chain = load_robot("ur5")
    q = np.angle(np.exp(1j * uniform_joints(chain, 3000, np.random.default_rng(5))))
    _, sides = arm_branches(chain, q)
    common = (sides["shoulder"] == 0) & (sides["wrist"] == 0)
    return chain, q[common & (sides["elbow"] == 0)], q[common & (sides["elbow"] == 1)]


def test_branch_split_only_when_both_sides_hold_enough_poses(ur5_branches):
    chain, one, other = ur5_branches
    assert len(one) >= 200 and len(other) >= 200
    assert branch_split(chain, one[:200]) is None
    _, notes = splits(chain, _nominal_observations(chain, one[:200]))
    assert any("no arm-branch split" in note for note in notes)
    # 10 % on the other elbow side: below BRANCH_MIN_SHARE, no split.
    few = np.vstack([one[:180], other[:20]])
    assert branch_split(chain, few) is None
    # 40 %: the elbow split, each side left out in turn, the sides apart.
    q = np.vstack([one[:120], other[:80]])
    split = branch_split(chain, q)
    assert split is not None and split.name == "elbow branch" and split.kind == "region"
    assert {len(t) for t in split.tests} == {120, 80}
    assert not set(split.tests[0]) & set(split.tests[1])
    found, _ = splits(chain, _nominal_observations(chain, q))
    assert "elbow branch" in [s.name for s in found]


def test_time_tail_split_holds_the_last_poses_in_time(ur5):
    chain, _, obs = ur5
    times = np.random.default_rng(6).permutation(obs.n_poses).astype(float) * 2.5 + 1000.0
    found, _ = splits(chain, dataclasses.replace(obs, times=times))
    tail = next(s for s in found if "in time" in s.name)
    assert tail.kind == "region" and len(tail.tests) == 1
    expected = np.sort(np.argsort(times)[-round(selection.TIME_TAIL * obs.n_poses):])
    assert np.array_equal(tail.tests[0], expected)
    # Without times, no such split.
    assert not any("in time" in s.name for s in splits(chain, obs)[0])


def _socket_observations(placements):
    """Ball-in-socket observations of a Panda (joint values arbitrary: splits only need the ids)."""
    n = len(placements)
    fixture = Fixture("pair", {"0": [0.0, 0.0, 0.0], "1": [50.0, 0.0, 0.0]})
    joints = np.random.default_rng(7).uniform(-1.0, 1.0, (n, 7))
    return Observations.of(joints, placement=placements, socket=np.array(["0", "1"] * (n // 2)), fixture=fixture)


def test_socket_data_are_split_at_random_within_sockets_and_by_fixture_placement():
    placements = np.repeat(["front", "left", "high"], 20)
    obs = _socket_observations(placements)
    found, _ = splits(load_robot("panda"), obs)
    assert [(s.name, s.kind) for s in found] == [("random 5-fold", "random"), ("fixture placements", "region")]
    random_, by_placement = found
    # Random folds: every pose held out once, and every held-out pose keeps poses of its own
    # socket in the training part (they say where that socket is).
    assert np.array_equal(np.sort(np.concatenate(random_.tests)), np.arange(60))
    sockets = np.char.add(placements, obs.socket)
    for test in random_.tests:
        train = np.setdiff1d(np.arange(60), test)
        assert set(sockets[test]) <= set(sockets[train]) and 10 <= len(test) <= 14
    for test in by_placement.tests:
        assert len(set(placements[test])) == 1 and len(test) == 20
    assert sorted(set(placements[t[0]] for t in by_placement.tests)) == ["front", "high", "left"]
    with pytest.raises(InputError) as one_placement:
        splits(load_robot("panda"), _socket_observations(np.repeat(["front"], 8)))
    assert "one fixture placement" in str(one_placement.value) and "\n" not in str(one_placement.value)


def test_too_few_poses_are_refused_with_one_line(ur5):
    # Only below what the simplest model needs (kinematic offsets: 15 parameters from 3
    # coordinates a pose); 25 poses are a small campaign, split leave-one-out (issue 24).
    chain, _, obs = ur5
    assert splits(chain, obs.subset(np.arange(25)))[0][0].name == "leave-one-out"
    with pytest.raises(InputError) as refused:
        compare(chain, obs.subset(np.arange(4)))
    message = str(refused.value)
    assert "4 poses" in message and "kinematic offsets" in message and "\n" not in message
    with pytest.raises(InputError) as one_fold:
        compare(chain, obs, folds=1)
    assert "--folds" in str(one_fold.value)


# ---------------------------------------------------------------------------- the rule
RANDOM = Split("random 5-fold", "random", tuple(np.arange(5)[:, None]), tuple(f"fold {k}" for k in range(5)))
REGION = Split("joint-space regions", "region", tuple(np.arange(5)[:, None]), tuple(f"region {k}" for k in range(5)))
SIMPLE = Candidate("kinematic full", "kinematic", {"parameters": "full"})
RICHER = Candidate("kinematic full+compliance", "kinematic", {"parameters": "full+compliance"})
HYBRID = Candidate("hybrid full", "hybrid", {"parameters": "full"}, base="kinematic full")
SIMPLE_REGION = [1.00, 1.20, 0.80, 1.10, 0.90]


def _score(fold_means):
    return Score(list(fold_means), {"mean_mm": float(np.mean(fold_means))}, 0.1)


def _table(random, region):
    """{label: {split: Score}} from per-fold means on the random and the region split."""
    return {label: {RANDOM.name: _score(random[label]), REGION.name: _score(region[label])} for label in region}


def test_rule_keeps_the_simplest_when_the_gain_is_within_its_spread():
    # The richer model is 0.02 mm better on average over the random folds, but its gain varies
    # by +-0.07 mm from fold to fold.
    region = {SIMPLE.label: SIMPLE_REGION, RICHER.label: SIMPLE_REGION}
    random = {SIMPLE.label: [0.5] * 5, RICHER.label: [0.45, 0.56, 0.40, 0.55, 0.44]}
    chosen, reasons, dropped = recommend(_table(random, region), [SIMPLE, RICHER], [RANDOM, REGION])
    assert chosen is SIMPLE and not dropped
    assert any("keep it" in line for line in reasons)


def test_rule_takes_a_richer_model_whose_gain_exceeds_its_spread():
    region = {SIMPLE.label: SIMPLE_REGION, RICHER.label: [m + d for m, d in
                                                          zip(SIMPLE_REGION, [0.01, -0.01, 0.0, 0.01, -0.01])]}
    random = {SIMPLE.label: [0.5] * 5, RICHER.label: [0.45, 0.46, 0.44, 0.45, 0.45]}
    chosen, reasons, _ = recommend(_table(random, region), [SIMPLE, RICHER], [RANDOM, REGION])
    assert chosen is RICHER
    assert any("more than the fold-to-fold spread" in line for line in reasons)


def test_rule_does_not_take_a_model_better_at_random_but_worse_on_the_regions():
    # Far better on the random folds, worse on every region left out: the guard holds.
    region = {SIMPLE.label: SIMPLE_REGION, RICHER.label: [m + 0.1 + d for m, d in
                                                          zip(SIMPLE_REGION, [0.01, -0.01, 0.0, 0.01, -0.01])]}
    random = {SIMPLE.label: [0.5] * 5, RICHER.label: [0.3] * 5}
    chosen, reasons, _ = recommend(_table(random, region), [SIMPLE, RICHER], [RANDOM, REGION])
    assert chosen is SIMPLE
    assert any(line.startswith(f"{RICHER.label} not taken") for line in reasons)


def test_rule_takes_the_lowest_random_error_of_the_models_that_pass():
    # UR10 series A, a random half (bench/model_choice.py): the hybrid is three times better on
    # random folds and about as good as the simplest on the regions, where another model is best.
    region = {SIMPLE.label: SIMPLE_REGION, RICHER.label: [m - 0.05 for m in SIMPLE_REGION],
              HYBRID.label: [m + d for m, d in zip(SIMPLE_REGION, [0.02, -0.10, 0.03, -0.05, 0.04])]}
    random = {SIMPLE.label: [0.40] * 5, RICHER.label: [0.37, 0.38, 0.36, 0.37, 0.37],
              HYBRID.label: [0.14, 0.15, 0.13, 0.15, 0.14]}
    chosen, _, dropped = recommend(_table(random, region), [SIMPLE, RICHER, HYBRID], [RANDOM, REGION])
    assert chosen is HYBRID and not dropped


def test_rule_drops_a_hybrid_that_does_not_beat_its_base():
    # Far better at random, a little worse on the regions left out: dropped, with a line.
    region = {SIMPLE.label: SIMPLE_REGION, HYBRID.label: [m + 0.01 for m in SIMPLE_REGION]}
    random = {SIMPLE.label: [0.5] * 5, HYBRID.label: [0.1] * 5}
    chosen, _, dropped = recommend(_table(random, region), [SIMPLE, HYBRID], [RANDOM, REGION])
    assert chosen is SIMPLE
    assert len(dropped) == 1 and dropped[0].startswith("hybrid full dropped") and "kinematic full" in dropped[0]


def test_rule_never_picks_a_model_worse_than_the_simplest_at_random():
    # Clearly better on the regions, worse on random folds: not taken.
    region = {SIMPLE.label: SIMPLE_REGION, RICHER.label: [m - 0.3 for m in SIMPLE_REGION]}
    random = {SIMPLE.label: [0.5] * 5, RICHER.label: [0.55] * 5}
    chosen, _, _ = recommend(_table(random, region), [SIMPLE, RICHER], [RANDOM, REGION])
    assert chosen is SIMPLE


def test_rule_does_not_take_a_model_for_failing_on_one_region():
    # The fold means compare measured on the training part of that case (mm): the richest
    # kinematic set is as good as the simplest on four regions and three times worse on the
    # fifth; the hybrid is better on every region.
    erratic = Candidate("kinematic full+compliance+gains", "kinematic", {"parameters": "full+compliance+gains"})
    region = {SIMPLE.label: [0.458, 0.344, 0.364, 0.346, 1.030], erratic.label: [0.467, 0.339, 0.359, 0.339, 3.436],
              HYBRID.label: [0.220, 0.120, 0.119, 0.139, 0.978]}
    random = {SIMPLE.label: [0.367, 0.372, 0.347, 0.375, 0.363], erratic.label: [0.365, 0.361, 0.340, 0.364, 0.358],
              HYBRID.label: [0.094, 0.102, 0.093, 0.098, 0.098]}
    chosen, _, _ = recommend(_table(random, region), [SIMPLE, erratic, HYBRID], [RANDOM, REGION])
    assert chosen is HYBRID
    assert np.mean(region[chosen.label]) <= np.mean(region[SIMPLE.label])


def test_rule_takes_the_model_that_models_more_when_the_random_folds_cannot_tell():
    # UR5, a random half: the hybrids on full and full+compliance differ by 1 % on the random
    # folds, within the fold-to-fold spread; full+compliance models more.
    compliant = Candidate("hybrid full+compliance", "hybrid", {"parameters": "full+compliance"},
                          base=RICHER.label)
    region = {SIMPLE.label: SIMPLE_REGION, RICHER.label: [m - 0.05 for m in SIMPLE_REGION],
              HYBRID.label: [m - 0.06 for m in SIMPLE_REGION], compliant.label: [m - 0.06 for m in SIMPLE_REGION]}
    random = {SIMPLE.label: [0.40] * 5, RICHER.label: [0.37] * 5, HYBRID.label: [0.138, 0.142, 0.13, 0.15, 0.14],
              compliant.label: [0.14, 0.14, 0.14, 0.14, 0.14]}
    chosen, reasons, _ = recommend(_table(random, region), [SIMPLE, RICHER, HYBRID, compliant], [RANDOM, REGION])
    assert chosen is compliant
    assert "models more of the robot" in reasons[-1]
    # Clearly behind on the random folds, it is not taken for modelling more.
    random[compliant.label] = [0.16] * 5
    chosen, _, _ = recommend(_table(random, region), [SIMPLE, RICHER, HYBRID, compliant], [RANDOM, REGION])
    assert chosen is HYBRID


def test_differences_no_instrument_resolves_are_ties():
    # Two parameter sets that differ only where the richer one's compliances were left out:
    # 1e-4 mm apart on every fold, with no spread.  That is no gain, and no loss either.
    region = {SIMPLE.label: SIMPLE_REGION, RICHER.label: [m + 1e-4 for m in SIMPLE_REGION]}
    random = {SIMPLE.label: [0.5] * 5, RICHER.label: [0.5 - 1e-4] * 5}
    chosen, reasons, _ = recommend(_table(random, region), [SIMPLE, RICHER], [RANDOM, REGION])
    assert chosen is SIMPLE and not any("not taken" in line for line in reasons)
    fallback, why = outside_choice(_table(random, region), [SIMPLE, RICHER], [RANDOM, REGION], HYBRID)
    assert fallback is RICHER and "worse" not in why
    # A millimetre's hundredth with no spread is a gain.
    random[RICHER.label] = [0.49] * 5
    assert recommend(_table(random, region), [SIMPLE, RICHER], [RANDOM, REGION])[0] is RICHER


# ---------------------------------------------------------------------------- compare
# A KR 150-2 cell (deg): the arm reaching forward over a table, where gravity loads q2 and q3.
CELL_LOW = np.radians([-60, -120, 0, -30, 30, -30])
CELL_HIGH = np.radians([60, -20, 90, 30, 90, 30])


def test_compare_recommends_compliance_for_a_robot_whose_joints_give_way():
    """Joints 20 times softer than the typical preset's (a few tenths of a mm of sag over the
    cell) and no backlash: the compliance calibration explains what the rigid one cannot."""
    chain = load_robot("kr150-2")
    typical = make_true_robot(chain, "typical", seed=2)
    soft = Compliance(typical.compliance.stiffness / 20.0, typical.compliance.link_masses, typical.compliance.payload)
    truth = dataclasses.replace(typical, compliance=soft, backlash=np.zeros(6))
    rng = np.random.default_rng(8)
    q = CELL_LOW + rng.random((100, 6)) * (CELL_HIGH - CELL_LOW)
    comparison = compare(chain, truth.observations(q, rng), only=["kinematic full", "kinematic full+compliance"])
    assert comparison.recommended.label == "kinematic full+compliance", comparison.reasons
    region = next(s.name for s in comparison.splits if s.kind == "region")
    rigid = comparison.scores["kinematic full"][region].pooled["mean_mm"]
    compliant = comparison.scores["kinematic full+compliance"][region].pooled["mean_mm"]
    assert compliant < 0.5 * rigid
    # Every model beats the nominal registered on the same folds.
    assert rigid < comparison.scores[selection.NOMINAL][region].pooled["mean_mm"]


def test_kriging_conditioned_on_its_own_data_reproduces_the_fit():
    rng = np.random.default_rng(9)
    X = rng.uniform(-200.0, 200.0, (60, 3))
    Y = np.column_stack([np.sin(X[:, 0] / 80.0), np.cos(X[:, 1] / 120.0) * X[:, 2] / 200.0, X[:, 0] * 1e-3])
    Y = Y + rng.normal(scale=0.01, size=Y.shape)
    fitted = Kriging(random_state=0).fit(X, Y)
    again = fitted.conditioned_on(X, Y)
    assert np.array_equal(again.theta_, fitted.theta_) and np.array_equal(again.nugget_, fitted.nugget_)
    new = rng.uniform(-190.0, 190.0, (40, 3))  # inside the training box: no extrapolation warning
    for points in (X, new):
        np.testing.assert_allclose(again.predict(points), fitted.predict(points), rtol=0, atol=1e-10)
    # On other data it keeps the hyperparameters and conditions on those data.
    other = fitted.conditioned_on(X[:40], Y[:40])
    assert np.array_equal(other.theta_, fitted.theta_)
    assert not np.allclose(other.predict(new), fitted.predict(new))


# ---------------------------------------------------------------------------- the command line
@pytest.fixture(scope="module")
def measurement_file(tmp_path_factory):
    """A UR5 with the typical errors: 60 poses measured, as a CSV in file units."""
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=4)
    rng = np.random.default_rng(10)
    path = tmp_path_factory.mktemp("compare") / "meas.csv"
    write_measurements(path, truth.measurements(uniform_joints(chain, 60, rng), rng))
    return path


@pytest.fixture
def two_candidates(monkeypatch):
    """The command line's comparisons limited to two kinematic parameter sets, so that each
    runs in seconds (which models are compared, and how, is tested above)."""
    every = selection.candidates
    keep = ("kinematic full", "kinematic full+gains")

    def fewer(observations, **options):
        models, notes = every(observations, **options)
        return [c for c in models if c.label in keep], notes

    monkeypatch.setattr(selection, "candidates", fewer)


def test_compare_prints_the_tables_and_json(measurement_file, two_candidates):
    shown = runner.invoke(app, ["compare", "ur5", str(measurement_file), "--folds", "3", "--beyond-limits"])
    assert shown.exit_code == 0, shown.output
    for text in ("held-out error on random 3-fold", "held-out error on joint-space regions", "nominal (registered)",
                 "kinematic full+gains", "recommended (*):"):
        assert text in shown.output
    printed = runner.invoke(app, ["compare", "ur5", str(measurement_file), "--folds", "3", "--beyond-limits",
                                  "--json"])
    assert printed.exit_code == 0, printed.output
    doc = json.loads(printed.output)
    labels = [m["label"] for m in doc["models"]]
    assert labels == ["nominal (registered)", "kinematic full", "kinematic full+gains"]
    assert doc["recommended"]["label"] in labels[1:] and doc["poses"] == 60
    for model in doc["models"]:
        assert {s["name"] for s in doc["splits"]} == set(model["scores"])
        for score in model["scores"].values():
            assert score["pooled"]["n"] == 60 and len(score["fold_means_mm"]) == 3


def test_calibrate_auto_fits_the_recommended_method_and_keeps_the_comparison(measurement_file, two_candidates,
                                                                           tmp_path):
    out = tmp_path / "auto.json"
    result = runner.invoke(app, ["calibrate", "ur5", str(measurement_file), "--method", "auto", "--out", str(out),
                                 "--beyond-limits", "--json"])
    assert result.exit_code == 0, result.output
    model = load_model(out)
    comparison = model.training["comparison"]
    recommended = comparison["recommended"]
    assert model.method == recommended["method"]
    assert all(model.options.get(k) == v for k, v in recommended["settings"].items()), model.options
    assert [m["label"] for m in comparison["models"]][1:] == ["kinematic full", "kinematic full+gains"]
    assert comparison["poses"] == model.training["n_poses"] == 60
    # The report shows the choice, its tables and its reasons, and the training coverage.
    report = tmp_path / "auto.html"
    result = runner.invoke(app, ["report", str(out), str(measurement_file), "--out", str(report), "--beyond-limits"])
    assert result.exit_code == 0, result.output
    page = report.read_text()
    assert "Model choice" in page and recommended["label"] in page and "Training coverage" in page
    assert all(line.split(":")[0] in page for line in comparison["reasons"])


def test_calibrate_auto_refuses_a_method_option_with_one_line(measurement_file, tmp_path):
    out = tmp_path / "auto.json"
    result = runner.invoke(app, ["calibrate", "ur5", str(measurement_file), "--method", "auto", "--parameters",
                                 "full+gains", "--out", str(out), "--beyond-limits"])
    assert result.exit_code == 2
    assert "--parameters" in result.output and "auto" in result.output
    assert len(result.output.strip().splitlines()) == 1 and "Traceback" not in result.output
    assert not out.exists()


def test_held_out_socket_poses_are_scored_against_where_the_training_poses_put_their_socket():
    placements = np.repeat(["front", "left", "high"], 20)
    obs = _socket_observations(placements)
    chain = load_robot("panda")
    fitted = selection._Nominal(chain).fit(chain, obs)
    random_, by_placement = splits(chain, obs)[0]
    balls = chain.fk_positions(obs.joints)
    sockets = np.char.add(placements, obs.socket)
    test = random_.tests[0]
    train = np.setdiff1d(np.arange(60), test)
    found = selection._held_out_errors(fitted, obs, train, test)
    expected = [balls[i] - balls[train][sockets[train] == sockets[i]].mean(axis=0) for i in test]
    np.testing.assert_allclose(found, expected, atol=1e-9)
    # A placement left out has no training pose at its sockets: each socket's held-out poses
    # are scored against their own mean.
    test = by_placement.tests[0]
    found = selection._held_out_errors(fitted, obs, np.setdiff1d(np.arange(60), test), test)
    expected = [balls[i] - balls[test][sockets[test] == sockets[i]].mean(axis=0) for i in test]
    np.testing.assert_allclose(found, expected, atol=1e-9)
