"""Outside its training domain an auto model answers with the kinematic calibration without
gains (robocal.methods.fallback): per configuration in predict and in the joint commands,
through the model file, and chosen by the documented rule.  Real-data figures:
bench/model_choice.py."""
import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from refusals import assert_refused, copy_inputs
from robocal.compensation import CompensatorProtocol
from robocal.interfaces.cli import app
from robocal.io.library import load_robot
from robocal.io.model_file import load_model, save_model
from robocal.io.tables import write_measurements
from robocal.methods import fitted_from_model_file, make_method, selection
from robocal.methods.fallback import DomainFallback, wrap
from robocal.methods.selection import Candidate, Score, Split, outside_choice
from robocal.simulation import make_true_robot
from robocal.simulation.sampling import uniform_joints

runner = CliRunner()


@pytest.fixture(scope="module")
def half_range():
    """A UR5 with the typical errors measured with q1 in the lower half of its range only;
    configurations of the whole range to predict at; an auto-like model (full+gains inside,
    full+compliance outside) fitted on the measured half."""
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=5)
    rng = np.random.default_rng(5)
    q = uniform_joints(chain, 160, rng)
    lower = q[:, 0] < 0.0
    train = truth.observations(q[lower][:90], rng)
    inside = make_method("kinematic", parameters="full+gains").fit(chain, train)
    outside = make_method("kinematic", parameters="full+compliance").fit(chain, train)
    model = wrap(make_method("kinematic", parameters="full+gains").fit(chain, train), outside,
                 "kinematic full+compliance")
    every = uniform_joints(chain, 200, np.random.default_rng(6))
    return chain, truth, train, inside, outside, model, every


def test_predict_takes_the_fallback_exactly_where_the_domain_check_says_outside(half_range):
    _, _, _, inside, outside, model, q = half_range
    out = ~model.domain_.check(q).inside
    assert 20 < out.sum() < len(q) - 20  # both kinds are exercised
    predicted = model.predict(q)
    np.testing.assert_allclose(predicted[~out], inside.predict(q[~out]), atol=1e-9)
    np.testing.assert_allclose(predicted[out], outside.predict(q[out]), atol=1e-9)
    assert np.array_equal(model.compensator_.outside_mask(q), out)


def test_commands_take_the_fallback_where_its_configuration_is_outside(half_range):
    _, _, _, inside, outside, model, q = half_range
    targets = model.reference_.fk(q)  # (N, 4, 4) reachable poses over the whole range
    mixed = model.compensator_.commands(targets, hint=q)
    mine = inside.compensator_.commands(targets, hint=q)
    other = outside.compensator_.commands(targets, hint=q)
    out = other.success & ~model.domain_.check(np.where(other.success[:, None], other.q, mine.q)).inside
    assert out.any() and (~out & mine.success).any()
    np.testing.assert_allclose(mixed.q[out], other.q[out], atol=1e-12)
    np.testing.assert_allclose(mixed.q[~out & mine.success], mine.q[~out & mine.success], atol=1e-12)
    assert np.array_equal(mixed.success[out], other.success[out])


def test_command_of_one_target_takes_the_fallback_as_commands_do(half_range):
    _, _, _, _, _, model, q = half_range
    targets = model.reference_.fk(q[:40])
    mixed = model.compensator_.commands(targets, hint=q[:40])
    assert (~model.compensator_.outside_mask(mixed.q[mixed.success])).any()
    assert model.compensator_.outside_mask(mixed.q[mixed.success]).any()
    for i in range(40):
        one = model.compensator_.command(targets[i], q[i])
        assert one.success[0] == mixed.success[i]
        np.testing.assert_allclose(one.q[0], mixed.q[i], atol=1e-8, equal_nan=True)
        np.testing.assert_allclose(one.corrected[0], mixed.corrected[i], atol=1e-6, equal_nan=True)


def test_the_fallback_declares_the_compensator_protocol_and_forwards_nothing_else(half_range):
    _, _, _, inside, _, model, _ = half_range
    fallback = model.compensator_
    assert isinstance(fallback, CompensatorProtocol) and isinstance(inside.compensator_, CompensatorProtocol)
    for name in ("chain", "error_model", "error_input", "nominal", "controller", "reference"):
        assert getattr(fallback, name) is getattr(fallback.inside, name)
    # What the protocol does not declare is not the chosen model's by accident.
    assert not hasattr(fallback, "corrected_targets") and not hasattr(fallback, "_point")
    assert fallback.label == "kinematic full+compliance"


def test_the_model_file_keeps_the_fallback_and_older_files_stay_schema_1(half_range, tmp_path):
    chain, _, _, inside, _, model, q = half_range
    path = tmp_path / "auto.json"
    save_model(model.to_model_file(chain), path)
    document = json.loads(path.read_text())
    assert document["schema_version"] == 2 and document["outside_domain"]["label"] == "kinematic full+compliance"
    again = fitted_from_model_file(load_model(path), path)
    assert isinstance(again.compensator_, DomainFallback)
    np.testing.assert_allclose(again.predict(q), model.predict(q), atol=1e-9)
    plain = tmp_path / "plain.json"
    save_model(inside.to_model_file(chain), plain)
    assert json.loads(plain.read_text())["schema_version"] == 1 and "outside_domain" not in plain.read_text()


def test_a_fallback_entry_without_a_domain_is_refused_as_damaged(half_range, tmp_path):
    from robocal.errors import FileFormatError
    from robocal.io import model_file
    chain, _, _, _, _, model, _ = half_range
    document = replace(model.to_model_file(chain), domain=None)
    path = tmp_path / "no_domain.json"
    model_file.save_model(document, path)
    with pytest.raises(FileFormatError, match="records no domain"):
        fitted_from_model_file(load_model(path), path)


def test_the_command_line_refuses_a_fallback_model_without_its_domain_with_one_line(half_range, tmp_path,
                                                                                   monkeypatch):
    """A fallback entry whose file lost its domain: exit status 2, one line, no traceback,
    nothing written (re-registering such a model: tests/test_auto_reregistration.py)."""
    chain, truth, _, _, _, model, q = half_range
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    save_model(model.to_model_file(chain), inputs / "auto.json")
    damaged = replace(model.to_model_file(chain), domain=None)
    save_model(damaged, inputs / "no_domain.json")
    write_measurements(inputs / "new.csv", truth.measurements(q[:25], np.random.default_rng(12)))
    folder = tmp_path / "work"
    folder.mkdir()
    before = copy_inputs(inputs, folder, monkeypatch)
    assert_refused(["evaluate", "no_domain.json", "new.csv"], "records no domain", folder, before)


# ---------------------------------------------------------------------------- the rule
RANDOM = Split("random 5-fold", "random", tuple(np.arange(5)[:, None]), tuple(f"fold {k}" for k in range(5)))
REGION = Split("joint-space regions", "region", tuple(np.arange(5)[:, None]), tuple(f"region {k}" for k in range(5)))
RIGID = Candidate("kinematic full", "kinematic", {"parameters": "full"})
COMPLIANT = Candidate("kinematic full+compliance", "kinematic", {"parameters": "full+compliance"})
GAINS = Candidate("kinematic full+gains", "kinematic", {"parameters": "full+gains"})
HYBRID = Candidate("hybrid full+gains", "hybrid", {"parameters": "full+gains"}, base="kinematic full+gains")
RIGID_REGION = [1.00, 1.20, 0.80, 1.10, 0.90]


def _table(region):
    return {label: {RANDOM.name: Score([0.5] * 5, {"mean_mm": 0.5}, 0.1),
                    REGION.name: Score(list(means), {"mean_mm": float(np.mean(means))}, 0.1)}
            for label, means in region.items()}


def test_outside_the_domain_compliance_answers_unless_the_regions_show_it_worse():
    candidates = [RIGID, GAINS, COMPLIANT, HYBRID]
    # As good as the rigid calibration within the spread: compliance answers outside.
    tied = {RIGID.label: RIGID_REGION,
            COMPLIANT.label: [m + d for m, d in zip(RIGID_REGION, [.02, -.03, .01, 0, -.01])],
            GAINS.label: RIGID_REGION, HYBRID.label: RIGID_REGION}
    chosen, why = outside_choice(_table(tied), candidates, [RANDOM, REGION], HYBRID)
    assert chosen is COMPLIANT and "gravity" in why
    # Worse on every region by more than the spread: the rigid calibration.
    worse = dict(tied, **{COMPLIANT.label: [m + 0.2 + d for m, d in zip(RIGID_REGION, [.01, -.01, 0, .01, -.01])]})
    chosen, why = outside_choice(_table(worse), candidates, [RANDOM, REGION], HYBRID)
    assert chosen is RIGID and "worse" in why


def test_no_fallback_when_it_is_the_chosen_model_or_there_is_no_kinematic_candidate():
    tied = {RIGID.label: RIGID_REGION, COMPLIANT.label: RIGID_REGION}
    assert outside_choice(_table(tied), [RIGID, COMPLIANT], [RANDOM, REGION], COMPLIANT) == (None, None)
    constraint = Candidate("constraint full", "constraint", {"parameters": "full"})
    assert outside_choice(_table({constraint.label: RIGID_REGION}), [constraint], [RANDOM, REGION],
                          constraint) == (None, None)


def test_the_rule_judges_the_poses_inside_each_folds_domain():
    """A fold whose held-out poses all lie outside its training domain (the other arm branch)
    is where the fallback answers: it does not count against the chosen model."""
    def score(inside):
        return Score([0.5] * 5, {"mean_mm": 0.5}, 0.1, list(inside), float(np.nanmean(inside)))

    # All held-out poses: the hybrid fails one region badly.  Inside the domains it is better
    # on every fold that has any (the failing fold had none inside).
    rigid = Score(RIGID_REGION, {"mean_mm": float(np.mean(RIGID_REGION))}, 0.1,
                  [1.00, 1.20, 0.80, 1.10, float("nan")], 1.025)
    hybrid = Score([0.5, 0.7, 0.3, 0.6, 9.0], {"mean_mm": 2.22}, 0.1, [0.5, 0.7, 0.3, 0.6, float("nan")], 0.525)
    scores = {RIGID.label: {RANDOM.name: score([0.5] * 5), REGION.name: rigid},
              "hybrid full": {RANDOM.name: score([0.2] * 5), REGION.name: hybrid}}
    hybrid_full = Candidate("hybrid full", "hybrid", {"parameters": "full"}, base=RIGID.label)
    chosen, reasons, _ = selection.recommend(scores, [RIGID, hybrid_full], [RANDOM, REGION])
    assert chosen is hybrid_full, reasons
    gain, spread = selection._gain(scores, hybrid_full.label, RIGID.label, [REGION])
    assert gain == pytest.approx(0.5) and spread == pytest.approx(0.0)


# ---------------------------------------------------------------------------- command line
def test_calibrate_auto_writes_the_fallback_and_evaluate_says_what_answered(tmp_path, monkeypatch):
    chain = load_robot("ur5")
    truth = make_true_robot(chain, "typical", seed=4)
    rng = np.random.default_rng(11)
    q = uniform_joints(chain, 140, rng)
    measured, elsewhere = tmp_path / "meas.csv", tmp_path / "elsewhere.csv"
    write_measurements(measured, truth.measurements(q[q[:, 0] < 0.0][:60], rng))
    write_measurements(elsewhere, truth.measurements(q[q[:, 0] >= 0.0][:40], rng))
    every = selection.candidates

    def two(observations, **options):
        models, notes = every(observations, **options)
        return [c for c in models if c.label in (GAINS.label, COMPLIANT.label)], notes

    monkeypatch.setattr(selection, "candidates", two)
    # Whatever the folds say of these two, the gains model is what is tested here.
    monkeypatch.setattr(selection, "recommend",
                        lambda scores, models, splits_: (models[0], ["gains, for the test"], []))
    out = tmp_path / "auto.json"
    result = runner.invoke(app, ["calibrate", "ur5", str(measured), "--method", "auto", "--out", str(out),
                                 "--beyond-limits", "--json"])
    assert result.exit_code == 0, result.output
    model = load_model(out)
    assert model.outside is not None and model.outside[0] == COMPLIANT.label
    assert model.training["comparison"]["outside_domain"]["label"] == COMPLIANT.label
    shown = runner.invoke(app, ["evaluate", str(out), str(elsewhere), "--beyond-limits", "--json"])
    assert shown.exit_code == 0, shown.output
    assert f"answered by {COMPLIANT.label}" in json.loads(shown.output)["domain_summary"]
