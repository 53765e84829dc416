"""What says "held out" checks it by content (robocal.io.fingerprint): a byte copy, a re-ordered
copy or a mix of the training file is not called held-out by `report` or `evaluate`; new
measurements are."""
import csv
import json
import shutil

import pytest

from refusals import run_ok


@pytest.fixture(scope="module")
def folder(tmp_path_factory, ur5_files):
    # ur5_files: the 60 poses of seed 1 (meas.csv, here train.csv) and their kinematic model.
    root = tmp_path_factory.mktemp("held")
    shutil.copy(ur5_files / "meas.csv", root / "train.csv")
    shutil.copy(ur5_files / "model.json", root / "model.json")
    run_ok("simulate", "ur5", "--n", "40", "--seed", "2", "--out", root / "new.csv")
    shutil.copy(root / "train.csv", root / "copy.csv")
    train = list(csv.reader(open(root / "train.csv", newline="")))
    new = list(csv.reader(open(root / "new.csv", newline="")))
    with open(root / "mixed.csv", "w", newline="") as stream:
        csv.writer(stream).writerows([train[0]] + new[1:21] + train[1:11][::-1])
    # hostile pass 5: the training file as a controller or a script rewrites it, and half of it
    joints, xyz = range(6), [train[0].index(c) for c in "xyz"]
    with open(root / "rounded.csv", "w", newline="") as stream:
        csv.writer(stream).writerows([train[0]] + [[f"{float(v):.3f}" if k in joints else v for k, v in enumerate(row)]
                                                   for row in train[1:]])
    with open(root / "metres.csv", "w", newline="") as stream:
        csv.writer(stream).writerows([[f"{c}[m]" if k in xyz else c for k, c in enumerate(train[0])]]
                                     + [[repr(float(v) / 1000) if k in xyz else v for k, v in enumerate(row)]
                                        for row in train[1:]])
    with open(root / "half.csv", "w", newline="") as stream:
        csv.writer(stream).writerows([train[0]] + train[1:31] + new[1:31])
    return root


@pytest.mark.parametrize("name, training", [("copy.csv", 60), ("mixed.csv", 10), ("new.csv", 0),
                                            ("rounded.csv", 60), ("metres.csv", 60), ("half.csv", 30)])
def test_evaluate_counts_the_training_poses_by_content(folder, name, training):
    result = json.loads(run_ok("evaluate", folder / "model.json", folder / name, "--json").output)
    assert result["training_poses"] == training


@pytest.mark.parametrize("name, says", [
    ("copy.csv", "training poses (not held out: every one"),
    ("mixed.csv", "10 of 30 poses are training poses"),
    ("new.csv", "held-out poses (none of them is a training pose)"),
])
def test_the_report_labels_the_poses_it_scores_by_content(folder, tmp_path, name, says):
    run_ok("report", folder / "model.json", folder / name, "--out", tmp_path / "r.html")
    assert says in (tmp_path / "r.html").read_text()
