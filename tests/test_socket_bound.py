"""The 95 % bound of ball-in-socket (constraint) models (robocal.methods.socket_bound): its
held-out deviations, its coverage of a placement left out on a simulated KR 150-2, what it
says of the true absolute error, its model-file round trip, and calibrate, compensate and
evaluate from the command line."""
import csv
import json
import warnings

import numpy as np
import pytest

from refusals import PLATE, run_ok
from robocal.errors import InputError, RobocalWarning
from robocal.interfaces.jobs import load_fitted
from robocal.io.library import load_robot
from robocal.io.observations import Observations, read_observations
from robocal.methods import make_method
from robocal.methods.bound import PositionBound
from robocal.methods.socket_bound import KIND, fit_socket_bound, held_out_deviations, socket_groups
from robocal.simulation import read_truth

HELD_OUT = "P5"


@pytest.fixture(scope="module")
def sockets(tmp_path_factory):
    """A simulated KR 150-2 (``typical`` errors) in the three sockets of the example plate at
    five placements, 10 configurations per socket; placement P5 held out; the constraint
    model of the other four and its bound, fitted in Python and by ``calibrate``."""
    folder = tmp_path_factory.mktemp("socket_bound")
    run_ok("simulate", "kr150-2", "--sampling", "sockets", "--fixture", PLATE, "--placements", 5, "--per-socket", 10,
           "--joint-noise", 0.002, "--errors", "typical", "--seed", 2, "--out", folder / "all.csv",
           "--truth", folder / "truth.json")
    lines = (folder / "all.csv").read_text().splitlines(keepends=True)
    header, rows = lines[0], lines[1:]
    (folder / "train.csv").write_text(header + "".join(r for r in rows if f",{HELD_OUT}," not in r))
    (folder / "test.csv").write_text(header + "".join(r for r in rows if f",{HELD_OUT}," in r))
    run_ok("calibrate", "kr150-2", folder / "train.csv", "--method", "constraint", "--fixture", PLATE,
           "--out", folder / "model.json")
    chain = load_robot("kr150-2")
    train = read_observations(folder / "train.csv", chain, PLATE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobocalWarning)
        model = make_method("constraint").fit(chain, train)
        bound = fit_socket_bound(model, chain, train)
    return {"folder": folder, "chain": chain, "train": train, "model": model, "bound": bound,
            "test": read_observations(folder / "test.csv", chain, PLATE), "truth": read_truth(folder / "truth.json")}


def test_a_held_out_deviation_leaves_the_configuration_out_of_its_socket_mean():
    centres = np.array([[0.0, 0, 0], [3.0, 0, 0], [6.0, 0, 0], [1.0, 1.0, 1.0]])
    deviation = held_out_deviations(centres, np.array(["a", "a", "a", "b"]))
    np.testing.assert_allclose(deviation[:3], [[-4.5, 0, 0], [0, 0, 0], [4.5, 0, 0]])
    assert np.all(np.isnan(deviation[3]))  # a socket seen once says nothing


def test_the_bound_covers_the_socket_consistency_of_a_placement_left_out(sockets):
    model, bound, test = sockets["model"], sockets["bound"], sockets["test"]
    assert isinstance(bound, PositionBound) and bound.calibration["kind"] == KIND
    assert bound.calibration["scores"] == "placements left out"
    deviation = np.linalg.norm(held_out_deviations(model.predict(test.joints), socket_groups(test)), axis=1)
    values = bound.predict(test.joints)
    assert np.all(np.isfinite(values))
    assert 0.85 <= np.mean(deviation <= values) <= 1.0
    assert np.median(values) <= 3.0 * np.median(deviation)


def test_the_bound_grows_far_from_the_training_configurations(sockets):
    bound, chain, test = sockets["bound"], sockets["chain"], sockets["test"]
    far = chain.random_configurations(200, rng=1)
    outside = ~bound.inside_mask(far)
    assert outside.sum() >= 50
    assert np.median(bound.predict(far[outside])) > 1.5 * np.median(bound.predict(test.joints))


def test_the_consistency_bound_is_no_bound_on_the_absolute_error(sockets):
    # The simulated robot's base is off by millimetres, which no socket sees: the true ball
    # position in the model's (nominal) base frame lies far beyond the consistency bound.
    model, bound, test, truth = sockets["model"], sockets["bound"], sockets["test"], sockets["truth"]
    absolute = np.linalg.norm(truth.positions(test.joints) - model.predict(test.joints), axis=1)
    assert np.mean(absolute <= bound.predict(test.joints)) < 0.5


def test_the_bound_survives_its_model_file(sockets):
    folder, test = sockets["folder"], sockets["test"]
    model, fitted = load_fitted(folder / "model.json")
    assert model.bound["calibration"]["kind"] == KIND
    again = PositionBound.from_dict(fitted.bound_.to_dict(), fitted)
    np.testing.assert_allclose(again.predict(test.joints), fitted.bound_.predict(test.joints))
    assert np.all(fitted.bound_.predict(test.joints) > 0)


def test_fit_socket_bound_refuses_position_data(sockets):
    chain = sockets["chain"]
    q = chain.random_configurations(20, rng=0)
    with pytest.raises(InputError, match="ball-in-socket observations"):
        fit_socket_bound(sockets["model"], chain, Observations.of(q, chain.fk_positions(q)))


def test_compensate_and_evaluate_give_the_socket_bound(sockets, tmp_path):
    folder = sockets["folder"]
    answer = json.loads(run_ok("compensate", folder / "model.json", "examples/kr150-targets.csv",
                               "--out", tmp_path / "c.csv", "--json").stdout)
    assert "socket consistency" in answer["bound_note"] and answer["bound95_median_mm"] > 0
    with open(tmp_path / "c.csv", newline="") as handle:
        rows = [row for row in csv.DictReader(handle) if row["reachable"] == "1"]
    assert rows and all(float(row["bound95_mm"]) > 0 for row in rows)
    evaluated = json.loads(run_ok("evaluate", folder / "model.json", folder / "test.csv", "--json").stdout)
    within = evaluated["bound95"]
    assert within["poses"] == 30 and 0.85 <= within["within_share"] <= 1.0
    assert within["median_bound_mm"] <= 3.0 * within["median_error_mm"]
    assert "invisible" in evaluated["bound_note"]


def test_one_placement_is_bounded_from_random_folds_within_its_sockets(sockets):
    chain, train = sockets["chain"], sockets["train"]
    one = train.subset(np.flatnonzero(train.placement == "P1"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RobocalWarning)
        model = make_method("constraint").fit(chain, one)
        bound = fit_socket_bound(model, chain, one)
    assert bound.calibration["scores"] == "placements left out and random folds within the sockets"
    assert bound.calibration["folds"] == 5
    assert np.all(np.isfinite(bound.predict(one.joints))) and bound.residual_mm > 0


@pytest.mark.parametrize("left_out, named", [("high", True), ("mid_left", False)])
def test_a_placement_whose_seatings_the_model_does_not_expect_is_named(left_out, named):
    # MUKCa Panda 2, one placement left out: `high`'s seatings deviate by 1.0 mm even when it is
    # trained on (0.21 to 0.36 mm at the others), and evaluate names it; a good placement is
    # not named.
    from robocal.io.datasets import mukca
    from robocal.methods.evaluation import socket_scores
    from robocal.methods.socket_bound import fit_model_bound

    dataset = mukca("panda_2")
    obs = dataset.observations
    train, test = (obs.subset(np.flatnonzero((obs.placement == left_out) == held)) for held in (False, True))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = make_method("constraint", parameters="full+gains").fit(dataset.chain, train)
        fitted.bound_ = fit_model_bound(fitted, dataset.chain, train)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scores = socket_scores(fitted, test)
    off = scores["bound95"]["placements_off"]
    said = [str(w.message) for w in caught if issubclass(w.category, RobocalWarning)]
    if named:
        assert [entry["placement"] for entry in off] == [left_out] and off[0]["within_share"] < 0.5
        assert any(f"fixture placement {left_out}:" in line and "check that placement" in line for line in said), said
    else:
        assert off == [] and not any("fixture placement" in line for line in said), said


def test_evaluate_names_a_placement_whose_seatings_are_off_from_the_command_line(tmp_path):
    # The same from the command line: MUKCa Panda 2 calibrated without placement `high`, then
    # evaluated on it: exit 0, one warning naming the placement, and --json lists it.
    from user_files import invoke

    assert invoke(tmp_path, ["dataset", "mukca-panda-2", "--out", "p2"]).code == 0
    rows = list(csv.reader(open(tmp_path / "p2.csv")))
    column = rows[0].index("fixture")
    for name, held in (("train.csv", False), ("high.csv", True)):
        kept = [rows[0]] + [row for row in rows[1:] if (row[column] == "high") == held]
        (tmp_path / name).write_text("\n".join(",".join(row) for row in kept) + "\n")
    fixture = ["--fixture", "p2_fixture.toml"]
    assert invoke(tmp_path, ["calibrate", "p2.toml", "train.csv", "--method", "constraint", "--out", "m.json",
                             *fixture]).code == 0
    done = invoke(tmp_path, ["evaluate", "m.json", "high.csv", "--json", *fixture])
    assert done.code == 0, done.lines
    named = [line for line in done.lines if "fixture placement high:" in line]
    assert len(named) == 1 and "check that placement" in named[0], done.lines
    off = json.loads(done.result.stdout)["bound95"]["placements_off"]
    assert [entry["placement"] for entry in off] == ["high"] and off[0]["within_share"] < 0.5
