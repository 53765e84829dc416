# ruff: noqa: E501  (one input per table row)
"""Labels that claim what was not checked. evaluate and report given the
training file itself, or the training poses reordered, subset, duplicated, with columns
moved or rounded, count them as training poses (never as held-out ones), and the report says
so."""
import csv
import io
import json
import random
import shutil

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


# --------------------------------------------------------------------------------------------
# A model re-registered on a new set-up (calibrate MODEL.json --method frames) was fitted to
# the new poses too: its base and tool come from them.  Scored on them, it is not held out.

def _lines(path):
    return path.read_text().splitlines()


@pytest.fixture(scope="module")
def moved(tmp_path_factory):
    """The base files, with 50 new poses of the same simulated UR5 (the same seed draws
    ur5.csv's 60 poses first, then these): ``frames.csv`` (25) re-registered
    ``ur5_model.json`` into ``moved.json``, ``held.csv`` (25) is new to it; ``again.json``
    is ``moved.json`` re-registered on ``held.csv``."""
    folder = prepare(tmp_path_factory.mktemp("moved"))
    outcome = invoke(folder, ["simulate", "ur5", "--n", "110", "--errors", "typical", "--seed", "1", "--out", "all.csv"])
    assert outcome.code == 0, outcome.output
    lines = _lines(folder / "all.csv")
    assert [line.split(",")[:6] for line in lines[:61]] == [line.split(",")[:6] for line in _lines(folder / "ur5.csv")]
    (folder / "frames.csv").write_text("\n".join(lines[:1] + lines[61:86]) + "\n")
    (folder / "held.csv").write_text("\n".join(lines[:1] + lines[86:]) + "\n")
    for args in (["calibrate", "ur5_model.json", "frames.csv", "--method", "frames", "--out", "moved.json"],
                 ["calibrate", "moved.json", "held.csv", "--method", "frames", "--out", "again.json"]):
        outcome = invoke(folder, args)
        assert outcome.code == 0, outcome.output
    return folder


def _mixed(folder):
    frames, held = _lines(folder / "frames.csv"), _lines(folder / "held.csv")
    return "\n".join(held + frames[1:11]) + "\n"


REREGISTERED = [
    # (id, model, the file scored (a name, or a callable of the folder giving its text), poses, training poses)
    ("its-reregistration-poses", "moved.json", "frames.csv", 25, 25),
    ("its-reregistration-poses-reversed", "moved.json", lambda f: "\n".join(_lines(f / "frames.csv")[:1] + _lines(f / "frames.csv")[:0:-1]) + "\n", 25, 25),
    ("its-calibration-poses", "moved.json", "ur5.csv", 60, 60),
    ("new-poses", "moved.json", "held.csv", 25, 0),
    ("new-poses-and-ten-reregistration-poses", "moved.json", _mixed, 35, 10),
    # a second re-registration replaces the first's frames: the first's poses are new to it
    ("second-reregistration-on-its-poses", "again.json", "held.csv", 25, 25),
    ("second-reregistration-on-the-firsts-poses", "again.json", "frames.csv", 25, 0),
]


@pytest.mark.parametrize("model, data, poses, training", [row[1:] for row in REREGISTERED], ids=[row[0] for row in REREGISTERED])
def test_a_reregistered_model_counts_its_reregistration_poses(moved, tmp_path, model, data, poses, training):
    shutil.copytree(moved, tmp_path, dirs_exist_ok=True)
    if callable(data):
        (tmp_path / "e.csv").write_text(data(moved))
        data = "e.csv"
    outcome = invoke(tmp_path, ["evaluate", model, data, "--json"])
    assert outcome.code == 0, outcome.output
    result = json.loads(outcome.result.stdout)
    assert (result["n"], result["training_poses"]) == (poses, training)


@pytest.mark.parametrize("data, says", [
    ("frames.csv", "training poses (not held out: every one is a pose the model was trained on)"),
    ("held.csv", "held-out poses (none of them is a training pose)")], ids=["reregistration-poses", "new-poses"])
def test_report_on_a_reregistered_model_says_whether_it_saw_the_poses(moved, tmp_path, data, says):
    shutil.copytree(moved, tmp_path, dirs_exist_ok=True)
    outcome = invoke(tmp_path, ["report", "moved.json", data, "--out", "r.html"])
    assert outcome.code == 0, outcome.output
    assert says in (tmp_path / "r.html").read_text()
