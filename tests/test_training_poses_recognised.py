# ruff: noqa: E501  (one input per table row)
"""Labels that claim what was not checked. evaluate and report given the
training file itself, or the training poses reordered, subset, duplicated, with columns
moved or rounded, count them as training poses (never as held-out ones), and the report says
so."""
import csv
import io
import json
import random

import pytest

from user_files import invoke, prepare


def variant(change):
    def make(base):
        rows = list(csv.reader(io.StringIO((base / "ur5.csv").read_text())))
        out = io.StringIO()
        csv.writer(out, lineterminator="\n").writerows(change(rows))
        return out.getvalue()
    return make


VARIANTS = [
    ("same-file", lambda r: r, 60),
    ("first-half", lambda r: r[:31], 30),
    ("reversed", lambda r: [r[0]] + r[:0:-1], 60),
    ("shuffled", lambda r: [r[0]] + random.Random(1).sample(r[1:], len(r) - 1), 60),
    ("columns-reordered", lambda r: [[row[i] for i in [6, 7, 8, 0, 1, 2, 3, 4, 5, 9, 10, 11]] for row in r], 60),
    ("rounded-to-micrometres", lambda r: [r[0]] + [[f"{float(v):.3f}" for v in row] for row in r[1:]], 60),
    ("every-row-twice", lambda r: r + r[1:], 120),
    ("without-sigma-columns", lambda r: [row[:9] for row in r], 60),
    # the same configurations, read to a coarser resolution or written otherwise: not new poses
    ("joints-rounded-to-a-tenth-of-a-degree", lambda r: [r[0]] + [[f"{float(v):.1f}" for v in row[:6]] + row[6:] for row in r[1:]], 60),
    ("xyz-shifted-by-a-micrometre", lambda r: [r[0]] + [row[:6] + [f"{float(v) + 0.001!r}" for v in row[6:9]] + row[9:] for row in r[1:]], 60),
    ("wrist-one-turn-off", lambda r: [r[0]] + [row[:5] + [repr(float(row[5]) - 360.0 if float(row[5]) > 0 else float(row[5]) + 360.0)] + row[6:] for row in r[1:]], 60),
    ("remeasured-with-tracker-noise", lambda r: [r[0]] + [row[:6] + [repr(float(v) + 0.01 * (-1) ** k) for k, v in enumerate(row[6:9])] + row[9:] for row in r[1:]], 60),
]


@pytest.mark.parametrize("change, training", [v[1:] for v in VARIANTS], ids=[v[0] for v in VARIANTS])
def test_training_poses_are_counted_as_training(tmp_path, change, training):
    prepare(tmp_path, {"e.csv": variant(change)})
    outcome = invoke(tmp_path, ["evaluate", "ur5_model.json", "e.csv", "--json"])
    assert outcome.code == 0, outcome.output
    result = json.loads(outcome.result.stdout)
    assert result["n"] == training and result["training_poses"] == training


@pytest.mark.parametrize("model, data, training", [
    ("sock_model.json", "sockets.csv", 72), ("ur5_model.json", "ur5.csv", 60)],
    ids=["ball-in-socket", "kinematic"])
def test_evaluate_on_the_training_file_says_so(tmp_path, model, data, training):
    prepare(tmp_path)
    outcome = invoke(tmp_path, ["evaluate", model, data, "--json"])
    assert outcome.code == 0, outcome.output
    assert json.loads(outcome.result.stdout)["training_poses"] == training


@pytest.mark.parametrize("change", [VARIANTS[1][1], VARIANTS[5][1]], ids=["first-half", "rounded"])
def test_report_on_training_poses_says_they_are_not_held_out(tmp_path, change):
    prepare(tmp_path, {"e.csv": variant(change)})
    outcome = invoke(tmp_path, ["report", "ur5_model.json", "e.csv", "--out", "r.html"])
    assert outcome.code == 0, outcome.output
    page = (tmp_path / "r.html").read_text()
    assert "not held out: every one is a pose the model was trained on" in page


def test_evaluate_on_training_poses_says_they_lie_inside_the_domain(tmp_path):
    prepare(tmp_path)
    outcome = invoke(tmp_path, ["evaluate", "ur5_model.json", "ur5.csv"])
    assert outcome.code == 0, outcome.output
    assert "training poses" in outcome.output
    assert "all 60 poses lie inside the training domain" in outcome.output
